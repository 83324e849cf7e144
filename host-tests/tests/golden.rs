//! Golden byte vectors of the example blobs (single axis, triad, and six IMUs: full, linear,
//! without asymmetry, both of those without the lever arm, and the spinning round fitted by
//! `calflash`, flown at up to 300 Hz) and the correction outputs they must produce.
//!
//! A format or arithmetic change shows up here as a diff of checked-in files; accept a
//! deliberate change with `SPINCAL_ACCEPT=1 cargo test -p host-tests --test golden` and commit
//! the files. The QEMU test (`tests/qemu.rs`) holds the Cortex-M4F to the same vectors.

use host_tests::golden::{self, Step};
use spincal::blob;

fn accept() -> bool {
    std::env::var("SPINCAL_ACCEPT").is_ok_and(|v| v == "1")
}

#[test]
fn blobs_match_their_golden_bytes() {
    if accept() {
        golden::refit_spin_case();
    }
    for (name, data, _) in golden::examples() {
        let bytes = golden::encode(&data);
        let path = golden::dir().join(format!("{name}.blob"));
        if accept() {
            std::fs::write(&path, &bytes).unwrap();
        }
        let stored = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(
            bytes,
            stored,
            "{name}: encoding differs from {}",
            path.display()
        );
        let decoded = blob::decode(&stored).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            decoded.data(),
            &data,
            "{name}: golden blob decodes to other data"
        );
    }
}

#[test]
fn vectors_match_the_host_correction() {
    if accept() {
        golden::refit_spin_case();
    }
    for (name, data, kind) in golden::examples() {
        let case = golden::compute(name, &data, kind);
        let path = golden::dir().join(format!("{name}.vectors"));
        if accept() {
            std::fs::write(&path, golden::render(&case)).unwrap();
        }
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let stored = golden::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(stored.kind, case.kind);
        assert_eq!(stored.steps.len(), case.steps.len(), "{name}: step count");
        for (i, (got, want)) in case.steps.iter().zip(&stored.steps).enumerate() {
            match (got, want) {
                (Step::Env(a, b), Step::Env(c, d)) => {
                    assert_eq!(
                        (a.to_bits(), b.to_bits()),
                        (c.to_bits(), d.to_bits()),
                        "{name} step {i}"
                    );
                }
                _ => assert_eq!(got, want, "{name} step {i}"),
            }
        }
    }
}

#[test]
fn vectors_cover_every_flag() {
    let mut seen = 0u8;
    let mut clean = 0;
    for (name, _, _) in golden::examples() {
        let text = std::fs::read_to_string(golden::dir().join(format!("{name}.vectors"))).unwrap();
        for step in golden::parse(&text).unwrap().steps {
            if let Step::Sample { flags, .. } = step {
                seen |= flags;
                clean += usize::from(flags == 0);
            }
        }
    }
    // Everything but NO_CALIBRATION (the identity fallback has no blob) and
    // CALIBRATION_SUSPECT (the health check's vectors hold it).
    assert_eq!(seen, 0b1010_1111, "flags seen: {seen:#010b}");
    assert!(clean > 100, "only {clean} clean samples");
}

#[test]
fn parse_reports_the_line() {
    let err = golden::parse("blob a.blob\nkind triad\nraw 1 2 3 => 0 0 zz flags 00\n").unwrap_err();
    assert_eq!(err.line, 3);
    assert!(err.message.contains("hex"), "{err}");
}

/// The health check's vectors: the host's corrector and monitor over the stored raw samples
/// report the stored health, bit for bit; the cases reach DRIFTED (with the overlay) and
/// SUSPECT (with the flag).
#[test]
fn health_vectors_match_the_host_monitor() {
    use host_tests::health_golden;
    for (name, shift) in health_golden::cases() {
        let path = golden::dir().join(format!("{name}.vectors"));
        if accept() {
            let case = health_golden::compute(name, shift);
            std::fs::write(&path, health_golden::render(&case)).unwrap();
        }
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let stored =
            health_golden::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let bytes = std::fs::read(golden::dir().join(&stored.blob)).unwrap();
        let cal = blob::decode(&bytes).unwrap();
        let raw: Vec<[u16; 6]> = stored.steps.iter().map(|s| s.raw).collect();
        let steps = health_golden::run(&cal, stored.rate, &raw);
        for (i, (got, want)) in steps.iter().zip(&stored.steps).enumerate() {
            assert_eq!(got, want, "{name} step {i}");
        }
        let last = stored.steps.iter().rev().find_map(|s| s.check).unwrap();
        match name {
            "health_drifted" => assert_eq!(last.verdict, spincal::health::Verdict::Drifted as u8),
            _ => {
                assert_eq!(last.verdict, spincal::health::Verdict::Suspect as u8);
                assert_ne!(
                    last.flags & spincal::correct::Flags::CALIBRATION_SUSPECT.bits(),
                    0
                );
            }
        }
    }
}

/// A signed blob of the example IMU (`imu.signed`, key `station.pub`, seed `[1; 32]`, counter
/// 1), and the same at counter 2 (`imu2.signed`): what the device's benchmark verifies and
/// commits. The signature is deterministic (Ed25519).
#[test]
fn the_signed_example_matches_its_golden_bytes() {
    let key = ed25519_dalek::SigningKey::from_bytes(&[1; 32]);
    let public = spincal::signed::StationKey {
        public: key.verifying_key().to_bytes(),
    };
    let blob = golden::encode(&spincal::model::CalibrationData::example_imu());
    let bytes = calflash::signing::sign(&blob, &key, 1, false).unwrap();
    let (path, key_path) = (
        golden::dir().join("imu.signed"),
        golden::dir().join("station.pub"),
    );
    let second = calflash::signing::sign(&blob, &key, 2, false).unwrap();
    let second_path = golden::dir().join("imu2.signed");
    if accept() {
        std::fs::write(&path, &bytes).unwrap();
        std::fs::write(&second_path, &second).unwrap();
        std::fs::write(&key_path, public.public).unwrap();
    }
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
    assert_eq!(std::fs::read(&second_path).unwrap(), second);
    assert_eq!(std::fs::read(&key_path).unwrap(), public.public);
    let serial = spincal::model::CalibrationData::example_imu()
        .identity
        .serial;
    assert!(spincal::signed::verify(&bytes, &[public], &serial, 0).is_ok());
}
