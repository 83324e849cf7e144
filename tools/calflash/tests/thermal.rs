//! Thermal calibration from temperature ramps: a ramp calibrates, bad temperature columns are
//! refused with located messages, the continuous model's stated errors cover the truth over
//! 200 simulated ramps (coefficients and the device's corrected output), and it beats PX4's
//! per-axis cubic on curves that are not cubic.

mod common;

use calflash::formula;
use calflash::obs::Table;
use calflash::sensor::thermal::{self, Scale, ThermalFit};
use calflash::sensor::{AxisFit, Options, Thermal, single};
use calflash::sim::ramp::Ramp;
use calflash::sim::truth::SingleTruth;
use calflash::sim::{self, Sensor, plan, px4};
use common::truth_in_legendre::{in_x, legendre_of};
use common::{calflash, stated};
use rayon::prelude::*;
use spincal::correct::AnyAxisCorrector;
use spincal::model::{Quantity, TemperatureModel};

/// The chamber of the tests: -40 to 70 C in two hours, as even as asked.
fn chamber(uneven: bool) -> Ramp {
    Ramp {
        uneven,
        ..Ramp::even(-40.0, 70.0, 7200.0)
    }
}

fn simulate_ramp(dir: &std::path::Path, name: &str, extra: &[&str]) -> std::path::PathBuf {
    let mut args = vec![
        "simulate",
        "--sensor",
        "single-accel",
        "--plan",
        "head:16",
        "--repeat",
        "25",
        "-o",
        name,
    ];
    args.extend(extra);
    let (code, out, err) = calflash(dir, &args);
    assert_eq!(code, 0, "{out}{err}");
    dir.join(name)
}

#[test]
fn a_chamber_ramp_calibrates_and_the_device_gets_a_temperature_series() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate_ramp(
        d,
        "ramp.csv",
        &[
            "--ramp",
            "-40:70",
            "--uneven",
            "--temp-step",
            "1",
            "--lag",
            "60",
            "--self-heating",
            "2:300",
        ],
    );
    let text = std::fs::read_to_string(d.join("ramp.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert!(header.contains(&"time") && header.contains(&"chamber_temp"));
    let ti = header.iter().position(|h| *h == "temp").unwrap();
    assert!(
        text.lines().skip(1).all(|l| l
            .split(',')
            .nth(ti)
            .unwrap()
            .parse::<f64>()
            .unwrap()
            .fract()
            == 0.0),
        "temperatures in whole degrees"
    );
    // A fit per setpoint cannot take it: every temperature has a handful of observations.
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            "ramp.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "R1",
            "--thermal",
            "table",
            "--blob",
            "t.bin",
            "--no-db",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("needs at least"), "{err}");
    assert!(!d.join("t.bin").exists());
    // The default takes it as a ramp.
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            "ramp.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "R1",
            "--blob",
            "r.bin",
            "--report",
            "r.html",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let report = std::fs::read_to_string(d.join("r.html")).unwrap();
    for needle in [
        "<h2>Temperature</h2>",
        "bias at zero input (m/s^2) against temperature",
        "scale factor change from ",
        "1-sigma calibration error of the corrected input over the temperature",
        "the device's Chebyshev series of",
        // 16 positions 25 times: each observation counted once, not once a breakpoint.
        " 400 observations in one model continuous in temperature",
    ] {
        assert!(report.contains(needle), "the report lacks {needle}");
    }
    assert!(
        out.contains("continuous temperature model") && out.contains("read in steps of 1 C"),
        "{out}"
    );
    assert!(
        out.contains("ACCEPT the device's Chebyshev series of"),
        "{out}"
    );
    assert!(
        out.contains("the sensor's temperature differs from the chamber's by"),
        "{out}"
    );
    let blob = std::fs::read(d.join("r.bin")).unwrap();
    let cal = spincal::blob::decode(&blob).unwrap();
    assert!(matches!(
        cal.data().environment.temperature_model,
        TemperatureModel::Chebyshev(_)
    ));
}

/// Rewrites column `name` of a CSV with `f(row index, line fields)`.
fn rewrite(path: &std::path::Path, name: &str, f: impl Fn(usize, &[&str]) -> Option<String>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let i = header.iter().position(|h| *h == name).unwrap();
    let mut out = vec![header.join(",")];
    for (r, l) in lines.enumerate() {
        let mut fields: Vec<String> = l.split(',').map(String::from).collect();
        let view: Vec<&str> = l.split(',').collect();
        if let Some(v) = f(r, &view) {
            fields[i] = v;
        }
        out.push(fields.join(","));
    }
    std::fs::write(path, out.join("\n") + "\n").unwrap();
}

#[test]
fn bad_temperature_columns_are_located_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run_with = |file: &str, sensor: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            file,
            "--sensor",
            sensor,
            "--serial",
            "R1",
            "--blob",
            "bad.bin",
            "--no-db",
        ];
        args.extend(extra);
        let (code, out, err) = calflash(d, &args);
        assert_ne!(code, 0, "{file}: {out}");
        assert!(!d.join("bad.bin").exists(), "{file}: a blob was written");
        err
    };
    let run = |file: &str, extra: &[&str]| run_with(file, "single-accel", extra);
    let run_as = |file: &str, sensor: &str| run_with(file, sensor, &[]);
    // No temperature column when a continuous model is asked for.
    simulate_ramp(d, "none.csv", &["--ramp", "-40:70"]);
    let text = std::fs::read_to_string(d.join("none.csv")).unwrap();
    let no_temp: String = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [&f[..4], &f[5..]].concat().join(",") + "\n"
        })
        .collect();
    assert!(text.starts_with("time,input,input_p,input_o,temp,"));
    std::fs::write(d.join("none.csv"), no_temp).unwrap();
    let e = run("none.csv", &["--thermal", "continuous"]);
    assert!(
        e.contains("none.csv") && e.contains("needs the column `temp`"),
        "{e}"
    );
    // A reading no unit is calibrated at.
    simulate_ramp(d, "cold.csv", &["--ramp", "-40:70"]);
    rewrite(&d.join("cold.csv"), "temp", |r, _| {
        (r == 40).then(|| "-300".to_string())
    });
    let e = run("cold.csv", &[]);
    assert!(e.contains("cold.csv: line 42: temp = -300"), "{e}");
    // A ramp under 5 C supports no temperature term.
    simulate_ramp(d, "narrow.csv", &["--ramp", "24:27"]);
    let e = run("narrow.csv", &[]);
    assert!(e.contains("span 3.0 C") && e.contains("order: none"), "{e}");
    // A triad's ramp at two supply voltages: its continuous model follows the temperature
    // only, and says so.
    let (code, out, err) = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "accel",
            "--plan",
            "tumble:24",
            "--repeat",
            "10",
            "--ramp=-40:70",
            "--volts",
            "3.0,3.6",
            "-o",
            "triad.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let e = run_as("triad.csv", "accel");
    assert!(
        e.contains("triad.csv") && e.contains("the supply voltage varies"),
        "{e}"
    );
    // A ramp where a table of setpoints is asked for.
    let (code, out, err) = calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "accel",
            "--plan",
            "tumble:24",
            "--repeat",
            "10",
            "--ramp=-40:70",
            "-o",
            "triad1.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let e = run_with("triad1.csv", "accel", &["--thermal", "table"]);
    assert!(
        e.contains("spread from -40.0 to 70.0 C") && e.contains("--thermal continuous"),
        "{e}"
    );
    // A supply voltage that is not one, in a ramp at two voltages.
    simulate_ramp(d, "volts.csv", &["--ramp=-40:70", "--volts", "4.5,5.5"]);
    rewrite(&d.join("volts.csv"), "volt", |r, _| {
        (r == 10).then(|| "-5".to_string())
    });
    let e = run("volts.csv", &[]);
    assert!(
        e.contains("volts.csv: line 12: volt = -5 is not a supply voltage"),
        "{e}"
    );
    // The input column pasted into the temperature's place.
    simulate_ramp(d, "mixed.csv", &["--ramp", "-40:70"]);
    rewrite(&d.join("mixed.csv"), "temp", |_, f| Some(f[1].to_string()));
    let e = run("mixed.csv", &[]);
    assert!(
        e.contains("jump back and forth") && e.contains("line "),
        "{e}"
    );
}

#[test]
fn stated_errors_cover_the_truth_over_200_ramps() {
    coverage(false);
}

#[test]
fn stated_errors_cover_the_truth_over_200_uneven_ramps_fitted_with_weights() {
    coverage(true);
}

/// 200 simulated ramps (even, or fast at first and slow at the end, where the fit is weighted
/// and its covariance is the sandwich estimate).
fn coverage(uneven: bool) {
    let truth = SingleTruth {
        k2: 0.0,
        k3: 0.0,
        kp: 0.0,
        ko: 0.0,
        k0_temp: 0.6,
        k0_temp2: -0.01,
        k0_temp3: 2e-4,
        k1_temp: 80e-6,
        ..SingleTruth::default()
    };
    let ramp = chamber(uneven);
    let dir = tempfile::tempdir().unwrap();
    let conditions = plan::plan(&["head:16".into()], &[25.0], &[5.0], 25, true).unwrap();
    let (conditions, _) = sim::ramp::run(&ramp, &conditions);
    struct Seed {
        orders: Vec<u32>,
        covered: Vec<(String, bool)>,
        z: Vec<f64>,
    }
    // THERMAL_SEEDS=1000 for a closer look; the test's verdict is on seeds 1 to 200.
    let n_seeds: u64 = std::env::var("THERMAL_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let seeds: Vec<Seed> = (1..=n_seeds)
        .into_par_iter()
        .map(|seed| {
            let sensor = Sensor::Single {
                gyro: false,
                truth: truth.clone(),
            };
            let obs = sim::simulate(&sensor, &conditions, seed, false);
            let path = dir.path().join(format!("{seed}.csv"));
            obs.write_csv(std::fs::File::create(&path).unwrap())
                .unwrap();
            let mut opts = Options::new(&path, "COV");
            opts.model = Some("output ~ 1 + input".into());
            opts.thermal = Thermal::Continuous;
            opts.created = Some(0);
            let c = single::calibrate(&opts, Quantity::Acceleration).unwrap();
            let tf = c.thermal.first().unwrap();
            // The truth in the fit's terms: the bias and the scale factor in x.
            let bias = legendre_of(&in_x(
                &[truth.k0, truth.k0_temp, truth.k0_temp2, truth.k0_temp3],
                &tf.scale,
            ));
            let slope = legendre_of(&in_x(&[truth.k1, truth.k1 * truth.k1_temp], &tf.scale));
            let f = &tf.fit.fit;
            let crit = calflash::stats::dist::t_upper_quantile(0.025, f.dof as f64);
            let mut covered = Vec::new();
            let mut check = |name: String, want: f64| {
                if let Some(i) = f.names.iter().position(|n| *n == name) {
                    let ok = (f.coefficients[i] - want).abs() <= crit * f.std_errors[i];
                    covered.push((name, ok));
                }
            };
            for (k, b) in bias.iter().enumerate() {
                check(
                    if k == 0 {
                        "1".into()
                    } else {
                        thermal::column(k as u32)
                    },
                    *b,
                );
            }
            check("input".into(), slope[0]);
            check("input:temp_leg1".into(), slope[1]);
            // The device between its series' nodes: its error against its own 1-sigma.
            let cal = spincal::blob::decode(&c.blob).unwrap();
            let mut dev = AnyAxisCorrector::new(&cal).unwrap();
            let mut nodes = c.temps.clone();
            nodes.sort_by(f64::total_cmp);
            let mut z = Vec::new();
            for w in nodes.windows(2) {
                let t = 0.5 * (w[0] + w[1]);
                dev.set_environment(t as f32, 5.0);
                for i in 0..=8 {
                    let x = plan::G * (f64::from(i) / 4.0 - 1.0);
                    let code = truth.output(x, 0.0, 0.0, t, 5.0, 0.0).round();
                    let want = truth.input(code, t, 5.0);
                    let got = f64::from(dev.correct(code as i32).values[0]);
                    let sigma = f64::from(dev.sigma(code as i32).unwrap());
                    z.push((got - want) / sigma);
                }
            }
            Seed {
                orders: tf.orders.clone(),
                covered,
                z,
            }
        })
        .collect();
    // The orders the data call for: a cubic bias, a linear scale factor.
    let right = seeds.iter().filter(|s| s.orders == [3, 1]).count();
    assert!(
        right >= 180,
        "orders [3, 1] chosen for {right} of 200 seeds"
    );
    let names = [
        "1",
        "temp_leg1",
        "temp_leg2",
        "temp_leg3",
        "input",
        "input:temp_leg1",
    ];
    for name in names {
        let (n, hits) = stated::covered(seeds.iter().flat_map(|s| &s.covered), name);
        let rate = hits as f64 / n as f64;
        let (n1, h1) = stated::covered(
            seeds
                .iter()
                .filter(|s| s.orders == [3, 1])
                .flat_map(|s| &s.covered),
            name,
        );
        println!(
            "{name}: 95 % intervals cover the truth in {hits} of {n} fits ({rate:.3}); {h1} of {n1} where the orders are right"
        );
        assert!(n >= 180, "{name} estimated in {n} fits");
        if thermal::is_thermal(name) {
            assert!((rate - 0.95).abs() <= 0.035, "{name}: coverage {rate:.3}");
        }
    }
    let z: Vec<f64> = seeds.iter().flat_map(|s| s.z.iter().copied()).collect();
    stated::assert_normal("device between its nodes", &z);
}

#[test]
fn the_model_at_a_temperature_is_a_refit_about_that_temperature() {
    // Independent check of J(T) b and J C J': refit with the temperature shifted so that T is
    // its zero; the coefficients there are the model's at T, with the same standard errors.
    let truth = SingleTruth {
        k2: 0.0,
        k3: 0.0,
        kp: 0.0,
        ko: 0.0,
        k1_temp: 3e-4,
        ..SingleTruth::default()
    };
    let ramp = Ramp {
        from: -20.0,
        to: 60.0,
        ..chamber(false)
    };
    let conditions = plan::plan(&["head:12".into()], &[25.0], &[5.0], 10, true).unwrap();
    let (conditions, _) = sim::ramp::run(&ramp, &conditions);
    let obs = sim::simulate(
        &Sensor::Single { gyro: false, truth },
        &conditions,
        3,
        false,
    );
    let mut table: Table = obs.to_table("ramp.csv");
    let scale = Scale {
        lo: -20.0,
        hi: 60.0,
    };
    let at = 37.5;
    let x0 = scale.x(at);
    let x: Vec<f64> = table
        .column("temp")
        .unwrap()
        .iter()
        .map(|t| scale.x(*t))
        .collect();
    table.push_column("shifted", x.iter().map(|v| v - x0).collect());
    thermal::push_columns(&mut table, "temp", &scale, 2);
    let base = formula::parse("output ~ 1 + input").unwrap();
    let fit = |f: &formula::Formula, t: &Table| {
        AxisFit::fit(f, t, "input", 0.05, (std::path::Path::new("x"), "x"), false).unwrap()
    };
    let orders = vec![2, 1];
    let tf = ThermalFit {
        base: base.clone(),
        orders: orders.clone(),
        scale,
        fit: fit(&thermal::expand(&base, &orders), &table),
        reasons: Vec::new(),
        temps: table.column("temp").unwrap().to_vec(),
    };
    let model = tf.at(at);
    // The same space of models in powers of x - x0.
    let refit = fit(
        &formula::parse("output ~ 1 + input + shifted + shifted^2 + input:shifted").unwrap(),
        &table,
    );
    for name in ["1", "input"] {
        let (a, b) = (model.index(name).unwrap(), refit.index(name).unwrap());
        let rel = |p: f64, q: f64| (p - q).abs() / q.abs();
        assert!(
            rel(model.fit.coefficients[a], refit.fit.coefficients[b]) < 1e-9,
            "{name}"
        );
        assert!(
            rel(model.fit.std_errors[a], refit.fit.std_errors[b]) < 1e-6,
            "{name}: {} vs {}",
            model.fit.std_errors[a],
            refit.fit.std_errors[b]
        );
    }
    assert!((tf.fit.fit.rss - refit.fit.rss).abs() < 1e-9 * refit.fit.rss);
}

#[test]
fn against_px4_the_error_is_halved_where_the_curve_is_not_a_cubic() {
    let dir = tempfile::tempdir().unwrap();
    let scenarios = px4::scenarios();
    for s in &scenarios {
        let errors: Vec<px4::Errors> = (1..=3u64)
            .into_par_iter()
            .map(|seed| px4::run(s, seed, dir.path(), px4::Told::default()).unwrap())
            .collect();
        let rms = |f: fn(&px4::Errors) -> f64| {
            (errors.iter().map(|e| f(e).powi(2)).sum::<f64>() / errors.len() as f64).sqrt()
        };
        let (device, reference) = (rms(|e| e.device), rms(|e| e.px4));
        println!(
            "{}: device {:.3} mm/s^2, PX4 {:.3} mm/s^2",
            s.name,
            device * 1e3,
            reference * 1e3
        );
        if s.name.starts_with("cubic") {
            // PX4's own model, which calflash must find among the terms its preset tests
            // (nonlinearity, asymmetry, cross-axis): 1.07 times PX4's error over 50 seeds
            // (BENCHMARKS.md), 1.03 with the sensor's model given; 3 seeds vary more.
            assert!(device <= 1.15 * reference, "{}", s.name);
        } else {
            assert!(device <= 0.5 * reference, "{}", s.name);
        }
    }
}

#[test]
fn a_still_unit_in_a_ramp_and_a_bench_run_at_one_temperature_make_one_calibration() {
    // PX4's procedure: the unit still (input +1 g) while the chamber ramps gives the bias
    // against temperature; a dividing head at 25 C gives the scale factor and the rest.
    let truth = SingleTruth {
        k3: 0.0,
        kp: 0.0,
        ko: 0.0,
        k0_temp: 0.6,
        k0_temp2: -0.01,
        k0_temp3: 2e-4,
        k1_temp: 0.0,
        ..SingleTruth::default()
    };
    let ramp = chamber(false);
    let still = plan::plan(&["head:1".into()], &[25.0], &[5.0], 300, true).unwrap();
    let (mut conditions, _) = sim::ramp::run(&ramp, &still);
    conditions.extend(plan::plan(&["head:16".into()], &[25.0], &[5.0], 3, true).unwrap());
    let obs = sim::simulate(
        &Sensor::Single {
            gyro: false,
            truth: truth.clone(),
        },
        &conditions,
        11,
        false,
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("still.csv");
    obs.write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let mut opts = Options::new(&path, "STILL");
    opts.created = Some(0);
    let c = single::calibrate(&opts, Quantity::Acceleration).unwrap();
    let tf = c.thermal.first().expect("a continuous model");
    assert_eq!(tf.orders[0], 3, "{:?}", tf.reasons);
    let input = tf
        .base
        .term_names()
        .iter()
        .position(|n| n == "input")
        .unwrap();
    assert_eq!(tf.orders[input], 0);
    assert!(
        tf.reasons[input].contains("the most these observations can estimate"),
        "{}",
        tf.reasons[input]
    );
    // The device, between the ramp's temperatures, within 3 of its own 1-sigma.
    let cal = spincal::blob::decode(&c.blob).unwrap();
    let mut dev = AnyAxisCorrector::new(&cal).unwrap();
    for k in 0..20 {
        let t = -38.0 + 5.6 * f64::from(k);
        dev.set_environment(t as f32, 5.0);
        for i in 0..=8 {
            let x = plan::G * (f64::from(i) / 4.0 - 1.0);
            let code = truth.output(x, 0.0, 0.0, t, 5.0, 0.0).round();
            let want = truth.input(code, t, 5.0);
            let got = f64::from(dev.correct(code as i32).values[0]);
            let sigma = f64::from(dev.sigma(code as i32).unwrap());
            assert!(
                (got - want).abs() <= 3.0 * sigma,
                "{t} C, {x}: {got} vs {want} (1-sigma {sigma})"
            );
        }
    }
}

#[test]
fn two_ramp_calibrations_of_a_unit_compare_at_common_temperatures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cubic.json"),
        r#"{"k2":0,"k3":0,"kp":0,"ko":0,"k0_temp":0.6,"k0_temp2":-0.01,"k0_temp3":2e-4,"k1_temp":0}"#,
    )
    .unwrap();
    std::fs::write(
        d.join("shocked.json"),
        r#"{"k2":0,"k3":0,"kp":0,"ko":0,"k0":32915.4,"k0_temp":0.6,"k0_temp2":-0.01,"k0_temp3":2e-4,"k1_temp":0}"#,
    )
    .unwrap();
    let cal = |name: &str, truth: &str, seed: &str| {
        simulate_ramp(
            d,
            &format!("{name}.csv"),
            &["--ramp=-40:70", "--truth", truth, "--seed", seed],
        );
        let (code, out, err) = calflash(
            d,
            &[
                "calibrate",
                &format!("{name}.csv"),
                "--sensor",
                "single-accel",
                "--serial",
                "U-7",
                "--blob",
                &format!("{name}.bin"),
                "--json",
                &format!("{name}.json"),
                "--no-db",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
    };
    cal("first", "cubic.json", "2");
    cal("again", "cubic.json", "5");
    cal("shocked", "shocked.json", "6");
    let compared = |a: &str, b: &str, changed: bool| {
        let (code, out, err) = calflash(d, &["compare", a, b]);
        assert_eq!(code, if changed { 3 } else { 0 }, "{out}{err}");
        out
    };
    // The same unit again: the models agree at every 5 C of the range.
    let same = compared("first.json", "again.json", false);
    let points = same.matches("output at ").count();
    assert_eq!(points, 23, "{same}");
    assert!(!same.contains("<1e-300"), "{same}");
    // A bias shifted by 10 counts (25 times its standard error) moves everywhere.
    let moved = compared("first.json", "shocked.json", true);
    assert_eq!(
        moved.lines().filter(|l| l.ends_with(": CHANGED")).count(),
        23,
        "{moved}"
    );
    assert!(
        moved.contains("verdict: CHANGED: 23 output(s) changed"),
        "{moved}"
    );
}

#[test]
fn a_ramp_at_two_supply_voltages_gives_a_series_the_device_blends_between_them() {
    let truth = SingleTruth {
        k2: 0.0,
        k3: 0.0,
        kp: 0.0,
        ko: 0.0,
        k0_temp: 0.6,
        k0_temp2: -0.01,
        k0_temp3: 2e-4,
        k1_temp: 80e-6,
        k0_volt: 3.0,
        k1_volt: 2e-3,
        ..SingleTruth::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("volt.json"), serde_json::to_string(&truth).unwrap()).unwrap();
    let path = simulate_ramp(
        d,
        "volt.csv",
        &[
            "--ramp=-40:70",
            "--volts",
            "4.5,5.5",
            "--truth",
            "volt.json",
        ],
    );
    let mut opts = Options::new(&path, "VOLT");
    opts.created = Some(0);
    let c = single::calibrate(&opts, Quantity::Acceleration).unwrap();
    assert!(
        c.notes
            .iter()
            .any(|n| n.contains("the supply voltage varies from 4.5 to 5.5 V")),
        "{:?}",
        c.notes
    );
    let cal = spincal::blob::decode(&c.blob).unwrap();
    assert_eq!(cal.data().environment.voltages.as_slice(), &[4.5, 5.5]);
    let mut dev = AnyAxisCorrector::new(&cal).unwrap();
    for k in 0..12 {
        let t = -37.0 + 9.3 * f64::from(k);
        for v in [4.5, 4.8, 5.0, 5.5] {
            dev.set_environment(t as f32, v as f32);
            for i in 0..=4 {
                let x = 0.9 * plan::G * (f64::from(i) / 2.0 - 1.0);
                let code = truth.output(x, 0.0, 0.0, t, v, 0.0).round();
                let want = truth.input(code, t, v);
                let got = dev.correct(code as i32);
                assert!(got.flags.is_clean(), "{t} C, {v} V: {:?}", got.flags);
                let sigma = f64::from(dev.sigma(code as i32).unwrap());
                let err = f64::from(got.values[0]) - want;
                assert!(
                    err.abs() <= 3.0 * sigma,
                    "{t} C, {v} V, {x}: error {err} against 1-sigma {sigma}"
                );
            }
        }
    }
}

/// Issue 68: a ramp's model is continuous in temperature, one fit of every observation that
/// each of the device's coefficient sets carries. Its report draws each residual once (it drew
/// each once per set, at temperatures it was not taken at) and does not call the sets "table
/// points".
#[test]
fn a_ramp_report_draws_each_residual_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, out, err) = common::calflash(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:16",
            "--repeat",
            "10",
            "--ramp=-40:70",
            "--uneven",
            "-o",
            "ramp.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = common::calflash(
        d,
        &[
            "calibrate",
            "ramp.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "R-1",
            "--report",
            "ramp.html",
            "--no-db",
            "-q",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let html = std::fs::read_to_string(d.join("ramp.html")).unwrap();
    assert!(
        html.contains("observations in one model continuous in temperature"),
        "the summary"
    );
    assert!(!html.contains("table points;"), "sets called table points");
    for title in ["residuals against the input", "residuals in test order"] {
        let at = html
            .find(title)
            .unwrap_or_else(|| panic!("no figure `{title}`"));
        let figure = &html[at..html[at..].find("</svg>").unwrap() + at];
        assert_eq!(figure.matches("<circle").count(), 160, "{title}");
    }
}
