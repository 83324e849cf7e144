//! The README and the guide run as written (issues 35, 48): every ```sh block is taken from
//! `README.md` and then from the guide's chapters (`docs/src/`, in `SUMMARY.md`'s order), and
//! each of its commands run in order, in one scratch directory, as a newcomer would type them,
//! so that an example cannot drift from the tool again.
//!
//! - `calflash ...` and `cargo run --release -p calflash -- ...` run this build's `calflash`.
//! - The device port (`/dev/ttyUSB0`, `tcp://127.0.0.1:4444`) is the example unit as `cargo
//!   xtask unit` starts it: the firmware built as IMU-0042 on QEMU, its UART on a local TCP
//!   port. Without QEMU (and unless `SPINCAL_REQUIRE_QEMU=1`) the device's own protocol
//!   handler over a simulated NOR flash stands in, said (`host-tests/src/tcp_unit.rs`).
//! - The shared history (`CALFLASH_DB=postgres://...`) is a real PostgreSQL server started here
//!   (`host-tests/src/postgres.rs`); without one the commands that need it are skipped, said.
//! - `cargo xtask ...` is not run here: CI runs `cargo xtask test` itself (`.ci/run`), and the
//!   main job has its own test (`host-tests/tests/mainjob.rs`).
//! - `../shared` is beside the scratch directory as it is beside a checkout; without it the
//!   commands that read it are skipped, said.
//!
//! `README_SHOW=1` prints each command's exit code and first line of output.
//!
//! A command's comment states what it must do: `exits N` its exit code (0 otherwise), and a
//! verdict word in capitals (ACCEPT, REVIEW, REJECT, OK, DRIFTED, SUSPECT, UNCHANGED, CHANGED,
//! HELD, SHIFTED, MOVED) that its output must hold.
#![allow(dead_code)] // the modules below are shared with other test crates

#[path = "../../../host-tests/src/nor.rs"]
mod nor;
#[path = "../../../host-tests/src/postgres.rs"]
mod postgres;
#[path = "../../../host-tests/src/qemu.rs"]
mod qemu;
#[path = "../../../host-tests/src/tcp_unit.rs"]
mod tcp_unit;
#[path = "../../../host-tests/src/unit.rs"]
mod unit;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The verdict words a comment can promise.
const VERDICTS: [&str; 11] = [
    "ACCEPT",
    "REVIEW",
    "REJECT",
    "OK",
    "DRIFTED",
    "SUSPECT",
    "UNCHANGED",
    "CHANGED",
    "HELD",
    "SHIFTED",
    "MOVED",
];

/// Far above what any README command needs in a debug build.
const LIMIT_S: u32 = 900;

/// One command of a block: its file and line, the command and its comment.
#[derive(Debug)]
struct Line {
    file: String,
    block: usize,
    at: usize,
    command: String,
    comment: String,
}

/// The commands of every ```sh block, continuation lines joined.
fn commands(readme: &str) -> Vec<Line> {
    let mut out = Vec::new();
    let mut inside = false;
    let mut block = 0;
    let mut pending: Option<Line> = None;
    for (i, raw) in readme.lines().enumerate() {
        let at = i + 1;
        if !inside {
            inside = raw.trim_start() == "```sh";
            block += usize::from(inside);
            continue;
        }
        if raw.trim_start().starts_with("```") {
            inside = false;
            continue;
        }
        let (code, comment) = split_comment(raw);
        let (code, more) = match code.trim_end().strip_suffix('\\') {
            Some(c) => (c.to_string(), true),
            None => (code.to_string(), false),
        };
        let line = pending.get_or_insert_with(|| Line {
            file: String::new(),
            block,
            at,
            command: String::new(),
            comment: String::new(),
        });
        line.command.push_str(code.trim());
        line.command.push(' ');
        if !comment.is_empty() {
            line.comment.push_str(comment);
            line.comment.push(' ');
        }
        if !more
            && let Some(l) = pending.take()
            && !l.command.trim().is_empty()
        {
            out.push(Line {
                command: l.command.trim().to_string(),
                ..l
            });
        }
    }
    out
}

/// The README, then the guide's chapters in the order `docs/src/SUMMARY.md` lists them: each
/// command with its file (`README.md`, `docs/src/fit.md`), blocks numbered across them all.
fn documents(repo: &Path) -> Vec<Line> {
    let mut files = vec!["README.md".to_string()];
    let summary = std::fs::read_to_string(repo.join("docs/src/SUMMARY.md"))
        .expect("docs/src/SUMMARY.md: the guide's contents");
    for l in summary.lines() {
        if let Some((_, rest)) = l.split_once("](") {
            let name = rest.trim_end_matches(')');
            files.push(format!("docs/src/{name}"));
        }
    }
    let mut out = Vec::new();
    let mut blocks = 0;
    for file in files {
        let text = std::fs::read_to_string(repo.join(&file))
            .unwrap_or_else(|e| panic!("{file}, listed in docs/src/SUMMARY.md: {e}"));
        let lines = commands(&text);
        let most = lines.iter().map(|l| l.block).max().unwrap_or(0);
        out.extend(lines.into_iter().map(|l| Line {
            file: file.clone(),
            block: l.block + blocks,
            ..l
        }));
        blocks += most;
    }
    out
}

/// A shell line split at its comment: a `#` at the start or after a space, outside quotes.
fn split_comment(line: &str) -> (&str, &str) {
    let (mut single, mut double) = (false, false);
    let mut prev = ' ';
    for (i, c) in line.char_indices() {
        match c {
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && prev.is_whitespace() => {
                return (&line[..i], line[i + 1..].trim());
            }
            _ => {}
        }
        prev = c;
    }
    (line, "")
}

/// The exit code a comment promises (`exits N`), 0 when it says none.
fn promised_exit(comment: &str) -> i32 {
    let words: Vec<&str> = comment.split_whitespace().collect();
    words
        .windows(2)
        .find(|w| w[0] == "exits")
        .and_then(|w| {
            w[1].trim_matches(|c: char| !c.is_ascii_digit())
                .parse()
                .ok()
        })
        .unwrap_or(0)
}

/// The verdict words a comment promises.
fn promised_words(comment: &str) -> Vec<&'static str> {
    let words: Vec<&str> = comment
        .split(|c: char| !c.is_ascii_alphabetic())
        .filter(|w| !w.is_empty())
        .collect();
    VERDICTS
        .iter()
        .copied()
        .filter(|v| words.contains(v))
        .collect()
}

/// The scratch directory: `work/` (where the commands run, with `examples/` linked from the
/// repository), `shared` linked beside it when the checkout has one, and `home/` for the
/// user's data directory (the default unit history).
fn scratch(repo: &Path) -> (tempfile::TempDir, PathBuf, bool) {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::create_dir_all(dir.path().join("home")).unwrap();
    std::os::unix::fs::symlink(repo.join("examples"), work.join("examples")).unwrap();
    let shared = repo.join("../shared");
    let has_shared = shared.is_dir();
    if has_shared {
        std::os::unix::fs::symlink(shared.canonicalize().unwrap(), dir.path().join("shared"))
            .unwrap();
    }
    (dir, work, has_shared)
}

/// The unit on the README's port, as `cargo xtask unit` starts it: the example firmware built
/// as IMU-0042 under QEMU (mps2-an386), its flash erased, its UART on a local TCP port. Where
/// QEMU cannot run (and `SPINCAL_REQUIRE_QEMU` does not require it), the device's own protocol
/// handler over a simulated NOR flash on the host, said.
fn example_unit(scratch: &Path) -> (String, Option<unit::QemuUnit>) {
    let stand_in = |why: &str| {
        eprintln!(
            "README test: the QEMU unit cannot run ({why}): the README's port is the device's protocol handler on the host instead"
        );
        let port =
            tcp_unit::TcpUnit::serve_forever(tcp_unit::device(tcp_unit::blank_flash(), "IMU-0042"));
        (port, None)
    };
    if !qemu::available_or_skip("every_readme_example_runs_as_written (its unit on a port)") {
        return stand_in("no qemu-system-arm or thumb target");
    }
    let elf = match qemu::build_firmware_as(Some("IMU-0042")) {
        Ok(dir) => dir.join("device"),
        Err(e) => panic!("the example unit's firmware does not build: {e}"),
    };
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap();
    let flash = scratch.join("IMU-0042-flash.bin");
    let log = scratch.join("IMU-0042-qemu.log");
    let unit = unit::QemuUnit::power_on_at(&elf, Some(&flash), &log, Some(port))
        .unwrap_or_else(|e| panic!("the QEMU unit does not start: {e}"));
    eprintln!("README test: unit IMU-0042 on QEMU at tcp://127.0.0.1:{port}");
    (format!("tcp://127.0.0.1:{port}"), Some(unit))
}

#[test]
fn every_readme_example_runs_as_written() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let lines = documents(&repo);
    assert!(lines.len() > 40, "only {} commands found", lines.len());
    let (dir, work, has_shared) = scratch(&repo);
    let home = dir.path().join("home");
    let (port, _unit) = example_unit(dir.path());
    let postgres = postgres::Server::start("every_readme_example_runs_as_written").unwrap();
    let history = postgres.as_ref().map(|pg| {
        pg.execute("postgres", "CREATE DATABASE calflash");
        pg.url("calflash")
    });
    let bin = env!("CARGO_BIN_EXE_calflash");
    // Each command runs in its own shell after the variables the blocks set so far.
    let mut prelude = format!(
        "set -o pipefail\ncalflash() {{ '{bin}' \"$@\"; }}\ncargo() {{ if [ \"$1 $2 $3 $4 $5\" = 'run --release -p calflash --' ]; then shift 5; '{bin}' \"$@\"; else echo \"README test: cargo $* is not run here\" >&2; return 97; fi; }}\n"
    );
    let mut ran = 0;
    let mut skipped = Vec::new();
    let mut failed = Vec::new();
    // A block whose shared history could not be had is skipped from there on.
    let mut without_history = None;
    for line in &lines {
        let mut cmd = line
            .command
            .replace("/dev/ttyUSB0", &port)
            .replace("tcp://127.0.0.1:4444", &port);
        let what = format!("{} line {}: `{}`", line.file, line.at, line.command);
        if cmd.starts_with("cargo xtask") {
            skipped.push(format!("{what}: CI runs it (.ci/run)"));
            continue;
        }
        if cmd.contains("../shared") && !has_shared {
            skipped.push(format!("{what}: ../shared is not beside this checkout"));
            continue;
        }
        if without_history == Some(line.block) {
            skipped.push(format!(
                "{what}: after the shared history, which is not here"
            ));
            continue;
        }
        if let Some(start) = cmd.find("postgres://") {
            let Some(url) = &history else {
                skipped.push(format!("{what}: PostgreSQL is not installed"));
                without_history = Some(line.block);
                continue;
            };
            let end = cmd[start..]
                .find(char::is_whitespace)
                .map_or(cmd.len(), |e| start + e);
            cmd.replace_range(start..end, url);
        }
        let assignment = cmd.starts_with("export ")
            || cmd.starts_with("unset ")
            || cmd.split_once('=').is_some_and(|(name, _)| {
                !name.is_empty() && name.chars().all(|c| c.is_ascii_uppercase() || c == '_')
            });
        if assignment {
            prelude.push_str(&cmd);
            prelude.push('\n');
            continue;
        }
        let out = Command::new("timeout")
            .arg(LIMIT_S.to_string())
            .arg("bash")
            .arg("-c")
            .arg(format!("{prelude}{cmd}"))
            .current_dir(&work)
            .env("HOME", &home)
            .env_remove("XDG_DATA_HOME")
            .env_remove("CALFLASH_DB")
            .env_remove("CALFLASH_SIGN_KEY")
            // The example unit is QEMU on a host running the other tests: it answers slower
            // than a unit on a bench (a chunk timed out at the 3 s default on a loaded CI
            // machine), so the walk waits as a user of a slow link would.
            .env("CALFLASH_TIMEOUT", "30")
            .output()
            .expect("bash runs");
        let code = out.status.code().unwrap_or(-1);
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        let expected = promised_exit(&line.comment);
        ran += 1;
        if std::env::var("README_SHOW").is_ok_and(|v| v == "1") {
            println!(
                "{} line {} exit {code}: {}",
                line.file,
                line.at,
                stdout.lines().next().unwrap_or("")
            );
        }
        if code != expected || stderr.contains("panicked") {
            failed.push(format!(
                "{what}: exit {code}, the README promises {expected}{}\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
                if code == 124 { " (killed after the time limit)" } else { "" }
            ));
            continue;
        }
        for word in promised_words(&line.comment) {
            if !stdout
                .split(|c: char| !c.is_ascii_alphabetic())
                .any(|w| w == word)
            {
                failed.push(format!(
                    "{what}: the README says {word}; it printed\n{stdout}"
                ));
            }
        }
    }
    for s in &skipped {
        println!("SKIPPED {s}");
    }
    println!("ran {ran} README commands, skipped {}", skipped.len());
    // Every failure, in README order (a later one may follow from an earlier one).
    assert!(
        failed.is_empty(),
        "{} of {ran} README commands failed:\n\n{}",
        failed.len(),
        failed.join("\n\n")
    );
    drop(dir);
}

#[test]
fn commands_are_read_as_a_shell_reads_them() {
    let text = "intro\n```sh\ncalflash a \\\n    --b c   # one ACCEPT, exits 3\n# only a comment\nX=1 # set\n```\n```text\nnot run\n```\n";
    let lines = commands(text);
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert_eq!(lines[0].command, "calflash a --b c");
    assert_eq!(lines[0].at, 3);
    assert_eq!(promised_exit(&lines[0].comment), 3);
    assert_eq!(promised_words(&lines[0].comment), vec!["ACCEPT"]);
    assert_eq!(lines[1].command, "X=1");
    assert_eq!(split_comment("a '#b' \"#c\" #d"), ("a '#b' \"#c\" ", "d"));
    assert_eq!(split_comment("a#b"), ("a#b", ""));
}

/// Every chapter in `docs/src/` is in `SUMMARY.md` (mdBook leaves the others out), every
/// chapter `SUMMARY.md` lists is there, and the README links each of them.
#[test]
fn the_guide_lists_every_chapter_and_the_readme_links_them() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let summary = std::fs::read_to_string(repo.join("docs/src/SUMMARY.md")).unwrap();
    let listed: Vec<String> = summary
        .lines()
        .filter_map(|l| {
            l.split_once("](")
                .map(|(_, r)| r.trim_end_matches(')').to_string())
        })
        .collect();
    let mut present: Vec<String> = std::fs::read_dir(repo.join("docs/src"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md") && n != "SUMMARY.md")
        .collect();
    present.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(
        sorted, present,
        "docs/src/SUMMARY.md against the files in docs/src"
    );
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    for name in listed.iter().filter(|n| *n != "introduction.md") {
        assert!(
            readme.contains(&format!("](docs/src/{name})")),
            "README.md does not link docs/src/{name}"
        );
    }
    // The README stays a first screen and a tour, not the guide.
    assert!(
        readme.lines().count() < 150,
        "README.md has {} lines",
        readme.lines().count()
    );
}

/// Each chapter with commands shows its first one near its top, the theory after it (issue 68:
/// the flight chapter opened with 1,147 words before its first command).
#[test]
fn every_chapter_shows_a_command_before_its_theory() {
    const FIRST_LINES: usize = 15;
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut late = Vec::new();
    for entry in std::fs::read_dir(repo.join("docs/src")).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        if let Some(at) = text.lines().position(|l| l.starts_with("```"))
            && at >= FIRST_LINES
        {
            late.push(format!(
                "{}: first code block at line {}",
                path.display(),
                at + 1
            ));
        }
    }
    assert!(late.is_empty(), "{}", late.join("\n"));
}
