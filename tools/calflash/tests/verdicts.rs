//! A verdict means what it says, over many simulated units: a spin rig whose fixture is
//! tilted (diagonals at (1000, 25) rad/s, as the reference flights' bench has) fits every
//! lever-arm component its plan moves, so a good unit is not a misfit and is not rejected for
//! its correction's inverse; a model that lacks a term the units have is never ACCEPTed.
//! The figures are in BENCHMARKS.md (`cargo test --release -p calflash --test verdicts --
//! --nocapture`).

mod common;

use calflash::sensor::{Options, Verdict, triad};
use calflash::sim::{self, Sensor, plan, truth::ImuTruth};

/// Units per case.
const UNITS: u64 = 100;

/// The spinning round's rig with its fixture tilted: the README's tumble, axis spins and
/// centrifuge, and spins with the spin axis vertical (up and down) at (+-1000, +-25, 0),
/// (+-1000, 0, +-25) and (0, +-20, +-20) rad/s in the unit's axes.
fn tilted_rig() -> Vec<plan::Condition> {
    let items = [
        "tumble:24".to_string(),
        "rate:-1900:1900:9".into(),
        "centrifuge:1:1500:6".into(),
    ];
    let mut conds = plan::plan(&items, &[25.0], &[3.3], 1, false).unwrap();
    let template = conds[0];
    let pairs = [
        ([1000.0, 25.0, 0.0]),
        [1000.0, 0.0, 25.0],
        [0.0, 20.0, 20.0],
    ];
    for base in pairs {
        for s1 in [1.0, -1.0] {
            for s2 in [1.0, -1.0] {
                let mut w = base;
                let first = w.iter().position(|v| *v != 0.0).unwrap();
                let second = w.iter().rposition(|v| *v != 0.0).unwrap();
                w[first] *= s1;
                w[second] *= s2;
                let norm = w.iter().map(|v| v * v).sum::<f64>().sqrt();
                for up in [1.0, -1.0] {
                    conds.push(plan::Condition {
                        f: w.map(|v| up * plan::G * v / norm),
                        w,
                        dw: [0.0; 3],
                        ..template
                    });
                }
            }
        }
    }
    conds
}

/// What the calibrations of `UNITS` units said: how many were ACCEPTed and REJECTed, how many
/// named a misfit, how many were rejected for their inverse.
#[derive(Debug, Default)]
struct Said {
    accept: usize,
    reject: usize,
    misfit: usize,
    inverse_reject: usize,
    units: usize,
}

fn calibrate_units(truth: &ImuTruth, nonlinear: bool, seeds: std::ops::Range<u64>) -> Said {
    let conds = tilted_rig();
    let dir = tempfile::tempdir().unwrap();
    let mut said = Said::default();
    for seed in seeds {
        let obs = sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &conds, seed, false);
        let file = dir.path().join(format!("u{seed}.csv"));
        obs.write_csv(std::fs::File::create(&file).unwrap())
            .unwrap();
        let opts = Options::new(&file, "U");
        let c = triad::calibrate(&opts, triad::Kind::Imu, nonlinear)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        said.units += 1;
        said.accept += usize::from(c.verdict() == Verdict::Accept);
        said.reject += usize::from(c.verdict() == Verdict::Reject);
        said.misfit +=
            usize::from(c.findings.iter().any(|f| {
                f.verdict != Verdict::Accept && f.text.contains("the model does not fit")
            }));
        said.inverse_reject +=
            usize::from(c.findings.iter().any(|f| {
                f.verdict == Verdict::Reject && f.text.contains("from the exact inverse")
            }));
    }
    said
}

#[test]
fn a_good_unit_on_a_tilted_fixture_is_neither_a_misfit_nor_rejected_for_its_inverse() {
    let said = calibrate_units(&ImuTruth::spinning_round(), true, 1..UNITS + 1);
    println!("the right model, {UNITS} units: {said:?}");
    // The misfit test is Bonferroni at 5 % over the unit's six fits, and needs twice the noise.
    assert!(said.misfit <= 2, "{said:?}");
    assert_eq!(said.inverse_reject, 0, "{said:?}");
    assert!(said.accept >= UNITS as usize * 9 / 10, "{said:?}");
}

#[test]
fn a_model_without_a_term_the_units_have_is_never_accepted() {
    // The spinning round with a g-squared term the linear model lacks: 1e-5 per m/s^2 on each
    // accelerometer is 31 m/s^2 at the centrifuge's 1,764 m/s^2.
    let mut truth = ImuTruth::spinning_round();
    truth.accel.k2 = [1e-5, -1e-5, 1e-5];
    let said = calibrate_units(&truth, false, 1..UNITS / 4 + 1);
    println!(
        "a model without the g-squared term, {} units: {said:?}",
        UNITS / 4
    );
    assert_eq!(said.accept, 0, "{said:?}");
    assert_eq!(said.misfit, said.units, "{said:?}");
}

/// A term kept by the fit's selection does not make the predicted mission error too small:
/// a linear gyro (no g-sensitivity) calibrated on the shell-optimal plan keeps a spurious
/// g-term on some units (p < 0.05 by chance); over the flight inside the bench's specific
/// force, the realised error of those calibrations was 1.7 to 2.0 times their predicted RMS
/// (all units: 1.3). It is now covered (`mission::judge`: the prediction is the model's before
/// the choice of terms, whose covariance the unit states). The figures are in BENCHMARKS.md.
#[test]
fn a_term_kept_by_selection_is_covered_by_the_predicted_mission_error() {
    use calflash::sim::truth::TriadTruth;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"))
            .current_dir(d)
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.code().is_some_and(|c| c == 0 || c == 2),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--flight",
        "shell:seconds=20",
        "--sample-rate",
        "1000",
        "-o",
        "shell.csv",
    ]);
    run(&[
        "design",
        "optimize",
        "--sensor",
        "gyro",
        "--model",
        "triad-nonlinear",
        "--candidates",
        "rate:-2000:2000:41",
        "--n",
        "60",
        "--mission",
        "shell.csv",
        "-o",
        "plan.csv",
    ]);
    let truth_path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/linear_gyro.truth.json");
    let truth: TriadTruth =
        serde_json::from_str(&std::fs::read_to_string(&truth_path).unwrap()).unwrap();
    // The flight's samples inside the bench's specific force (1 g on each axis).
    let mut reader = csv::Reader::from_path(d.join("shell.csv")).unwrap();
    let head = reader.headers().unwrap().clone();
    let at = |n: &str| head.iter().position(|h| h == n).unwrap();
    let (fi, wi) = (["f_x", "f_y", "f_z"].map(at), ["w_x", "w_y", "w_z"].map(at));
    let flight: Vec<([f64; 3], [f64; 3])> = reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            let v = |k: usize| r[k].parse::<f64>().unwrap();
            (fi.map(v), wi.map(v))
        })
        .filter(|(f, _)| f.iter().all(|x| x.abs() <= 10.0028))
        .collect();
    let value = |name: &str, f: &[f64; 3], w: &[f64; 3]| -> f64 {
        let base = |n: &str| match n {
            "w_x" => w[0],
            "w_y" => w[1],
            "w_z" => w[2],
            "f_x" => f[0],
            "f_y" => f[1],
            "f_z" => f[2],
            _ => panic!("{n}"),
        };
        if name == "1" {
            1.0
        } else if let Some(v) = name.strip_suffix("^2") {
            base(v).powi(2)
        } else if let Some(v) = name.strip_suffix("^3") {
            base(v).powi(3)
        } else if let Some((v, _)) = name.split_once(":abs(") {
            base(v) * base(v).abs()
        } else {
            base(name)
        }
    };
    // (realised mean square, predicted mean square) pooled over the axes, for the units whose
    // selection kept a term the truth has not, and for all.
    let (mut kept, mut all) = ([0.0f64; 2], [0.0f64; 2]);
    let mut kept_count = 0;
    for seed in 1..=40u64 {
        let s = seed.to_string();
        run(&[
            "simulate",
            "--sensor",
            "gyro",
            "--plan-file",
            "plan.csv",
            "--truth",
            truth_path.to_str().unwrap(),
            "--seed",
            &s,
            "-o",
            "b.csv",
        ]);
        run(&[
            "calibrate",
            "b.csv",
            "--sensor",
            "gyro",
            "--serial",
            "G",
            "--no-db",
            "--mission",
            "shell.csv",
            "--json",
            "r.json",
        ]);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
        for (k, (names, b)) in common::record_axes(&r).into_iter().enumerate() {
            let true_of = |n: &str| match n {
                "1" => truth.bias[k],
                "w_x" => truth.s[k][0],
                "w_y" => truth.s[k][1],
                "w_z" => truth.s[k][2],
                _ => 0.0,
            };
            let scale = b[names
                .iter()
                .position(|n| *n == ["w_x", "w_y", "w_z"][k])
                .unwrap()];
            let ms = flight
                .iter()
                .map(|(f, w)| {
                    let e: f64 = names
                        .iter()
                        .zip(&b)
                        .map(|(n, bj)| (bj - true_of(n)) * value(n, f, w))
                        .sum::<f64>()
                        / scale;
                    e * e
                })
                .sum::<f64>()
                / flight.len() as f64;
            let predicted = r["mission"]["outputs"][k]["rms"].as_f64().unwrap().powi(2);
            all[0] += ms;
            all[1] += predicted;
            if names
                .iter()
                .any(|n| n.starts_with("f_") || n.contains('^') || n.contains("abs"))
            {
                kept[0] += ms;
                kept[1] += predicted;
                kept_count += 1;
            }
        }
    }
    let ratio = |x: [f64; 2]| (x[0] / x[1]).sqrt();
    println!(
        "realised / predicted RMS over the flight: {:.2} for the {kept_count} axes that kept a term by selection, {:.2} for all 120",
        ratio(kept),
        ratio(all)
    );
    assert!(kept_count >= 6, "{kept_count}");
    assert!(ratio(kept) < 1.4, "{}", ratio(kept));
    // These units have no g-sensitivity at all, and the prediction carries the whole model's
    // uncertainty in the g-terms the bench dropped (as the unit's stated error does): it is on
    // the safe side here (0.57). On units with and without one, drawn from a model not ours,
    // it is 0.81 to 0.99 (`mission_independent`).
    assert!((0.45..1.25).contains(&ratio(all)), "{}", ratio(all));
}
