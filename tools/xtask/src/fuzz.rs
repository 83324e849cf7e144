//! Fuzzing with `cargo +nightly fuzz`: a smoke run of every target in `cargo xtask test`
//! (a minute at most in total), and `cargo xtask fuzz --secs N` for a longer run whose
//! executions and findings are printed for BENCHMARKS.md / RELIABILITY.md.
//!
//! Needs the nightly toolchain; installs `cargo-fuzz` from crates.io when it is missing. When
//! either cannot be had, it says so and the step is skipped, never passed.

use std::process::{Command, Stdio};
use std::time::Instant;

use crate::root;

/// The targets in `fuzz/fuzz_targets/`.
pub const TARGETS: [&str; 5] = [
    "blob_decode",
    "frame_decode",
    "store_flash",
    "device_session",
    "signed_verify",
];

/// What one target's run did.
pub struct Outcome {
    pub target: &'static str,
    pub runs: u64,
    pub secs: u64,
    pub corpus: usize,
    pub crashed: bool,
}

fn nightly_cargo() -> Command {
    let mut c = Command::new("cargo");
    c.arg("+nightly").current_dir(root().join("fuzz"));
    // The outer `cargo xtask` sets these for the stable toolchain; the nightly one chooses its own.
    for v in [
        "RUSTC",
        "RUSTDOC",
        "CARGO",
        "RUSTUP_TOOLCHAIN",
        "CARGO_TARGET_DIR",
    ] {
        c.env_remove(v);
    }
    c
}

/// Whether fuzzing can run here; `Err(reason)` when it cannot (the step is then skipped).
pub fn ready() -> Result<(), String> {
    let quiet = |c: &mut Command| {
        c.stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if !quiet(nightly_cargo().arg("--version")) {
        return Err(
            "the nightly toolchain is not installed (rustup toolchain install nightly)".into(),
        );
    }
    if quiet(nightly_cargo().args(["fuzz", "--version"])) {
        return Ok(());
    }
    println!(
        "xtask: cargo-fuzz is missing; installing it from crates.io (cargo install cargo-fuzz --locked)"
    );
    let installed = Command::new("cargo")
        .args(["install", "cargo-fuzz", "--locked"])
        .env_remove("RUSTUP_TOOLCHAIN")
        .status()
        .is_ok_and(|s| s.success());
    if installed && quiet(nightly_cargo().args(["fuzz", "--version"])) {
        Ok(())
    } else {
        Err("cargo-fuzz is not installed and `cargo install cargo-fuzz --locked` failed".into())
    }
}

/// Builds the targets and runs each for `secs` seconds from its committed seeds, writing new
/// inputs to a scratch corpus (the checkout is left as it was). Findings go to
/// `fuzz/artifacts/TARGET/`.
///
/// # Errors
/// When the build fails or a target cannot be started.
pub fn run(secs: u64) -> Result<Vec<Outcome>, String> {
    println!("xtask: building the fuzz targets (cargo +nightly fuzz build)");
    let built = nightly_cargo()
        .args(["fuzz", "build"])
        .status()
        .map_err(|e| e.to_string())?;
    if !built.success() {
        return Err("cargo +nightly fuzz build failed".into());
    }
    let scratch = root().join("target").join("fuzz-corpus");
    let mut out = Vec::new();
    for target in TARGETS {
        let corpus = scratch.join(target);
        std::fs::create_dir_all(&corpus).map_err(|e| format!("{}: {e}", corpus.display()))?;
        let seeds = root().join("fuzz").join("corpus").join(target);
        let mut cmd = nightly_cargo();
        cmd.args(["fuzz", "run", target]).arg(&corpus);
        if seeds.is_dir() {
            cmd.arg(&seeds);
        }
        cmd.arg("--")
            .arg(format!("-max_total_time={secs}"))
            .arg("-print_final_stats=1");
        let start = Instant::now();
        let result = cmd
            .output()
            .map_err(|e| format!("cannot run the fuzz target {target}: {e}"))?;
        let log = String::from_utf8_lossy(&result.stderr);
        let runs = log
            .lines()
            .find_map(|l| l.strip_prefix("stat::number_of_executed_units:"))
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0);
        let crashed = !result.status.success();
        if crashed {
            let tail: Vec<&str> = log.lines().rev().take(40).collect();
            println!("xtask: fuzz target {target} FOUND A FAILURE:");
            for l in tail.iter().rev() {
                println!("  {l}");
            }
        }
        let corpus_len = std::fs::read_dir(&corpus).map_or(0, Iterator::count);
        let o = Outcome {
            target,
            runs,
            secs: start.elapsed().as_secs(),
            corpus: corpus_len,
            crashed,
        };
        println!(
            "xtask: fuzz {:<15} {:>10} executions in {:>4} s, corpus {:>5}, {}",
            o.target,
            o.runs,
            o.secs,
            o.corpus,
            if o.crashed {
                "FAILURE (see fuzz/artifacts)"
            } else {
                "no findings"
            }
        );
        out.push(o);
    }
    Ok(out)
}

/// `cargo xtask fuzz [--secs N]`.
pub fn command(args: &[String]) -> Result<(), String> {
    let secs =
        match args {
            [] => 300,
            [flag, v] if flag == "--secs" => v
                .parse()
                .map_err(|_| format!("--secs: expected whole seconds, found `{v}`"))?,
            _ => return Err(
                "usage: cargo xtask fuzz [--secs N]   (each target runs N seconds; default 300)"
                    .into(),
            ),
        };
    ready()?;
    let outcomes = run(secs)?;
    let crashed: Vec<&str> = outcomes
        .iter()
        .filter(|o| o.crashed)
        .map(|o| o.target)
        .collect();
    if crashed.is_empty() {
        Ok(())
    } else {
        Err(format!("fuzzing found failures in {}", crashed.join(", ")))
    }
}

/// The `cargo xtask test` step: `Ok(None)` passed, `Ok(Some(reason))` skipped, `Err` failed.
pub fn smoke() -> Result<Option<String>, String> {
    if let Err(why) = ready() {
        return Ok(Some(why));
    }
    // A minute at most in total across the targets.
    let each = 60 / TARGETS.len() as u64;
    let outcomes = run(each)?;
    let crashed: Vec<&str> = outcomes
        .iter()
        .filter(|o| o.crashed)
        .map(|o| o.target)
        .collect();
    if crashed.is_empty() {
        Ok(None)
    } else {
        Err(format!("fuzzing found failures in {}", crashed.join(", ")))
    }
}
