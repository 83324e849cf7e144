//! calflash against statsmodels (OLS, OLSInfluence, compare_f_test, get_prediction) on four
//! datasets: a tumble with cubic terms, a rate table with an outlier, a nearly collinear
//! thermal run, and a model without intercept. The references were made by
//! `crosscheck/statsmodels_reference.py`; agreement is required to 1e-9 relative.

use std::path::PathBuf;

use calflash::formula;
use calflash::obs::Format;
use calflash::regression::{self, Request};
use calflash::stats::Options;
use serde_json::Value;

const TOL: f64 = 1e-9;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn vec_of(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN))
        .collect()
}

/// Relative agreement, with 1e-6 of the vector's largest magnitude as the floor for entries
/// near zero.
fn close(what: &str, got: &[f64], want: &[f64]) {
    close_tol(what, got, want, TOL);
}

fn close_tol(what: &str, got: &[f64], want: &[f64], tol_rel: f64) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let err = (g - w).abs();
        let tol = tol_rel * w.abs().max(1e-6 * scale);
        assert!(
            err <= tol,
            "{what}[{i}]: calflash {g:e}, statsmodels {w:e}, error {err:e} > {tol:e}"
        );
    }
}

fn one(what: &str, got: f64, want: &Value) {
    close(what, &[got], &[want.as_f64().unwrap()]);
}

/// p-values: relative agreement while they are representable with room to spare.
fn close_p(what: &str, got: &[f64], want: &[f64], tol: f64) {
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        if *w < 1e-280 {
            assert!(*g < 1e-270, "{what}[{i}]: {g:e} vs {w:e}");
        } else {
            assert!(
                (g - w).abs() <= tol * w,
                "{what}[{i}]: calflash {g:e}, reference {w:e}"
            );
        }
    }
}

fn request(name: &str, reference: &Value) -> Request {
    let predict_at = reference["statsmodels"]["predictions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            p["at"]
                .as_object()
                .unwrap()
                .iter()
                .map(|(k, v)| (k.clone(), v.as_f64().unwrap()))
                .collect()
        })
        .collect();
    Request {
        file: data(&format!("{name}.csv")),
        format: Format::Auto,
        formula: formula::parse(reference["formula"].as_str().unwrap()).unwrap(),
        predict_at,
        curve: None,
        compare: reference
            .get("compare")
            .map(|c| formula::parse(c["formula"].as_str().unwrap()).unwrap()),
        backward: None,
        holdout_every: None,
        options: Options::default(),
    }
}

fn matrix(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().flat_map(vec_of).collect()
}

/// The quantities both references have, compared with `r` (statsmodels or the exact values).
/// `tol(k)` is the relative tolerance for quantity `k`.
fn compare_common(
    label: &str,
    reg: &calflash::regression::Regression,
    r: &Value,
    tol: impl Fn(&str) -> f64,
) {
    let f = &reg.fit;
    let inf = &f.influence;
    let w = |k: &str| format!("{label} {k}");
    let per_term = |k: &str, got: &[f64]| close_tol(&w(k), got, &vec_of(&r[k]), tol(k));
    per_term("params", &f.coefficients);
    per_term("bse", &f.std_errors);
    per_term("tvalues", &f.t);
    close_p(
        &w("pvalues"),
        &f.p_values,
        &vec_of(&r["pvalues"]),
        tol("pvalues"),
    );
    let cov: Vec<f64> = f.covariance.transpose().iter().copied().collect();
    close_tol(
        &w("cov_params"),
        &cov,
        &matrix(&r["cov_params"]),
        tol("cov_params"),
    );
    for (k, got) in [("ssr", f.rss), ("scale", f.sigma2), ("rsquared", f.r2)] {
        close_tol(&w(k), &[got], &[r[k].as_f64().unwrap()], tol(k));
    }
    let per_obs = |k: &str, got: &[f64]| close_with(&w(k), got, &vec_of(&r[k]), tol(k), 1);
    per_obs("resid", &f.residuals);
    per_obs("hat", &inf.leverage);
    per_obs("student_internal", &inf.student_internal);
    per_obs("student_external", &inf.student_external);
    per_obs("cooks_distance", &inf.cooks_distance);
    per_obs("dffits", &inf.dffits);
    let dfb: Vec<f64> = inf.dfbetas.transpose().iter().copied().collect();
    close_with(
        &w("dfbetas"),
        &dfb,
        &matrix(&r["dfbetas"]),
        tol("dfbetas"),
        inf.dfbetas.ncols(),
    );
    for (k, (p, v)) in reg
        .predictions
        .iter()
        .zip(r["predictions"].as_array().unwrap())
        .enumerate()
    {
        let t = tol("predictions");
        for (name, got) in [
            ("value", p.prediction.value),
            ("variance", p.prediction.variance),
            ("observation_variance", p.prediction.observation_variance),
        ] {
            close_tol(
                &w(&format!("prediction {k} {name}")),
                &[got],
                &[v[name].as_f64().unwrap()],
                t,
            );
        }
    }
}

/// Per-observation quantities (`cols` columns, row-major): relative agreement, with the RMS of
/// each column as the floor. An entry near zero cannot be more precise than its inputs' rounding:
/// a residual of 6e-8 on a response of 2.9 carries 4e-16 of rounding, 1e-8 of itself, however
/// it is computed.
fn close_with(what: &str, got: &[f64], want: &[f64], tol: f64, cols: usize) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let mut ss = vec![0.0f64; cols];
    for (i, w) in want.iter().enumerate() {
        ss[i % cols] += w * w;
    }
    let rows = (want.len() / cols) as f64;
    let rms: Vec<f64> = ss.iter().map(|s| (s / rows).sqrt()).collect();
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let err = (g - w).abs();
        let t = tol * w.abs().max(rms[i % cols]);
        assert!(
            err <= t,
            "{what}[{i}]: calflash {g:e}, reference {w:e}, error {err:e} > {t:e}"
        );
    }
}

fn check(name: &str) -> calflash::regression::Regression {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(data(&format!("{name}.reference.json"))).unwrap(),
    )
    .unwrap();
    let reg = regression::run(&request(name, &reference)).unwrap();
    let f = &reg.fit;
    let sm = &reference["statsmodels"];
    assert_eq!(f.n as u64, sm["n"].as_u64().unwrap());
    // Against the 50-digit values: calflash is accurate to 1e-9 everywhere.
    compare_common("exact", &reg, &reference["exact"], |_| TOL);
    // Against statsmodels: to 1e-9, except where statsmodels itself is further than that from
    // the exact values (its leave-one-out DFBETAS, its prediction variances on the nearly
    // collinear set): there to twice statsmodels' own recorded error.
    let sm_error = &reference["statsmodels_error"];
    compare_common("statsmodels", &reg, sm, |k| {
        TOL.max(2.0 * sm_error[k].as_f64().unwrap())
    });
    close(
        "statsmodels ci_lower",
        &f.ci_lower,
        &vec_of(&sm["ci_lower"]),
    );
    close(
        "statsmodels ci_upper",
        &f.ci_upper,
        &vec_of(&sm["ci_upper"]),
    );
    one("statsmodels rsquared_adj", f.adj_r2, &sm["rsquared_adj"]);
    one("statsmodels fvalue", f.f, &sm["fvalue"]);
    close_p(
        "statsmodels f_pvalue",
        &[f.f_p],
        &[sm["f_pvalue"].as_f64().unwrap()],
        TOL,
    );
    one("statsmodels llf", f.log_likelihood, &sm["llf"]);
    one("statsmodels aic", f.aic, &sm["aic"]);
    one("statsmodels bic", f.bic, &sm["bic"]);
    one(
        "numpy condition number",
        f.condition_number,
        &sm["condition_number_svd"],
    );
    let want_vif = vec_of(&sm["vif"]);
    let (got, want): (Vec<f64>, Vec<f64>) = f
        .vif
        .iter()
        .zip(&want_vif)
        .filter(|(_, w)| !w.is_nan())
        .map(|(g, w)| (g.unwrap(), *w))
        .unzip();
    close("statsmodels vif", &got, &want);
    one(
        "statsmodels durbin_watson",
        f.durbin_watson,
        &sm["durbin_watson"],
    );
    let runs = reg.runs[0].1;
    one("statsmodels runs_z", runs.z, &sm["runs_z"]);
    close_p(
        "statsmodels runs_p",
        &[runs.p],
        &[sm["runs_p"].as_f64().unwrap()],
        TOL,
    );
    if let Some(c) = reference.get("compare") {
        let got = reg.comparison.as_ref().unwrap();
        one("statsmodels compare f", got.test.f, &c["f"]);
        close_p(
            "statsmodels compare p",
            &[got.test.p],
            &[c["p"].as_f64().unwrap()],
            TOL,
        );
        assert_eq!(got.test.df_num as u64, c["df_num"].as_u64().unwrap());
    }
    reg
}

#[test]
fn tumble_with_cubic_terms() {
    check("tumble_cubic");
}

#[test]
fn rate_table_with_an_outlier() {
    let reg = check("rate_outlier");
    // And the outlier is the one flagged.
    let flagged: Vec<usize> = reg.fit.influence.outliers.iter().map(|(i, _)| *i).collect();
    assert_eq!(flagged, [37]);
    assert_eq!(reg.lines[37], 39);
}

#[test]
fn nearly_collinear_thermal_run() {
    let reg = check("collinear_thermal");
    assert!(
        reg.warnings
            .iter()
            .any(|w| w.starts_with("near-collinearity")),
        "{:?}",
        reg.warnings
    );
}

#[test]
fn model_without_intercept() {
    let reg = check("no_intercept");
    assert!(!reg.fit.intercept && reg.fit.vif.iter().all(Option::is_some));
}
