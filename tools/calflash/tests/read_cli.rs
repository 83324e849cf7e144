//! `calflash read --port`: what a unit holds, read without writing to it (red team four: a
//! station had no way to ask a unit's serial, blob hash, counter or slots before or after a
//! flash). On the device's protocol handler over a simulated NOR flash (the QEMU unit's own
//! test, `host-tests/tests/unit_on_port.rs`, reads the real firmware the same way).
#![allow(dead_code)] // the modules below are shared with other test crates

#[path = "../../../host-tests/src/nor.rs"]
mod nor;
#[path = "../../../host-tests/src/tcp_unit.rs"]
mod tcp_unit;

mod common;

use common::calflash;
use sha2::Digest as _;

#[test]
fn read_says_what_a_unit_holds_before_and_after_a_flash_and_writes_nothing_to_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let port =
        tcp_unit::TcpUnit::serve_forever(tcp_unit::device(tcp_unit::blank_flash(), "IMU-0042"));
    // Before: no calibration, both slots empty; -o refuses and writes no file.
    let (code, out, err) = calflash(d, &["read", "--port", &port]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("unit IMU-0042 (an IMU)"), "{out}");
    assert!(out.contains("no calibration"), "{out}");
    assert!(
        out.contains("slots: A ") && !out.contains("valid (sequence"),
        "{out}"
    );
    let (code, _, err) = calflash(d, &["read", "--port", &port, "-o", "none.blob"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("holds no calibration; nothing written to none.blob"),
        "{err}"
    );
    assert!(!d.join("none.blob").exists());
    // A calibration flashed.
    let example =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            example.to_str().unwrap(),
            "--sensor",
            "imu",
            "--serial",
            "IMU-0042",
            "--blob",
            "u.blob",
            "--no-db",
        ],
    );
    assert!(code == 0 && d.join("u.blob").exists(), "{out}{err}");
    let (code, out, err) = calflash(
        d,
        &["flash", "--blob", "u.blob", "--port", &port, "--no-db"],
    );
    assert_eq!(code, 0, "{out}{err}");
    // After: the blob read back, byte for byte, and its hash stated.
    let (code, out, err) = calflash(d, &["read", "--port", &port, "-o", "back.blob", "--json"]);
    assert_eq!(code, 0, "{out}{err}");
    let flashed = std::fs::read(d.join("u.blob")).unwrap();
    assert_eq!(std::fs::read(d.join("back.blob")).unwrap(), flashed);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let sha: String = sha2::Sha256::digest(&flashed)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(v["blob_sha256"], sha.as_str(), "{v}");
    assert_eq!(v["calibration"], "IMU-0042");
    assert_eq!(v["blob_len"], flashed.len());
    assert_eq!(v["unit"], "IMU-0042");
    assert_eq!(v["locked"], false);
    let valid = v["slots"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["state"] == "valid")
        .count();
    assert_eq!(valid, 1, "{v}");
    // Reading wrote nothing: the same again.
    let (code, again, _) = calflash(d, &["read", "--port", &port, "--json"]);
    assert_eq!(code, 0);
    assert_eq!(again, out);
    // A unit that does not answer is named.
    let (code, _, err) = calflash(
        d,
        &["read", "--port", "tcp://127.0.0.1:1", "--timeout", "0.5"],
    );
    assert_eq!(code, 1);
    assert!(err.contains("tcp://127.0.0.1:1"), "{err}");
}
