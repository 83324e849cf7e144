//! Continuous temperature models of triads and IMUs: a ramp calibrates an IMU end to end, and
//! over 200 simulated ramps of an accelerometer triad (curved biases, drifting scale factors)
//! the stated errors cover the truth, for the coefficients and for the device's corrected
//! output between the temperatures of its table.

mod common;

use calflash::sensor::thermal::ThermalFit;
use calflash::sensor::triad::{self, Kind};
use calflash::sensor::{Options, Thermal, Verdict};
use calflash::sim::ramp::Ramp;
use calflash::sim::truth::{ImuTruth, TriadTruth};
use calflash::sim::{self, Sensor, plan};
use common::truth_in_legendre::{in_x, legendre_of};
use common::{calflash, stated};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use spincal::correct::AnyTriadCorrector;
use spincal::model::TemperatureModel;

/// Simulates an IMU (the default unit, or `truth`) through a tumble and rate steps along an
/// uneven ramp read in whole degrees behind the chamber, and calibrates it; the output.
fn imu_ramp(d: &std::path::Path, name: &str, truth: Option<&ImuTruth>) -> String {
    let csv = format!("{name}.csv");
    let mut args = vec![
        "simulate",
        "--sensor",
        "imu",
        "--plan",
        "tumble:24",
        "--plan",
        "rate:-10:10:5",
        "--repeat",
        "8",
        "--ramp=-40:70",
        "--uneven",
        "--temp-step",
        "1",
        "--lag",
        "60",
        "-o",
        &csv,
    ];
    let truth_file = format!("{name}.truth.json");
    if let Some(t) = truth {
        std::fs::write(d.join(&truth_file), serde_json::to_string(t).unwrap()).unwrap();
        args.extend(["--truth", &truth_file]);
    }
    let (code, out, err) = calflash(d, &args);
    assert_eq!(code, 0, "{out}{err}");
    let (blob, report, json) = (
        format!("{name}.bin"),
        format!("{name}.html"),
        format!("{name}.json"),
    );
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            &csv,
            "--sensor",
            "imu",
            "--serial",
            "IMU-RAMP",
            "--blob",
            &blob,
            "--report",
            &report,
            "--json",
            &json,
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    out
}

#[test]
fn an_imu_ramp_calibrates_into_a_series_or_with_lever_arms_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = imu_ramp(d, "imu", None);
    assert!(out.contains("unit IMU-RAMP: ACCEPT"), "{out}");
    for want in [
        "continuous temperature model over -40.0 to 70.0 C",
        "read in steps of 1 C",
        "weights that even out their density",
        "a_x: temperature order of bias (1): order 1",
        "g_z: temperature order of w_z: order 1",
        "the device's Chebyshev series of",
        "follows the continuous temperature model within",
    ] {
        assert!(out.contains(want), "{want}: {out}");
    }
    let blob = std::fs::read(d.join("imu.bin")).unwrap();
    let cal = spincal::blob::decode(&blob).unwrap();
    let env = &cal.data().environment;
    assert!(
        matches!(env.temperature_model, TemperatureModel::Chebyshev(n) if (2..=16).contains(&n)),
        "{:?}",
        env.temperature_model
    );
    assert_eq!(env.temperature_span.lo, -40.0);
    let html = std::fs::read_to_string(d.join("imu.html")).unwrap();
    assert!(html.contains("<h2>Temperature</h2>") && html.contains("g_z: temperature order"));
    assert!(html.contains("1-sigma calibration error of each corrected output"));
    assert!(
        html.contains("the device&#39;s Chebyshev series of")
            || html.contains("the device's Chebyshev series of")
    );
    let json = std::fs::read_to_string(d.join("imu.json")).unwrap();
    assert!(
        json.contains("\"temp\": 20.0"),
        "the record holds the model every 5 C"
    );
    // Lever arms of 5 mm: the device proves their sensing directions per set of a table.
    let mut truth = ImuTruth::default();
    truth.accel.lever = [[0.005, 0.0, 0.0], [0.0, 0.005, 0.0], [0.0, 0.0, 0.005]];
    let out = imu_ramp(d, "lever", Some(&truth));
    assert!(
        out.contains("an IMU with lever arms: the device gets a table"),
        "{out}"
    );
    assert!(out.contains("the device's table of"), "{out}");
    let blob = std::fs::read(d.join("lever.bin")).unwrap();
    let cal = spincal::blob::decode(&blob).unwrap();
    assert_eq!(
        cal.data().environment.temperature_model,
        TemperatureModel::Table
    );
    assert!(matches!(
        cal.data().sensor,
        spincal::model::Sensor::Imu {
            lever_arm: Some(_),
            ..
        }
    ));
}

/// The accelerometer of the tests: its biases curve with the temperature, its scale factors
/// drift.
fn truth() -> TriadTruth {
    TriadTruth {
        bias_temp2: [-0.004, 0.003, 0.002],
        ..TriadTruth::accelerometer()
    }
}

/// The truth's bias and sensitivity matrix at `t`.
fn truth_at(truth: &TriadTruth, t: f64) -> (Vector3<f64>, Matrix3<f64>) {
    let dt = t - sim::truth::REF_TEMP;
    let b = Vector3::from_fn(|i, _| {
        truth.bias[i] + truth.bias_temp[i] * dt + truth.bias_temp2[i] * dt * dt
    });
    let s = Matrix3::from_fn(|i, j| truth.s[i][j] * (1.0 + truth.scale_temp[i] * dt));
    (b, s)
}

struct Seed {
    /// Per axis: the orders of the bias and the own scale factor, and whether the others are 0.
    right: bool,
    /// (coefficient, covered) of the temperature terms.
    covered: Vec<(String, bool)>,
    /// The device's error against its 1-sigma, between the table's temperatures.
    z: Vec<f64>,
}

fn one_seed(
    truth: &TriadTruth,
    conditions: &[plan::Condition],
    dir: &std::path::Path,
    seed: u64,
) -> Seed {
    let obs = sim::simulate(&Sensor::Accel(truth.clone()), conditions, seed, false);
    let path = dir.join(format!("{seed}.csv"));
    obs.write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let mut opts = Options::new(&path, "TRIAD-COV");
    opts.thermal = Thermal::Continuous;
    opts.keep_all_terms = true;
    opts.created = Some(0);
    let c = triad::calibrate(&opts, Kind::Accel, false).unwrap();
    assert!(c.verdict() <= Verdict::Review, "{:?}", c.findings);
    assert_eq!(c.thermal.len(), 3);
    let mut covered = Vec::new();
    let mut right = true;
    for (i, tf) in c.thermal.iter().enumerate() {
        let own = ["f_x", "f_y", "f_z"][i];
        let orders: Vec<(String, u32)> = tf
            .base
            .term_names()
            .into_iter()
            .zip(tf.orders.iter().copied())
            .collect();
        right &= orders.iter().all(|(n, k)| {
            *k == match n.as_str() {
                "1" => 2,
                n if n == own => 1,
                _ => 0,
            }
        });
        let bias = legendre_of(&in_x(
            &[truth.bias[i], truth.bias_temp[i], truth.bias_temp2[i]],
            &tf.scale,
        ));
        let sii = truth.s[i][i];
        let slope = legendre_of(&in_x(&[sii, sii * truth.scale_temp[i]], &tf.scale));
        check(tf, "temp_leg1", bias[1], &mut covered);
        check(tf, "temp_leg2", bias[2], &mut covered);
        check(tf, &format!("{own}:temp_leg1"), slope[1], &mut covered);
    }
    // The device halfway between its series' nodes (or its table's temperatures), at the
    // tumble's gravity directions and in free fall: its error against the truth in its own
    // 1-sigma.
    let cal = spincal::blob::decode(&c.blob).unwrap();
    let mut dev = AnyTriadCorrector::new(&cal).unwrap();
    let mut temps = c.temps.clone();
    temps.sort_by(f64::total_cmp);
    let mut z = Vec::new();
    for w in temps.windows(2) {
        let t = 0.5 * (w[0] + w[1]);
        dev.set_environment(t as f32, 5.0);
        let (b, s) = truth_at(truth, t);
        let inv = s.try_inverse().unwrap();
        for f in [
            [plan::G, 0.0, 0.0],
            [-plan::G, 0.0, 0.0],
            [0.0, plan::G, 0.0],
            [0.0, -plan::G, 0.0],
            [0.0, 0.0, plan::G],
            [0.0, 0.0, -plan::G],
            [0.0; 3],
        ] {
            let u = truth.accel_output(f, [0.0; 3], [0.0; 3], t, 5.0);
            let raw = u.map(|v| v.round() as i32);
            // What the rounded codes stand for.
            let want = inv * (Vector3::from_fn(|i, _| f64::from(raw[i])) - b);
            let got = dev.correct(raw).values;
            let sigma = dev.sigma(raw).unwrap();
            for i in 0..3 {
                z.push((f64::from(got[i]) - want[i]) / f64::from(sigma[i]));
            }
        }
    }
    Seed { right, covered, z }
}

fn check(tf: &ThermalFit, name: &str, want: f64, covered: &mut Vec<(String, bool)>) {
    let f = &tf.fit.fit;
    let crit = calflash::stats::dist::t_upper_quantile(0.025, f.dof as f64);
    if let Some(i) = f.names.iter().position(|n| n == name) {
        let kind = name.rsplit(':').next().unwrap_or(name);
        let what = if name.contains(':') {
            format!("scale:{kind}")
        } else {
            format!("bias:{kind}")
        };
        covered.push((
            what,
            (f.coefficients[i] - want).abs() <= crit * f.std_errors[i],
        ));
    }
}

#[test]
fn a_triads_stated_errors_cover_the_truth_over_200_ramps() {
    let truth = truth();
    let ramp = Ramp::even(-40.0, 70.0, 7200.0);
    let dir = tempfile::tempdir().unwrap();
    let conditions = plan::plan(&["tumble:24".into()], &[25.0], &[5.0], 10, false).unwrap();
    let (conditions, _) = sim::ramp::run(&ramp, &conditions);
    let n_seeds: u64 = std::env::var("THERMAL_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let seeds: Vec<Seed> = (1..=n_seeds)
        .into_par_iter()
        .map(|seed| one_seed(&truth, &conditions, dir.path(), seed))
        .collect();
    let right = seeds.iter().filter(|s| s.right).count();
    println!(
        "orders right (bias 2, own scale 1, others 0) on all three axes: {right} of {n_seeds}"
    );
    assert!(right as f64 >= 0.8 * n_seeds as f64, "{right}");
    for what in ["bias:temp_leg1", "bias:temp_leg2", "scale:temp_leg1"] {
        let (n, hits) = stated::covered(seeds.iter().flat_map(|s| &s.covered), what);
        let rate = hits as f64 / n as f64;
        println!("{what}: 95 % intervals cover the truth in {hits} of {n} fits ({rate:.3})");
        assert!(n as u64 >= 3 * n_seeds * 9 / 10, "{what}: estimated in {n}");
        assert!((rate - 0.95).abs() <= 0.035, "{what}: coverage {rate:.3}");
    }
    let z: Vec<f64> = seeds.iter().flat_map(|s| s.z.iter().copied()).collect();
    stated::assert_normal(
        "device between its series' nodes or table's temperatures",
        &z,
    );
}

/// A recording of `truth` at rest with gravity along `f` while the chamber ramps from -40 to
/// 70 C, 10 samples a second for 20 minutes: `t`, the six counts and the temperature; `moved`
/// turns the unit over from that sample on.
fn still_recording(path: &std::path::Path, truth: &ImuTruth, moved: Option<usize>) {
    let n = 12_000;
    let pose = plan::Condition {
        f: [0.0, 0.0, plan::G],
        w: [0.0; 3],
        dw: [0.0; 3],
        h: [0.0; 3],
        temp: 25.0,
        volt: 5.0,
        dir: 0.0,
    };
    let conditions: Vec<plan::Condition> = (0..n)
        .map(|k| plan::Condition {
            f: if moved.is_some_and(|m| k >= m) {
                [plan::G, 0.0, 0.0]
            } else {
                pose.f
            },
            ..pose
        })
        .collect();
    let (conditions, temps) = sim::ramp::run(&Ramp::even(-40.0, 70.0, 1200.0), &conditions);
    let obs = sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &conditions, 5, true);
    let col = |name: &str| obs.names.iter().position(|n| n == name).unwrap();
    let counts = ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"].map(col);
    let mut text = String::from("t,ax,ay,az,gx,gy,gz,temp\n");
    for (k, row) in obs.rows.iter().enumerate() {
        let c: Vec<String> = counts
            .iter()
            .map(|i| format!("{}", row[*i].round()))
            .collect();
        text.push_str(&format!(
            "{:.1},{},{:.3}\n",
            temps.time[k],
            c.join(","),
            temps.reported[k]
        ));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_still_unit_recorded_in_a_ramp_and_a_bench_run_make_one_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Curved biases on both triads, drifting scale factors.
    let mut truth = ImuTruth::default();
    truth.accel.bias_temp2 = [-0.004, 0.003, 0.002];
    truth.gyro.bias_temp2 = [0.003, -0.002, 0.001];
    let bench = plan::plan(
        &["tumble:24".into(), "rate:-10:10:5".into()],
        &[25.0],
        &[5.0],
        3,
        false,
    )
    .unwrap();
    let obs = sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &bench, 4, false);
    obs.write_csv(std::fs::File::create(d.join("bench.csv")).unwrap())
        .unwrap();
    still_recording(&d.join("still.csv"), &truth, None);
    let mut opts = Options::new(d.join("bench.csv"), "STILL-RAMP");
    opts.created = Some(0);
    opts.still_ramp = Some(d.join("still.csv"));
    let c = triad::calibrate(&opts, Kind::Imu, false).unwrap();
    assert!(c.verdict() <= Verdict::Review, "{:?}", c.findings);
    assert!(
        c.notes
            .iter()
            .any(|n| n.contains("the still pose's specific force")),
        "{:?}",
        c.notes
    );
    assert_eq!(c.thermal.len(), 6);
    // Each axis' bias follows the truth's curve through the ramp (the accelerometer's z axis
    // carries its scale factor's drift times g: one pose cannot tell them apart).
    for t in [-30.0, 0.0, 40.0, 65.0] {
        let dt = t - sim::truth::REF_TEMP;
        for (k, tf) in c.thermal.iter().enumerate() {
            let (triad, i) = if k < 3 {
                (&truth.accel, k)
            } else {
                (&truth.gyro, k - 3)
            };
            let mut want = triad.bias[i] + triad.bias_temp[i] * dt + triad.bias_temp2[i] * dt * dt;
            if k == 2 {
                want += triad.s[2][2] * triad.scale_temp[2] * dt * plan::G;
            }
            let f = tf.at(t);
            let i0 = f.index("1").unwrap();
            let (got, se) = (f.fit.coefficients[i0], f.fit.std_errors[i0]);
            assert!(
                (got - want).abs() <= 4.0 * se,
                "{} at {t} C: bias {got} vs truth {want} ({:.1} standard errors)",
                tf.fit.output,
                (got - want) / se
            );
        }
    }
    // An output may not overwrite the recording.
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "bench.csv",
            "--sensor",
            "imu",
            "--serial",
            "S",
            "--still-ramp",
            "still.csv",
            "--blob",
            "still.csv",
            "--no-db",
        ],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("still.csv") && err.contains("--still-ramp"),
        "{err}"
    );
    assert!(
        std::fs::read_to_string(d.join("still.csv"))
            .unwrap()
            .starts_with("t,ax")
    );
    // What a still recording cannot be.
    let run = |still: &str, bench: &str| {
        let mut o = Options::new(d.join(bench), "STILL-RAMP");
        o.still_ramp = Some(d.join(still));
        triad::calibrate(&o, Kind::Imu, false)
            .unwrap_err()
            .to_string()
    };
    still_recording(&d.join("moved.csv"), &truth, Some(7000));
    let e = run("moved.csv", "bench.csv");
    assert!(
        e.contains("moved.csv") && e.contains("line 7002") && e.contains("one still pose"),
        "{e}"
    );
    let text = std::fs::read_to_string(d.join("still.csv")).unwrap();
    let no_temp: String = text
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
        .collect();
    std::fs::write(d.join("no_temp.csv"), no_temp).unwrap();
    let e = run("no_temp.csv", "bench.csv");
    assert!(
        e.contains("no_temp.csv") && e.contains("no temperature column"),
        "{e}"
    );
    let two = plan::plan(&["tumble:24".into()], &[25.0, 40.0], &[5.0], 1, false).unwrap();
    sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &two, 4, false)
        .write_csv(std::fs::File::create(d.join("two.csv")).unwrap())
        .unwrap();
    let e = run("still.csv", "two.csv");
    assert!(
        e.contains("two.csv") && e.contains("span 25.0 to 40.0 C"),
        "{e}"
    );
}
