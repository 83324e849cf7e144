//! Building the thumb firmware and running it under `qemu-system-arm` (mps2-an386).

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The firmware target.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// Set to `1` to make a missing QEMU or thumb target a failure instead of a skip (CI does).
pub const REQUIRE_ENV: &str = "SPINCAL_REQUIRE_QEMU";

/// The repository root: the nearest folder above the crate that holds the firmware (this
/// module is also taken by path into calflash's README test, two floors further down).
#[must_use]
pub fn root() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.ancestors()
        .find(|d| d.join("firmware").join("Cargo.toml").is_file())
        .unwrap_or_else(|| here.parent().expect("the crate sits in the repository"))
        .to_path_buf()
}

/// Why QEMU tests cannot run here, if they cannot.
#[must_use]
pub fn unavailable() -> Option<String> {
    let qemu = Command::new("qemu-system-arm").arg("--version").output();
    if !matches!(qemu, Ok(ref o) if o.status.success()) {
        return Some(
            "qemu-system-arm is not installed (Debian: apt-get install -y qemu-system-arm)".into(),
        );
    }
    let targets = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output();
    match targets {
        Ok(o)
            if String::from_utf8_lossy(&o.stdout)
                .lines()
                .any(|l| l.trim() == TARGET) =>
        {
            None
        }
        Ok(_) => Some(format!(
            "the {TARGET} target is not installed (rustup target add {TARGET})"
        )),
        // Without rustup the toolchain may still have the target; let the build tell.
        Err(_) => None,
    }
}

/// Returns `true` when the test should run; prints a notice and returns `false` when QEMU
/// tests cannot run here and are not required; panics when they are required.
///
/// # Panics
/// When `SPINCAL_REQUIRE_QEMU=1` and QEMU or the target is missing.
#[must_use]
pub fn available_or_skip(test: &str) -> bool {
    match unavailable() {
        None => true,
        Some(why) if std::env::var(REQUIRE_ENV).is_ok_and(|v| v == "1") => {
            panic!("{test}: {why}, and {REQUIRE_ENV}=1 requires it")
        }
        Some(why) => {
            eprintln!("SKIPPED {test}: {why}");
            false
        }
    }
}

/// Builds the firmware workspace in release mode and returns the directory of its binaries.
///
/// # Errors
/// The build's output when it fails.
pub fn build_firmware() -> Result<PathBuf, String> {
    build_firmware_as(None)
}

/// [`build_firmware`] for a unit whose serial number is `serial` (the example device's
/// `SPINCAL_UNIT_SERIAL`): its `device` binary alone, built in a target directory of its own
/// (`firmware/target/unit-SERIAL`) so that the tests' QEMU-0001 build is left as it is.
///
/// # Errors
/// When cargo fails; its stderr is in the message.
pub fn build_firmware_as(serial: Option<&str>) -> Result<PathBuf, String> {
    build_firmware_with(serial, false)
}

/// [`build_firmware_as`] with cargo's own progress on the terminal (`cargo xtask unit`: a first
/// build takes minutes, and a person waits for it).
///
/// # Errors
/// When cargo fails (its messages were on the terminal).
pub fn build_firmware_shown(serial: Option<&str>) -> Result<PathBuf, String> {
    build_firmware_with(serial, true)
}

fn build_firmware_with(serial: Option<&str>, shown: bool) -> Result<PathBuf, String> {
    let dir = root().join("firmware");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&dir)
        .args(["build", "--release", "--target", TARGET])
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR");
    // A unit of its own runs only the device's firmware; the tests' build makes every binary.
    let target = match serial {
        Some(s) => {
            let t = dir.join("target").join(format!("unit-{s}"));
            cmd.args(["--bin", "device"])
                .env("SPINCAL_UNIT_SERIAL", s)
                .env("CARGO_TARGET_DIR", &t);
            t
        }
        None => {
            cmd.arg("--bins");
            dir.join("target")
        }
    };
    if shown {
        let status = cmd
            .stderr(std::process::Stdio::inherit())
            .status()
            .map_err(|e| format!("cannot run cargo: {e}"))?;
        if !status.success() {
            return Err("firmware build failed (cargo's messages above)".into());
        }
        return Ok(target.join(TARGET).join("release"));
    }
    let out = cmd.output().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "firmware build failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(target.join(TARGET).join("release"))
}

/// What a QEMU run printed and how it ended.
#[derive(Debug)]
pub struct Run {
    /// Exit code (the firmware's semihosting exit status), `None` when killed.
    pub code: Option<i32>,
    /// Everything printed on the semihosting console and the serial port.
    pub stdout: String,
    /// QEMU's own complaints.
    pub stderr: String,
}

/// The QEMU command line for a firmware ELF, with `extra` arguments before `-kernel`.
#[must_use]
pub fn command(elf: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-cpu",
        "cortex-m4",
        "-machine",
        "mps2-an386",
        "-nographic",
        "-monitor",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
    ])
    .args(extra)
    .arg("-kernel")
    .arg(elf);
    cmd
}

/// Runs `elf` under QEMU until it exits or `timeout` passes (then it is killed).
///
/// # Errors
/// When QEMU cannot be started.
pub fn run(elf: &Path, extra: &[&str], timeout: Duration) -> Result<Run, String> {
    let mut child = command(elf, extra)
        .arg("-serial")
        .arg("null")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let mut stdout = child.stdout.take().expect("piped");
    let mut stderr = child.stderr.take().expect("piped");
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status.code();
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ok(Run {
        code,
        stdout: out_thread.join().unwrap_or_default(),
        stderr: err_thread.join().unwrap_or_default(),
    })
}
