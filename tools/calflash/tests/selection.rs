//! Backward elimination (with the hierarchy kept), the partial F test, hold-out validation and
//! prediction variance, on simulated rate-table data whose true model is known.

use calflash::formula;
use calflash::obs::Format;
use calflash::regression::{self, CurveSpec, Request};
use calflash::stats::Options;

/// volts = 2.5 + 0.005 rate + 2e-7 rate^2 + 1e-4 (temp - 25) + noise (sigma 1e-3); no
/// rate:temp, no rate^3.
fn data(dir: &std::path::Path) -> std::path::PathBuf {
    let mut s = String::from("rate,temp,volts\n");
    let mut state = 12_345u64;
    let mut gauss = || {
        // Sum of 12 uniforms minus 6: close enough to normal for a test.
        (0..12)
            .map(|_| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1);
                (state >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 6.0
    };
    for k in 0..21 {
        let rate = -500.0 + 50.0 * f64::from(k);
        for temp in [-20.0, 10.0, 40.0, 70.0] {
            let v = 2.5 + 0.005 * rate + 2e-7 * rate * rate + 1e-4 * (temp - 25.0) + 1e-3 * gauss();
            s.push_str(&format!("{rate},{temp},{v}\n"));
        }
    }
    let p = dir.join("rt.csv");
    std::fs::write(&p, s).unwrap();
    p
}

fn request(file: std::path::PathBuf, model: &str) -> Request {
    Request {
        file,
        format: Format::Auto,
        formula: formula::parse(model).unwrap(),
        predict_at: vec![],
        curve: None,
        compare: None,
        backward: None,
        holdout_every: None,
        options: Options::default(),
    }
}

#[test]
fn backward_elimination_drops_the_terms_the_truth_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let mut req = request(
        data(dir.path()),
        "volts ~ 1 + rate + rate^2 + rate^3 + temp + rate:temp",
    );
    req.backward = Some(0.05);
    let reg = regression::run(&req).unwrap();
    let e = reg.elimination.unwrap();
    let dropped: Vec<&str> = e.steps.iter().map(|s| s.dropped.as_str()).collect();
    assert!(
        dropped.contains(&"rate^3") && dropped.contains(&"rate:temp"),
        "{dropped:?}"
    );
    assert_eq!(reg.formula.to_string(), "volts ~ 1 + rate + rate^2 + temp");
    assert!(e.steps.iter().all(|s| s.p_value > 0.05));
    assert!(
        reg.fit.p_values.iter().all(|p| *p < 0.05),
        "{:?}",
        reg.fit.p_values
    );
}

#[test]
fn hierarchy_protects_contained_terms() {
    let dir = tempfile::tempdir().unwrap();
    // temp alone is weak when its effect is tiny; with rate:temp kept by force it cannot go.
    let file = data(dir.path());
    let text = std::fs::read_to_string(&file).unwrap();
    // Give rate:temp a strong effect and temp none.
    let mut s = String::from("rate,temp,volts\n");
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let volts = v[2] - 1e-4 * (v[1] - 25.0) + 1e-5 * v[0] * v[1];
        s.push_str(&format!("{},{},{volts}\n", v[0], v[1]));
    }
    std::fs::write(&file, s).unwrap();
    let mut req = request(file, "volts ~ 1 + rate + rate^2 + temp + rate:temp");
    req.backward = Some(0.05);
    let reg = regression::run(&req).unwrap();
    assert!(
        reg.formula.terms.iter().any(|t| t.name() == "temp"),
        "{}",
        reg.formula
    );
    let e = reg.elimination.unwrap();
    assert!(e.steps.is_empty(), "{:?}", e.steps);
    assert_eq!(e.protected.len(), 1);
    assert_eq!(e.protected[0].0, "temp");
}

#[test]
fn partial_f_sees_a_missing_square_and_holdout_matches_prediction() {
    let dir = tempfile::tempdir().unwrap();
    let file = data(dir.path());
    let mut req = request(file.clone(), "volts ~ 1 + rate + rate^2 + temp");
    req.compare = Some(formula::parse("volts ~ 1 + rate + temp").unwrap());
    req.holdout_every = Some(4);
    req.curve = Some(CurveSpec {
        variable: "rate".into(),
        from: -1000.0,
        to: 1000.0,
        points: 41,
        hold: vec![],
    });
    let reg = regression::run(&req).unwrap();
    let c = reg.comparison.unwrap();
    assert!(c.test.p < 1e-20 && c.test.df_num == 1, "{c:?}");
    // The hold-out error is what the fit predicts for new observations (sigma 1e-3).
    let h = reg.holdout.unwrap();
    assert_eq!((h.n_train, h.n_test), (63, 21));
    assert!((h.rms_error / h.predicted_rms - 1.0).abs() < 0.35, "{h:?}");
    assert!((h.predicted_rms / 1e-3 - 1.0).abs() < 0.2, "{h:?}");
    // The prediction variance is smallest inside the calibrated range and grows outside it.
    let curve = reg.curve.unwrap();
    assert_eq!(curve.observed, (-500.0, 500.0));
    let var_at = |x: f64| {
        curve
            .points
            .iter()
            .find(|(r, _)| *r == x)
            .unwrap()
            .1
            .variance
    };
    assert!(var_at(0.0) < var_at(500.0) && var_at(500.0) < var_at(1000.0) / 4.0);
    // The reduced model leaves a pattern along rate that the runs test sees.
    let reg = regression::run(&request(file, "volts ~ 1 + rate + temp")).unwrap();
    assert!(
        reg.warnings
            .iter()
            .any(|w| w.starts_with("the residuals have a pattern along rate")),
        "{:?}",
        reg.warnings
    );
}
