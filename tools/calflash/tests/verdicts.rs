//! A verdict means what it says, over many simulated units: a spin rig whose fixture is
//! tilted (diagonals at (1000, 25) rad/s, as the reference flights' bench has) fits every
//! lever-arm component its plan moves, so a good unit is not a misfit and is not rejected for
//! its correction's inverse; a model that lacks a term the units have is never ACCEPTed.
//! The figures are in BENCHMARKS.md (`cargo test --release -p calflash --test verdicts --
//! --nocapture`).

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
