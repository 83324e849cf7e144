//! Every command of the red-team tests runs under a watchdog: one that does not finish within
//! [`LIMIT`] is killed and the test fails naming it, so a hang is a failure, not a stuck CI.
//! Command lines are written as one string split at spaces (`cli`), or as arguments (`calflash`)
//! where one holds a space.
#![allow(dead_code)] // each test file uses its own part

use std::io::Read as _;
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Far above what any of these commands needs in a debug build.
pub const LIMIT: Duration = Duration::from_secs(120);

/// What a run of `calflash` gave.
pub struct Ran {
    pub status: ExitStatus,
    pub out: String,
    pub err: String,
}

impl Ran {
    pub fn code(&self) -> Option<i32> {
        self.status.code()
    }

    /// Asserts the exit code and that stderr holds `says`.
    pub fn expect(&self, code: i32, says: &str, what: &str) {
        assert_eq!(self.code(), Some(code), "{what}: {}{}", self.out, self.err);
        assert!(self.err.contains(says), "{what}: {}", self.err);
        assert!(!self.err.contains("panicked"), "{what}: {}", self.err);
    }
}

/// Runs `calflash` with the arguments of `line` (split at spaces) in `dir`.
pub fn cli(dir: &Path, line: &str) -> Ran {
    calflash(dir, &line.split_whitespace().collect::<Vec<_>>())
}

/// Runs `calflash args` in `dir` under the watchdog.
pub fn calflash(dir: &Path, args: &[&str]) -> Ran {
    calflash_with(dir, args, Stdio::piped())
}

pub fn calflash_with(dir: &Path, args: &[&str], stdout: Stdio) -> Ran {
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

/// Every file in `dir`, hidden ones included, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}
