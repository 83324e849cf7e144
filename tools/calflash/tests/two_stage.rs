//! Two stages of calibration (sensors before assembly, then the assembled IMU): over simulated
//! units with nonlinear, asymmetric sensors whose biases curve in temperature, the two-stage
//! calibration's error over the operating range against one stage's of about the same
//! observations, the honesty of its stated 1-sigma, and the check between the stages.

use std::path::{Path, PathBuf};

use calflash::sensor::record::Record;
use calflash::sensor::stages::{Check, one};
use calflash::sensor::triad::{self, Kind};
use calflash::sensor::{Calibrated, Options, Thermal, Verdict, single};
use calflash::sim::plan::{self, Condition};
use calflash::sim::stages::AssembledTruth;
use rayon::prelude::*;
use spincal::model::Quantity;

/// The chamber's temperatures for stage one and for one stage.
const TEMPS: [f64; 5] = [-20.0, 5.0, 25.0, 45.0, 70.0];

fn write(obs: &calflash::sim::Observations, path: &Path) {
    let mut f = std::fs::File::create(path).unwrap();
    obs.write_csv(&mut f).unwrap();
}

fn conditions(items: &[&str], temps: &[f64], repeat: usize, single: bool) -> Vec<Condition> {
    let items: Vec<String> = items.iter().map(|s| s.to_string()).collect();
    plan::plan(&items, temps, &[3.3], repeat, single).unwrap()
}

/// Stage one of every sensor of `truth`: each on its own fixture (a dividing head of 24
/// angles, a rate table of 24 rates up to 8 rad/s) at the five temperatures; the records'
/// paths.
fn stage_one(truth: &AssembledTruth, dir: &Path, seed: u64) -> Vec<PathBuf> {
    (0..6)
        .map(|k| {
            let plan = if k < 3 {
                conditions(&["head:56"], &TEMPS, 1, true)
            } else {
                conditions(&["rate:-8:8:41", "rate:0:0:15"], &TEMPS, 1, true)
            };
            let obs = truth.stage_one(k, &plan, seed * 10 + k as u64);
            let csv = dir.join(format!("s1_{}.csv", one::OUTPUTS[k]));
            write(&obs, &csv);
            let mut opts = Options::new(&csv, &format!("S{seed}-{k}"));
            opts.thermal = Thermal::Table;
            opts.created = Some(0);
            opts.keep_all_terms = true;
            opts.asymmetry = Some(true);
            let q = if k < 3 {
                Quantity::Acceleration
            } else {
                Quantity::AngularRate
            };
            let c = single::calibrate(&opts, q).unwrap();
            if c.verdict() == Verdict::Reject {
                for f in &c.findings {
                    println!("stage one {k}: {:?} {}", f.verdict, f.text);
                }
            }
            let json = dir.join(format!("s1_{}.json", one::OUTPUTS[k]));
            std::fs::write(
                &json,
                serde_json::to_string(&Record::new(&c, &csv.display().to_string())).unwrap(),
            )
            .unwrap();
            json
        })
        .collect()
}

/// The assembled unit's plan: a 26-position tumble (axes, edges and corners) and rate steps about the six axis
/// directions, at 25 C.
fn unit_plan(temps: &[f64], repeat: usize) -> Vec<Condition> {
    conditions(
        &["tumble:26", "rate:-8:8:4", "diagonal:-8:8:2"],
        temps,
        repeat,
        false,
    )
}

fn two_stage(truth: &AssembledTruth, dir: &Path, seed: u64) -> (Calibrated, Check) {
    let records = stage_one(truth, dir, seed);
    let obs = truth.stage_two(&unit_plan(&[25.0], 1), seed + 7);
    let csv = dir.join("unit.csv");
    write(&obs, &csv);
    let sensors = one::read_all(&records).unwrap();
    let mut opts = Options::new(&csv, "IMU-1");
    opts.created = Some(0);
    opts.keep_all_terms = true;
    triad::stage_two::calibrate(&opts, &sensors).unwrap()
}

/// One stage: the assembled unit through the same tumble and rate steps at the five
/// temperatures, every term (g-squared, cubic, odd-quadratic per axis) fitted at once.
fn one_stage(truth: &AssembledTruth, dir: &Path, seed: u64) -> Calibrated {
    let obs = truth.stage_two(&unit_plan(&TEMPS, 1), seed + 11);
    let csv = dir.join("one.csv");
    write(&obs, &csv);
    let mut opts = Options::new(&csv, "IMU-1");
    opts.created = Some(0);
    opts.thermal = Thermal::Table;
    opts.keep_all_terms = true;
    triad::calibrate(&opts, Kind::Imu, true).unwrap()
}

/// What a calibration's forward model predicts (counts) for output `k` at condition `c`, and
/// its stated 1-sigma (over the features the device states it with: all but the cubic,
/// odd-quadratic and asymmetry terms).
fn predicted(fit: &calflash::stats::Fit, k: usize, c: &Condition) -> (f64, f64) {
    let coef = |n: &str| {
        fit.names
            .iter()
            .position(|m| m == n)
            .map_or(0.0, |i| fit.coefficients[i])
    };
    let (inputs, values) = if k < 3 {
        (["f_x", "f_y", "f_z"], c.f)
    } else {
        (["w_x", "w_y", "w_z"], c.w)
    };
    let z: f64 = (0..3).map(|j| coef(inputs[j]) * values[j]).sum::<f64>()
        + if k < 3 {
            0.0
        } else {
            (0..3)
                .map(|j| coef(["f_x", "f_y", "f_z"][j]) * c.f[j])
                .sum()
        };
    let x = z / coef(inputs[k % 3]);
    let feature = |n: &str| -> f64 {
        match n {
            "1" => 1.0,
            "sensed^2" => x * x,
            "sensed^3" => x * x * x,
            "sensed:abs(sensed)" => x * x.abs(),
            "sensed_kink" => x.abs(),
            n if n.starts_with("lever_") => 0.0,
            n => match inputs.iter().position(|m| *m == n) {
                Some(j) => values[j],
                None => ["f_x", "f_y", "f_z"]
                    .iter()
                    .position(|m| *m == n)
                    .map_or(0.0, |j| c.f[j]),
            },
        }
    };
    let phi: Vec<f64> = fit.names.iter().map(|n| feature(n)).collect();
    let value = fit.coefficients.iter().zip(&phi).map(|(b, f)| b * f).sum();
    let stated: Vec<f64> = fit
        .names
        .iter()
        .zip(&phi)
        .map(|(n, f)| {
            if matches!(
                n.as_str(),
                "sensed^3" | "sensed:abs(sensed)" | "sensed_kink"
            ) {
                0.0
            } else {
                *f
            }
        })
        .collect();
    let p = stated.len();
    let var: f64 = (0..p)
        .flat_map(|a| (0..p).map(move |b| (a, b)))
        .map(|(a, b)| stated[a] * fit.covariance[(a, b)] * stated[b])
        .sum();
    (value, var.max(0.0).sqrt())
}

/// A calibration against the truth over the operating range at each of its temperatures:
/// gravity from 20 directions at rest (accelerometers) and rates up to 8 rad/s about the six
/// axis directions (gyros). Per output family, the sum of squared errors (SI) and the count;
/// and how many errors fall inside 1.96 stated sigma.
#[derive(Default, Clone, Copy)]
struct Score {
    sq: [f64; 2],
    n: [usize; 2],
    inside: usize,
    total: usize,
    inside_f: [usize; 2],
}

fn score(c: &Calibrated, truth: &AssembledTruth) -> Score {
    let mut s = Score::default();
    let cal = spincal::blob::decode(&c.blob).unwrap();
    let mut device = spincal::correct::AnyImuCorrector::new(&cal, 1000.0).unwrap();
    for point in &c.points {
        let t = point.temp.unwrap_or(25.0);
        device.set_environment(t as f32, 3.3);
        let accel = conditions(&["sphere:20"], &[t], 1, false);
        let gyro = conditions(&["rate:-8:8:7"], &[t], 1, false);
        for k in 0..6 {
            let fit = &point.axes[k].fit;
            let family = usize::from(k >= 3);
            for cond in if k < 3 { &accel } else { &gyro } {
                let (value, _) = predicted(fit, k, cond);
                let slope = truth.sensors[k].k1;
                let err = (value - truth.outputs(cond)[k]) / slope;
                let inputs: [f32; 6] =
                    std::array::from_fn(|j| (if j < 3 { cond.f[j] } else { cond.w[j - 3] }) as f32);
                let stated = f64::from(device.sigma(&inputs).unwrap()[k]);
                s.sq[family] += err * err;
                s.n[family] += 1;
                s.inside += usize::from(err.abs() <= 1.96 * stated);
                s.inside_f[family] += usize::from(err.abs() <= 1.96 * stated);
                s.total += 1;
            }
        }
    }
    s
}

fn rms(scores: &[Score], family: usize) -> f64 {
    let sq: f64 = scores.iter().map(|s| s.sq[family]).sum();
    let n: usize = scores.iter().map(|s| s.n[family]).sum();
    (sq / n as f64).sqrt()
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
    let coverage = |s: &[Score]| {
        s.iter().map(|x| x.inside).sum::<usize>() as f64
            / s.iter().map(|x| x.total).sum::<usize>() as f64
    };
    for (name, family) in [("accelerometers, m/s^2", 0), ("gyros, rad/s", 1)] {
        println!(
            "{name}: RMS error over the operating range: two stages {:.3e}, one stage {:.3e}, ratio {:.3}",
            rms(&two, family),
            rms(&one, family),
            rms(&two, family) / rms(&one, family)
        );
    }
    println!(
        "95% intervals cover the truth: two stages {:.4}, one stage {:.4}",
        coverage(&two),
        coverage(&one)
    );
    for f in 0..2 {
        println!(
            "family {f} coverage two {:.4} one {:.4}",
            two.iter().map(|x| x.inside_f[f]).sum::<usize>() as f64
                / two.iter().map(|x| x.n[f]).sum::<usize>() as f64,
            one.iter().map(|x| x.inside_f[f]).sum::<usize>() as f64
                / one.iter().map(|x| x.n[f]).sum::<usize>() as f64
        );
    }
    assert!(rms(&two, 0) < rms(&one, 0));
    assert!(rms(&two, 1) < rms(&one, 1));
    assert!(
        (0.915..=0.985).contains(&coverage(&two)),
        "{}",
        coverage(&two)
    );
}
