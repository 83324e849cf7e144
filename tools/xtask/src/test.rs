//! `cargo xtask test`: every check CI runs, all of them, failures reported together.

use std::process::Command;
use std::time::Instant;

use host_tests::qemu::{REQUIRE_ENV, TARGET};

use crate::{cargo, disk, root, setup};

struct Step {
    name: &'static str,
    cmd: Command,
}

fn step(name: &'static str, args: &[&str]) -> Step {
    let mut cmd = cargo();
    cmd.args(args);
    // A whole run builds everything once: incremental state would only add ~1 GB to the disk.
    // A setting of the caller's own wins.
    if std::env::var_os("CARGO_INCREMENTAL").is_none() {
        cmd.env("CARGO_INCREMENTAL", "0");
    }
    Step { name, cmd }
}

/// Prints the free space under the builds; warns when it is below what a fresh run writes.
fn report_disk(when: &str) -> Option<u64> {
    let free = disk::free_bytes(&root())?;
    let warning = if free < disk::NEEDED_BYTES {
        format!(
            " (a fresh run writes about {}: builds may fail for want of space)",
            disk::human(disk::NEEDED_BYTES)
        )
    } else {
        String::new()
    };
    println!(
        "xtask: {} free on the build disk {when}{warning}",
        disk::human(free)
    );
    Some(free)
}

pub fn run() -> Result<(), String> {
    let setup = setup::run(true)?;
    report_disk("at the start");
    let mut steps = vec![
        step("rustfmt", &["fmt", "--all", "--check"]),
        {
            let mut s = step("rustfmt (firmware)", &["fmt", "--check"]);
            s.cmd.current_dir(root().join("firmware"));
            s
        },
        {
            let mut s = step("rustfmt (fuzz)", &["fmt", "--check"]);
            s.cmd.current_dir(root().join("fuzz"));
            s
        },
        step(
            "clippy (host)",
            &[
                "clippy",
                "--workspace",
                "--all-targets",
                "--",
                "-D",
                "warnings",
            ],
        ),
        step(
            "clippy (calflash with probe-rs, built not run)",
            &[
                "clippy",
                "-p",
                "calflash",
                "--features",
                "probe",
                "--",
                "-D",
                "warnings",
            ],
        ),
        step(
            "clippy (thumb, no default features)",
            &[
                "clippy",
                "-p",
                "spincal",
                "--target",
                TARGET,
                "--no-default-features",
                "--",
                "-D",
                "warnings",
            ],
        ),
        step(
            "clippy (thumb, defmt)",
            &[
                "clippy",
                "-p",
                "spincal",
                "--target",
                TARGET,
                "--features",
                "defmt",
                "--",
                "-D",
                "warnings",
            ],
        ),
        {
            let mut s = step(
                "clippy (firmware)",
                &[
                    "clippy",
                    "--release",
                    "--target",
                    TARGET,
                    "--",
                    "-D",
                    "warnings",
                ],
            );
            s.cmd.current_dir(root().join("firmware"));
            s
        },
        step(
            "build (thumb, no default features)",
            &[
                "build",
                "-p",
                "spincal",
                "--target",
                TARGET,
                "--no-default-features",
            ],
        ),
        {
            let mut s = step("docs", &["doc", "--workspace", "--no-deps"]);
            s.cmd.env("RUSTDOCFLAGS", "-D warnings");
            s
        },
        {
            // Every test binary runs, whatever fails before it: one failure must not hide others.
            let mut s = step(
                "tests (host and QEMU)",
                &["test", "--workspace", "--no-fail-fast"],
            );
            if setup.qemu_missing.is_none() {
                s.cmd.env(REQUIRE_ENV, "1");
            }
            if setup.postgres_missing.is_none() {
                s.cmd.env("SPINCAL_REQUIRE_POSTGRES", "1");
            }
            if setup.chromium_missing.is_none() {
                s.cmd.env("SPINCAL_REQUIRE_CHROMIUM", "1");
            }
            s
        },
    ];
    let mut failed = Vec::new();
    let total = Instant::now();
    for s in &mut steps {
        println!("\n=== xtask test: {} ===", s.name);
        let start = Instant::now();
        let ok = s.cmd.status().is_ok_and(|st| st.success());
        println!(
            "=== {}: {} in {:.0?} ===",
            s.name,
            if ok { "ok" } else { "FAILED" },
            start.elapsed()
        );
        if !ok {
            failed.push(s.name);
        }
    }
    println!("\n=== xtask test: fuzz smoke (cargo +nightly fuzz, a minute in total) ===");
    let start = Instant::now();
    let fuzz = crate::fuzz::smoke();
    let fuzz_line = match &fuzz {
        Ok(None) => "ok".to_string(),
        Ok(Some(why)) => format!("SKIPPED: {why}"),
        Err(e) => {
            failed.push("fuzz smoke");
            format!("FAILED: {e}")
        }
    };
    println!("=== fuzz smoke: {fuzz_line} in {:.0?} ===", start.elapsed());
    println!("\n=== xtask test: the guide (mdbook build docs, then every link) ===");
    let start = Instant::now();
    let guide = crate::guide::check();
    let guide_line = match &guide {
        Ok(None) => "ok".to_string(),
        Ok(Some(why)) => format!("SKIPPED: {why}"),
        Err(e) => {
            failed.push("the guide");
            format!("FAILED: {e}")
        }
    };
    println!("=== the guide: {guide_line} in {:.0?} ===", start.elapsed());
    println!("\n=== summary ({:.0?}) ===", total.elapsed());
    for s in &steps {
        println!(
            "  {:<40} {}",
            s.name,
            if failed.contains(&s.name) {
                "FAILED"
            } else {
                "ok"
            }
        );
    }
    println!("  {:<40} {fuzz_line}", "fuzz smoke");
    println!("  {:<40} {guide_line}", "the guide (mdbook)");
    if let Some(free) = report_disk("at the end")
        && !failed.is_empty()
        && free < (1 << 30)
    {
        println!("xtask: the disk is (nearly) full: a failed build may be that, not the code");
    }
    if let Some(why) = &setup.qemu_missing {
        println!("  {:<40} SKIPPED: {why}", "QEMU tests");
    }
    if let Some(why) = &setup.postgres_missing {
        println!("  {:<40} SKIPPED: {why}", "PostgreSQL tests");
    }
    if let Some(why) = &setup.chromium_missing {
        println!("  {:<40} SKIPPED: {why}", "reports in a browser");
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} of {} steps failed: {}",
            failed.len(),
            steps.len() + 2,
            failed.join(", ")
        ))
    }
}
