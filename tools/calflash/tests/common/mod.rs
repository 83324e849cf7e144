//! Shared by the command-line tests.

use std::path::Path;
use std::process::Command;

/// Runs `calflash` with `args` in `dir`; returns its exit code, stdout and stderr.
pub fn calflash(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_calflash"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("calflash runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
