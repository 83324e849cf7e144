//! The mission error a calibration predicts, after its model selection, on units and flights we
//! did not make: the flights are the three reference flights of
//! `../shared/data/reference-flights` (an independent 6-DOF's shells, RocketPy's rocket), the
//! units are gyro triads drawn from a forward model written here, apart from `sim/`:
//!
//! ```text
//! code_k = c0_k + c1_k (n_k . w + G_k . f) + e,   e ~ N(0, 2^2) counts
//! ```
//!
//! with `n_k` the sensing direction (its axis tilted by about 3 mrad per component), `c1` the
//! converter's counts per rad/s over the flight's gyro range (+-0.5 %), `c0` mid-scale +-800
//! counts, and `G_k` the g-sensitivity row: zero on a third of the units (a term the selection
//! may keep by chance), a MEMS gyro's on a third, and near the bench's detection limit on the
//! rest (a term the selection may keep or drop). Each unit is calibrated with `calibrate --mission` on the plan `design
//! optimize --mission` gives for the flight; its realised error along the flight (the samples
//! inside the bench's specific force) is the fitted model's code against the unit's, over the
//! fitted scale factor, held against the predicted (`record.mission.outputs[k].rms`) per unit
//! and pooled over all replicates, per axis.
//!
//! Skips with a notice where `../shared` is absent (a user's clone).

mod common;

use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const G: f64 = 9.806_65;
/// Units per flight.
const UNITS: u64 = 80;

fn flights() -> Option<PathBuf> {
    let root =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/reference-flights");
    root.join("shell155/truth_trajectory.csv")
        .exists()
        .then_some(root)
}

/// One drawn gyro triad.
struct Unit {
    c0: [f64; 3],
    c1: [f64; 3],
    n: [[f64; 3]; 3],
    g: [[f64; 3]; 3],
}

impl Unit {
    fn draw(rng: &mut ChaCha8Rng, per_rad_s: f64, sensitive: bool, g_sigma: f64) -> Self {
        let z = Normal::new(0.0, 1.0).unwrap();
        let mut n = [[0.0; 3]; 3];
        for (k, row) in n.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = if j == k { 1.0 } else { 3e-3 * z.sample(rng) };
            }
            let norm = row.iter().map(|x| x * x).sum::<f64>().sqrt();
            row.iter_mut().for_each(|x| *x /= norm);
        }
        let c0 = std::array::from_fn(|_| 32_768.0 + 800.0 * z.sample(rng));
        let c1 = std::array::from_fn(|_| per_rad_s * (1.0 + 5e-3 * z.sample(rng)));
        let g = std::array::from_fn(|_| {
            std::array::from_fn(|_| {
                if sensitive {
                    g_sigma * z.sample(rng)
                } else {
                    0.0
                }
            })
        });
        Unit { c0, c1, n, g }
    }

    /// Axis `k`'s code without noise at rate `w` and specific force `f`.
    fn code(&self, k: usize, f: &[f64; 3], w: &[f64; 3]) -> f64 {
        let dot = |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        self.c0[k] + self.c1[k] * (dot(&self.n[k], w) + dot(&self.g[k], f))
    }
}

/// The flight's `(f, w)` samples from its truth file.
fn read_flight(path: &Path) -> Vec<([f64; 3], [f64; 3])> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let head = reader.headers().unwrap().clone();
    let at = |n: &str| head.iter().position(|h| h == n).unwrap();
    let (fi, wi) = (["f_x", "f_y", "f_z"].map(at), ["w_x", "w_y", "w_z"].map(at));
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            let v = |k: usize| r[k].parse::<f64>().unwrap();
            (fi.map(v), wi.map(v))
        })
        .collect()
}

/// A fitted term's value at `(f, w)`: the gyro preset's terms are the bias, the rates and the
/// specific force.
fn feature(name: &str, f: &[f64; 3], w: &[f64; 3]) -> f64 {
    match name {
        "1" => 1.0,
        "w_x" => w[0],
        "w_y" => w[1],
        "w_z" => w[2],
        "f_x" => f[0],
        "f_y" => f[1],
        "f_z" => f[2],
        other => panic!("a term this test does not know: {other}"),
    }
}

struct Tally {
    /// Per axis: realised mean square, predicted mean square, summed over the units.
    all: [[f64; 2]; 3],
    /// Per axis: the sum of squares of each unit's realised over predicted, and their count.
    z: [[f64; 2]; 3],
    /// The same over the axes whose selection kept a g-term the unit does not have.
    spurious: [f64; 2],
    spurious_count: usize,
}

fn run_flight(dir: &Path, truth: &Path, range: f64, seed0: u64, tally: &mut Tally) {
    let run = |args: &[&str]| {
        let (code, out, err) = common::calflash(dir, args);
        assert!(code == 0 || code == 2, "{args:?}: {out}{err}");
        out
    };
    let truth_s = truth.to_str().unwrap();
    let candidates = format!("rate:{}:{}:41", -range.round(), range.round());
    run(&[
        "design",
        "optimize",
        "--sensor",
        "gyro",
        "--model",
        "triad-nonlinear",
        "--candidates",
        &candidates,
        "--n",
        "60",
        "--mission",
        truth_s,
        "-o",
        "plan.csv",
    ]);
    let mut plan = csv::Reader::from_path(dir.join("plan.csv")).unwrap();
    let head = plan.headers().unwrap().clone();
    let at = |n: &str| head.iter().position(|h| h == n).unwrap();
    let (fi, wi) = (["f_x", "f_y", "f_z"].map(at), ["w_x", "w_y", "w_z"].map(at));
    let rows: Vec<([f64; 3], [f64; 3])> = plan
        .records()
        .map(|r| {
            let r = r.unwrap();
            let v = |k: usize| r[k].parse::<f64>().unwrap();
            (fi.map(v), wi.map(v))
        })
        .collect();
    let flight: Vec<([f64; 3], [f64; 3])> = read_flight(truth)
        .into_iter()
        .filter(|(f, w)| {
            f.iter().all(|x| x.abs() <= G * 1.000_1) && w.iter().all(|x| x.abs() <= range)
        })
        .collect();
    assert!(flight.len() > 1000, "{}", flight.len());
    let per_rad_s = 32_768.0 / range;
    for seed in seed0..seed0 + UNITS {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // A third of the units have no g-sensitivity, a third a MEMS gyro's (2e-4 rad/s per
        // m/s^2, about 0.1 deg/s per g), a third one near the bench's detection limit: its
        // standard error on such a plan is 0.003 to 0.016 rad/s per m/s^2, so terms drawn at
        // 0.01 straddle the 5 % test.
        let (sensitive, g_sigma) = match seed % 3 {
            0 => (false, 0.0),
            1 => (true, 2e-4),
            _ => (true, 0.01),
        };
        let unit = Unit::draw(&mut rng, per_rad_s, sensitive, g_sigma);
        let noise = Normal::new(0.0, 2.0).unwrap();
        let mut text = String::from("f_x,f_y,f_z,w_x,w_y,w_z,temp,g_x,g_y,g_z\n");
        for (f, w) in &rows {
            let codes: Vec<String> = (0..3)
                .map(|k| format!("{}", unit.code(k, f, w) + noise.sample(&mut rng)))
                .collect();
            text += &format!(
                "{},{},{},{},{},{},25,{}\n",
                f[0],
                f[1],
                f[2],
                w[0],
                w[1],
                w[2],
                codes.join(",")
            );
        }
        std::fs::write(dir.join("b.csv"), text).unwrap();
        run(&[
            "calibrate",
            "b.csv",
            "--sensor",
            "gyro",
            "--serial",
            "G",
            "--no-db",
            "--mission",
            truth_s,
            "--json",
            "r.json",
        ]);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("r.json")).unwrap()).unwrap();
        for (k, (names, b)) in common::record_axes(&r).into_iter().enumerate() {
            let own = ["w_x", "w_y", "w_z"][k];
            let scale = b[names.iter().position(|n| *n == own).unwrap()];
            let ms = flight
                .iter()
                .map(|(f, w)| {
                    let fitted: f64 = names
                        .iter()
                        .zip(&b)
                        .map(|(n, bj)| bj * feature(n, f, w))
                        .sum();
                    let e = (fitted - unit.code(k, f, w)) / scale;
                    e * e
                })
                .sum::<f64>()
                / flight.len() as f64;
            let predicted = r["mission"]["outputs"][k]["rms"].as_f64().unwrap().powi(2);
            tally.z[k][0] += ms / predicted;
            tally.z[k][1] += 1.0;
            tally.all[k][0] += ms;
            tally.all[k][1] += predicted;
            if unit.g[k].iter().all(|x| *x == 0.0) && names.iter().any(|n| n.starts_with("f_")) {
                tally.spurious[0] += ms;
                tally.spurious[1] += predicted;
                tally.spurious_count += 1;
            }
        }
    }
}

/// Over 240 units (80 per reference flight), every replicate counted, the realised mission
/// error is not above the predicted on any axis: each unit's realised over predicted has an RMS
/// of 0.75 to 1.25, and the RMS realised over the RMS predicted is 0.6 to 1.25. Before the
/// prediction took the model before the choice of terms, the pooled ratio was 1.35, 1.38 and
/// 1.19 on 120 of these units.
#[test]
fn the_predicted_mission_error_holds_after_selection_on_units_and_flights_we_did_not_make() {
    let Some(root) = flights() else {
        println!(
            "skipped: ../shared/data/reference-flights is absent (a user's clone has no shared data)"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut tally = Tally {
        all: [[0.0; 2]; 3],
        z: [[0.0; 2]; 3],
        spurious: [0.0; 2],
        spurious_count: 0,
    };
    // Each flight's gyro range (rad/s): the shells' +-2000 of their spin axis, the rocket's
    // +-70.
    for (i, (case, range)) in [
        ("shell155", 2000.0),
        ("shell105", 2000.0),
        ("rocket_calisto", 70.0),
    ]
    .into_iter()
    .enumerate()
    {
        run_flight(
            dir.path(),
            &root.join(case).join("truth_trajectory.csv"),
            range,
            1 + i as u64 * UNITS,
            &mut tally,
        );
    }
    let ratio = |x: [f64; 2]| (x[0] / x[1]).sqrt();
    let pooled = tally.all.map(ratio);
    let per_unit = tally.z.map(ratio);
    println!(
        "over {} units: RMS of each unit's realised / predicted mission error: g_x {:.3}, g_y {:.3}, g_z {:.3}; pooled RMS realised / RMS predicted: {:.3}, {:.3}, {:.3}; the {} axes that kept a g-term the unit has not: {:.3}",
        3 * UNITS,
        per_unit[0],
        per_unit[1],
        per_unit[2],
        pooled[0],
        pooled[1],
        pooled[2],
        tally.spurious_count,
        ratio(tally.spurious)
    );
    // Four seed blocks of 240 gave 0.81 to 0.99 per unit and 0.72 to 1.00 pooled: a dropped
    // term is stated at the whole model's variance whether the unit has it or not, so a
    // population where most units have none is predicted on the safe side.
    for k in 0..3 {
        assert!(
            (0.75..=1.25).contains(&per_unit[k]),
            "axis {k}: RMS of realised / predicted {}",
            per_unit[k]
        );
        assert!(
            (0.6..=1.25).contains(&pooled[k]),
            "axis {k}: pooled realised / predicted {}",
            pooled[k]
        );
    }
    assert!(tally.spurious_count >= 10, "{}", tally.spurious_count);
}
