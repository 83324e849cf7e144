//! `calflash calibrate` over a directory: a batch on every core gives each unit exactly the
//! calibration one file at a time gives, a unit that fails does not stop the others (the exit
//! status and the table say which), and options of one unit are refused in a batch.

mod common;

use common::calflash;

fn simulate(d: &std::path::Path, file: &str, seed: u64) {
    let (code, out, err) = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:36",
            "--temps=-40,25,85",
            "--seed",
            &seed.to_string(),
            "-o",
            file,
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
}

/// The calibration in a blob, its creation time set aside.
fn calibration(path: &std::path::Path) -> spincal::model::CalibrationData {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut data = spincal::blob::decode(&bytes).unwrap().data().clone();
    data.identity.created_unix_s = 0;
    data
}

#[test]
fn a_batch_gives_each_unit_what_one_file_at_a_time_gives() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("in")).unwrap();
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::fs::create_dir_all(d.join("one")).unwrap();
    let serials: Vec<String> = (1..=6).map(|i| format!("ACC-{i:04}")).collect();
    for (i, s) in serials.iter().enumerate() {
        simulate(d, &format!("in/{s}.csv"), i as u64 + 1);
    }
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "in",
            "--sensor",
            "single-accel",
            "--out-dir",
            "out",
            "--reports",
            "--db",
            "units.sqlite",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("6 units on"), "{out}");
    for s in &serials {
        assert!(out.contains(s.as_str()), "{out}");
        for ext in ["blob", "json", "html", "txt"] {
            assert!(d.join(format!("out/{s}.{ext}")).is_file(), "{s}.{ext}");
        }
        let (code, o, e) = calflash(
            d,
            &[
                "calibrate",
                &format!("in/{s}.csv"),
                "--sensor",
                "single-accel",
                "--serial",
                s,
                "--blob",
                &format!("one/{s}.blob"),
                "--no-db",
            ],
        );
        assert_eq!(code, 0, "{o}{e}");
        assert_eq!(
            calibration(&d.join(format!("out/{s}.blob"))),
            calibration(&d.join(format!("one/{s}.blob"))),
            "{s}: the batch and one file at a time differ"
        );
    }
    let db = calflash::db::Db::open(&d.join("units.sqlite")).unwrap();
    for s in &serials {
        assert_eq!(db.history(s).unwrap().len(), 1, "{s}");
    }
}

#[test]
fn a_unit_that_fails_does_not_stop_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("out")).unwrap();
    simulate(d, "GOOD-1.csv", 1);
    simulate(d, "GOOD-2.csv", 2);
    std::fs::write(d.join("BAD-3.csv"), "output,input\n1,2\nnot,numbers\n").unwrap();
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "GOOD-1.csv",
            "BAD-3.csv",
            "GOOD-2.csv",
            "--sensor",
            "single-accel",
            "--out-dir",
            "out",
            "--no-db",
        ],
    );
    assert_eq!(code, 1, "{out}{err}");
    assert!(err.contains("1 of 3 units failed: BAD-3"), "{err}");
    assert!(out.contains("BAD-3") && out.contains("FAILED: "), "{out}");
    assert!(d.join("out/GOOD-1.blob").is_file() && d.join("out/GOOD-2.blob").is_file());
    assert!(!d.join("out/BAD-3.blob").exists());
    let said = std::fs::read_to_string(d.join("out/BAD-3.txt")).unwrap();
    assert!(said.contains("BAD-3.csv"), "{said}");
    // One unit's options in a batch, and a batch without --out-dir, are refused.
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "GOOD-1.csv",
            "GOOD-2.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--out-dir",
            "out",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("--serial names one unit's"), "{err}");
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "GOOD-1.csv",
            "GOOD-2.csv",
            "--sensor",
            "single-accel",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("give it"), "{err}");
    let (code, _, err) = calflash(d, &["calibrate", "GOOD-1.csv", "--sensor", "single-accel"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("--serial: the unit's serial number is required"),
        "{err}"
    );
}
