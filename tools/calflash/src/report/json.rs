//! The `--json` output of `calflash fit`: schema `calflash.fit/1`.
//!
//! Stable: fields are only ever added, never renamed or removed, within a schema version.
//! Vectors over terms follow `terms`; vectors over observations follow the data (and `line`
//! gives each observation's line in the file). A number that is undefined (a p-value of a
//! model with no terms besides the intercept, a studentized residual at leverage 1) is `null`.
//!
//! | field | meaning |
//! |---|---|
//! | `schema` | `"calflash.fit/1"` |
//! | `file`, `model`, `response` | the data file, the fitted model as a formula, its response |
//! | `n_obs`, `n_terms`, `dof`, `alpha` | observations, terms, residual degrees of freedom, significance level |
//! | `terms` | term names; `"1"` is the intercept |
//! | `coefficients`, `std_errors`, `t`, `p`, `ci_lower`, `ci_upper` | per term; `p` two-sided, interval at `1 - alpha` |
//! | `covariance` | coefficient covariance, rows and columns in the order of `terms` |
//! | `vif` | variance inflation factor per term (`null` for the intercept) |
//! | `rss`, `sigma2`, `tss` | residual sum of squares, residual variance `rss / dof`, total sum of squares |
//! | `r2`, `adj_r2` | centered with an intercept, uncentered without; `adj_r2 = 1 - (n - k)/dof (1 - r2)` |
//! | `f`, `f_p`, `df_model` | F test of the model against the intercept alone (or against zero) |
//! | `log_likelihood`, `aic`, `bic` | Gaussian log-likelihood, `-2 llf + 2 p`, `-2 llf + ln(n) p` |
//! | `condition_number` | largest over smallest singular value of the design matrix |
//! | `durbin_watson`, `runs_tests` | residual pattern in data order, and runs tests along each variable |
//! | `line`, `fitted`, `residuals`, `leverage` | per observation |
//! | `student_internal`, `student_external` | internally and externally studentized residuals |
//! | `cooks_distance`, `dffits`, `dfbetas` | influence; `dfbetas` is one array of `n_terms` per observation |
//! | `thresholds`, `outliers`, `influential` | flag thresholds, flagged observations (index, line, statistics) |
//! | `warnings` | the warnings printed |
//! | `predictions` | per `--predict-at`: `at`, `value`, `variance` (of the fitted value), `observation_variance` |
//! | `curve` | `--curve`: `variable`, `hold`, `observed_range`, `points` of `{x, value, variance, observation_variance}` |
//! | `comparison` | `--compare`: `reduced`, `f`, `df_num`, `df_den`, `p`, `reduced_aic` |
//! | `elimination` | `--backward`: `start`, `steps` (`dropped`, `p_value`, `aic_before`, `aic_after`), `protected` |
//! | `holdout` | `--holdout-every`: `every`, `n_train`, `n_test`, `rms_error`, `max_abs_error`, `predicted_rms` |

use nalgebra::DMatrix;
use serde::Serialize;
use serde::ser::{SerializeSeq, Serializer};

use crate::regression::Regression;
use crate::stats::influence::{InfluenceRule, Thresholds};
use crate::stats::pattern::RunsTest;
use crate::stats::select::{PartialF, Step};

/// The schema identifier.
pub const SCHEMA: &str = "calflash.fit/1";

struct Rows<'a>(&'a DMatrix<f64>);

impl Serialize for Rows<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.0.nrows()))?;
        for r in self.0.row_iter() {
            let row: Vec<f64> = r.iter().copied().collect();
            seq.serialize_element(&row)?;
        }
        seq.end()
    }
}

#[derive(Serialize)]
struct RunsJson<'a> {
    order: &'a str,
    #[serde(flatten)]
    test: &'a RunsTest,
}

#[derive(Serialize)]
struct Outlier {
    index: usize,
    line: u64,
    student_external: f64,
    p_bonferroni: f64,
}

#[derive(Serialize)]
struct Influential<'a> {
    index: usize,
    line: u64,
    leverage: f64,
    cooks_distance: f64,
    dffits: f64,
    rules: &'a [InfluenceRule],
}

#[derive(Serialize)]
struct PredictionJson {
    at: serde_json::Map<String, serde_json::Value>,
    value: f64,
    variance: f64,
    observation_variance: f64,
}

#[derive(Serialize)]
struct CurvePoint {
    x: f64,
    value: f64,
    variance: f64,
    observation_variance: f64,
}

#[derive(Serialize)]
struct CurveJson<'a> {
    variable: &'a str,
    hold: serde_json::Map<String, serde_json::Value>,
    observed_range: [f64; 2],
    points: Vec<CurvePoint>,
}

#[derive(Serialize)]
struct ComparisonJson<'a> {
    reduced: &'a str,
    reduced_aic: f64,
    #[serde(flatten)]
    test: &'a PartialF,
}

#[derive(Serialize)]
struct Protected<'a> {
    term: &'a str,
    p_value: f64,
}

#[derive(Serialize)]
struct EliminationJson<'a> {
    start: &'a str,
    steps: &'a [Step],
    protected: Vec<Protected<'a>>,
}

#[derive(Serialize)]
struct FitJson<'a> {
    schema: &'static str,
    file: String,
    model: String,
    response: &'a str,
    n_obs: usize,
    n_terms: usize,
    dof: usize,
    alpha: f64,
    terms: &'a [String],
    coefficients: &'a [f64],
    std_errors: &'a [f64],
    t: &'a [f64],
    p: &'a [f64],
    ci_lower: &'a [f64],
    ci_upper: &'a [f64],
    covariance: Rows<'a>,
    vif: &'a [Option<f64>],
    rss: f64,
    sigma2: f64,
    tss: f64,
    r2: f64,
    adj_r2: f64,
    f: f64,
    f_p: f64,
    df_model: usize,
    log_likelihood: f64,
    aic: f64,
    bic: f64,
    condition_number: f64,
    durbin_watson: f64,
    runs_tests: Vec<RunsJson<'a>>,
    warnings: &'a [String],
    thresholds: &'a Thresholds,
    outliers: Vec<Outlier>,
    influential: Vec<Influential<'a>>,
    predictions: Vec<PredictionJson>,
    curve: Option<CurveJson<'a>>,
    comparison: Option<ComparisonJson<'a>>,
    elimination: Option<EliminationJson<'a>>,
    holdout: Option<&'a crate::regression::Holdout>,
    line: &'a [u64],
    fitted: &'a [f64],
    residuals: &'a [f64],
    leverage: &'a [f64],
    student_internal: &'a [f64],
    student_external: &'a [f64],
    cooks_distance: &'a [f64],
    dffits: &'a [f64],
    dfbetas: Rows<'a>,
}

fn point_map(p: &[(String, f64)]) -> serde_json::Map<String, serde_json::Value> {
    p.iter()
        .map(|(k, v)| (k.clone(), serde_json::json!(v)))
        .collect()
}

/// Writes the report as JSON.
///
/// # Errors
/// Whatever the writer returns.
pub fn write(reg: &Regression, out: impl std::io::Write) -> serde_json::Result<()> {
    let f = &reg.fit;
    let inf = &f.influence;
    let doc = FitJson {
        schema: SCHEMA,
        file: reg.file.display().to_string(),
        model: reg.formula.to_string(),
        response: &reg.formula.response,
        n_obs: f.n,
        n_terms: f.p,
        dof: f.dof,
        alpha: f.alpha,
        terms: &f.names,
        coefficients: &f.coefficients,
        std_errors: &f.std_errors,
        t: &f.t,
        p: &f.p_values,
        ci_lower: &f.ci_lower,
        ci_upper: &f.ci_upper,
        covariance: Rows(&f.covariance),
        vif: &f.vif,
        rss: f.rss,
        sigma2: f.sigma2,
        tss: f.tss,
        r2: f.r2,
        adj_r2: f.adj_r2,
        f: f.f,
        f_p: f.f_p,
        df_model: f.df_model,
        log_likelihood: f.log_likelihood,
        aic: f.aic,
        bic: f.bic,
        condition_number: f.condition_number,
        durbin_watson: f.durbin_watson,
        runs_tests: reg
            .runs
            .iter()
            .map(|(o, t)| RunsJson { order: o, test: t })
            .collect(),
        warnings: &reg.warnings,
        thresholds: &inf.thresholds,
        outliers: inf
            .outliers
            .iter()
            .map(|(i, p)| Outlier {
                index: *i,
                line: reg.lines[*i],
                student_external: inf.student_external[*i],
                p_bonferroni: *p,
            })
            .collect(),
        influential: inf
            .influential
            .iter()
            .map(|(i, rules)| Influential {
                index: *i,
                line: reg.lines[*i],
                leverage: inf.leverage[*i],
                cooks_distance: inf.cooks_distance[*i],
                dffits: inf.dffits[*i],
                rules,
            })
            .collect(),
        predictions: reg
            .predictions
            .iter()
            .map(|p| PredictionJson {
                at: point_map(&p.at),
                value: p.prediction.value,
                variance: p.prediction.variance,
                observation_variance: p.prediction.observation_variance,
            })
            .collect(),
        curve: reg.curve.as_ref().map(|c| CurveJson {
            variable: &c.variable,
            hold: point_map(&c.hold),
            observed_range: [c.observed.0, c.observed.1],
            points: c
                .points
                .iter()
                .map(|(x, p)| CurvePoint {
                    x: *x,
                    value: p.value,
                    variance: p.variance,
                    observation_variance: p.observation_variance,
                })
                .collect(),
        }),
        comparison: reg.comparison.as_ref().map(|c| ComparisonJson {
            reduced: &c.reduced,
            reduced_aic: c.reduced_aic,
            test: &c.test,
        }),
        elimination: reg.elimination.as_ref().map(|e| EliminationJson {
            start: &e.start,
            steps: &e.steps,
            protected: e
                .protected
                .iter()
                .map(|(t, p)| Protected {
                    term: t,
                    p_value: *p,
                })
                .collect(),
        }),
        holdout: reg.holdout.as_ref(),
        line: &reg.lines,
        fitted: &f.fitted,
        residuals: &f.residuals,
        leverage: &inf.leverage,
        student_internal: &inf.student_internal,
        student_external: &inf.student_external,
        cooks_distance: &inf.cooks_distance,
        dffits: &inf.dffits,
        dfbetas: Rows(&inf.dfbetas),
    };
    serde_json::to_writer(out, &doc)
}
