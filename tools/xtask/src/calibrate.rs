//! `cargo xtask calibrate`: the main job on the QEMU device.
//!
//! Until `calflash` can fit and flash a calibration, this boots the demo firmware on QEMU
//! mps2-an386: it decodes and validates the example IMU calibration blob on the Cortex-M4F,
//! corrects a stream of raw samples from a spinning unit and prints what it computed.

use std::time::Duration;

use host_tests::qemu;

use crate::setup;

pub fn run(_args: &[String]) -> Result<(), String> {
    let setup = setup::run(false)?;
    if let Some(why) = setup.qemu_missing {
        return Err(format!("the QEMU device is not available: {why}"));
    }
    println!("xtask: building the device firmware for {}", qemu::TARGET);
    let bin = qemu::build_firmware()?;
    println!("xtask: booting it on QEMU mps2-an386 (Cortex-M4F)\n");
    let run = qemu::run(&bin.join("demo"), &[], Duration::from_secs(120))?;
    print!("{}", run.stdout);
    if run.code != Some(0) {
        return Err(format!("the demo firmware failed:\n{}", run.stderr));
    }
    Ok(())
}
