//! The task runner: `cargo xtask <task>`.
//!
//! - `test`: everything CI checks, on a fresh machine too (it installs what it needs).
//! - `bench`: instruction counts on the Cortex-M4F under QEMU `-icount`, code and RAM sizes,
//!   and the host criterion benchmarks.
//! - `bench-fit`: the regression engine against statsmodels, in the same run.
//! - `calibrate`: the main job, end to end, on the QEMU device.
//! - `unit`: the example unit on QEMU with its UART on a local TCP port, left running.
//! - `history`: a local PostgreSQL shared unit history, left running.
//! - `fuzz`: a longer fuzzing run of every target (`--secs N` each).
//! - `setup`: only the setup steps.
#![forbid(unsafe_code)]

mod bench;
mod calibrate;
mod disk;
mod fuzz;
mod guide;
mod history;
mod setup;
mod test;
mod unit;

use std::process::ExitCode;

const USAGE: &str =
    "usage: cargo xtask <test | bench | bench-fit | calibrate | unit | history | fuzz | guide | setup>

  test       rustfmt, clippy (host and thumb), docs, every host test and the QEMU tests;
             installs the thumb target and qemu-system-arm when missing
  bench      instruction counts on the Cortex-M4F (QEMU -icount), sizes, host benchmarks
  bench-fit  the regression engine at n = 10^4..10^6 by 10 terms, and statsmodels in the same run
  calibrate  the main job on the QEMU device
  unit       the example unit on QEMU, its UART on tcp://127.0.0.1:4444, left running
  history    a local PostgreSQL shared history on 127.0.0.1:5433, left running
  fuzz       every fuzz target for --secs N seconds (default 300), with executions and findings
  guide      build the guide (docs/) into target/book with mdBook (installed from the crate
             registry when missing) and check every link
  setup      add the thumb target and install qemu-system-arm, nothing else";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => test::run(),
        Some("bench") => bench::run(&args[1..]),
        Some("bench-fit") => bench::fit(),
        Some("calibrate") => calibrate::run(&args[1..]),
        Some("unit") => unit::run(&args[1..]),
        Some("history") => history::run(&args[1..]),
        Some("fuzz") => fuzz::command(&args[1..]),
        Some("guide") => match guide::check() {
            Ok(None) => Ok(()),
            Ok(Some(why)) => Err(why),
            Err(e) => Err(e),
        },
        Some("setup") => setup::run(true).map(|_| ()),
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            Ok(())
        }
        _ => Err(USAGE.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A task's options, each `--name VALUE`, as `(name, value)` pairs in their order; `-h` or
/// `--help` answers with `usage`, as does an option without its value.
fn options<'a>(args: &'a [String], usage: &str) -> Result<Vec<(&'a str, &'a str)>, String> {
    let mut out = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "-h" || a == "--help" {
            return Err(usage.to_string());
        }
        let value = it.next().ok_or(format!("{a} needs a value\n\n{usage}"))?;
        out.push((a.as_str(), value.as_str()));
    }
    Ok(out)
}

/// The repository root.
fn root() -> std::path::PathBuf {
    host_tests::qemu::root()
}

/// `cargo` as the one running us.
fn cargo() -> std::process::Command {
    let mut cmd =
        std::process::Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.current_dir(root());
    cmd
}
