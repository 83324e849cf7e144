//! `calflash lot`: a lot from the unit history judged as a lot. Units that break the lot's
//! correlation of bias and scale are named (each coefficient alone within the lot's spread), a
//! unit's newest fit is the one judged, a lot too small for a covariance is judged coefficient
//! by coefficient and says how many units it needs, and a drift shows on the control chart.

mod common;
#[path = "common/lot_history.rs"]
mod lot_history;

use common::calflash;

const T0: i64 = 1_795_478_400; // 2026-11-24

#[test]
fn units_unlike_their_lot_are_named_with_the_coefficients_that_make_them_so() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("units.sqlite");
    // 400 units; five whose x-axis bias is high but scale low (against the correlation),
    // each within 2.5 MADs of the lot on its own.
    let odd = [17, 101, 202, 303, 399];
    lot_history::write(&db, "LOT-A-", 400, T0, 7, |i, b, k| {
        if odd.contains(&i) {
            b[0] = 32_768.0 + 80.0;
            k[0] = 1_670.0 - 3.5;
        }
    });
    // Another lot in the same history, and a newer fit of one unit of lot A that is odd.
    lot_history::write(&db, "LOT-B-", 50, T0, 8, |_, b, _| b[1] += 500.0);
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute(
        "INSERT INTO records (serial, kind, time, data_hash, coefficients, blob, outcome)
         VALUES ('LOT-A-000050', 'fit', ?1, 'later', ?2, x'', 'accept')",
        rusqlite::params![
            T0 + 10_000,
            lot_history::coefficients([32_768.0, 32_768.0 + 600.0, 32_768.0], [1_670.0; 3])
        ],
    )
    .unwrap();
    drop(conn);
    let d = dir.path();
    let (code, out, err) = calflash(
        d,
        &[
            "lot",
            "LOT-A-",
            "--db",
            "units.sqlite",
            "--json",
            "lot.json",
            "--chart",
            "ax:1",
            "--report",
            "lot.html",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    println!("{out}");
    assert!(out.contains("400 units, 6 coefficients"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("lot.json")).unwrap()).unwrap();
    let named: Vec<&str> = v["outliers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["serial"].as_str().unwrap())
        .collect();
    for i in odd.iter().chain(&[50]) {
        let s = format!("LOT-A-{i:06}");
        assert!(named.contains(&s.as_str()), "{s} not named: {named:?}");
    }
    assert!(named.len() <= 8, "{named:?}");
    // The newer fit of unit 50 is judged (its y bias is 15 MADs off), and said so.
    let u50 = v["outliers"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["serial"] == "LOT-A-000050")
        .unwrap();
    assert_eq!(u50["coefficients"][0][0], "ay:1", "{u50}");
    assert_eq!(v["judged_by"], "robust covariance");
    assert_eq!(v["charts"][0]["coefficient"], "ax:1");
    let html = std::fs::read_to_string(d.join("lot.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 2, "distances and one chart");
    assert!(
        html.contains("LOT-A-000050") && html.contains("ay:1 +15.0"),
        "the outliers' table"
    );
    // Issue 68: the spread in a datasheet's unit: the scale factor's MAD of 2 counts in 1670
    // is about 1200 ppm (the biases are in the input's units: the fixture's outputs are
    // single axes).
    let ppm: f64 = v["spread"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "ax:input")
        .map(|s| {
            assert_eq!(s["engineering"]["unit"], "ppm", "{s}");
            s["engineering"]["mad"].as_f64().unwrap()
        })
        .unwrap();
    assert!((900.0..1500.0).contains(&ppm), "{ppm}");
    assert!(html.contains("spread (MAD)") && html.contains(" ppm</td>"));
    // Issue 68: the chart says what it is judged with.
    assert!(
        html.contains("baseline the first 100 units in time order; limits at 3 sigma"),
        "the chart's parameters"
    );
}

#[test]
fn a_small_lot_is_judged_coefficient_by_coefficient_and_says_how_many_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("units.sqlite");
    lot_history::write(&db, "SMALL-", 12, T0, 9, |i, b, _| {
        if i == 4 {
            b[2] += 1_000.0;
        }
    });
    let (code, out, err) = calflash(dir.path(), &["lot", "SMALL-", "--db", "units.sqlite"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("coefficient by coefficient: 12 units are too few for a robust covariance of 6 coefficients: it needs at least 30"),
        "{out}"
    );
    assert!(
        out.contains("SMALL-000004") && out.contains("az:1 z="),
        "{out}"
    );
    // One unit is no lot; a date range with none, neither.
    let (code, _, err) = calflash(dir.path(), &["lot", "SMALL-000001", "--db", "units.sqlite"]);
    assert_ne!(code, 0);
    assert!(err.contains("at least 2 are needed"), "{err}");
    let (code, _, err) = calflash(
        dir.path(),
        &[
            "lot",
            "SMALL-",
            "--db",
            "units.sqlite",
            "--since",
            "2027-01-01",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("a lot of 0 unit(s)"), "{err}");
    // A lot nobody recorded is named as such.
    let (code, _, err) = calflash(
        dir.path(),
        &["lot", "--lot", "L-NONE", "--db", "units.sqlite"],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("no such lot: no unit in") && err.contains("was calibrated in lot `L-NONE`"),
        "{err}"
    );
    let (code, _, err) = calflash(
        dir.path(),
        &["lot", "SMALL-", "--db", "units.sqlite", "--chart", "nope"],
    );
    assert_ne!(code, 0);
    assert!(err.contains("no coefficient nope; it has ax:1"), "{err}");
}

#[test]
fn a_drifting_process_is_out_of_control_on_its_chart() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("units.sqlite");
    // From unit 300 on, the x-axis scale drifts up by 1.5 of its sigma.
    lot_history::write(&db, "DRIFT-", 400, T0, 11, |i, _, k| {
        if i >= 300 {
            k[0] += 3.0;
        }
    });
    let (code, out, err) = calflash(
        dir.path(),
        &[
            "lot",
            "DRIFT-",
            "--db",
            "units.sqlite",
            "--chart",
            "ax:input",
            "--chart-kind",
            "ewma",
            "--json",
            "d.json",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("d.json")).unwrap()).unwrap();
    let out_of_control: Vec<u64> = v["charts"][0]["chart"]["out_of_control"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    assert!(out_of_control.len() > 20, "{out_of_control:?}");
    let late = out_of_control.iter().filter(|&&i| i >= 300).count();
    assert!(late * 10 >= out_of_control.len() * 8, "{out_of_control:?}");
}

/// `calibrate --lot NAME`: the unit is recorded in lot NAME and compared with the lot's other
/// units: one whose bias is unlike theirs is a REVIEW that names the bias, one like them is
/// not. A batch compares each of its units with the lot as it stood before the batch.
#[test]
fn calibrate_with_its_lot_reviews_a_unit_unlike_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../examples/data/single_accel.truth.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let simulate = |i: u64, bias_shift: f64, obs: &str| {
        let mut t = truth.clone();
        // Units of one process: biases and scale factors spread a little.
        let spread = (i as f64 * 0.618_034).fract() - 0.5;
        t["k0"] = (t["k0"].as_f64().unwrap() + 6.0 * spread + bias_shift).into();
        t["k1"] = (t["k1"].as_f64().unwrap() * (1.0 + 0.002 * spread)).into();
        let name = format!("t{i}.json");
        std::fs::write(d.join(&name), t.to_string()).unwrap();
        let (code, out, err) = calflash(
            d,
            &[
                "simulate",
                "--sensor",
                "single-accel",
                "--plan",
                "head:36",
                "--temps=25",
                "--truth",
                &name,
                "--seed",
                &i.to_string(),
                "-o",
                obs,
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
    };
    let unit = |i: u64, bias_shift: f64| {
        let obs = format!("obs{i}.csv");
        simulate(i, bias_shift, &obs);
        let serial = format!("ACC-7-{i:03}");
        calflash(
            d,
            &[
                "calibrate",
                &obs,
                "--sensor",
                "single-accel",
                "--serial",
                &serial,
                "--db",
                "units.sqlite",
                "--lot",
                "L-0419",
            ],
        )
    };
    // The first unit has no lot to be compared with: said, as a REVIEW.
    let (code, out, err) = unit(0, 0.0);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("not compared with its lot"), "{out}");
    for i in 1..12 {
        let (code, out, err) = unit(i, 0.0);
        assert_eq!(code, 0, "{out}{err}");
        if i >= 3 {
            assert!(
                out.contains(&format!("lot `L-0419` ({i} units)"))
                    && out.contains("within the limit"),
                "{out}"
            );
        }
    }
    // 40 counts of bias off (about 0.1 g) is unlike the lot.
    let (code, out, err) = unit(12, 40.0);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("REVIEW"), "{out}");
    assert!(out.contains("unlike its lot in output:1 z=+"), "{out}");
    // The lot is what the history says it is.
    let (code, out, err) = calflash(d, &["lot", "--lot", "L-0419", "--db", "units.sqlite"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("calflash lot  lot `L-0419`: 13 units"),
        "{out}"
    );
    // Red team four: another unit's coefficients copied into the odd unit's `coefficients`
    // column, which no seal covers. The lot is built from the sealed records: the odd unit is
    // still named.
    let outliers = |json: &str| -> Vec<String> {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(json)).unwrap()).unwrap();
        v["outliers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|o| o["serial"].as_str().unwrap().to_string())
            .collect()
    };
    let lot_json = |json: &str| {
        calflash(
            d,
            &[
                "lot",
                "--lot",
                "L-0419",
                "--db",
                "units.sqlite",
                "--json",
                json,
            ],
        )
    };
    let (code, out, err) = lot_json("before.json");
    assert_eq!(code, 0, "{out}{err}");
    let before = outliers("before.json");
    assert!(before.contains(&"ACC-7-012".to_string()), "{before:?}");
    let conn = rusqlite::Connection::open(d.join("units.sqlite")).unwrap();
    let (record, coefficients): (String, String) = conn
        .query_row(
            "SELECT record, coefficients FROM records WHERE serial = 'ACC-7-012' AND kind = 'fit'",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    conn.execute(
        "UPDATE records SET coefficients = (SELECT coefficients FROM records
           WHERE serial = 'ACC-7-001' AND kind = 'fit') WHERE serial = 'ACC-7-012'",
        [],
    )
    .unwrap();
    let (code, out, err) = lot_json("copied.json");
    assert_eq!(code, 0, "{out}{err}");
    assert_eq!(outliers("copied.json"), before, "{out}");
    // The record itself edited: the lot is not judged on it, and says which unit's.
    let edited = record.replacen("\"verdict\":\"accept\"", "\"verdict\":\"review\"", 1);
    assert_ne!(edited, record);
    conn.execute(
        "UPDATE records SET record = ?1 WHERE serial = 'ACC-7-012'",
        [&edited],
    )
    .unwrap();
    let (code, out, err) = lot_json("edited.json");
    assert_ne!(code, 0, "{out}{err}");
    assert!(
        err.contains("the fit of ACC-7-012: its record is not as calflash wrote it"),
        "{err}"
    );
    conn.execute(
        "UPDATE records SET record = ?1, coefficients = ?2 WHERE serial = 'ACC-7-012'",
        [&record, &coefficients],
    )
    .unwrap();
    drop(conn);
    let (code, out, err) = calflash(
        d,
        &["history", "ACC-7-012", "--db", "units.sqlite", "--json"],
    );
    assert_eq!(code, 0, "{out}{err}");
    let h: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(h[0]["lot"], "L-0419");
    // A batch of three, one of them odd: each compared with the 13 units before the batch.
    std::fs::create_dir_all(d.join("batch")).unwrap();
    std::fs::create_dir_all(d.join("out")).unwrap();
    for (i, shift) in [(20, 0.0), (21, 40.0), (22, 0.0)] {
        simulate(i, shift, &format!("batch/ACC-7-{i:03}.csv"));
    }
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "batch",
            "--sensor",
            "single-accel",
            "--out-dir",
            "out",
            "--db",
            "units.sqlite",
            "--lot",
            "L-0419",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    for (i, odd) in [(20, false), (21, true), (22, false)] {
        let said = std::fs::read_to_string(d.join(format!("out/ACC-7-{i:03}.txt"))).unwrap();
        assert!(said.contains("lot `L-0419` (13 units)"), "{said}");
        assert_eq!(said.contains("unlike its lot in output:1"), odd, "{said}");
    }
    let (code, out, _) = calflash(d, &["lot", "--lot", "L-0419", "--db", "units.sqlite"]);
    assert_eq!(code, 0);
    assert!(out.contains(": 16 units"), "{out}");
    // Issue 68: the spread in a datasheet's unit beside the counts: the scale factor in ppm,
    // the cross-axis term in mrad, the square term per input unit.
    let row = |name: &str| {
        out.lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name}: {out}"))
            .to_string()
    };
    assert!(row("output:input").contains(" ppm ("), "{out}");
    assert!(row("output:input_o").contains(" mrad ("), "{out}");
    assert!(row("output:input^2").contains(" ppm/input unit ("), "{out}");
    assert!(row("output:1").contains(" input units ("), "{out}");
    // The first batch of a new lot: every unit REVIEW, and the table and the index say why
    // on the unit's row (there was no lot to compare with), not only each unit's summary.
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "batch",
            "--sensor",
            "single-accel",
            "--out-dir",
            "out-new",
            "--reports",
            "--db",
            "units.sqlite",
            "--lot",
            "L-NEW",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    for i in 20..23 {
        let row = out
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("ACC-7-{i:03} ")))
            .unwrap_or_else(|| panic!("no row for unit {i}: {out}"));
        assert!(
            row.contains("REVIEW") && row.contains("not compared with its lot"),
            "{row}"
        );
    }
    let index = std::fs::read_to_string(d.join("out-new/index.html")).unwrap();
    // One line per unit, each giving the reason.
    assert_eq!(
        index
            .lines()
            .filter(|l| l.starts_with("<tr><td class=\"unit\">")
                && l.contains("not compared with its lot"))
            .count(),
        3,
        "{index}"
    );
}

/// Two stations record one lot: the charts are drawn over the lot and per station, where a
/// drift of one station's fixture shows; `--station` takes one station's units.
#[test]
fn charts_per_station_show_the_station_that_drifts() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("units.sqlite");
    // Units alternate between the stations; from unit 200 on, station B's fixture reads the
    // x-axis scale 3 sigma high.
    lot_history::write(&db, "TWO-", 400, T0, 13, |i, _, k| {
        if i >= 200 && i % 2 == 1 {
            k[0] += 6.0;
        }
    });
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute(
        "UPDATE records SET station = CASE WHEN CAST(substr(serial, 5) AS INTEGER) % 2 = 1 THEN 'B' ELSE 'A' END",
        [],
    )
    .unwrap();
    drop(conn);
    let (code, out, err) = calflash(
        dir.path(),
        &[
            "lot",
            "TWO-",
            "--db",
            "units.sqlite",
            "--chart",
            "ax:input",
            "--chart-kind",
            "ewma",
            "--json",
            "two.json",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("two.json")).unwrap())
            .unwrap();
    let charts = v["charts"].as_array().unwrap();
    let names: Vec<&str> = charts
        .iter()
        .map(|c| c["coefficient"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["ax:input", "ax:input at A", "ax:input at B"]);
    let out_of = |k: usize| {
        charts[k]["chart"]["out_of_control"]
            .as_array()
            .unwrap()
            .len()
    };
    // Station A holds: at most one false signal (an EWMA's excursion spans neighbouring
    // points; at lambda 0.2 and 3 sigma an in-control process signals once in about 500).
    let a_points: Vec<u64> = charts[1]["chart"]["out_of_control"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_u64().unwrap())
        .collect();
    let signals =
        a_points.windows(2).filter(|w| w[1] > w[0] + 5).count() + usize::from(!a_points.is_empty());
    assert!(signals <= 1, "station A holds: {a_points:?}");
    assert!(out_of(2) > 50, "station B drifts: {out}");
    // Station B's points out of control are after its drift (its 100th unit).
    let late = charts[2]["chart"]["out_of_control"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i.as_u64().unwrap() >= 100)
        .count();
    assert_eq!(late, out_of(2), "{out}");
    let (code, out, err) = calflash(
        dir.path(),
        &["lot", "TWO-", "--db", "units.sqlite", "--station", "B"],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("200 units"), "{out}");
}
