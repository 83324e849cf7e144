//! Held out on real recordings we did not make (issue 66): `selfcal` fitted on the first two
//! thirds of a recording's still intervals and judged on the later intervals and the rotations
//! between them, beside imu_tk fitted on the same part (its stored calibrations in
//! `../shared/tools/realbench/ref`), both judged by one independent judge (`common/judge.rs`,
//! which reproduces the realbench judge's figures for imu_tk here). Skipped with a notice where
//! `../shared` is absent (a user's clone).

use std::path::{Path, PathBuf};

mod common;
#[path = "common/judge.rs"]
mod judge;

use common::calflash;
use judge::{Cal, Rec};

fn shared() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if d.join("tools/realbench/ref").is_dir() && d.join("data").is_dir() {
        Some(d)
    } else {
        println!(
            "held-out judge: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            d.display()
        );
        None
    }
}

fn numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect()
}

/// Two files of `t x y z` (the judge's and imu_tk's form).
fn two_files(acc: &Path, gyro: &Path) -> Rec {
    let read = |p: &Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(numbers)
            .collect()
    };
    let (a, g) = (read(acc), read(gyro));
    Rec {
        t: a.iter().map(|r| r[0]).collect(),
        acc: a.iter().map(|r| [r[1], r[2], r[3]]).collect(),
        gyro: g.iter().map(|r| [r[1], r[2], r[3]]).collect(),
    }
}

/// Six columns `ax ay az gx gy gz`, no time: `t = i / rate`.
fn six_columns(p: &Path, rate: f64) -> Rec {
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(numbers)
        .collect();
    Rec {
        t: (0..rows.len()).map(|i| i as f64 / rate).collect(),
        acc: rows.iter().map(|r| [r[0], r[1], r[2]]).collect(),
        gyro: rows.iter().map(|r| [r[3], r[4], r[5]]).collect(),
    }
}

/// imucal's session: `n_samples, gyr_x, gyr_y, gyr_z` (deg/s), `acc_x, acc_y, acc_z` (m/s^2), at
/// 102.4 Hz.
fn ferraris_session(dir: &Path) -> Rec {
    let text = std::fs::read_to_string(dir.join("example_ferraris_session.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text.lines().skip(1).map(numbers).collect();
    Rec {
        t: rows.iter().map(|r| r[0] / 102.4).collect(),
        acc: rows.iter().map(|r| [r[4], r[5], r[6]]).collect(),
        gyro: rows.iter().map(|r| [r[1], r[2], r[3]]).collect(),
    }
}

/// One recording, its facts and what was measured before this test (issue 66's table).
struct Case {
    name: &'static str,
    rec: Rec,
    g: f64,
    init: f64,
    /// selfcal's options for the file's units.
    units: &'static [&'static str],
    /// calflash's working unit per unit of the file's values (accelerometer, gyro).
    k: [f64; 2],
    /// The realbench judge's held-out figures for imu_tk (its data README): acc mm/s^2, gyro deg.
    imu_tk: [f64; 2],
    /// calflash's held-out accelerometer figure before the gyro's change (mm/s^2): not to worsen.
    acc_before: f64,
}

fn cases(d: &Path) -> Vec<Case> {
    let data = d.join("data");
    let mpu = |n: &str| six_columns(&data.join(format!("mpu9150-imu-calib/{n}.log")), 100.0);
    vec![
        Case {
            name: "xsens-mti",
            rec: two_files(
                &data.join("xsens-mti/acc.txt"),
                &data.join("xsens-mti/gyro.txt"),
            ),
            g: 9.81744,
            init: 50.0,
            units: &[],
            k: [1.0, 1.0],
            imu_tk: [1.5353, 0.6266],
            acc_before: 1.2790,
        },
        Case {
            name: "mpu9150-imu1",
            rec: mpu("imu1"),
            g: 9.8204,
            init: 6.0,
            units: &["--units", "m/s2,rad/s"],
            k: [1.0, 1.0],
            imu_tk: [19.6331, 0.1713],
            acc_before: 5.6740,
        },
        Case {
            name: "mpu9150-imu2",
            rec: mpu("imu2"),
            g: 9.8204,
            init: 6.0,
            units: &["--units", "m/s2,rad/s"],
            k: [1.0, 1.0],
            imu_tk: [15.2717, 0.2037],
            acc_before: 3.9542,
        },
    ]
}

/// calflash's gyro held out is at most imu_tk's on every shared multi-pose recording imu_tk can
/// fit held out, and its accelerometer no worse than before (issue 66: 0.285 and 0.312 deg
/// against imu_tk's 0.171 and 0.204 on the two MPU-9150 logs, when the turns ran between the
/// poses' means with the poses' bias). The judge here is checked first: imu_tk's stored
/// held-out calibrations give the realbench judge's figures to 1e-3.
#[test]
fn held_out_gyro_is_at_most_imu_tk_and_the_accelerometer_no_worse() {
    let Some(d) = shared() else { return };
    let out = tempfile::tempdir().unwrap();
    let mut table = String::new();
    for c in cases(&d) {
        let ivs = judge::still_intervals(&c.rec, c.init, 6.0);
        let (k, t_cut) = judge::split(&c.rec, &ivs);
        let later = &ivs[k..];
        let reference: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(
                d.join("tools/realbench/ref")
                    .join(c.name)
                    .join("heldout/imutk.json"),
            )
            .unwrap(),
        )
        .unwrap();
        let (ra, rg) = judge::judge(&c.rec, &Cal::from_json(&reference), later, c.g);
        assert!(
            (ra - c.imu_tk[0]).abs() < 1e-3 && (rg - c.imu_tk[1]).abs() < 1e-3,
            "{}: this judge gives imu_tk {ra:.4} mm/s^2, {rg:.4} deg; realbench {:?}",
            c.name,
            c.imu_tk
        );
        let part = out.path().join(c.name);
        std::fs::create_dir_all(&part).unwrap();
        judge::write_part(&c.rec, t_cut, &part);
        let (g, init) = (c.g.to_string(), c.init.to_string());
        let mut args = vec![
            "selfcal",
            "acc.txt",
            "gyro.txt",
            "--g",
            &g,
            "--init-rest",
            &init,
            "--serial",
            "HELD",
            "--no-db",
            "--json",
            "r.json",
        ];
        args.extend(c.units);
        let (code, said, err) = calflash(&part, &args);
        assert_eq!(code, 0, "{}: {said}{err}", c.name);
        let record: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(part.join("r.json")).unwrap()).unwrap();
        let (a, gy) = judge::judge(&c.rec, &Cal::from_selfcal(&record, c.k), later, c.g);
        table.push_str(&format!(
            "{}: {k} + {} intervals; held out acc {a:.4} mm/s^2 (imu_tk {:.4}, before {:.4}), gyro {gy:.4} deg (imu_tk {:.4})\n",
            c.name,
            later.len(),
            c.imu_tk[0],
            c.acc_before,
            c.imu_tk[1]
        ));
        assert!(gy <= c.imu_tk[1], "{table}");
        assert!(a <= c.acc_before * 1.001, "{table}");
    }
    println!("{table}");
}

/// imucal's Ferraris session (`../shared/data/imucal-ferraris`: six faces held still, then a
/// turn of -360 deg about each axis, annotated by its authors) calibrates through `selfcal
/// --sections` with its section list, and the judge gives |a| - g and the turns' error no worse
/// than imucal's own calibration of it (its figures: 3.5984 mm/s^2, 0.6720 deg, reproduced here
/// first). In-sample only: neither tool can fit a Ferraris session on the part before the
/// judge's cut (the y and z turns lie after it).
#[test]
fn the_ferraris_session_calibrates_and_beats_imucal() {
    let Some(d) = shared() else { return };
    let dir = d.join("data/imucal-ferraris");
    let rec = ferraris_session(&dir);
    let ivs = judge::still_intervals(&rec, 2.5, 6.0);
    let imucal: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.join("tools/realbench/ref/imucal-ferraris/full/imucal.json"))
            .unwrap(),
    )
    .unwrap();
    let (ra, rg) = judge::judge(&rec, &Cal::from_json(&imucal), &ivs, 9.81);
    assert!(
        (ra - 3.5984).abs() < 1e-3 && (rg - 0.6720).abs() < 1e-3,
        "this judge gives imucal {ra:.4} mm/s^2, {rg:.4} deg"
    );
    let out = tempfile::tempdir().unwrap();
    let (code, said, err) = calflash(
        out.path(),
        &[
            "selfcal",
            dir.join("example_ferraris_session.csv").to_str().unwrap(),
            "--sections",
            dir.join("example_ferraris_session_list.json")
                .to_str()
                .unwrap(),
            "--units",
            "m/s2,deg/s",
            "--sample-rate",
            "102.4",
            "--init-rest",
            "2.5",
            "--g",
            "9.81",
            "--serial",
            "FERRARIS",
            "--no-db",
            "--json",
            "r.json",
        ],
    );
    assert_eq!(code, 0, "{said}{err}");
    assert!(said.lines().next().unwrap().ends_with(": ACCEPT"), "{said}");
    assert!(said.contains("Ferraris session"), "{said}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("r.json")).unwrap()).unwrap();
    let cal = Cal::from_selfcal(&record, [1.0, std::f64::consts::PI / 180.0]);
    let (a, g) = judge::judge(&rec, &cal, &ivs, 9.81);
    println!(
        "Ferraris session, in-sample: acc {a:.4} mm/s^2 (imucal {ra:.4}), gyro {g:.4} deg (imucal {rg:.4})"
    );
    assert!(a <= ra && g <= rg, "acc {a:.4} mm/s^2, gyro {g:.4} deg");
}

/// The Ferraris session held out as the judge splits it: fitted on the part before the cut (the
/// six faces and the turn about x; the y and z turns lie after it, so the rotations between
/// poses give those axes' scales) and judged on the four later intervals and three rotations.
/// Neither reference can be fitted there (imucal needs all nine sections; imu_tk finds 9
/// intervals and needs 12); imucal's fit of the whole session judged on the same intervals
/// (it saw them: 2.3313 mm/s^2, 0.5556 deg, realbench's figures) is the bar.
#[test]
fn the_ferraris_session_held_out() {
    let Some(d) = shared() else { return };
    let dir = d.join("data/imucal-ferraris");
    let rec = ferraris_session(&dir);
    let ivs = judge::still_intervals(&rec, 2.5, 6.0);
    let (k, t_cut) = judge::split(&rec, &ivs);
    let out = tempfile::tempdir().unwrap();
    judge::write_part(&rec, t_cut, out.path());
    let part_rows = rec.t.iter().take_while(|&&t| t <= t_cut).count();
    // The section list of the part: the sections that end before the cut.
    let list: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("example_ferraris_session_list.json")).unwrap(),
    )
    .unwrap();
    let part: serde_json::Map<String, serde_json::Value> = list
        .as_object()
        .unwrap()
        .iter()
        .filter(|(_, v)| v["end"].as_u64().unwrap() as usize <= part_rows)
        .map(|(n, v)| (n.clone(), v.clone()))
        .collect();
    assert_eq!(part.len(), 7, "{part:?}");
    std::fs::write(
        out.path().join("part.json"),
        serde_json::to_string(&part).unwrap(),
    )
    .unwrap();
    let (code, said, err) = calflash(
        out.path(),
        &[
            "selfcal",
            "acc.txt",
            "gyro.txt",
            "--sections",
            "part.json",
            "--units",
            "m/s2,deg/s",
            "--init-rest",
            "2.5",
            "--g",
            "9.81",
            "--serial",
            "FERRARIS",
            "--no-db",
            "--json",
            "r.json",
        ],
    );
    assert_eq!(code, 0, "{said}{err}");
    assert!(said.contains("turns of -360 deg about x give"), "{said}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("r.json")).unwrap()).unwrap();
    let cal = Cal::from_selfcal(&record, [1.0, std::f64::consts::PI / 180.0]);
    let (a, g) = judge::judge(&rec, &cal, &ivs[k..], 9.81);
    println!(
        "Ferraris session held out ({k} + {} intervals): acc {a:.4} mm/s^2, gyro {g:.4} deg (imucal, not held out: 2.3313, 0.5556)",
        ivs.len() - k
    );
    // Held out, no worse than imucal's fit that saw these intervals (1.87 and 0.545 here).
    assert!(
        a <= 2.3313 && g <= 0.5556,
        "acc {a:.4} mm/s^2, gyro {g:.4} deg"
    );
}

/// A section list that lacks a face, or runs past the recording, is refused naming it.
#[test]
fn a_bad_section_list_is_named() {
    let Some(d) = shared() else { return };
    let csv = d.join("data/imucal-ferraris/example_ferraris_session.csv");
    let out = tempfile::tempdir().unwrap();
    let list =
        std::fs::read_to_string(d.join("data/imucal-ferraris/example_ferraris_session_list.json"))
            .unwrap();
    for (name, text, expected) in [
        (
            "missing.json",
            list.replace("\"y_a\"", "\"y_down\""),
            "section \"y_a\" needs \"start\"",
        ),
        (
            "past.json",
            list.replace("9512", "99512"),
            "section \"z_rot\" runs 9205 to 99512: expected a start below its end, within the recording's 10376 samples",
        ),
    ] {
        std::fs::write(out.path().join(name), text).unwrap();
        let (code, _, err) = calflash(
            out.path(),
            &[
                "selfcal",
                csv.to_str().unwrap(),
                "--sections",
                name,
                "--units",
                "m/s2,deg/s",
                "--sample-rate",
                "102.4",
                "--init-rest",
                "2.5",
                "--g",
                "9.81",
                "--serial",
                "F",
                "--no-db",
            ],
        );
        assert_eq!(code, 1, "{err}");
        assert!(err.contains(&format!("{name}: {expected}")), "{err}");
    }
}
