//! `cargo xtask unit`: the example unit (QEMU mps2-an386, the `device` firmware) powered on
//! with its UART on a local TCP port, left running for `calflash ... --port tcp://...` from
//! another terminal, its calibration flash kept in a file across runs.

use std::io::BufRead as _;
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Duration;

use host_tests::qemu;
use host_tests::unit::QemuUnit;

use crate::setup;

const USAGE: &str = "usage: cargo xtask unit [--port N] [--serial S] [--flash FILE]

  --port N      the unit's UART on tcp://127.0.0.1:N (default 4444)
  --serial S    the unit's serial number, built into its firmware (default IMU-0042, the
                README's unit)
  --flash FILE  the unit's calibration flash, read at power-on and kept while it runs
                (default target/unit/SERIAL-flash.bin; delete it for a fresh, empty unit)

Runs until Enter is pressed or its input closes; the flash is saved every 2 s while it runs
(what a power cut then would leave) and at power-off.";

/// How often the running unit's flash is copied to its file.
const SAVE_EVERY: Duration = Duration::from_secs(2);

struct Job {
    port: u16,
    serial: String,
    flash: Option<PathBuf>,
}

fn parse(args: &[String]) -> Result<Job, String> {
    let mut job = Job {
        port: 4444,
        serial: "IMU-0042".into(),
        flash: None,
    };
    for (name, v) in crate::options(args, USAGE)? {
        match name {
            "--port" => {
                job.port = v
                    .strip_prefix("tcp://127.0.0.1:")
                    .unwrap_or(v)
                    .parse()
                    .map_err(|_| format!("--port: expected a TCP port number, found `{v}`"))?;
            }
            "--serial" => job.serial = v.to_string(),
            "--flash" => job.flash = Some(PathBuf::from(v)),
            other => return Err(format!("unknown option `{other}`\n\n{USAGE}")),
        }
    }
    if spincal::model::Serial::parse(&job.serial).is_none() {
        return Err(format!(
            "--serial: `{}` is not a unit's serial: 1 to {} printable ASCII characters",
            job.serial,
            spincal::model::SERIAL_CAPACITY
        ));
    }
    Ok(job)
}

pub fn run(args: &[String]) -> Result<(), String> {
    let job = parse(args)?;
    let setup = setup::run(false)?;
    if let Some(why) = setup.qemu_missing {
        return Err(format!("the QEMU unit is not available: {why}"));
    }
    let dir = crate::root().join("target").join("unit");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let flash = job
        .flash
        .unwrap_or_else(|| dir.join(format!("{}-flash.bin", job.serial)));
    println!(
        "xtask: building the example unit's firmware as {} (the first build takes minutes; cargo's progress below)",
        job.serial
    );
    let elf = qemu::build_firmware_shown(Some(&job.serial))?.join("device");
    let log = dir.join(format!("{}-qemu.log", job.serial));
    let mut unit = QemuUnit::power_on_at(&elf, Some(&flash), &log, Some(job.port))?;
    println!(
        "xtask: unit {} on tcp://127.0.0.1:{} (QEMU mps2-an386; its output in {}; its flash in {}{})",
        job.serial,
        job.port,
        log.display(),
        flash.display(),
        if flash.exists() {
            ""
        } else {
            ", erased: no calibration yet"
        }
    );
    println!("xtask: it runs until Enter is pressed (or this input closes); in another terminal:");
    println!(
        "  calflash flash --blob imu.blob --port tcp://127.0.0.1:{}",
        job.port
    );
    // Enter (or the end of the input) powers the unit off.
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::stdin().lock().read_line(&mut line);
        let _ = tx.send(());
    });
    while let Err(mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(SAVE_EVERY) {
        if !unit.running() {
            return Err(format!(
                "the QEMU unit stopped on its own (see {}); its flash as last saved is in {}",
                log.display(),
                flash.display()
            ));
        }
        unit.save_flash()?;
    }
    unit.power_off()?;
    println!(
        "xtask: unit {} powered off; its flash is in {}",
        job.serial,
        flash.display()
    );
    Ok(())
}
