//! The tool tried as a careless user and a hostile one would (issue 13; the list is kept in
//! `RELIABILITY.md`). Every command runs under a watchdog: one that does not finish within
//! [`LIMIT`] is killed and the test fails naming it, so a hang is a failure, not a stuck CI.

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Far above what any of these commands needs in a debug build.
const LIMIT: Duration = Duration::from_secs(120);

/// What a run of `calflash` gave.
struct Ran {
    status: ExitStatus,
    out: String,
    err: String,
}

impl Ran {
    fn code(&self) -> Option<i32> {
        self.status.code()
    }
}

/// Runs `calflash args` in `dir` under the watchdog.
fn calflash(dir: &Path, args: &[&str]) -> Ran {
    calflash_with(dir, args, Stdio::piped())
}

fn calflash_with(dir: &Path, args: &[&str], stdout: Stdio) -> Ran {
    let mut child = Command::new(env!("CARGO_BIN_EXE_calflash"))
        .current_dir(dir)
        .args(args)
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("calflash starts");
    let drain = |r: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = Vec::new();
            if let Some(mut r) = r {
                let _ = r.read_to_end(&mut s);
            }
            String::from_utf8_lossy(&s).into_owned()
        })
    };
    let out = drain(child.stdout.take().map(|r| Box::new(r) as _));
    let err = drain(child.stderr.take().map(|r| Box::new(r) as _));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("calflash {} hung: killed after {LIMIT:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ran {
        status,
        out: out.join().unwrap(),
        err: err.join().unwrap(),
    }
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data")
}

/// The single-axis example with line `line`'s `column` (0-based) replaced by `value`.
fn single_with(dir: &Path, name: &str, line: usize, column: usize, value: &str) -> PathBuf {
    edited(
        &examples().join("single_accel.csv"),
        dir,
        name,
        line,
        column,
        value,
    )
}

fn edited(src: &Path, dir: &Path, name: &str, line: usize, column: usize, value: &str) -> PathBuf {
    let text = std::fs::read_to_string(src).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<&str> = lines[line - 1].split(',').collect();
    fields[column] = value;
    lines[line - 1] = fields.join(",");
    let p = dir.join(name);
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    p
}

fn copy_example(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::copy(examples().join(name), &p).unwrap();
    p
}

/// Every file in `dir`, hidden ones included.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn calibrate_single(dir: &Path, data: &Path, extra: &[&str]) -> Ran {
    let mut args = vec![
        "calibrate",
        data.to_str().unwrap(),
        "--sensor",
        "single-accel",
        "--serial",
        "RT-1",
        "--no-db",
    ];
    args.extend(extra);
    calflash(dir, &args)
}

// ---- A unit can be given a calibration that should never reach it ----

#[test]
fn a_rejected_fit_writes_no_blob_unless_forced_and_then_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = copy_example(d, "single_accel.csv");
    let strict = [
        "--max-noise",
        "1e-6",
        "--blob",
        "r.blob",
        "--json",
        "r.json",
    ];
    let r = calibrate_single(d, &data, &strict);
    assert_eq!(r.code(), Some(3), "{}{}", r.out, r.err);
    assert!(r.out.contains("unit RT-1: REJECT"), "{}", r.out);
    assert!(!d.join("r.blob").exists(), "no blob for a REJECT");
    assert!(
        r.out
            .contains("blob: none written to r.blob: the calibration is judged REJECT"),
        "{}",
        r.out
    );
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(record["blob"], "", "the record holds no blob");

    let mut forced = strict.to_vec();
    forced.push("--force-blob");
    let r = calibrate_single(d, &data, &forced);
    assert_eq!(r.code(), Some(3));
    let bytes = std::fs::read(d.join("r.blob")).unwrap();
    let cal = spincal::blob::decode(&bytes).unwrap();
    assert!(
        cal.data().identity.fit_rejected,
        "the blob says its fit was rejected"
    );
    // An accepted fit's blob does not.
    let r = calibrate_single(d, &data, &["--blob", "ok.blob"]);
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    let ok = spincal::blob::decode(&std::fs::read(d.join("ok.blob")).unwrap()).unwrap();
    assert!(!ok.data().identity.fit_rejected);
}

#[test]
fn outputs_at_or_beyond_the_rails_are_left_out_of_the_fit_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let clean = calibrate_single(
        d,
        &copy_example(d, "single_accel.csv"),
        &["--blob", "c.blob"],
    );
    assert_eq!(clean.code(), Some(0));
    let good = spincal::blob::decode(&std::fs::read(d.join("c.blob")).unwrap()).unwrap();
    let center = |c: &spincal::model::Calibration| match &c.data().sensor {
        spincal::model::Sensor::Single { channel, .. } => channel.center,
        _ => unreachable!(),
    };
    for (i, value) in ["1e20", "70000", "65535", "-3", "1e308", "1e200"]
        .into_iter()
        .enumerate()
    {
        let data = single_with(d, &format!("rail{i}.csv"), 6, 6, value);
        let blob = format!("rail{i}.blob");
        let r = calibrate_single(d, &data, &["--blob", &blob]);
        assert_eq!(r.code(), Some(0), "{value}: {}{}", r.out, r.err);
        assert!(
            r.out.contains(
                "REVIEW 1 observation(s) with an output at or beyond the ADC rails 0 and 65535 were left out of the fit: line 6"
            ),
            "{value}: {}",
            r.out
        );
        let cal = spincal::blob::decode(&std::fs::read(d.join(&blob)).unwrap()).unwrap();
        assert!(
            (center(&cal) - center(&good)).abs() < 1.0,
            "{value}: centre {} against {}",
            center(&cal),
            center(&good)
        );
        // Applied, its corrections follow the input (not one constant for every sample).
        let r = calflash(
            d,
            &[
                "apply",
                data.to_str().unwrap(),
                "--blob",
                &blob,
                "--temp-column",
                "temp",
                "-o",
                "applied.csv",
            ],
        );
        assert_eq!(r.code(), Some(0), "{}", r.err);
        let text = std::fs::read_to_string(d.join("applied.csv")).unwrap();
        let values: Vec<f64> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        let spread = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(spread > 9.0, "{value}: corrections {values:?}");
    }
    // Every output on a rail: nothing to fit, and the message says why.
    let text = std::fs::read_to_string(examples().join("single_accel.csv")).unwrap();
    let railed: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l}\n")
            } else {
                let (head, _) = l.rsplit_once(',').unwrap();
                format!("{head},65535\n")
            }
        })
        .collect();
    std::fs::write(d.join("all_railed.csv"), railed).unwrap();
    let r = calibrate_single(d, &d.join("all_railed.csv"), &["--blob", "x.blob"]);
    assert_eq!(r.code(), Some(1));
    assert!(r.err.contains("rails"), "{}", r.err);
    assert!(!d.join("x.blob").exists());
}

#[test]
fn a_triad_count_beyond_the_rails_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = edited(
        &examples().join("imu_bench.csv"),
        d,
        "imu.csv",
        4,
        9,
        "1e308",
    );
    let r = calflash(
        d,
        &[
            "calibrate",
            data.to_str().unwrap(),
            "--sensor",
            "accel",
            "--serial",
            "RT-3",
            "--no-db",
            "--blob",
            "t.blob",
        ],
    );
    assert_ne!(r.code(), Some(1), "{}{}", r.out, r.err);
    assert!(r.out.contains("line 4"), "{}", r.out);
    assert!(r.out.contains("ADC rails"), "{}", r.out);
}

#[test]
fn a_command_that_fails_leaves_none_of_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = copy_example(d, "single_accel.csv");
    let r = calibrate_single(
        d,
        &data,
        &["--blob", "b.blob", "--report", "missing_dir/x.html"],
    );
    assert_eq!(r.code(), Some(1));
    assert!(
        r.err
            .contains("--report missing_dir/x.html: the directory missing_dir does not exist"),
        "{}",
        r.err
    );
    assert_eq!(listing(d), ["single_accel.csv"], "nothing written");
}

// ---- It hangs or panics ----

#[test]
fn values_too_large_to_square_get_a_located_error_not_a_hang() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let big = single_with(d, "big.csv", 6, 6, "1e308");
    let r = calflash(
        d,
        &[
            "fit",
            big.to_str().unwrap(),
            "--model",
            "output ~ 1 + input",
        ],
    );
    assert_eq!(r.code(), Some(1), "{}", r.out);
    assert!(
        r.err.contains("the fit overflows") && r.err.contains("line 6 (output = 1e308, input = "),
        "{}",
        r.err
    );
    let wide = single_with(d, "wide.csv", 6, 0, "1e200");
    let r = calflash(
        d,
        &[
            "fit",
            wide.to_str().unwrap(),
            "--model",
            "output ~ 1 + input + input^2",
        ],
    );
    assert_eq!(r.code(), Some(1));
    assert!(
        r.err
            .contains("wide.csv: line 6: the term input^2 overflows to inf (input = 1e200)"),
        "{}",
        r.err
    );
    let r = calibrate_single(d, &wide, &[]);
    assert_eq!(r.code(), Some(1));
    assert!(
        r.err.contains("line 6: the term input^2 overflows"),
        "{}",
        r.err
    );
}

#[test]
fn models_and_options_that_used_to_hang_or_panic_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = copy_example(d, "single_accel.csv");
    let cases: [(&[&str], i32, &str); 6] = [
        (
            &["--model", "output ~ 1"],
            1,
            "without the term `input` the model has no scale factor",
        ),
        (
            &["--breakpoint", "nan"],
            2,
            "'nan' for '--breakpoint <BREAKPOINT>': a finite number is expected",
        ),
        (&["--alpha", "nan"], 2, "'nan' for '--alpha <ALPHA>'"),
        (&["--alpha=-1"], 2, "'-1' for '--alpha <ALPHA>'"),
        (&["--alpha", "-1"], 2, "'-1' for '--alpha <ALPHA>'"),
        (
            &["--model", "volts ~ 1 + input"],
            1,
            "the single-axis workflow's response is the `output` column",
        ),
    ];
    for (args, code, says) in cases {
        let r = calibrate_single(d, &data, args);
        assert_eq!(r.code(), Some(code), "{args:?}: {}{}", r.out, r.err);
        assert!(r.err.contains(says), "{args:?}: {}", r.err);
        assert!(!r.err.contains("panicked"), "{args:?}: {}", r.err);
    }
}

#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    use std::os::unix::process::ExitStatusExt as _;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = copy_example(d, "single_accel.csv");
    // A pipe whose reader is gone before calflash writes a byte, as `| head -0` leaves it.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let r = calflash_with(
        d,
        &[
            "calibrate",
            data.to_str().unwrap(),
            "--sensor",
            "single-accel",
            "--serial",
            "RT-2",
            "--no-db",
            "--blob",
            "p.blob",
        ],
        Stdio::from(writer),
    );
    assert_eq!(r.status.signal(), Some(13), "ended by SIGPIPE, as `cat` is");
    assert_eq!(r.err, "", "no 'failed printing to stdout'");
}

#[test]
fn sizes_beyond_reason_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A staging file a killed run left behind goes the next time a command writes here.
    std::fs::write(d.join(".calflash-4000000000-abc.tmp"), "stale").unwrap();
    let cases: [(&[&str], i32, &str); 8] = [
        (
            &[
                "design",
                "evaluate",
                "--model",
                "single",
                "--plan",
                "head:1000000000",
            ],
            1,
            "`1000000000` is not a count from 1 to 1000000",
        ),
        (
            &[
                "design",
                "evaluate",
                "--model",
                "single",
                "--plan",
                "head:1000000,head:1000",
            ],
            1,
            "1001000 conditions with every temperature, voltage and repeat; a plan holds at most 1000000",
        ),
        (
            &[
                "simulate",
                "--sensor",
                "single-accel",
                "--plan",
                "head:100000000",
                "-o",
                "s.csv",
            ],
            1,
            "`100000000` is not a count from 1 to 1000000",
        ),
        (
            &[
                "simulate",
                "--sensor",
                "single-accel",
                "--plan",
                "head:1000",
                "--repeat",
                "10000",
                "-o",
                "s.csv",
            ],
            1,
            "a plan holds at most 1000000",
        ),
        (
            &[
                "design", "optimize", "--model", "single", "--n", "1000000", "--output", "p.csv",
            ],
            2,
            "'1000000' for '--n <N>': a count from 1 to 100000 is expected",
        ),
        (
            &[
                "design",
                "predict",
                "--model",
                "single",
                "--plan",
                "head:10",
                "--at",
                "input=1",
                "--monte-carlo",
                "100000000",
            ],
            2,
            "a count from 10 to 100000 is expected",
        ),
        (
            &[
                "design",
                "predict",
                "--model",
                "single",
                "--plan",
                "head:100000",
                "--at",
                "input=1",
                "--monte-carlo",
                "100000",
            ],
            1,
            "is 10000000000 simulated observations; at most 1e9",
        ),
        (
            &[
                "design",
                "optimize",
                "--model",
                "single",
                "--grid",
                "input=-1:1:1000",
                "--region",
                "input=-1:1:1000000000000",
                "--n",
                "10",
                "--output",
                "p.csv",
            ],
            2,
            "N is at most 1000000",
        ),
    ];
    for (args, code, says) in cases {
        let r = calflash(d, args);
        assert_eq!(r.code(), Some(code), "{args:?}: {}{}", r.out, r.err);
        assert!(r.err.contains(says), "{args:?}: {}", r.err);
    }
    let r = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:10",
            "-o",
            "s.csv",
        ],
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert_eq!(listing(d), ["s.csv"], "the stale staging file is gone");
    let r = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--spin",
            "300:3600",
            "--sample-rate",
            "10000",
            "-o",
            "f.csv",
        ],
    );
    assert_eq!(r.code(), Some(1));
    assert!(r.err.contains("a flight holds at most 1e7"), "{}", r.err);
}

// ---- It destroys or misfiles the user's work ----

#[test]
fn no_output_may_be_an_input_or_another_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = copy_example(d, "single_accel.csv");
    let original = std::fs::read(&data).unwrap();
    let r = calibrate_single(d, &data, &["--blob", "b.blob", "--json", "a.json"]);
    assert_eq!(r.code(), Some(0), "{}", r.err);
    std::fs::copy(d.join("a.json"), d.join("b.json")).unwrap();
    std::fs::hard_link(&data, d.join("link.csv")).unwrap();
    let before = listing(d);
    let cases: [&[&str]; 8] = [
        &[
            "calibrate",
            "single_accel.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--no-db",
            "--blob",
            "single_accel.csv",
        ],
        &[
            "calibrate",
            "single_accel.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--no-db",
            "--blob",
            "./sub/../link.csv",
        ],
        &[
            "calibrate",
            "single_accel.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--no-db",
            "--blob",
            "x.out",
            "--json",
            "./x.out",
        ],
        &[
            "apply",
            "single_accel.csv",
            "--blob",
            "b.blob",
            "-o",
            "link.csv",
        ],
        &["image", "--blob", "b.blob", "--hex", "b.blob"],
        &["compare", "a.json", "b.json", "--json", "a.json"],
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:5",
            "-o",
            "t",
            "--write-truth",
            "t",
        ],
        &[
            "calibrate",
            "single_accel.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--db",
            "single_accel.csv",
        ],
    ];
    std::fs::create_dir(d.join("sub")).unwrap();
    for args in cases {
        let r = calflash(d, args);
        assert_eq!(r.code(), Some(1), "{args:?}: {}{}", r.out, r.err);
        assert!(
            r.err.contains("the command would replace its own input")
                || r.err.contains("name one file"),
            "{args:?}: {}",
            r.err
        );
    }
    std::fs::remove_dir(d.join("sub")).unwrap();
    assert_eq!(listing(d), before, "nothing added");
    assert_eq!(
        std::fs::read(&data).unwrap(),
        original,
        "the input is intact"
    );
}

#[test]
fn history_and_compare_never_create_a_database_and_a_newer_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = calflash(d, &["history", "RT-1", "--db", "nowhere/units.sqlite"]);
    assert_eq!(r.code(), Some(1));
    assert!(r.err.contains("nowhere/units.sqlite"), "{}", r.err);
    let r = calflash(d, &["compare", "db:1", "db:2", "--db", "none.sqlite"]);
    assert_eq!(r.code(), Some(1));
    assert_eq!(listing(d), Vec::<String>::new(), "no database created");

    // A database written by a newer calflash.
    let db = d.join("newer.sqlite");
    let c = rusqlite::Connection::open(&db).unwrap();
    c.execute_batch("PRAGMA user_version = 99;").unwrap();
    drop(c);
    let r = calflash(d, &["history", "RT-1", "--db", "newer.sqlite"]);
    assert_eq!(r.code(), Some(1));
    assert!(r.err.contains("99"), "{}", r.err);
    let data = copy_example(d, "single_accel.csv");
    let r = calflash(
        d,
        &[
            "calibrate",
            data.to_str().unwrap(),
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--db",
            "newer.sqlite",
        ],
    );
    assert_ne!(r.code(), Some(0));
    assert!(r.err.contains("99"), "{}", r.err);
}

// ---- It accepts nonsense and answers with confident output ----

#[test]
fn nonsense_options_are_refused_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_example(d, "single_accel.csv");
    copy_example(d, "fine_steps.csv");
    let cal = [
        "calibrate",
        "single_accel.csv",
        "--sensor",
        "single-accel",
        "--serial",
        "RT-1",
        "--no-db",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        cal.iter().chain(extra).copied().collect()
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (with(&["--alpha", "2"]), "--alpha <ALPHA>"),
        (with(&["--alpha", "0"]), "--alpha <ALPHA>"),
        (with(&["--alpha", "1"]), "--alpha <ALPHA>"),
        (with(&["--max-noise", "nan"]), "--max-noise <MAX_NOISE>"),
        (
            vec!["compare", "a.json", "b.json", "--alpha", "2"],
            "--alpha <ALPHA>",
        ),
        (
            vec![
                "selfcal",
                "r.txt",
                "--g",
                "9.81",
                "--serial",
                "A",
                "--init-rest=-5",
            ],
            "--init-rest <INIT_REST>",
        ),
        (
            vec![
                "selfcal",
                "r.txt",
                "--g",
                "9.81",
                "--serial",
                "A",
                "--init-rest",
                "nan",
            ],
            "--init-rest <INIT_REST>",
        ),
        (
            vec![
                "selfcal", "r.txt", "--g", "9.81", "--serial", "A", "--window", "0",
            ],
            "--window <WINDOW>",
        ),
        (
            vec![
                "design",
                "predict",
                "--model",
                "single",
                "--plan",
                "head:10",
                "--at",
                "input=1",
                "--noise=-1",
            ],
            "--noise <NOISE>",
        ),
        (
            vec![
                "design",
                "evaluate",
                "--model",
                "single",
                "--plan",
                "head:10",
                "--noise=-2",
            ],
            "--noise <NOISE>",
        ),
        (
            vec![
                "design", "evaluate", "--model", "single", "--plan", "head:10", "--scale", "0",
            ],
            "--scale <SCALE>",
        ),
        (
            vec![
                "design",
                "predict",
                "--model",
                "single",
                "--grid",
                "input=-9:9:11",
                "--at",
                "input=1",
                "--target",
                "nan",
            ],
            "--target <TARGET>",
        ),
        (
            vec![
                "design",
                "predict",
                "--model",
                "single",
                "--grid",
                "input=-9:9:11",
                "--at",
                "input=1",
                "--target=-1",
            ],
            "--target <TARGET>",
        ),
        (
            vec![
                "design",
                "optimize",
                "--model",
                "single",
                "--grid",
                "input=-1:1:11",
                "--region",
                "input=-1:1:0",
                "--n",
                "10",
                "--output",
                "p.csv",
            ],
            "--region <REGION>",
        ),
        (
            vec![
                "flash",
                "--blob",
                "b.blob",
                "--port",
                "tcp:127.0.0.1:9",
                "--timeout",
                "0",
            ],
            "--timeout <TIMEOUT>",
        ),
        (
            vec![
                "flash",
                "--blob",
                "b.blob",
                "--port",
                "tcp:127.0.0.1:9",
                "--vectors",
                "0",
            ],
            "--vectors <VECTORS>",
        ),
        (
            vec![
                "simulate",
                "--sensor",
                "single-accel",
                "--plan",
                "head:5",
                "--temps",
                "nan",
                "-o",
                "s.csv",
            ],
            "--temps <TEMPS>",
        ),
        (
            vec!["threshold", "fine_steps.csv", "--scale", "0"],
            "--scale <SCALE>",
        ),
        (
            vec![
                "threshold",
                "fine_steps.csv",
                "--scale",
                "400",
                "--bias",
                "inf",
            ],
            "--bias <BIAS>",
        ),
    ];
    let before = listing(d);
    for (args, option) in cases {
        let r = calflash(d, &args);
        assert_eq!(r.code(), Some(2), "{args:?}: {}{}", r.out, r.err);
        assert!(
            r.err.starts_with("error: invalid value") && r.err.contains(option),
            "{args:?}: {}",
            r.err
        );
        assert_eq!(r.out, "", "{args:?}: nothing confident on stdout");
    }
    assert_eq!(listing(d), before, "nothing written");
}

#[test]
fn design_answers_only_about_what_the_model_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = calflash(
        d,
        &[
            "design", "predict", "--model", "single", "--plan", "head:10", "--at", "nope=1",
        ],
    );
    assert_eq!(r.code(), Some(1), "{}", r.out);
    assert!(
        r.err
            .contains("--at `nope=1`: the model reads no `nope`; it reads input"),
        "{}",
        r.err
    );
    assert_eq!(r.out, "");
}

#[test]
fn a_given_bias_is_used_even_when_the_run_has_an_input_of_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_example(d, "fine_steps.csv");
    let run = |extra: &[&str]| {
        let mut args = vec!["threshold", "fine_steps.csv", "--scale", "400"];
        args.extend(extra);
        let r = calflash(d, &args);
        assert_eq!(r.code(), Some(0), "{}", r.err);
        r.out
    };
    let own = run(&[]);
    let given = run(&["--bias", "32000"]);
    assert!(own.contains("(the run's mean at input 0)"), "{own}");
    assert!(
        given.contains("output at zero input  32000 counts (--bias; the run's mean at input 0 is "),
        "{given}"
    );
    assert_ne!(own, given, "the bias changes the figures");
}

#[test]
fn simulated_values_are_finite_and_codes_stay_within_the_rails() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "centrifuge:0:1e308:5",
            "-o",
            "c.csv",
        ],
    );
    assert_eq!(r.code(), Some(1));
    assert!(
        r.err
            .contains("`1e308` is not a number from -100000 to 100000 g"),
        "{}",
        r.err
    );
    let r = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "fine:-2000:2000:41",
            "--quantize",
            "-o",
            "q.csv",
        ],
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(
        r.out
            .contains("saturated at the 16-bit converter's rails 0 and 65535"),
        "{}",
        r.out
    );
    let text = std::fs::read_to_string(d.join("q.csv")).unwrap();
    for line in text.lines().skip(1) {
        let v: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!((0.0..=65535.0).contains(&v) && v.fract() == 0.0, "{line}");
    }
}

#[test]
fn an_allan_sample_too_large_to_square_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut text = String::new();
    for i in 0..400 {
        let g = if i == 150 {
            "1e300".to_string()
        } else {
            format!("{}", 32768 + i % 7)
        };
        text.push_str(&format!(
            "{:.2},32768,32770,36000,{g},32769,32767\n",
            f64::from(i) * 0.01
        ));
    }
    std::fs::write(d.join("still.csv"), text).unwrap();
    let r = calflash(d, &["allan", "still.csv", "--sensor", "gyro"]);
    assert_eq!(r.code(), Some(1), "{}", r.out);
    assert!(
        r.err
            .contains("still.csv:151: gyro axis x = 1e300: too large for the Allan deviation"),
        "{}",
        r.err
    );
}

// ---- Byte-order marks, negative values, long lines ----

#[test]
fn a_byte_order_mark_is_stripped_and_said() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plain = copy_example(d, "single_accel.csv");
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend(std::fs::read(&plain).unwrap());
    std::fs::write(d.join("bom.csv"), bom).unwrap();
    let a = calibrate_single(d, &plain, &[]);
    let b = calibrate_single(d, &d.join("bom.csv"), &[]);
    assert_eq!(b.code(), Some(0), "{}", b.err);
    assert!(
        b.err
            .contains("bom.csv starts with a UTF-8 byte-order mark; it is ignored"),
        "{}",
        b.err
    );
    let body = |s: &str| s.lines().skip(1).collect::<Vec<_>>().join("\n");
    assert_eq!(body(&a.out), body(&b.out), "the same fit");
}

#[test]
fn negative_option_values_need_no_equals_sign() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = calflash(
        d,
        &[
            "simulate", "--sensor", "accel", "--plan", "tumble:6", "--temps", "-40,25", "-o",
            "t.csv",
        ],
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(r.out.contains("12 observations"), "{}", r.out);
}

#[test]
fn a_huge_line_is_not_echoed_whole() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("long.csv"),
        format!("input,output\n1,{}\n", "7".repeat(20_000_000)),
    )
    .unwrap();
    let r = calibrate_single(d, &d.join("long.csv"), &[]);
    assert_eq!(r.code(), Some(1));
    assert!(r.err.len() < 400, "{} bytes of error", r.err.len());
    assert!(
        r.err.contains("long.csv:2:2:") && r.err.contains("(20000000 bytes)"),
        "{}",
        r.err
    );
}
