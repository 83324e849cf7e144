//! Missions end to end: a profile read and checked (each bad input named by line and column),
//! simulated flights read back as missions, the real Hedy rocket flight (skipped with a notice
//! when `../shared` is absent), and plans designed and judged for a mission.

mod common;

use std::path::{Path, PathBuf};

use common::calflash;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A still profile at 100 Hz with one line replaced.
fn profile(dir: &Path, bad: Option<(usize, &str)>) -> PathBuf {
    let mut text = String::from("t,ax,ay,az,gx,gy,gz\n");
    for i in 0..50u32 {
        let line = match bad {
            Some((k, l)) if k == i as usize => l.to_string(),
            _ => format!("{},0,0,9.81,0,0,0.1", f64::from(i) * 0.01),
        };
        text.push_str(&line);
        text.push('\n');
    }
    write(dir, "p.csv", &text)
}

#[test]
fn a_profile_that_is_not_a_flight_is_named_by_line_and_column() {
    let d = tempfile::tempdir().unwrap();
    for (bad, says) in [
        (
            (10, "0.05,0,0,9.81,0,0,0.1"),
            "line 12: time 0.05 s is not after the previous sample's 0.09 s",
        ),
        (
            (7, "0.07,0,NaN,9.81,0,0,0.1"),
            "line 9, column `ay`: `NaN` is not a finite number",
        ),
        (
            (7, "0.07,0,0,9.81,0,0"),
            "line 9: 6 fields where the header has 7",
        ),
        (
            (20, "0.2,0,0,9.81,0,0,20000"),
            "line 22, column `gz`: from 0.1 to 20000 rad/s in 0.01",
        ),
        (
            (20, "0.2,0,0,9.81e7,0,0,0.1"),
            "line 22, column `az`: 98100000 m/s^2 is beyond what a flight can make",
        ),
    ] {
        let p = profile(d.path(), Some(bad));
        let (code, _, err) = calflash(d.path(), &["mission", p.to_str().unwrap()]);
        assert_ne!(code, 0, "{bad:?}");
        assert!(err.contains(says), "{bad:?}: {err}");
        assert!(err.contains("p.csv"), "{err}");
    }
    // A value beyond reason in an unstated unit says which unit was assumed and how to state one.
    let p = profile(d.path(), Some((20, "0.2,0,0,9.81e7,0,0,0.1")));
    let (_, _, err) = calflash(d.path(), &["mission", p.to_str().unwrap()]);
    assert!(
        err.contains("m/s^2 was assumed: state it as --mission-columns fz=az:UNIT"),
        "{err}"
    );
    // Part of a triad, and a missing time column.
    let part = write(d.path(), "part.csv", "t,ax,ay\n0,1,2\n0.1,1,2\n");
    let (_, _, err) = calflash(d.path(), &["mission", part.to_str().unwrap()]);
    assert!(
        err.contains("the specific force has fx, fy but not fz"),
        "{err}"
    );
    let empty = write(d.path(), "empty.csv", "");
    let (_, _, err) = calflash(d.path(), &["mission", empty.to_str().unwrap()]);
    assert!(
        err.contains("empty.csv: empty; a mission profile is CSV with a header"),
        "{err}"
    );
    let binary = write(d.path(), "binary.csv", &"\u{1}".repeat(2 << 20));
    let (_, _, err) = calflash(d.path(), &["mission", binary.to_str().unwrap()]);
    assert!(err.contains("line 1 is longer than 1048576 bytes"), "{err}");
    let untimed = write(d.path(), "untimed.csv", "ax,ay,az\n0,1,2\n0,1,2\n");
    let (_, _, err) = calflash(d.path(), &["mission", untimed.to_str().unwrap()]);
    assert!(err.contains("no time column"), "{err}");
    // A good one: the units assumed are said, the spin axis found.
    let p = profile(d.path(), None);
    let (code, out, err) = calflash(d.path(), &["mission", p.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("specific force: no unit stated, read as m/s^2 (SI)"),
        "{out}"
    );
    assert!(
        out.contains("rate: no unit stated, read as rad/s (SI)"),
        "{out}"
    );
    assert!(out.contains("Spin about z"), "{out}");
    // Chosen columns with units: deg/s read as such.
    let (code, out, _) = calflash(
        d.path(),
        &[
            "mission",
            p.to_str().unwrap(),
            "--mission-columns",
            "wz=gz:deg/s",
        ],
    );
    assert_eq!(code, 0);
    assert!(out.contains("w_z          0.0017"), "{out}");
}

#[test]
fn a_simulated_shell_reads_back_as_its_mission() {
    let d = tempfile::tempdir().unwrap();
    let (code, out, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--flight",
            "shell:seconds=1,setback=12000,spin=250",
            "-o",
            "shell.csv",
            "--flight-truth",
            "truth.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("muzzle 0.0"), "{out}");
    let (code, out, err) = calflash(d.path(), &["mission", "shell.csv", "--json", "m.json"]);
    assert_eq!(code, 0, "{err}");
    // The stated setback (to the pulse's sampling at 10 kHz).
    assert!(out.contains("(12000.4 g) along +x"), "{out}");
    assert!(out.contains("Spin about x: peak 250.0 rev/s"), "{out}");
    // The observation files' names are SI: nothing assumed.
    assert!(!out.contains("no unit stated"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("m.json")).unwrap()).unwrap();
    assert_eq!(json["samples"], 10_201);
    let truth = std::fs::read_to_string(d.path().join("truth.csv")).unwrap();
    assert!(truth.starts_with("t,x,y,z,vx,vy,vz,qw,qx,qy,qz\n"));
    // A flight is of an IMU, and its spec is checked.
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate", "--sensor", "accel", "--flight", "shell", "-o", "x.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("--sensor imu"), "{err}");
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--flight",
            "shell:calibre=3",
            "-o",
            "x.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("a shell has no `calibre`"), "{err}");
    // A sensor's name in capitals is the same sensor.
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "IMU",
            "--flight",
            "shell:seconds=0.05",
            "-o",
            "caps.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
}

fn hedy() -> Option<PathBuf> {
    let p =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/hedy-rocket/imu.csv");
    if p.is_file() {
        Some(p)
    } else {
        println!(
            "hedy mission: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            p.display()
        );
        None
    }
}

const HEDY_COLUMNS: &str =
    "fx=Ax:m/s^2,fy=Ay:m/s^2,fz=Az:m/s^2,wx=Gx:deg/s,wy=Gy:deg/s,wz=Gz:deg/s";

#[test]
fn the_hedy_flight_is_a_mission() {
    let Some(imu) = hedy() else { return };
    let d = tempfile::tempdir().unwrap();
    let imu = imu.to_str().unwrap();
    let (code, out, err) = calflash(
        d.path(),
        &[
            "mission",
            imu,
            "--mission-columns",
            HEDY_COLUMNS,
            "--k2",
            "100",
        ],
    );
    assert_eq!(code, 0, "{err}");
    // The README's figures: the roll about y to 1,757 deg/s; 100 Hz resolves vibration to 50 Hz.
    assert!(
        out.contains("Spin about y: peak 4.9 rev/s (1757 deg/s)"),
        "{out}"
    );
    assert!(out.contains("24564 samples"), "{out}");
    assert!(out.contains("K2 100 ug/g^2 rectifies"), "{out}");
    assert!(
        out.contains("dw: no angular acceleration columns; differentiated"),
        "{out}"
    );
    // A design for it: the mission-optimal plan beats the uniform one on every axis.
    let (code, out, err) = calflash(
        d.path(),
        &[
            "design",
            "optimize",
            "--sensor",
            "gyro",
            "--model",
            "triad-nonlinear",
            "--candidates",
            "rate:-35:35:21",
            "--n",
            "40",
            "--mission",
            imu,
            "--mission-columns",
            HEDY_COLUMNS,
            "-o",
            "plan.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Over the mission"), "{out}");
    let ratios = variance_ratios(&out);
    assert_eq!(ratios.len(), 3, "{out}");
    // The roll gyro (y) gains most: its rates are the flight's widest.
    assert!(ratios.iter().all(|r| *r > 1.0), "{ratios:?}\n{out}");
    assert!(ratios[1] > 2.0, "{ratios:?}\n{out}");
}

/// The `variance/1st` of the uniform plan, per axis, from `design optimize`'s mission table.
fn variance_ratios(out: &str) -> Vec<f64> {
    out.lines()
        .filter(|l| l.trim_start().starts_with("uniform") && l.contains("40 points"))
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            // ... n rms worst ratio beyond worst
            f.get(f.len() - 3)?.parse().ok()
        })
        .collect()
}

#[test]
fn a_mission_the_equipment_cannot_reach_is_said_and_the_rest_is_extrapolation() {
    let d = tempfile::tempdir().unwrap();
    // A flight spinning at 100 to 200 rad/s about x; a rate table reaching 50 rad/s.
    let mut text = String::from("t,w_x,w_y,w_z,f_x,f_y,f_z\n");
    for i in 0..200 {
        let t = f64::from(i) * 0.01;
        text.push_str(&format!("{t},{},0,0,0,0,9.8\n", 100.0 + 50.0 * t));
    }
    let p = write(d.path(), "spin.csv", &text);
    let args = |cands: &'static str| {
        vec![
            "design".to_string(),
            "optimize".into(),
            "--sensor".into(),
            "gyro".into(),
            "--model".into(),
            "triad".into(),
            "--candidates".into(),
            cands.into(),
            "--n".into(),
            "24".into(),
            "--mission".into(),
            p.to_str().unwrap().into(),
            "-o".into(),
            "plan.csv".into(),
        ]
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        calflash(d.path(), &a)
    };
    let (code, _, err) = run(args("rate:-50:50:11"));
    assert_ne!(code, 0);
    assert!(err.contains("no moment of the flight"), "{err}");
    assert!(
        err.contains("w_x 0 % of the time below -51 and 100 % above 51"),
        "{err}"
    );
    // Reaching 150 rad/s (153 with the 1 % margin): half the flight inside, the rest
    // extrapolated and priced apart.
    let (code, out, err) = run(args("rate:-150:150:31"));
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("% of the flight within what the candidates reach"),
        "{out}"
    );
    assert!(
        out.contains("w_x 0 % of the time below -153 and 46.5 % above 153"),
        "{out}"
    );
    // evaluate judges plans over the flight too, and its JSON keeps the table.
    let (code, out, err) = calflash(
        d.path(),
        &[
            "design",
            "evaluate",
            "--sensor",
            "gyro",
            "--model",
            "triad",
            "--plan",
            "rate:-150:150:7",
            "--plan",
            "rate:-150:150:31",
            "--mission",
            p.to_str().unwrap(),
            "--json",
            "e.json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Over the mission"), "{out}");
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("e.json")).unwrap()).unwrap();
    assert_eq!(e["mission"]["plans"].as_array().unwrap().len(), 2);
    // A profile without the rates the gyro model reads.
    let still = write(
        d.path(),
        "still.csv",
        "t,f_x,f_y,f_z\n0,0,0,9.8\n0.1,0,0,9.8\n",
    );
    let (code, _, err) = calflash(
        d.path(),
        &[
            "design",
            "optimize",
            "--sensor",
            "gyro",
            "--model",
            "triad",
            "--candidates",
            "rate:-50:50:11",
            "--n",
            "24",
            "--mission",
            still.to_str().unwrap(),
            "-o",
            "p.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("the model reads `w_x`, which the mission profile"),
        "{err}"
    );
}

#[test]
fn the_predicted_mission_error_is_what_simulated_calibrations_give() {
    let d = tempfile::tempdir().unwrap();
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--flight",
            "rocket:seconds=30",
            "-o",
            "rocket.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = calflash(
        d.path(),
        &[
            "design",
            "predict",
            "--sensor",
            "gyro",
            "--model",
            "triad",
            "--plan",
            "rate:-40:40:9",
            "--mission",
            "rocket.csv",
            "--monte-carlo",
            "400",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let deviations: Vec<f64> = out
        .lines()
        .filter(|l| l.contains("Monte Carlo"))
        .filter_map(|l| {
            let pct = l
                .rsplit('(')
                .next()?
                .trim_end_matches(" %)")
                .trim_end_matches(')');
            pct.trim_end_matches(" %").parse().ok()
        })
        .collect();
    assert_eq!(deviations.len(), 3, "{out}");
    assert!(
        deviations.iter().all(|p: &f64| p.abs() < 10.0),
        "{deviations:?}\n{out}"
    );
}

#[test]
fn a_calibration_is_judged_over_its_mission() {
    let d = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| calflash(d.path(), args);
    let (code, _, err) = run(&[
        "simulate",
        "--sensor",
        "accel",
        "--plan",
        "tumble:24",
        "--plan",
        "centrifuge:1:6:4",
        "--repeat",
        "2",
        "-o",
        "acc.csv",
    ]);
    assert_eq!(code, 0, "{err}");
    // A rocket pulling up to 6.4 g: within what the centrifuge reached but for the boost's peak.
    let (code, _, err) = run(&[
        "simulate",
        "--sensor",
        "imu",
        "--flight",
        "rocket:seconds=20",
        "-o",
        "rocket.csv",
    ]);
    assert_eq!(code, 0, "{err}");
    let calibrate = |extra: &[&str]| {
        let mut a = vec![
            "calibrate",
            "acc.csv",
            "--sensor",
            "accel",
            "--serial",
            "M1",
            "--db",
            "h.sqlite",
            "--mission",
            "rocket.csv",
        ];
        a.extend_from_slice(extra);
        run(&a)
    };
    // A loose requirement: the predicted error is met, and the left-out nonlinear terms, at
    // their bench bound, stay under it.
    let (code, out, err) = calibrate(&[
        "--requirement",
        "a=0.5",
        "--report",
        "r.html",
        "--json",
        "r.json",
    ]);
    assert!(code == 0 || code == 2, "{err}");
    assert!(
        out.contains("mission rocket.csv: predicted 1-sigma error over the flight"),
        "{out}"
    );
    assert!(out.contains("a_x: rms "), "{out}");
    assert!(out.contains("left-out term f_x"), "{out}");
    assert!(!out.contains("exceeds the requirement"), "{out}");
    // The record keeps the judgement: per output the predicted error and the left-out terms.
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(record["mission"]["outputs"].as_array().unwrap().len(), 3);
    assert!(record["mission"]["outputs"][0]["rms"].as_f64().unwrap() > 0.0);
    assert!(!record["mission"]["terms"].as_array().unwrap().is_empty());
    let html = std::fs::read_to_string(d.path().join("r.html")).unwrap();
    assert!(html.contains("<h2>Over the mission</h2>"));
    assert!(html.contains("Predicted error along the flight, m/s^2"));
    // The requirement drawn across the flight, the left-out terms in a figure of their own
    // beside it, the tables' units in a column.
    assert!(html.contains("requirement 0.5 m/s^2"), "{html}");
    assert!(
        html.contains("left-out terms over the flight, m/s^2"),
        "{html}"
    );
    assert!(html.contains("<th>up to, over the flight</th><th>unit</th>"));
    assert!(html.contains("<td>a_x</td><td>m/s^2</td>"), "{html}");
    // A requirement tighter than the bench can give: REVIEW, naming the output; its findings
    // worst first.
    let (_, out, _) = calibrate(&["--requirement", "a=1e-5", "--report", "tight.html"]);
    let tight = std::fs::read_to_string(d.path().join("tight.html")).unwrap();
    // The report lists what needs a person, then folds the checks that passed.
    let words: Vec<&str> = tight
        .split("<li><b>")
        .skip(1)
        .filter_map(|l| l.split("</b>").next())
        .collect();
    assert!(
        !words.is_empty() && words.iter().all(|w| *w != "ACCEPT"),
        "{words:?}"
    );
    let folded = tight.find("check(s) passed (ACCEPT)</summary>").unwrap();
    assert!(tight.find("<li><b>REVIEW</b>").unwrap() < folded);
    // The terminal: the worst first.
    let verdicts: Vec<&str> = out
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|w| ["ACCEPT", "REVIEW", "REJECT"].contains(w))
        .collect();
    assert!(
        verdicts.contains(&"REVIEW") && verdicts.contains(&"ACCEPT"),
        "{out}"
    );
    assert!(
        verdicts
            .windows(2)
            .all(|w| !(w[0] == "ACCEPT" && w[1] != "ACCEPT")),
        "the worst first: {verdicts:?}"
    );
    assert!(out.contains("unit M1: REVIEW"), "{out}");
    assert!(
        out.contains("a_x: predicted 1-sigma error over the flight"),
        "{out}"
    );
    assert!(out.contains("exceeds the requirement 0.00001"), "{out}");
    // Without a requirement, a left-out term that may cost over three times the predicted
    // error is named.
    let (_, out, _) = calibrate(&[]);
    assert!(
        out.contains(", left out of the model, may cost up to"),
        "{out}"
    );
    // Issue 68: a requirement between the RMS (the verdict's statistic, about 1.2 mm/s^2) and
    // the worst moment (about 2.9 mm/s^2): every output over it is named, and which statistic
    // the verdict uses.
    let (_, out, _) = calibrate(&["--requirement", "a=0.002"]);
    for o in ["a_x", "a_y", "a_z"] {
        assert!(
            out.contains(&format!(
                "{o}: within the requirement 0.002 by the verdict's statistic (the RMS over the flight"
            )),
            "{o}: {out}"
        );
    }
    assert!(
        out.contains("but over it at the flight's worst moment"),
        "{out}"
    );
    // A requirement that cannot be read.
    let (code, _, err) = calibrate(&["--requirement", "a=-1"]);
    assert_ne!(code, 0);
    assert!(err.contains("expected a=SI,g=SI"), "{err}");
    // A key this accelerometer triad has not (a gyro's family, a word, a gyro output) is
    // refused naming the keys that apply, and nothing is written; a key given twice too.
    for key in ["g=1e-4", "gyro=1e-4", "w=1e-4", "g_x=1e-4"] {
        let (code, _, err) = calibrate(&["--requirement", key, "--json", "refused.json"]);
        assert_eq!(code, 1, "{key}: {err}");
        let name = key.split('=').next().unwrap();
        assert!(
            err.contains(&format!("--requirement `{name}`"))
                && err.contains("the keys that apply are a_x, a, a_y, a_z"),
            "{key}: {err}"
        );
        assert!(!d.path().join("refused.json").exists(), "{key}");
    }
    let (code, _, err) = calibrate(&["--requirement", "a=1e-9,a=100"]);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("`a` is given twice"), "{err}");
}

/// A single gyro's requirement is its family's, `g=` (it was read as an accelerometer's: `g=`
/// was ignored and `a=` applied).
#[test]
fn a_single_gyro_is_held_to_the_gyro_requirement() {
    let d = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| calflash(d.path(), args);
    let (code, _, err) = run(&[
        "simulate",
        "--sensor",
        "single-gyro",
        "--plan",
        "rate:-8:8:9",
        "--repeat",
        "2",
        "-o",
        "gyro.csv",
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = run(&[
        "simulate",
        "--sensor",
        "imu",
        "--flight",
        "rocket:seconds=20",
        "-o",
        "rocket.csv",
    ]);
    assert_eq!(code, 0, "{err}");
    let calibrate = |req: &str| {
        run(&[
            "calibrate",
            "gyro.csv",
            "--sensor",
            "single-gyro",
            "--serial",
            "G1",
            "--no-db",
            "--mission",
            "rocket.csv",
            "--requirement",
            req,
        ])
    };
    let (_, out, err) = calibrate("g=1e-9");
    assert!(out.contains("exceeds the requirement"), "{out}{err}");
    let (code, _, err) = calibrate("a=1e-9");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("the keys that apply are"), "{err}");
}

/// An IMU calibrated on a rate table (its accelerometers' lever arms fitted) judged over a
/// spinning shell: the terms its model leaves out are priced on the rows as its own fit read
/// them (lever-arm regressors included). This panicked before ("the reader read every model
/// column"): the lever-arm columns are made by the fit, not read from the file.
#[test]
fn an_imu_with_lever_arms_is_judged_over_a_spinning_flight() {
    let d = tempfile::tempdir().unwrap();
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    let truth = examples.join("spinning_round.truth.json");
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            truth.to_str().unwrap(),
            "--flight",
            "shell:seconds=2",
            "-o",
            "shell.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let bench = examples.join("imu_bench.csv");
    let (code, out, err) = calflash(
        d.path(),
        &[
            "calibrate",
            bench.to_str().unwrap(),
            "--sensor",
            "imu",
            "--serial",
            "M-LEVER",
            "--mission",
            "shell.csv",
            "--json",
            "m.json",
            "--no-db",
        ],
    );
    assert!(code == 0 || code == 3, "{out}{err}");
    assert!(out.contains("lever-arm components are estimated"), "{out}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("m.json")).unwrap()).unwrap();
    assert_eq!(record["mission"]["outputs"].as_array().unwrap().len(), 6);
    // a_z has lever-arm terms; a term its model left out is priced over the flight.
    let priced: Vec<&str> = record["mission"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|t| t["output"].as_str())
        .collect();
    assert!(priced.contains(&"a_z"), "{priced:?}");
}
