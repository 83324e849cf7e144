//! Red team four: every reader of observations and recordings has a bound. An endless stream of
//! valid rows (a FIFO a logger never closes) is refused after 10^7 rows, naming the file, by
//! `fit`, `threshold`, `apply` (observations and recordings), `allan` and `calibrate`, instead
//! of aborting with "memory allocation of ... failed" once the memory runs out.

#![cfg(unix)]

mod common;

use std::io::Write as _;
use std::path::{Path, PathBuf};

use common::calflash;

/// A FIFO at `path` fed `header` and then `row` for ever by a thread, until its reader goes
/// away.
fn endless(path: &Path, header: &'static str, row: &'static str) -> std::thread::JoinHandle<u64> {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success());
    let path: PathBuf = path.to_path_buf();
    std::thread::spawn(move || {
        let Ok(mut f) = std::fs::OpenOptions::new().write(true).open(&path) else {
            return 0;
        };
        let block = row.repeat(4096);
        if f.write_all(header.as_bytes()).is_err() {
            return 0;
        }
        let mut rows = 0u64;
        while f.write_all(block.as_bytes()).is_ok() {
            rows += 4096;
        }
        rows
    })
}

fn refused(dir: &Path, name: &str, header: &'static str, row: &'static str, args: &[&str]) {
    let fifo = dir.join(name);
    let writer = endless(&fifo, header, row);
    let mut all: Vec<&str> = args.to_vec();
    for a in &mut all {
        if *a == "FIFO" {
            *a = name;
        }
    }
    let (code, out, err) = calflash(dir, &all);
    let rows = writer.join().unwrap();
    assert_ne!(code, 0, "{args:?}: {out}{err}");
    assert!(
        err.contains(&format!("{name}: more than 10000000 rows: read no further")),
        "{args:?}: {err}"
    );
    assert!(!err.contains("memory allocation"), "{err}");
    assert!(rows >= 10_000_000, "{args:?}: the writer wrote {rows} rows");
}

#[test]
fn an_endless_stream_of_rows_is_refused_by_every_reader_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obs = "input,output\n";
    refused(
        d,
        "fit.fifo",
        obs,
        "1,2\n",
        &["fit", "FIFO", "--model", "output ~ input"],
    );
    refused(
        d,
        "threshold.fifo",
        obs,
        "1,2\n",
        &["threshold", "FIFO", "--scale", "100"],
    );
    // calibrate reads a file's header before its rows (it opens it twice, so not a FIFO): a
    // file of 10^7 + 1 rows.
    let big = d.join("calibrate.csv");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&big).unwrap());
    f.write_all(obs.as_bytes()).unwrap();
    for k in 0..=10_000_000u32 {
        writeln!(f, "{},{}", k % 20, 30_000 + k % 20).unwrap();
    }
    drop(f);
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "calibrate.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "U-1",
            "--no-db",
        ],
    );
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("calibrate.csv: more than 10000000 rows: read no further"),
        "{err}"
    );
    std::fs::remove_file(&big).unwrap();
    refused(
        d,
        "calibrate.fifo",
        obs,
        "1,2\n",
        &["fit", "FIFO", "--model", "output ~ 1 + input"],
    );
    // A blob to apply: the example single accelerometer's.
    let example =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/single_accel.csv");
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            example.to_str().unwrap(),
            "--sensor",
            "single-accel",
            "--serial",
            "U-1",
            "--blob",
            "u1.blob",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    refused(
        d,
        "apply.fifo",
        "output\n",
        "32768\n",
        &["apply", "FIFO", "--blob", "u1.blob", "--output", "out.csv"],
    );
    assert!(!d.join("out.csv").exists(), "nothing half-written");
    // Recordings without timestamps: six counts a line, and the three-number lines that asked
    // for 4.29 GB at once.
    refused(
        d,
        "recording.fifo",
        "",
        "1,2,3,4,5,6\n",
        &["allan", "FIFO", "--sample-rate", "100"],
    );
    // (One sensor's file is read a second time when it is not both sensors', so it is a file
    // here, not a FIFO.)
    let three = d.join("three.csv");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&three).unwrap());
    for _ in 0..=10_000_000u32 {
        f.write_all(b"1,2,3\n").unwrap();
    }
    drop(f);
    let (code, out, err) = calflash(
        d,
        &[
            "allan",
            "three.csv",
            "--sample-rate",
            "100",
            "--sensor",
            "gyro",
        ],
    );
    assert_ne!(code, 0, "{out}{err}");
    assert!(
        err.contains("three.csv: more than 10000000 rows: read no further"),
        "{err}"
    );
}
