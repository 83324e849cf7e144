//! Two stages against one on units from a forward model written here, apart from `sim/`: the
//! model of `../shared/data/reference-flights/two-stage/README` (an independent simulator's),
//! drawn afresh per unit so that the Monte Carlo is not three units but a population.
//!
//! The model, per single-axis sensor `k` (counts):
//!
//! ```text
//! out = K0(T) + K1(T) (x + k2 x^2 + k3 x^3) + n,   n ~ N(0, 2^2)
//! K0(T) = k0 + a1 dT + a2 dT^2,   K1(T) = k1 (1 + b1 dT + b2 dT^2),   dT = T - 25 C
//! ```
//!
//! with `x` what the sensor senses along its own axis: at stage one its input exactly; in the
//! assembled unit `n_k . (f + w x (w x r_k))` for an accelerometer (sensing direction `n_k`
//! about 3 mrad off its axis, lever arm `r_k` of 1-4 mm per component) and `n_k . w + G_k . f`
//! for a gyro (g-sensitivity `G_k` about 1e-4 rad/s per m/s^2). The draws: `k0` 32768 +- 800,
//! `k1` 400 (accelerometers, per m/s^2) or 900 (gyros, per rad/s) +- 0.5 %, `k2` 1.5e-4 and
//! `k3` 4e-6 (accelerometers) or 1.2e-4 and 2e-6 (gyros) standard deviation, `a1` 0.5 counts/C,
//! `a2` 2e-3 counts/C^2, `b1` 1e-4 /C, `b2` 2e-7 /C^2.
//!
//! The plans are the reference units': stage one at -20, 5, 25, 45 and 70 C, each accelerometer
//! on a dividing head (28 angles, twice), each gyro on a rate table (9 rates from -8 to 8 rad/s
//! four times and 20 at rest); stage two at 25 C, 26 still poses and turns at +-4 and +-8 rad/s
//! about the three axes and three diagonals, the turning axis up and down (74 observations);
//! one stage the same 74 at the five temperatures (370).

#[path = "common/stage_score.rs"]
mod stage_score;

use std::path::Path;

use calflash::design::stages;
use calflash::sensor::{Calibrated, Verdict};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use stage_score::{Input, Score, Truth, coverage, coverage_all, rms, stated_rms, z_rms, z0};

const G: f64 = 9.806_65;
const TEMPS: [f64; 5] = [-20.0, 5.0, 25.0, 45.0, 70.0];
const NOISE: f64 = 2.0;
const OUTPUTS: [&str; 6] = ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"];

#[derive(Clone, Copy)]
struct Sensor {
    k0: f64,
    k1: f64,
    k2: f64,
    k3: f64,
    a1: f64,
    a2: f64,
    b1: f64,
    b2: f64,
    /// The asymmetry, `asym max(x, 0)` (the reference units' model; none drawn here).
    asym: f64,
}

impl Sensor {
    fn slope(&self, t: f64) -> f64 {
        let d = t - 25.0;
        self.k1 * (1.0 + self.b1 * d + self.b2 * d * d)
    }
    fn out(&self, x: f64, t: f64) -> f64 {
        let d = t - 25.0;
        self.k0
            + self.a1 * d
            + self.a2 * d * d
            + self.slope(t) * (x + self.k2 * x * x + self.k3 * x * x * x + self.asym * x.max(0.0))
    }
}

struct Unit {
    sensors: [Sensor; 6],
    /// Sensing directions, unit axes.
    n: [[f64; 3]; 6],
    /// Accelerometer lever arms, m.
    r: [[f64; 3]; 3],
    /// Gyro g-sensitivity rows, rad/s per m/s^2.
    g: [[f64; 3]; 3],
    /// Each sensor's relative scale change in assembly.
    ds: [f64; 6],
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalised(v: [f64; 3]) -> [f64; 3] {
    let n = dot(&v, &v).sqrt();
    v.map(|c| c / n)
}

impl Unit {
    fn draw(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut normal = |s: f64| Normal::new(0.0, s).unwrap().sample(&mut rng);
        let sensors = std::array::from_fn(|k| {
            let gyro = k >= 3;
            let k1 = if gyro { 900.0 } else { 400.0 };
            Sensor {
                k0: 32768.0 + 800.0 * (2.0 * normal(0.5).tanh()),
                k1: k1 * (1.0 + normal(0.005)),
                k2: normal(if gyro { 1.2e-4 } else { 1.5e-4 }),
                k3: normal(if gyro { 2e-6 } else { 4e-6 }),
                a1: normal(0.5),
                a2: normal(2e-3),
                b1: normal(1e-4),
                b2: normal(2e-7),
                asym: 0.0,
            }
        });
        let n = std::array::from_fn(|k| {
            let mut v: [f64; 3] = std::array::from_fn(|_| normal(3e-3));
            v[k % 3] = 1.0;
            normalised(v)
        });
        let r = std::array::from_fn(|_| {
            std::array::from_fn(|_| {
                let m = 1e-3 + 3e-3 * (0.5 + 0.5 * normal(1.0).tanh());
                if normal(1.0) < 0.0 { -m } else { m }
            })
        });
        let g = std::array::from_fn(|_| std::array::from_fn(|_| normal(1e-4)));
        Self {
            sensors,
            n,
            r,
            g,
            ds: [0.0; 6],
        }
    }

    /// A shared reference unit (`../shared/data/reference-flights/two-stage/unitN`) from its
    /// `unit_truth.json`, the same model written by another's hand.
    fn reference(truth: &serde_json::Value) -> Self {
        let v3 = |x: &serde_json::Value| -> [f64; 3] {
            std::array::from_fn(|i| x[i].as_f64().expect("a number"))
        };
        let of = |k: usize| &truth["sensors"][OUTPUTS[k]];
        let num = |k: usize, name: &str| of(k)[name].as_f64().unwrap_or(0.0);
        Self {
            sensors: std::array::from_fn(|k| Sensor {
                k0: num(k, "k0"),
                k1: num(k, "k1"),
                k2: num(k, "k2"),
                k3: num(k, "k3"),
                a1: num(k, "a1"),
                a2: num(k, "a2"),
                b1: num(k, "b1"),
                b2: num(k, "b2"),
                asym: num(k, "asym"),
            }),
            n: std::array::from_fn(|k| v3(&of(k)["sensing_direction_in_unit_axes"])),
            r: std::array::from_fn(|k| v3(&of(k)["lever_arm_m"])),
            g: std::array::from_fn(|k| v3(&of(3 + k)["g_sensitivity_rad_s_per_m_s2"])),
            ds: std::array::from_fn(|k| num(k, "assembly_scale_change_ds")),
        }
    }

    /// What sensor `k` senses along its own axis in the assembled unit.
    fn sensed(&self, k: usize, f: &[f64; 3], w: &[f64; 3]) -> f64 {
        if k < 3 {
            let centripetal = cross(w, &cross(w, &self.r[k]));
            let at = [
                f[0] + centripetal[0],
                f[1] + centripetal[1],
                f[2] + centripetal[2],
            ];
            (1.0 + self.ds[k]) * dot(&self.n[k], &at)
        } else {
            (1.0 + self.ds[k]) * dot(&self.n[k], w) + dot(&self.g[k - 3], f)
        }
    }
}

impl Truth for Unit {
    fn outputs(&self, input: &Input, temp: f64) -> [f64; 6] {
        std::array::from_fn(|k| self.sensors[k].out(self.sensed(k, &input.f, &input.w), temp))
    }
    fn slope(&self, k: usize, temp: f64) -> f64 {
        self.sensors[k].slope(temp)
    }
}

/// The 26 directions of {-1, 0, 1}^3 but zero, normalised.
fn directions() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for a in -1..=1 {
        for b in -1..=1 {
            for c in -1..=1 {
                if (a, b, c) != (0, 0, 0) {
                    out.push(normalised([f64::from(a), f64::from(b), f64::from(c)]));
                }
            }
        }
    }
    out
}

/// The assembled unit's plan at one temperature: 26 still poses, then turns at +-4 and +-8
/// rad/s about the three axes and three diagonals, the turning axis up and down.
fn unit_plan() -> Vec<Input> {
    let mut out: Vec<Input> = directions()
        .into_iter()
        .map(|u| Input {
            f: u.map(|c| G * c),
            w: [0.0; 3],
        })
        .collect();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let axes = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [s, s, 0.0],
        [s, 0.0, s],
        [0.0, s, s],
    ];
    for a in axes {
        for up in [1.0, -1.0] {
            for rate in [-8.0, -4.0, 4.0, 8.0] {
                out.push(Input {
                    f: a.map(|c| up * G * c),
                    w: a.map(|c| rate * c),
                });
            }
        }
    }
    out
}

fn noisy(rng: &mut ChaCha8Rng) -> f64 {
    Normal::new(0.0, NOISE).unwrap().sample(rng)
}

/// Stage one's file of sensor `k` (the reference units' columns) and its calibration.
fn stage_one(unit: &Unit, k: usize, dir: &Path, rng: &mut ChaCha8Rng) -> Calibrated {
    let s = unit.sensors[k];
    let mut text = String::from("input,input_p,input_o,temp,output\n");
    for t in TEMPS {
        if k < 3 {
            for _ in 0..2 {
                for i in 0..28 {
                    let th = 2.0 * std::f64::consts::PI * f64::from(i) / 28.0;
                    let (x, p) = (G * th.cos(), G * th.sin());
                    let y = s.out(x, t) + noisy(rng);
                    text += &format!("{x},{p},0,{t},{y}\n");
                }
            }
        } else {
            let rates = (0..4).flat_map(|_| (0..9).map(|i| -8.0 + 2.0 * f64::from(i)));
            for x in rates.chain(std::iter::repeat_n(0.0, 20)) {
                let y = s.out(x, t) + noisy(rng);
                text += &format!("{x},0,0,{t},{y}\n");
            }
        }
    }
    let csv = dir.join(format!("s1_{}.csv", OUTPUTS[k]));
    std::fs::write(&csv, text).unwrap();
    stages::stage_one(&csv, k, &format!("S-{}", OUTPUTS[k])).unwrap()
}

/// The unit's file (`f_x .. g_z` columns) over `plan` at `temps`.
fn unit_file(unit: &Unit, temps: &[f64], path: &Path, rng: &mut ChaCha8Rng) {
    let mut text = String::from("f_x,f_y,f_z,w_x,w_y,w_z,temp,a_x,a_y,a_z,g_x,g_y,g_z\n");
    for &t in temps {
        for p in unit_plan() {
            let y = unit.outputs(&p, t).map(|o| o + noisy(rng));
            let [f0, f1, f2] = p.f;
            let [w0, w1, w2] = p.w;
            let [y0, y1, y2, y3, y4, y5] = y;
            text += &format!("{f0},{f1},{f2},{w0},{w1},{w2},{t},{y0},{y1},{y2},{y3},{y4},{y5}\n");
        }
    }
    std::fs::write(path, text).unwrap();
}

fn two_stage(unit: &Unit, dir: &Path, rng: &mut ChaCha8Rng) -> Calibrated {
    let records: Vec<_> = (0..6)
        .map(|k| {
            let c = stage_one(unit, k, dir, rng);
            let json = dir.join(format!("s1_{}.json", OUTPUTS[k]));
            let csv = dir.join(format!("s1_{}.csv", OUTPUTS[k]));
            stages::write_record(&c, &csv, &json).unwrap();
            json
        })
        .collect();
    let csv = dir.join("unit.csv");
    unit_file(unit, &[25.0], &csv, rng);
    stages::stage_two(&csv, &records).unwrap().0
}

fn one_stage(unit: &Unit, dir: &Path, rng: &mut ChaCha8Rng) -> Calibrated {
    let csv = dir.join("one.csv");
    unit_file(unit, &TEMPS, &csv, rng);
    stages::one_stage(&csv).unwrap()
}

/// The operating range the errors are taken over: gravity along the 26 directions at rest
/// (accelerometers); rates of +-2, 4, 6 and 8 rad/s about the three axes and three diagonals,
/// the axis up (gyros).
fn range() -> (Vec<Input>, Vec<Input>) {
    let accel = directions()
        .into_iter()
        .map(|u| Input {
            f: u.map(|c| G * c),
            w: [0.0; 3],
        })
        .collect();
    let gyro = directions()
        .into_iter()
        .filter(|u| u.iter().filter(|c| **c != 0.0).count() <= 2 && u.iter().all(|c| *c >= 0.0))
        .flat_map(|u| {
            [-8.0, -6.0, -4.0, -2.0, 2.0, 4.0, 6.0, 8.0].map(|rate| Input {
                f: u.map(|c| G * c),
                w: u.map(|c| rate * c),
            })
        })
        .collect();
    (accel, gyro)
}

/// A unit the device refused a calibration of: its seed and each plan's REJECT.
type Refused = (u64, Option<String>, Option<String>);

/// Units drawn.
const UNITS: u64 = 120;

/// Both plans over the same drawn units: their RMS errors over the operating range, the share
/// of errors inside the device's 95 % intervals, and the error over the stated 1-sigma at zero
/// input (`BENCHMARKS.md`, "Two stages on an independent forward model").
#[test]
fn two_stages_and_one_on_an_independent_forward_model() {
    let (accel, gyro) = range();
    let all: Vec<Result<(Score, Score), Refused>> = (0..UNITS)
        .into_par_iter()
        .map(|seed| {
            let dir = tempfile::tempdir().unwrap();
            let unit = Unit::draw(70_000 + seed);
            let mut rng = ChaCha8Rng::seed_from_u64(90_000 + seed);
            let two = two_stage(&unit, dir.path(), &mut rng);
            let one = one_stage(&unit, dir.path(), &mut rng);
            // A calibration the device refuses (no blob) is counted, not scored.
            if two.blob.is_empty() || one.blob.is_empty() {
                let why = |c: &Calibrated| {
                    c.findings
                        .iter()
                        .find(|f| f.verdict == Verdict::Reject)
                        .map(|f| f.text.clone())
                };
                return Err((seed, why(&two), why(&one)));
            }
            Ok((
                stage_score::score(&two, &unit, &accel, &gyro),
                stage_score::score(&one, &unit, &accel, &gyro),
            ))
        })
        .collect();
    let refused: Vec<&Refused> = all.iter().filter_map(|r| r.as_ref().err()).collect();
    for (seed, two, one) in &refused {
        println!("unit {seed}: the device refused two stages: {two:?}; one stage: {one:?}");
    }
    let results: Vec<&(Score, Score)> = all.iter().filter_map(|r| r.as_ref().ok()).collect();
    let two: Vec<Score> = results.iter().map(|r| r.0).collect();
    let one: Vec<Score> = results.iter().map(|r| r.1).collect();
    println!(
        "independent forward model, {UNITS} units, {} scored ({} refused by the device's bounds)",
        results.len(),
        refused.len()
    );
    for (name, f) in [("accelerometers, m/s^2", 0), ("gyros, rad/s", 1)] {
        println!(
            "  {name}: RMS error two stages {:.3e}, one stage {:.3e} (two/one {:.3}); 95 % coverage {:.4} / {:.4}; z RMS at zero input {:.2} / {:.2}",
            rms(&two, f),
            rms(&one, f),
            rms(&two, f) / rms(&one, f),
            coverage(&two, f),
            coverage(&one, f),
            z0(&two, f),
            z0(&one, f)
        );
    }
    for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
        println!(
            "  {name}: RMS of the stated 1-sigma two stages {:.3e}, one stage {:.3e} (two/one {:.3})",
            stated_rms(&two, f),
            stated_rms(&one, f),
            stated_rms(&two, f) / stated_rms(&one, f)
        );
    }
    println!(
        "  95 % coverage, both families: two stages {:.4}, one stage {:.4}",
        coverage_all(&two),
        coverage_all(&one)
    );
    // The device's stated 1-sigma is the full model's: every term the correction applies has
    // its own feature in the blob's covariance factors (before, the cubic, odd-quadratic and
    // kink terms were folded into fewer: accelerometer coverage 0.921 and 0.999, z RMS at zero
    // input 0.35 to 0.66 but for the two-stage accelerometers).
    // Before, 3 of 120 were refused: the g-sensitivity's feedback of the lever term was
    // bounded at the largest legal sample rate (100 kHz), where its tangential part's loop gain
    // reached one on units with large g-sensitivity rows; it is the corrector's, at its rate.
    assert!(
        refused.is_empty(),
        "{} of {UNITS} units refused",
        refused.len()
    );
    for (name, s) in [("two stages", &two), ("one stage", &one)] {
        for (family, f) in [("accelerometers", 0), ("gyros", 1)] {
            assert!(
                (0.93..=0.97).contains(&coverage(s, f)),
                "{name}, {family}: coverage {}",
                coverage(s, f)
            );
            assert!(
                (0.9..=1.1).contains(&z0(s, f)),
                "{name}, {family}: z RMS at zero input {}",
                z0(s, f)
            );
        }
    }
    // The design's prediction (`design::stages`: our simulator's units through the same
    // plans, each calibration's stated 1-sigma over the range) against the measured ratio.
    let plans = |items: &[&str], temps: &[f64], single: bool| {
        let items: Vec<String> = items.iter().map(|s| (*s).to_string()).collect();
        calflash::sim::plan::plan(&items, temps, &[3.3], 1, single).unwrap()
    };
    let rate = "rate:-8:8:9";
    let unit_items = ["tumble:26", "rate:-8:8:4", "diagonal:-8:8:2"];
    let p = stages::Plans {
        accel_one: plans(&["head:56"], &TEMPS, true),
        gyro_one: plans(&[rate, rate, rate, rate, "rate:0:0:20"], &TEMPS, true),
        unit: plans(&unit_items, &[25.0], false),
        one_stage: plans(&unit_items, &TEMPS, false),
    };
    let range = stages::operating_range(&p, &TEMPS).unwrap();
    let predicted = stages::predict(&p, &range, 24).unwrap();
    for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
        let measured = rms(&two, f) / rms(&one, f);
        println!(
            "  {name}: the design predicts two stages {:.3e}, one stage {:.3e} (two/one {:.3}) over {} simulated units; measured {measured:.3}",
            predicted.two[f],
            predicted.one[f],
            predicted.ratio()[f],
            predicted.units
        );
        assert!(
            (predicted.ratio()[f] / measured - 1.0).abs() <= 0.1,
            "{name}: predicted {} against measured {measured}",
            predicted.ratio()[f]
        );
    }
    // On this model one stage wins for the accelerometers (its plan sees every term at every
    // temperature; stage one's eight terms over 280 rows determine the bias worse) and the two
    // tie for the gyros: the issue's 1.12 is reproduced.
    let ratio = rms(&two, 0) / rms(&one, 0);
    assert!(
        (1.05..=1.2).contains(&ratio),
        "accelerometers, two/one {ratio}"
    );
    let ratio = rms(&two, 1) / rms(&one, 1);
    assert!((0.9..=1.1).contains(&ratio), "gyros, two/one {ratio}");
}

/// The shared reference units (`../shared/data/reference-flights/two-stage/unit1..3`), each
/// calibrated in one stage from its own unit file as the README does, scored against its
/// `unit_truth.json`; none (with a notice) where the shared data is absent.
fn reference_units_one_stage(linear: bool, accel: &[Input], gyro: &[Input]) -> Vec<Score> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/reference-flights/two-stage");
    if !root.is_dir() {
        println!(
            "the shared reference units: SKIPPED, {} is absent",
            root.display()
        );
        return Vec::new();
    }
    ["unit1", "unit2", "unit3"]
        .iter()
        .map(|u| {
            let text = std::fs::read_to_string(root.join(u).join("unit_truth.json")).unwrap();
            let unit = Unit::reference(&serde_json::from_str(&text).unwrap());
            let mut opts = calflash::sensor::Options::new(root.join(u).join("unit.csv"), "REF");
            opts.created = Some(0);
            opts.linear = linear;
            let c = calflash::sensor::triad::calibrate(
                &opts,
                calflash::sensor::triad::Kind::Imu,
                !linear,
            )
            .unwrap();
            assert!(!c.blob.is_empty(), "{u}: refused");
            stage_score::score(&c, &unit, accel, gyro)
        })
        .collect()
}

/// One stage as the README calibrates a unit (`calibrate FILE --sensor imu`: the IMU preset
/// with its nonlinear terms, the data choosing which to keep, a table over the setpoints), on
/// the same independent units: its stated 1-sigma is true over the operating range, 95 %
/// intervals covering 0.93 to 0.97 of the errors and the error over its 1-sigma of RMS 0.9 to
/// 1.1, for accelerometers and gyros. Before, the README's IMU was linear (the units' g-squared
/// terms were left out: coverage 0.69) and the chosen model's own covariance stated the error
/// (0.92 and 0.87 with the nonlinear terms). With `--linear` the terms the data show are left
/// out of the correction and their estimate widens the stated error: it covers them, wider than
/// the band (a left-out term's error is a bias, not a spread).
#[test]
fn one_stage_as_the_readme_runs_it_states_its_error_on_an_independent_forward_model() {
    let (accel, gyro) = range();
    for linear in [false, true] {
        let all: Vec<Result<Score, Refused>> = (0..UNITS)
            .into_par_iter()
            .map(|seed| {
                let dir = tempfile::tempdir().unwrap();
                let unit = Unit::draw(70_000 + seed);
                let mut rng = ChaCha8Rng::seed_from_u64(90_000 + seed);
                let csv = dir.path().join("one.csv");
                unit_file(&unit, &TEMPS, &csv, &mut rng);
                let mut opts = calflash::sensor::Options::new(&csv, "UNIT");
                opts.created = Some(0);
                opts.linear = linear;
                let c = calflash::sensor::triad::calibrate(
                    &opts,
                    calflash::sensor::triad::Kind::Imu,
                    !linear,
                )
                .unwrap();
                if c.blob.is_empty() {
                    let why = c
                        .findings
                        .iter()
                        .find(|f| f.verdict == Verdict::Reject)
                        .map(|f| f.text.clone());
                    return Err((seed, why, None));
                }
                Ok(stage_score::score(&c, &unit, &accel, &gyro))
            })
            .collect();
        let refused: Vec<&Refused> = all.iter().filter_map(|r| r.as_ref().err()).collect();
        for (seed, why, _) in &refused {
            println!("unit {seed}: refused: {why:?}");
        }
        let mut one: Vec<Score> = all
            .iter()
            .filter_map(|r| r.as_ref().ok())
            .copied()
            .collect();
        // The shared reference units, calibrated from their own unit file (25 C), pooled with
        // the drawn ones and shown apart.
        let shared = reference_units_one_stage(linear, &accel, &gyro);
        for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
            if !shared.is_empty() {
                println!(
                    "  the {} shared reference units, {name}: 95 % coverage {:.4}; RMS z {:.3}",
                    shared.len(),
                    coverage(&shared, f),
                    z_rms(&shared, f)
                );
            }
        }
        one.extend(shared);
        println!(
            "one stage, the terms chosen by the data{}: {} scored, {} refused",
            if linear { ", --linear" } else { "" },
            one.len(),
            refused.len()
        );
        for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
            println!(
                "  {name}: RMS error {:.3e}, stated {:.3e}; 95 % coverage {:.4}; RMS z {:.3}; at zero input {:.2}",
                rms(&one, f),
                stated_rms(&one, f),
                coverage(&one, f),
                z_rms(&one, f),
                z0(&one, f)
            );
        }
        assert!(refused.is_empty(), "{} refused", refused.len());
        for (name, f) in [("accelerometers", 0), ("gyros", 1)] {
            if linear {
                assert!(
                    coverage(&one, f) >= 0.93,
                    "--linear, {name}: {}",
                    coverage(&one, f)
                );
            } else {
                assert!(
                    (0.93..=0.97).contains(&coverage(&one, f)),
                    "{name}: coverage {}",
                    coverage(&one, f)
                );
                assert!(
                    (0.9..=1.1).contains(&z_rms(&one, f)),
                    "{name}: RMS z {}",
                    z_rms(&one, f)
                );
            }
        }
    }
}
