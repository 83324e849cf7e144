//! Issue 68: a report a reviewer can tie to the bytes it describes. Every page carries where it
//! comes from (time, calflash's version and commit, station, operator, command line, the
//! SHA-256 of each input and of the blob) and a seal; `calflash verify-report` accepts a page
//! with its own bytes and refuses it, naming the file, with one byte changed in the blob, the
//! data or the page.

mod common;

use common::calflash;

#[test]
fn a_report_belongs_to_its_own_bytes_and_to_no_others() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/data/single_accel.csv");
    std::fs::copy(&example, d.join("data.csv")).unwrap();
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "data.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "ACC-9",
            "--blob",
            "u.blob",
            "--report",
            "u.html",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let html = std::fs::read_to_string(d.join("u.html")).unwrap();
    let p = calflash::report::provenance::read(&html).unwrap();
    assert_eq!(p.serial.as_deref(), Some("ACC-9"));
    assert!(p.command.contains("calibrate data.csv"), "{}", p.command);
    assert_eq!(p.inputs[0].path, "data.csv");
    assert_eq!(p.blob.as_ref().unwrap().path, "u.blob");
    assert!(html.contains("Where this page comes from"));
    let verify = |page: &str, blob: &str, data: &str| {
        calflash(d, &["verify-report", page, "--blob", blob, "--data", data])
    };
    let (code, out, err) = verify("u.html", "u.blob", "data.csv");
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("u.html: BELONGS") && out.contains("for unit ACC-9"),
        "{out}"
    );
    // One byte changed in each of the three.
    let flipped = |from: &str, to: &str, at: usize| {
        let mut b = std::fs::read(d.join(from)).unwrap();
        b[at] ^= 0x01;
        std::fs::write(d.join(to), b).unwrap();
    };
    flipped("u.blob", "v.blob", 40);
    let (code, out, _) = verify("u.html", "v.blob", "data.csv");
    assert_eq!(code, 3, "{out}");
    assert!(out.contains("DOES NOT BELONG: v.blob: SHA-256"), "{out}");
    assert!(out.contains("written as u.blob"), "{out}");
    flipped("data.csv", "other.csv", 100);
    let (code, out, _) = verify("u.html", "u.blob", "other.csv");
    assert_eq!(code, 3, "{out}");
    assert!(out.contains("DOES NOT BELONG: other.csv: SHA-256"), "{out}");
    let at = html.find("<h1>").unwrap() + 5;
    flipped("u.html", "w.html", at);
    let (code, out, _) = verify("w.html", "u.blob", "data.csv");
    assert_eq!(code, 3, "{out}");
    assert!(
        out.contains("the page was changed after calflash made it"),
        "{out}"
    );
    // `pdf -o` never writes over the report it prints.
    let (code, _, err) = calflash(d, &["pdf", "u.html", "-o", "u.html"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("-o u.html: that is the file the report reads"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(d.join("u.html")).unwrap(), html);
    // A page without a block is named as such.
    std::fs::write(d.join("bare.html"), "<html><body></body></html>").unwrap();
    let (code, out, _) = verify("bare.html", "u.blob", "data.csv");
    assert_eq!(code, 3);
    assert!(out.contains("has no provenance block"), "{out}");
}

/// The page names the unit history's record of the calibration it shows (issue 68: "no page
/// gives the history's record id"), under its seal, and `verify-report` says it; a second
/// calibration's page names the second record.
#[test]
fn a_calibration_page_names_its_history_record() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/data/single_accel.csv");
    std::fs::copy(&example, d.join("data.csv")).unwrap();
    for (k, page) in [(1, "a.html"), (2, "b.html")] {
        let (code, out, err) = calflash(
            d,
            &[
                "calibrate",
                "data.csv",
                "--sensor",
                "single-accel",
                "--serial",
                "ACC-9",
                "--blob",
                "u.blob",
                "--report",
                page,
                "--db",
                "units.sqlite",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        assert!(
            out.contains(&format!("recorded as db:{k} in units.sqlite")),
            "{out}"
        );
        let html = std::fs::read_to_string(d.join(page)).unwrap();
        let p = calflash::report::provenance::read(&html).unwrap();
        assert_eq!(
            p.record.as_deref(),
            Some(&*format!("db:{k} in units.sqlite"))
        );
        assert_eq!(html.matches("<section id=\"provenance\">").count(), 1);
        let (code, out, err) = calflash(
            d,
            &[
                "verify-report",
                page,
                "--blob",
                "u.blob",
                "--data",
                "data.csv",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        assert!(
            out.contains(&format!("the history's record db:{k} in units.sqlite")),
            "{out}"
        );
    }
}

/// A selfcal page names its history record too (the other commands that record a unit's
/// history write the id the same way: flight, health).
#[test]
fn a_selfcal_page_names_its_history_record() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::write_recording(&calflash::sim::recording::Tumble::default().record(), d);
    let (code, out, err) = calflash(
        d,
        &[
            "selfcal",
            "acc.txt",
            "gyro.txt",
            "--g",
            "9.81",
            "--serial",
            "SIM-R-1",
            "--report",
            "s.html",
            "--db",
            "units.sqlite",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("recorded as db:1 in units.sqlite"), "{out}");
    let html = std::fs::read_to_string(d.join("s.html")).unwrap();
    let p = calflash::report::provenance::read(&html).unwrap();
    assert_eq!(p.record.as_deref(), Some("db:1 in units.sqlite"));
}
