//! Two stages of calibration (sensors before assembly, then the assembled IMU): over simulated
//! units with nonlinear, asymmetric sensors whose biases curve in temperature, the two-stage
//! calibration's error over the operating range against one stage's of about the same
//! observations, the honesty of its stated 1-sigma, and the check between the stages.

mod common;

use std::path::Path;

use common::calflash;
#[path = "common/stage_score.rs"]
mod stage_score;
use stage_score::{Input, Score, Truth, coverage, coverage_all, rms, stated_rms, z0};

use calflash::design::stages::{self, Plans};
use calflash::sensor::record::Record;
use calflash::sensor::stages::{Check, one};
use calflash::sensor::{Calibrated, Verdict};
use calflash::sim::plan::{self, Condition};
use calflash::sim::stages::AssembledTruth;
use rayon::prelude::*;

/// The chamber's temperatures for stage one and for one stage.
const TEMPS: [f64; 5] = [-20.0, 5.0, 25.0, 45.0, 70.0];

fn conditions(items: &[&str], temps: &[f64], repeat: usize, single: bool) -> Vec<Condition> {
    let items: Vec<String> = items.iter().map(|s| s.to_string()).collect();
    plan::plan(&items, temps, &[3.3], repeat, single).unwrap()
}

/// The plans: stage one of each sensor on its own fixture (a dividing head of 56 angles, a rate
/// table of 41 rates up to 8 rad/s and 15 at rest) at the five temperatures; the assembled
/// unit through a 26-position tumble (axes, edges and corners) and rate steps about the six
/// axis directions, at 25 C (stage two) or at the five temperatures (one stage, every term
/// fitted at once).
fn plans() -> Plans {
    let unit = |temps: &[f64]| {
        conditions(
            &["tumble:26", "rate:-8:8:4", "diagonal:-8:8:2"],
            temps,
            1,
            false,
        )
    };
    Plans {
        accel_one: conditions(&["head:56"], &TEMPS, 1, true),
        gyro_one: conditions(&["rate:-8:8:41", "rate:0:0:15"], &TEMPS, 1, true),
        unit: unit(&[25.0]),
        one_stage: unit(&TEMPS),
    }
}

fn two_stage(truth: &AssembledTruth, dir: &Path, seed: u64) -> (Calibrated, Check) {
    stages::two_stages(&plans(), truth, dir, seed).unwrap()
}

fn one_stage(truth: &AssembledTruth, dir: &Path, seed: u64) -> Calibrated {
    stages::one_stage_of(&plans(), truth, dir, seed).unwrap()
}

/// Our simulator's unit as the shared scoring reads a truth.
struct Sim<'a>(&'a AssembledTruth);

impl Truth for Sim<'_> {
    fn outputs(&self, input: &Input, temp: f64) -> [f64; 6] {
        self.0.outputs(&Condition {
            f: input.f,
            w: input.w,
            dw: [0.0; 3],
            h: [0.0; 3],
            temp,
            volt: 3.3,
            dir: 0.0,
        })
    }
    fn slope(&self, k: usize, _temp: f64) -> f64 {
        self.0.sensors[k].k1
    }
}

/// The operating range: gravity from 20 directions at rest (accelerometers) and rates up to
/// 8 rad/s about the six axis directions (gyros).
fn range() -> (Vec<Input>, Vec<Input>) {
    let inputs = |items: &[&str]| -> Vec<Input> {
        conditions(items, &[25.0], 1, false)
            .iter()
            .map(|c| Input { f: c.f, w: c.w })
            .collect()
    };
    (inputs(&["sphere:20"]), inputs(&["rate:-8:8:7"]))
}

fn score(c: &Calibrated, truth: &AssembledTruth) -> Score {
    let (accel, gyro) = range();
    stage_score::score(c, &Sim(truth), &accel, &gyro)
}

#[test]
fn two_stages_calibrate_an_assembled_unit() {
    let dir = tempfile::tempdir().unwrap();
    let truth = AssembledTruth::draw(1);
    let (c, _) = two_stage(&truth, dir.path(), 1);
    for n in &c.notes {
        println!("note {n}");
    }
    for f in &c.findings {
        println!("{:?} {}", f.verdict, f.text);
    }
    assert_ne!(c.verdict(), Verdict::Reject);
}

/// Units drawn by seed for the Monte Carlo.
const UNITS: u64 = 200;

#[test]
fn two_stages_beat_one_and_state_their_error_honestly() {
    let results: Vec<(Score, Score, Check)> = (0..UNITS)
        .into_par_iter()
        .map(|seed| {
            let dir = tempfile::tempdir().unwrap();
            let truth = AssembledTruth::draw(1000 + seed);
            let (two, check) = two_stage(&truth, dir.path(), seed);
            let one = one_stage(&truth, dir.path(), seed);
            (score(&two, &truth), score(&one, &truth), check)
        })
        .collect();
    // The check between the stages on units whose assembly changed no bias or scale factor:
    // any part called moved is a false alarm (Holm at 0.05 over the twelve tests).
    let alarms = results
        .iter()
        .filter(|r| r.2.sensors.iter().any(|s| s.bias_moved || s.scale_moved))
        .count();
    let rate = alarms as f64 / UNITS as f64;
    let band = 0.05 + 3.0 * (0.05 * 0.95 / UNITS as f64).sqrt();
    println!(
        "no change in assembly: the check calls a part moved in {alarms} of {UNITS} units ({rate:.3}; at most {band:.3})"
    );
    assert!(rate <= band, "false alarms {rate}");
    // a_y's scale factor changed in assembly by 5 of its check's standard errors (the median
    // over the units above): found and named.
    let mut se: Vec<f64> = results.iter().map(|r| r.2.sensors[1].scale_se).collect();
    se.sort_by(f64::total_cmp);
    let shift = 5.0 * se[se.len() / 2];
    let found: Vec<(bool, bool)> = (0..UNITS)
        .into_par_iter()
        .map(|seed| {
            let dir = tempfile::tempdir().unwrap();
            let mut truth = AssembledTruth::draw(1000 + seed);
            truth.scale_change[1] = shift;
            let (c, check) = two_stage(&truth, dir.path(), seed);
            let named = c.findings.iter().any(|f| {
                f.verdict == Verdict::Review
                    && f.text.starts_with("a_y")
                    && f.text.contains("scale factor moved")
            });
            (check.sensors[1].scale_moved, named)
        })
        .collect();
    let hits = found.iter().filter(|(m, n)| *m && *n).count();
    println!(
        "a_y's scale factor moved {:.0} ppm in assembly (5 standard errors): found and named in {hits} of {UNITS} units",
        shift * 1e6
    );
    assert!(hits as f64 >= 0.95 * UNITS as f64, "{hits}");
    let two: Vec<Score> = results.iter().map(|r| r.0).collect();
    let one: Vec<Score> = results.iter().map(|r| r.1).collect();
    println!(
        "at zero input, the error over the device's stated 1-sigma, RMS: two stages {:.2} (accelerometers), {:.2} (gyros); one stage {:.2}, {:.2}",
        z0(&two, 0),
        z0(&two, 1),
        z0(&one, 0),
        z0(&one, 1)
    );
    // The stated 1-sigma at zero input is the full model's there: every term the correction
    // applies has its own feature in the blob's factors (folded, the two stages' accelerometers
    // were 1.42, then 1.01; their gyros 0.76; one stage 0.38 and 0.41).
    for (name, s) in [("two stages", &two), ("one stage", &one)] {
        for f in 0..2 {
            assert!(
                (0.9..=1.1).contains(&z0(s, f)),
                "{name}, family {f}, at zero input: z RMS {}",
                z0(s, f)
            );
        }
    }
    for (name, family) in [("accelerometers, m/s^2", 0), ("gyros, rad/s", 1)] {
        println!(
            "{name}: RMS error over the operating range: two stages {:.3e}, one stage {:.3e}, ratio {:.3}",
            rms(&two, family),
            rms(&one, family),
            rms(&two, family) / rms(&one, family)
        );
        println!(
            "{name}: RMS of the stated 1-sigma: two stages {:.3e}, one stage {:.3e}",
            stated_rms(&two, family),
            stated_rms(&one, family)
        );
    }
    println!(
        "95% intervals cover the truth: two stages {:.4}, one stage {:.4}",
        coverage_all(&two),
        coverage_all(&one)
    );
    for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
        println!(
            "{name}: the device's 95% intervals cover the truth: two stages {:.4}, one stage {:.4}",
            coverage(&two, f),
            coverage(&one, f)
        );
        for (plan, s) in [("two stages", &two), ("one stage", &one)] {
            assert!(
                (0.915..=0.985).contains(&coverage(s, f)),
                "{plan}, {name}: {}",
                coverage(s, f)
            );
        }
    }
    assert!(rms(&two, 0) < rms(&one, 0));
    assert!(rms(&two, 1) < rms(&one, 1));
    assert!(
        (0.915..=0.985).contains(&coverage_all(&two)),
        "{}",
        coverage_all(&two)
    );
}

/// The six stage-one records of a simulated unit in `d` (`s1/OUTPUT.json`), made by the CLI;
/// the names, comma-separated.
fn stage_one_cli(d: &Path, seed: &str, shift: Option<&str>) -> String {
    let mut args = vec![
        "simulate",
        "--sensor",
        "imu",
        "--stages",
        "s1",
        "--plan",
        "tumble:26",
        "--plan",
        "rate:-8:8:4",
        "--plan",
        "diagonal:-8:8:2",
        "--temps=-20,5,25,45,70",
        "--seed",
        seed,
        "--write-truth",
        "truth.json",
        "-o",
        "unit.csv",
    ];
    if let Some(s) = shift {
        args.extend(["--assembly-shift", s]);
    }
    let (code, out, err) = calflash(d, &args);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("stage one, g_z: 280 observations"), "{out}");
    // The station's key signs each stage-one record; stage two trusts its public half.
    if !d.join("station.key").exists() {
        let (code, out, err) = calflash(d, &["keygen", "station"]);
        assert_eq!(code, 0, "{out}{err}");
    }
    one::OUTPUTS
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let (csv, json, serial) = (
                format!("s1/{o}.csv"),
                format!("s1/{o}.json"),
                format!("S-{seed}-{k}"),
            );
            let sensor = if k < 3 { "single-accel" } else { "single-gyro" };
            let (code, out, err) = calflash(
                d,
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
                    "--db",
                    "history.sqlite",
                    "--sign-key",
                    "station.key",
                ],
            );
            assert_eq!(code, 0, "{out}{err}");
            json
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// The id of the station key `stage_one_cli` signed with (`station.pub` in `d`).
fn signing_id(d: &Path) -> String {
    let key = calflash::signing::load_public(&d.join("station.pub")).unwrap();
    key.id().iter().map(|b| format!("{b:02x}")).collect()
}

fn stage_two_cli(d: &Path, records: &str, data: &str) -> (i32, String, String) {
    calflash(
        d,
        &[
            "calibrate",
            data,
            "--sensor",
            "imu",
            "--serial",
            "IMU-7",
            "--keep-all-terms",
            "--trust-key",
            "station.pub",
            "--stage-one",
            records,
            "--blob",
            "unit.blob",
            "--json",
            "unit.json",
            "--report",
            "unit.html",
            "--no-db",
        ],
    )
}

#[test]
fn calflash_calibrates_in_two_stages_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let records = stage_one_cli(d, "5", None);
    let (code, out, err) = stage_two_cli(d, &records, "unit.csv");
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("stage one holds for the six sensors"), "{out}");
    assert!(out.contains("between the stages: g_z S-5-5"), "{out}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("unit.json")).unwrap()).unwrap();
    assert_eq!(record["stages"]["sensors"].as_array().unwrap().len(), 6);
    assert_eq!(
        record["points"].as_array().unwrap().len(),
        5,
        "stage one's temperatures"
    );
    let cal = spincal::blob::decode(&std::fs::read(d.join("unit.blob")).unwrap()).unwrap();
    let env = &cal.data().environment;
    assert_eq!(env.temperatures.len(), 5);
    assert_eq!(
        (env.temperature_span.lo, env.temperature_span.hi),
        (-20.0, 70.0)
    );
    let html = std::fs::read_to_string(d.join("unit.html")).unwrap();
    assert!(
        html.contains("between the stages"),
        "the report says what each stage did"
    );
    // The same from the unit history, by the sensors' serials.
    let by_serial: Vec<String> = (0..6).map(|k| format!("history:S-5-{k}")).collect();
    let (code, out, err) = calflash(
        d,
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
            &by_serial.join(","),
            "--json",
            "from_history.json",
            "--db",
            "history.sqlite",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let again: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("from_history.json")).unwrap())
            .unwrap();
    let sensors = |v: &serde_json::Value| v["stages"]["sensors"].as_array().unwrap().clone();
    for (a, b) in sensors(&again).iter().zip(&sensors(&record)) {
        assert_eq!(a["bias_change"], b["bias_change"]);
        assert_eq!(a["scale_change"], b["scale_change"]);
        assert!(
            a["record"]
                .as_str()
                .unwrap()
                .contains("history.sqlite record"),
            "{a}"
        );
    }
    // Red team four: the same six sensors calibrated into a second unit are named, each with
    // the unit they are built into.
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "unit.csv",
            "--sensor",
            "imu",
            "--serial",
            "IMU-9",
            "--keep-all-terms",
            "--trust-key",
            "station.pub",
            "--stage-one",
            &by_serial.join(","),
            "--db",
            "history.sqlite",
        ],
    );
    assert_eq!(code, 0, "REVIEW: {out}{err}");
    for k in 0..6 {
        let line = format!(
            "REVIEW {}: sensor S-5-{k} is already built into unit IMU-7",
            one::OUTPUTS[k]
        );
        assert!(out.contains(&line), "want `{line}` in {out}");
    }
    let mut unknown = by_serial.clone();
    unknown[5] = "history:NOPE".into();
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "unit.csv",
            "--sensor",
            "imu",
            "--serial",
            "IMU-7",
            "--trust-key",
            "station.pub",
            "--stage-one",
            &unknown.join(","),
            "--db",
            "history.sqlite",
        ],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("has no calibration of sensor NOPE"), "{err}");

    // Assembly stressed a_y: its scale factor moved by 0.2 %.
    let shifted = tempfile::tempdir().unwrap();
    let s = shifted.path();
    let records = stage_one_cli(s, "5", Some("a_y=2e-3"));
    let (code, out, err) = stage_two_cli(s, &records, "unit.csv");
    assert_eq!(code, 0, "REVIEW is not a rejection: {out}{err}");
    assert!(
        out.contains("REVIEW a_y (sensor S-5-1): the scale factor moved in assembly by +2"),
        "{out}"
    );
}

#[test]
fn stage_one_records_that_do_not_fit_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let records = stage_one_cli(d, "6", None);
    let list: Vec<&str> = records.split(',').collect();
    let fails = |records: &str, data: &str, want: &str| {
        let (code, out, err) = stage_two_cli(d, records, data);
        assert_eq!(code, 1, "{out}{err}");
        assert!(err.contains(want), "want `{want}` in: {err}");
        assert!(!d.join("unit.blob").exists(), "nothing written");
    };
    // A missing axis.
    fails(
        &list[..5].join(","),
        "unit.csv",
        "six records are expected, one per sensor in the order a_x,a_y,a_z,g_x,g_y,g_z; 5 given: g_z missing",
    );
    // A gyro's record for an accelerometer's output.
    let mut swapped = list.clone();
    swapped.swap(0, 3);
    fails(
        &swapped.join(","),
        "unit.csv",
        "s1/g_x.json (a_x): the record is of a gyro (in rad/s); a_x is an accelerometer (in m/s^2)",
    );
    // The same sensor twice.
    let mut twice = list.clone();
    twice[1] = list[0];
    fails(&twice.join(","), "unit.csv", "are the same sensor S-6-0");
    // A rejected stage one.
    let text = std::fs::read_to_string(d.join(list[2])).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["verdict"] = "reject".into();
    std::fs::write(d.join("rejected.json"), v.to_string()).unwrap();
    let mut rejected = list.clone();
    rejected[2] = "rejected.json";
    fails(
        &rejected.join(","),
        "unit.csv",
        "rejected.json (a_z): stage one of sensor S-6-2 was judged REJECT",
    );
    // Records edited after they were written: each refused, naming what does not match.
    let edit = |name: &str, f: &dyn Fn(&mut serde_json::Value)| {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(list[2])).unwrap()).unwrap();
        f(&mut v);
        std::fs::write(d.join(name), v.to_string()).unwrap();
        let mut edited = list.clone();
        edited[2] = name;
        edited.join(",")
    };
    let coefficient = |k: usize, by: &'static dyn Fn(f64) -> f64| {
        move |v: &mut serde_json::Value| {
            for p in v["points"].as_array_mut().unwrap() {
                let c = &mut p["axes"][0]["coefficients"][k];
                *c = by(c.as_f64().unwrap()).into();
            }
        }
    };
    let broken = "a_z): its seal does not match its content";
    let bias = edit("bias.json", &coefficient(0, &|c| c + 100.0));
    fails(&bias, "unit.csv", broken);
    let scale = edit("scale.json", &coefficient(1, &|c| c * 1.01));
    fails(&scale, "unit.csv", broken);
    let covariance = edit("cov.json", &|v| {
        for p in v["points"].as_array_mut().unwrap() {
            for row in p["axes"][0]["covariance"].as_array_mut().unwrap() {
                for x in row.as_array_mut().unwrap() {
                    *x = (x.as_f64().unwrap() / 100.0).into();
                }
            }
        }
    });
    fails(&covariance, "unit.csv", broken);
    let hot = edit("hot.json", &|v| {
        let points = v["points"].as_array_mut().unwrap();
        let last = points.len() - 1;
        points[last]["temp"] = 90.0.into();
    });
    fails(
        &hot,
        "unit.csv",
        "hot.json (a_z): field `points[4].temp`: 90 C is not a temperature point of its blob (calibrated -20 to 70 C)",
    );
    let unsealed = edit("unsealed.json", &|v| {
        v.as_object_mut().unwrap().remove("seal");
    });
    fails(&unsealed, "unit.csv", "a_z): the record has no seal");
    // A REJECTed stage one whose blob was forced, its verdict edited to accept.
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "s1/a_z.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "S-6-2",
            "--keep-all-terms",
            "--asymmetry",
            "keep",
            "--thermal",
            "table",
            "--max-noise",
            "1e-6",
            "--force-blob",
            "--blob",
            "rej.blob",
            "--json",
            "rej.json",
            "--no-db",
        ],
    );
    // REJECT exits 3.
    assert_eq!(code, 3, "{out}{err}");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("rej.json")).unwrap()).unwrap();
    assert_eq!(v["verdict"], "reject");
    v["verdict"] = "accept".into();
    std::fs::write(d.join("accepted.json"), v.to_string()).unwrap();
    let mut forged = list.clone();
    forged[2] = "accepted.json";
    fails(
        &forged.join(","),
        "unit.csv",
        "accepted.json (a_z): field `verdict`: the record says ACCEPT, while its blob was written from a fit judged REJECT",
    );
    // Red team four: a record edited and re-sealed by hand (anyone can recompute a seal).
    // +100 counts on the bias at -20 C only, which stage two at 25 C cannot see.
    let station = signing_id(d);
    let reseal = |name: &str, keep_signature: bool, f: &dyn Fn(&mut Record)| {
        let rec: Record =
            serde_json::from_str(&std::fs::read_to_string(d.join(list[2])).unwrap()).unwrap();
        let signature = rec.signature.clone();
        let mut edited = rec;
        f(&mut edited);
        let mut edited = edited.sealed();
        if keep_signature {
            edited.signature = signature;
        }
        std::fs::write(d.join(name), serde_json::to_string(&edited).unwrap()).unwrap();
        let mut list = list.clone();
        list[2] = name;
        list.join(",")
    };
    let cold_bias = |r: &mut Record| {
        assert_eq!(r.points[0].temp, Some(-20.0));
        r.points[0].axes[0].coefficients[0] += 100.0;
    };
    fails(
        &reseal("resealed.json", true, &cold_bias),
        "unit.csv",
        &format!(
            "resealed.json (a_z): its signature by station key {station} does not match its content"
        ),
    );
    // The signature removed: an unsigned record is not taken from a station that signs.
    fails(
        &reseal("bare.json", false, &cold_bias),
        "unit.csv",
        "bare.json (a_z): the record is not signed",
    );
    // Taken unsigned on purpose: the coefficients are still checked against the record's own
    // blob, which the edit did not change.
    let unsigned = |records: &str, want: &str| {
        let (code, out, err) = calflash(
            d,
            &[
                "calibrate",
                "unit.csv",
                "--sensor",
                "imu",
                "--serial",
                "IMU-7",
                "--keep-all-terms",
                "--unsigned-stage-one",
                "--stage-one",
                records,
                "--json",
                "unsigned.json",
                "--no-db",
            ],
        );
        if want.is_empty() {
            assert_eq!(code, 0, "{out}{err}");
        } else {
            assert_eq!(code, 1, "{out}{err}");
            assert!(err.contains(want), "want `{want}` in: {err}");
        }
    };
    unsigned(
        &reseal("bare.json", false, &cold_bias),
        "bare.json (a_z): field `points[0].axes[0].coefficients`: at input",
    );
    // Another accelerometer's blob pasted into the record, re-sealed.
    let other: Record =
        serde_json::from_str(&std::fs::read_to_string(d.join(list[1])).unwrap()).unwrap();
    unsigned(
        &reseal("pasted.json", false, &|r: &mut Record| {
            r.blob.clone_from(&other.blob)
        }),
        "pasted.json (a_z): field `points[0].axes[0].coefficients`",
    );
    // A record signed by a station not trusted here.
    let (code, out, err) = calflash(d, &["keygen", "stranger"]);
    assert_eq!(code, 0, "{out}{err}");
    let stranger = calflash::signing::load_private(&d.join("stranger.key")).unwrap();
    let rec: Record =
        serde_json::from_str(&std::fs::read_to_string(d.join(list[2])).unwrap()).unwrap();
    std::fs::write(
        d.join("stranger.json"),
        serde_json::to_string(&rec.signed(&stranger)).unwrap(),
    )
    .unwrap();
    let mut strange = list.clone();
    strange[2] = "stranger.json";
    fails(
        &strange.join(","),
        "unit.csv",
        "stranger.json (a_z): signed by station key",
    );
    // The records as written, taken unsigned on purpose: the unit's record says so.
    unsigned(&list.join(","), "");
    let note = std::fs::read_to_string(d.join("unsigned.json")).unwrap();
    assert!(
        note.contains(&format!(
            "a_z (S-6-2) signed by station key {station}, which is not trusted here"
        )),
        "{note}"
    );
    // Records in each other's place: named as possibly swapped, and refused against the
    // unit's as-built list.
    let mut crossed = list.clone();
    crossed.swap(3, 4);
    let stage_two = |records: &str, data: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            data,
            "--sensor",
            "imu",
            "--serial",
            "IMU-7",
            "--keep-all-terms",
            "--trust-key",
            "station.pub",
            "--stage-one",
            records,
            "--blob",
            "crossed.blob",
            "--no-db",
        ];
        args.extend(extra);
        calflash(d, &args)
    };
    let (code, out, err) = stage_two(&crossed.join(","), "unit.csv", &[]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("both moved by more than 10 of their sigmas: their stage-one records may be in each other's place"),
        "{out}"
    );
    let built = "a_x=S-6-0,a_y=S-6-1,a_z=S-6-2,g_x=S-6-3,g_y=S-6-4,g_z=S-6-5";
    std::fs::remove_file(d.join("crossed.blob")).unwrap();
    let (code, out, err) = stage_two(&crossed.join(","), "unit.csv", &["--as-built", built]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("--stage-one s1/g_y.json (given for g_x) is the record of sensor S-6-4, which is mounted at g_y; the as-built list puts sensor S-6-3 at g_x"),
        "{err}"
    );
    assert!(!d.join("crossed.blob").exists());
    let (code, out, err) = stage_two(&records, "unit.csv", &["--as-built", built]);
    assert_eq!(code, 0, "{out}{err}");
    std::fs::remove_file(d.join("crossed.blob")).unwrap();
    // A sensor mounted backwards: its codes mirrored about mid-scale.
    let csv = std::fs::read_to_string(d.join("unit.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let ax = header.split(',').position(|c| c == "a_x").unwrap();
    let back: Vec<String> = std::iter::once(header.to_string())
        .chain(lines.map(|l| {
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            f[ax] = (65535.0 - f[ax].parse::<f64>().unwrap()).to_string();
            f.join(",")
        }))
        .collect();
    std::fs::write(d.join("back.csv"), back.join("\n") + "\n").unwrap();
    let (code, out, err) = stage_two(&records, "back.csv", &[]);
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        out.contains(
            "REJECT a_x (sensor S-6-0, stage one s1/a_x.json): senses along its own axis reversed"
        ) && out.contains("the sensor is mounted backwards"),
        "{out}"
    );
    assert!(!d.join("crossed.blob").exists());
    // A triad's record.
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "unit.csv",
            "--sensor",
            "imu",
            "--serial",
            "IMU-1",
            "--json",
            "imu1.json",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let mut triad = list.clone();
    triad[4] = "imu1.json";
    fails(
        &triad.join(","),
        "unit.csv",
        "imu1.json (g_y): a `imu` record; stage one is a single sensor's",
    );
    // The unit's data outside stage one's temperatures, or without a temperature.
    let csv = std::fs::read_to_string(d.join("unit.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let t = header.split(',').position(|c| c == "temp").unwrap();
    let hot: Vec<String> = std::iter::once(header.to_string())
        .chain(lines.map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            f[t] = "85";
            f.join(",")
        }))
        .collect();
    std::fs::write(d.join("hot.csv"), hot.join("\n") + "\n").unwrap();
    fails(
        &records,
        "hot.csv",
        "hot.csv: line 2: temp 85 C is outside the span stage one calibrated a_x over (-20 to 70 C",
    );
    let cold: Vec<String> = csv
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            f.iter()
                .enumerate()
                .filter(|(i, _)| *i != t)
                .map(|(_, v)| *v)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    std::fs::write(d.join("notemp.csv"), cold.join("\n") + "\n").unwrap();
    fails(
        &records,
        "notemp.csv",
        "the stage-one records hold temperature points (-20 C, 5 C, 25 C, 45 C, 70 C) but the data have no `temp` column",
    );
    // A unit's plan that turns the gyros faster than their stage one did.
    let (code, out, err) = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--stages",
            "s1b",
            "--plan",
            "tumble:26",
            "--plan",
            "rate:-12:12:4",
            "--seed",
            "6",
            "-o",
            "fast.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    // The unit's file named as one of stage one's: refused before anything is written.
    let before = std::fs::read(d.join("s1b/a_y.csv")).unwrap();
    let (code, _, err) = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--stages",
            "s1b",
            "--plan",
            "tumble:26",
            "--seed",
            "7",
            "-o",
            "s1b/a_y.csv",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("s1b/a_y.csv") && err.contains("--stages (its a_y.csv)"),
        "{err}"
    );
    assert_eq!(std::fs::read(d.join("s1b/a_y.csv")).unwrap(), before);
    fails(
        &records,
        "fast.csv",
        "g_x: the unit's plan drives the axis over -12.0000 to 12.0000 rad/s; stage one (s1/g_x.json) calibrated -8.0000 to 8.0000 rad/s",
    );
    // Not a single-axis unit: --stage-one with another sensor.
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "s1/a_x.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--stage-one",
            &records,
            "--no-db",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("--stage-one: stage two calibrates an assembled IMU"),
        "{err}"
    );
}

/// `design evaluate --stage-one`: a two-stage plan against one stage's before any test, with
/// the collinearity each fit suffers.
#[test]
fn design_compares_two_stages_with_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let unit = "tumble:26,rate:-8:8:4,diagonal:-8:8:2";
    let (code, out, err) = calflash(
        d,
        &[
            "design",
            "evaluate",
            "--model",
            "triad-nonlinear",
            "--sensor",
            "accel",
            "--temps=-20,5,25,45,70",
            "--stage-one",
            "head:56",
            "--plan",
            unit,
            "--plan",
            unit,
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("stage one: head:56 (56 observations per sensor at each of 5 temperature(s))"),
        "{out}"
    );
    assert!(
        out.contains("axis f_z: two stages: mean prediction variance"),
        "{out}"
    );
    // One stage on this plan suffers the asymmetry term's collinearity; stage two none.
    let vif = |line: &str| -> f64 {
        let at = line.find("largest VIF ").unwrap() + "largest VIF ".len();
        line[at..].split(',').next().unwrap().parse().unwrap()
    };
    let one = out
        .lines()
        .find(|l| l.contains("one stage tumble:26"))
        .unwrap();
    let two = out
        .lines()
        .find(|l| l.contains("misalignment fit"))
        .unwrap();
    assert!(vif(one) > 1000.0 && vif(two) < 1.5, "{out}");
    assert!(
        one.contains("RMS error of two stages against one at equal totals: "),
        "{one}"
    );
    // The calibrated comparison: the error each plan's calibrations state, and at equal cost
    // the winner; with stage one's fixtures cheap and the unit's table dear, two stages win.
    let calibrated = |costs: [&str; 2]| -> Vec<String> {
        let (code, out, err) = calflash(
            d,
            &[
                "design",
                "evaluate",
                "--model",
                "triad-nonlinear",
                "--sensor",
                "accel",
                "--temps=-20,5,25,45,70",
                "--stage-one",
                "head:56",
                "--plan",
                unit,
                "--plan",
                unit,
                "--cost-stage-one",
                costs[0],
                "--cost-unit",
                costs[1],
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        out.lines()
            .filter(|l| {
                l.contains(", accelerometers: two stages ") || l.contains(", gyros: two stages ")
            })
            .map(str::to_string)
            .collect()
    };
    let even = calibrated(["1", "1"]);
    assert_eq!(even.len(), 2, "{even:?}");
    assert!(even[0].contains("cost a unit 1754 against 370"), "{even:?}");
    assert!(even[0].ends_with("one stage wins"), "{even:?}");
    let cheap = calibrated(["0.01", "10"]);
    assert!(
        cheap.iter().all(|l| l.ends_with("two stages win")),
        "{cheap:?}"
    );
    // Costs mean nothing without a two-stage plan: refused, naming what is missing.
    let (code, _, err) = calflash(
        d,
        &[
            "design",
            "evaluate",
            "--model",
            "triad",
            "--sensor",
            "accel",
            "--plan",
            "tumble:24",
            "--cost-unit",
            "3",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--stage-one"), "{err}");
    // A one-stage plan that cannot estimate the nonlinear terms is named.
    let (code, _, err) = calflash(
        d,
        &[
            "design",
            "evaluate",
            "--model",
            "triad-nonlinear",
            "--sensor",
            "accel",
            "--stage-one",
            "head:56",
            "--plan",
            unit,
            "--plan",
            "tumble:6",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("one stage tumble:6, axis f_x: f_x^3 is not observable"),
        "{err}"
    );
}
