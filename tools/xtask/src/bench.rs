//! `cargo xtask bench`: instruction counts of the correction on the Cortex-M4F (QEMU
//! `-icount shift=10`, see `firmware/src/bin/bench.rs`), the code size of the correction path
//! from the firmware's symbol table, RAM, and the host criterion benchmarks.

use std::time::Duration;

use host_tests::qemu;
use object::{Object, ObjectSymbol};

use crate::{cargo, setup};

/// Sums the sizes of the ELF symbols whose demangled names satisfy `keep`.
fn symbol_sizes(elf: &[u8], keep: impl Fn(&str) -> bool) -> Result<Vec<(String, u64)>, String> {
    let file = object::File::parse(elf).map_err(|e| format!("bench ELF: {e}"))?;
    let mut out: Vec<(String, u64)> = file
        .symbols()
        .filter_map(|s| {
            let name = format!("{:#}", rustc_demangle::demangle(s.name().ok()?));
            keep(&name).then_some((name, s.size()))
        })
        .collect();
    out.sort();
    Ok(out)
}

pub fn run(args: &[String]) -> Result<(), String> {
    let host = !args.iter().any(|a| a == "--no-host");
    let setup = setup::run(false)?;
    if let Some(why) = setup.qemu_missing {
        return Err(format!("the Cortex-M4F benchmarks need QEMU: {why}"));
    }
    let bin = qemu::build_firmware()?;
    let elf = bin.join("bench");
    // The correction's benchmarks, then the flight filter's.
    let mut stdout = String::new();
    for name in ["bench", "bench_flight"] {
        let run = qemu::run(
            &bin.join(name),
            &["-icount", "shift=10"],
            Duration::from_secs(300),
        )?;
        if run.code != Some(0) {
            return Err(format!(
                "{name} firmware failed:\n{}{}",
                run.stdout, run.stderr
            ));
        }
        stdout.push_str(&run.stdout);
    }
    println!("Cortex-M4F (QEMU mps2-an386, -icount shift=10), release, thumbv7em-none-eabihf:\n");
    println!("| benchmark | instructions per operation | operations | total |");
    println!("|---|---:|---:|---:|");
    for line in stdout.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        if let ["bench", name, per, ops, total] = w[..] {
            println!("| {name} | {per} | {ops} | {total} |");
        }
    }
    println!("\n| RAM | bytes |\n|---|---:|");
    for line in stdout.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[..] {
            ["size", name, bytes] => println!("| size_of {name} | {bytes} |"),
            ["stack", name, bytes] => println!("| stack high-water of {name} | {bytes} |"),
            _ => {}
        }
    }
    let bytes = std::fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let syms = symbol_sizes(&bytes, |n| {
        n.starts_with("spincal::correct")
            || n.starts_with("bench::batch")
            || n.starts_with("bench::one")
            || n.starts_with("spincal_imu_")
    })?;
    println!("\n| .text of the correction path (symbol) | bytes |\n|---|---:|");
    for (name, size) in &syms {
        println!("| `{name}` | {size} |");
    }
    if host {
        println!("\nHost (criterion, this machine):\n");
        let ok = cargo()
            .args([
                "bench",
                "-p",
                "host-tests",
                "--bench",
                "correct",
                "--",
                "--noplot",
            ])
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return Err("host benchmarks failed".into());
        }
    }
    Ok(())
}

/// `cargo xtask bench-fit`: calflash's engine (criterion), then statsmodels on the same design
/// when Python has it (it says so and skips otherwise).
pub fn fit() -> Result<(), String> {
    let ok = cargo()
        .args([
            "bench", "-p", "calflash", "--bench", "fit", "--", "--noplot",
        ])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err("calflash fit benchmark failed".into());
    }
    let have = std::process::Command::new("python3")
        .args(["-c", "import statsmodels"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !have {
        println!(
            "statsmodels: SKIPPED, python3 cannot import statsmodels (pip install statsmodels)"
        );
        return Ok(());
    }
    let script = crate::root().join("tools/calflash/crosscheck/bench_statsmodels.py");
    let ok = std::process::Command::new("python3")
        .arg(script)
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        Ok(())
    } else {
        Err("statsmodels benchmark failed".into())
    }
}
