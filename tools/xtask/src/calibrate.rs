//! `cargo xtask calibrate`: the main job, end to end, on the QEMU device.
//!
//! Simulates an IMU's test data (or takes `--data FILE`), calibrates it with `calflash`
//! (fit, report, blob, record), boots the example device firmware on QEMU mps2-an386, flashes
//! the calibration over the emulated UART, verifies it on the device (read-back and test vectors
//! through the device's own correction), and records fit and flash in the unit history.

use std::path::PathBuf;

use host_tests::mainjob::{self, Job};

use crate::setup;

const USAGE: &str = "usage: cargo xtask calibrate [--data FILE] [--out DIR] [--db FILE] [--seed N]

  --data FILE  IMU observations to calibrate (CSV, columns as `calflash simulate --sensor imu`
               writes them); default: a simulated unit
  --out DIR    where the observations, report, blob, record and device log go
               (default target/calibrate)
  --db FILE    the unit history database (default DIR/units.sqlite)
  --seed N     seed of the simulated unit (default 43)
  --codes C    the unit's converter codes: unsigned16 (default), signed16, any width from 8
               to 32 bits, or LO:HI";

fn parse(args: &[String]) -> Result<Job, String> {
    let mut data = None;
    let mut out = crate::root().join("target").join("calibrate");
    let mut db = None;
    let mut seed = 43;
    let mut codes = mainjob::DEFAULT_CODES;
    for (name, v) in crate::options(args, USAGE)? {
        match name {
            "--data" => data = Some(PathBuf::from(v)),
            "--out" => out = PathBuf::from(v),
            "--db" => db = Some(PathBuf::from(v)),
            "--seed" => {
                seed = v
                    .parse()
                    .map_err(|_| format!("--seed: expected a whole number, found `{v}`"))?;
            }
            "--codes" => {
                codes = mainjob::codes(v).map_err(|e| format!("--codes: {e}"))?;
            }
            other => return Err(format!("unknown option `{other}`\n\n{USAGE}")),
        }
    }
    let db = db.unwrap_or_else(|| out.join("units.sqlite"));
    Ok(Job {
        data,
        workdir: out,
        db,
        seed,
        codes,
    })
}

pub fn run(args: &[String]) -> Result<(), String> {
    let job = parse(args)?;
    if let Some(d) = &job.data
        && !d.is_file()
    {
        return Err(format!("--data {}: no such file", d.display()));
    }
    let setup = setup::run(false)?;
    if let Some(why) = setup.qemu_missing {
        return Err(format!("the QEMU device is not available: {why}"));
    }
    println!("xtask: the main job, on the QEMU Cortex-M4F device\n");
    let s = mainjob::run(&job, |l| println!("{l}"))?;
    println!();
    for l in &s.lines {
        println!("{l}");
    }
    Ok(())
}
