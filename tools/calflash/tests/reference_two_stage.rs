//! Two stages on units we did not make (`../shared/data/reference-flights/two-stage/`, an
//! independent forward model: quadratic temperature curves for bias and scale, K2 and K3,
//! sensing directions a few mrad off, 1-4 mm lever arms, g-sensitivity, 2 counts of noise).
//! Each unit is calibrated with the project README's commands: six stage-one records, then the
//! assembled unit. unit3's a_z scale factor changed by +726 ppm in assembly (5 times the check's
//! own standard error); every other bias and scale factor of the three units held.
//!
//! The test skips with a notice where `../shared` is absent (a user's clone).

mod common;

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/reference-flights/two-stage")
}

fn run(dir: &Path, args: &[&str]) -> (i32, String) {
    let (code, out, err) = common::calflash(dir, args);
    (code, format!("{out}{err}"))
}

/// The README's six stage-one commands and its stage-two command, in a copy of the unit's
/// folder; the unit's record.
fn calibrate(unit: &str, dir: &Path) -> (i32, String, serde_json::Value) {
    let from = root().join(unit);
    std::fs::create_dir_all(dir.join("s1")).unwrap();
    std::fs::copy(from.join("unit.csv"), dir.join("unit.csv")).unwrap();
    let (code, out) = run(dir, &["keygen", "station"]);
    assert_eq!(code, 0, "{out}");
    for s in ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"] {
        let csv = format!("s1/{s}.csv");
        std::fs::copy(from.join(&csv), dir.join(&csv)).unwrap();
        let sensor = if s.starts_with('a') {
            "single-accel"
        } else {
            "single-gyro"
        };
        let serial = format!("S{}-{s}", if s.starts_with('a') { "A" } else { "G" });
        let json = format!("s1/{s}.json");
        let (code, out) = run(
            dir,
            &[
                "calibrate",
                &csv,
                "--sensor",
                sensor,
                "--serial",
                &serial,
                "--keep-all-terms",
                "--asymmetry",
                "keep",
                "--thermal",
                "table",
                "--json",
                &json,
                "--no-db",
                "--sign-key",
                "station.key",
                "--counter",
                "1",
            ],
        );
        assert_eq!(code, 0, "{unit} {s}: stage one\n{out}");
    }
    let (code, out) = run(
        dir,
        &[
            "calibrate",
            "unit.csv",
            "--sensor",
            "imu",
            "--serial",
            "IMU-7",
            "--keep-all-terms",
            "--trust-key",
            "station.pub",
            "--stage-one",
            "s1/a_x.json,s1/a_y.json,s1/a_z.json,s1/g_x.json,s1/g_y.json,s1/g_z.json",
            "--blob",
            "unit.blob",
            "--json",
            "unit.json",
            "--no-db",
        ],
    );
    let record = std::fs::read_to_string(dir.join("unit.json"))
        .unwrap_or_else(|e| panic!("{unit}: no unit.json ({e})\n{out}"));
    (code, out, serde_json::from_str(&record).unwrap())
}

fn f(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// The changed sensor is named (its change within 3 of its standard error of the truth), the
/// others are held (each bias and scale change within 3 of its standard error of zero), and
/// every sensing direction is found within 0.5 mrad of the truth's (the truth's are 1.4 to 9 mrad
/// off their axes).
#[test]
fn the_reference_units_changed_sensor_is_named_and_the_others_held() {
    if !root().join("unit3/unit.csv").is_file() {
        println!(
            "reference two-stage units: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            root().display()
        );
        return;
    }
    for unit in ["unit1", "unit2", "unit3"] {
        let d = tempfile::tempdir().unwrap();
        let (code, out, record) = calibrate(unit, d.path());
        let truth: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(root().join(unit).join("unit_truth.json")).unwrap(),
        )
        .unwrap();
        let changed = |s: &str| unit == "unit3" && s == "a_z";
        // A moved sensor is a REVIEW with its blob written (only a REJECT exits non-zero); a
        // held unit is ACCEPT.
        let expect = if unit == "unit3" {
            ("review", 0)
        } else {
            ("accept", 0)
        };
        assert_eq!(
            (record["verdict"].as_str().unwrap(), code),
            expect,
            "{unit}\n{out}"
        );
        assert!(
            d.path().join("unit.blob").is_file(),
            "{unit}: no blob\n{out}"
        );
        let sensors = record["stages"]["sensors"].as_array().unwrap();
        assert_eq!(sensors.len(), 6, "{unit}");
        for s in sensors {
            let name = s["output"].as_str().unwrap();
            let t = &truth["sensors"][name];
            let ds = f(t, "assembly_scale_change_ds");
            assert_eq!(
                ds != 0.0,
                changed(name),
                "{unit} {name}: the truth's own statement"
            );
            assert_eq!(
                s["scale_moved"].as_bool().unwrap(),
                changed(name),
                "{unit} {name}: {s}\n{out}"
            );
            assert!(!s["bias_moved"].as_bool().unwrap(), "{unit} {name}: {s}");
            let z_scale = (f(s, "scale_change") - ds) / f(s, "scale_se");
            let z_bias = f(s, "bias_change") / f(s, "bias_se");
            assert!(
                z_scale.abs() < 3.0 && z_bias.abs() < 3.0,
                "{unit} {name}: scale change {:.3e} against the truth's {ds:.3e} (z {z_scale:.2}), \
                 bias change z {z_bias:.2}",
                f(s, "scale_change")
            );
            let n: Vec<f64> = t["sensing_direction_in_unit_axes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            let e: Vec<f64> = s["direction"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let cos = n.iter().zip(&e).map(|(a, b)| a * b).sum::<f64>() / (norm(&n) * norm(&e));
            let off = cos.clamp(-1.0, 1.0).acos();
            assert!(
                off < 5e-4,
                "{unit} {name}: sensing direction {:.3} mrad from the truth's",
                off * 1e3
            );
        }
        if unit == "unit3" {
            assert!(
                out.contains("REVIEW a_z") && out.contains("scale factor moved in assembly"),
                "unit3: the moved sensor is named in the summary\n{out}"
            );
        }
    }
}
