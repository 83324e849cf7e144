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
