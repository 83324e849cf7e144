//! The station's keys from the command line: `keygen` writes a pair (the private one mode 600,
//! never overwritten), `sign` signs a blob with it (`--sign-key` or `$CALFLASH_SIGN_KEY`) and
//! refuses a key others can read; the unit's check accepts what it signed.

mod common;

use std::path::Path;

use common::calflash;

#[test]
fn keygen_then_sign_and_the_units_check_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            &bench.display().to_string(),
            "--sensor",
            "imu",
            "--serial",
            "IMU-S-1",
            "--blob",
            "u.blob",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = calflash(d, &["keygen", "station"]);
    assert_eq!(code, 0, "{out}{err}");
    let (code, _, err) = calflash(d, &["keygen", "station"]);
    assert_ne!(code, 0);
    assert!(err.contains("never overwritten"), "{err}");
    let (code, out, err) = calflash(
        d,
        &[
            "sign",
            "--blob",
            "u.blob",
            "--sign-key",
            "station.key",
            "--counter",
            "1",
            "-o",
            "u.signed",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("(75 over the blob)"), "{out}");
    let bytes = std::fs::read(d.join("u.signed")).unwrap();
    let public = calflash::signing::load_public(&d.join("station.pub")).unwrap();
    let unit = spincal::model::Serial::new("IMU-S-1").unwrap();
    assert!(spincal::signed::verify(&bytes, &[public], &unit, 0).is_ok());
    // The key from the environment; no key at all is named.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"))
        .current_dir(d)
        .env("CALFLASH_SIGN_KEY", d.join("station.key"))
        .args([
            "sign",
            "--blob",
            "u.blob",
            "--counter",
            "2",
            "-o",
            "u2.signed",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"))
        .current_dir(d)
        .env_remove("CALFLASH_SIGN_KEY")
        .args([
            "sign",
            "--blob",
            "u.blob",
            "--counter",
            "2",
            "-o",
            "u3.signed",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--sign-key"));
    // A signed blob is not signed again; a key others can read is refused.
    let (code, _, err) = calflash(
        d,
        &[
            "sign",
            "--blob",
            "u.signed",
            "--sign-key",
            "station.key",
            "--counter",
            "3",
            "-o",
            "x",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("signed already"), "{err}");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(
            d.join("station.key"),
            std::fs::Permissions::from_mode(0o640),
        )
        .unwrap();
        let (code, _, err) = calflash(
            d,
            &[
                "sign",
                "--blob",
                "u.blob",
                "--sign-key",
                "station.key",
                "--counter",
                "3",
                "-o",
                "y",
            ],
        );
        assert_ne!(code, 0);
        assert!(err.contains("readable by others"), "{err}");
        assert!(!d.join("y").exists());
    }
}

/// `calibrate --sign-key` signs the blob at one above the highest counter the unit's history
/// holds (or `--counter`), never a REJECT; `image --station-key` writes the keys sector a
/// flasher provisions the unit with, and refuses a blob such a unit would not boot.
#[test]
fn calibrate_signs_from_the_history_and_image_provisions_the_unit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let bench = bench.display().to_string();
    let (code, out, err) = calflash(d, &["keygen", "station"]);
    assert_eq!(code, 0, "{out}{err}");
    let public = calflash::signing::load_public(&d.join("station.pub")).unwrap();
    let unit = spincal::model::Serial::new("IMU-S-2").unwrap();
    let calibrate = |blob: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "IMU-S-2",
            "--blob",
            blob,
            "--db",
            "units.sqlite",
            "--sign-key",
            "station.key",
        ];
        args.extend_from_slice(extra);
        calflash(d, &args)
    };
    for (blob, counter) in [("a.blob", 1), ("b.blob", 2)] {
        let (code, out, err) = calibrate(blob, &[]);
        assert_eq!(code, 0, "{out}{err}");
        assert!(out.contains(&format!("counter {counter}")), "{out}");
        let bytes = std::fs::read(d.join(blob)).unwrap();
        let v = spincal::signed::verify(&bytes, &[public], &unit, counter - 1).unwrap();
        assert_eq!(v.counter, counter);
    }
    let (code, out, err) = calibrate("c.blob", &["--counter", "40"]);
    assert_eq!(code, 0, "{out}{err}");
    let bytes = std::fs::read(d.join("c.blob")).unwrap();
    assert_eq!(
        spincal::signed::verify(&bytes, &[public], &unit, 39)
            .unwrap()
            .counter,
        40
    );
    let (code, out, err) = calibrate("d.blob", &["--no-db"]);
    assert_ne!(code, 0, "{out}");
    assert!(err.contains("give --counter"), "{err}");
    assert!(!d.join("d.blob").exists());

    // The flasher's image: keys sector and slot 0.
    let image = |blob: &str, bin: &str| {
        calflash(
            d,
            &[
                "image",
                "--blob",
                blob,
                "--station-key",
                "station.pub",
                "--bin",
                bin,
            ],
        )
    };
    let (code, out, err) = image("c.blob", "unit.bin");
    assert_eq!(code, 0, "{out}{err}");
    let bytes = std::fs::read(d.join("unit.bin")).unwrap();
    let region = calflash::device::image::Region::from_memory_x();
    assert_eq!(bytes.len(), region.bytes() as usize);
    let at = region.keys_offset() as usize;
    let keys: &[u8; spincal::store::KEYS_SPAN] = bytes[at..at + spincal::store::KEYS_SPAN]
        .try_into()
        .unwrap();
    assert_eq!(spincal::store::Provisioning::read(keys).keys(), &[public]);
    // An unsigned blob for a provisioned unit: refused, nothing written.
    std::fs::write(
        d.join("u.blob"),
        spincal::signed::parts(&std::fs::read(d.join("c.blob")).unwrap()).0,
    )
    .unwrap();
    let (code, _, err) = image("u.blob", "bad.bin");
    assert_ne!(code, 0);
    assert!(
        err.contains("would not boot it") && err.contains("--sign-key"),
        "{err}"
    );
    assert!(!d.join("bad.bin").exists());
}
