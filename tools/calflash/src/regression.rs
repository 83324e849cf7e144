//! A fit of a formula to a file of observations, with everything `calflash fit` reports:
//! the fit, residual-pattern tests, warnings, predictions and a prediction curve, the partial F
//! test against a reduced model, backward elimination and hold-out validation.

use std::path::PathBuf;

use crate::formula::{self, Design, Formula, FormulaError};
use crate::obs::{self, Format, ObsError, Table};
use crate::stats::pattern::{self, RunsTest};
use crate::stats::select::{self, PartialF, Step};
use crate::stats::{Fit, FitError, Options, Prediction, fit};

/// Values of model variables: `[("rate", 100.0), ("temp", 25.0)]`.
pub type Point = Vec<(String, f64)>;

/// A prediction curve: one variable over a range, the others held.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveSpec {
    /// The variable swept.
    pub variable: String,
    /// From.
    pub from: f64,
    /// To.
    pub to: f64,
    /// Number of points.
    pub points: usize,
    /// Values of the other variables; the rest are held at their observed means.
    pub hold: Point,
}

/// What to fit and report.
#[derive(Debug, Clone)]
pub struct Request {
    /// The observations.
    pub file: PathBuf,
    /// Their format.
    pub format: Format,
    /// The model.
    pub formula: Formula,
    /// Prediction points.
    pub predict_at: Vec<Point>,
    /// A prediction curve.
    pub curve: Option<CurveSpec>,
    /// A reduced model to test against.
    pub compare: Option<Formula>,
    /// Backward elimination at this significance level.
    pub backward: Option<f64>,
    /// Hold every k-th observation out of the fit and predict it.
    pub holdout_every: Option<usize>,
    /// Fit options.
    pub options: Options,
}

/// A failure to fit, in words that name the file, line, column or term.
#[derive(Debug, thiserror::Error)]
pub enum RegressionError {
    /// Reading the observations failed.
    #[error(transparent)]
    Obs(#[from] ObsError),
    /// The formula does not parse.
    #[error(transparent)]
    Formula(#[from] FormulaError),
    /// The model names a column the file does not have.
    #[error("{file}: the model uses `{name}` (in {term}), but the file has no such column; its columns are: {}", available.join(", "))]
    UnknownVariable {
        /// File.
        file: PathBuf,
        /// The column name.
        name: String,
        /// The first term using it.
        term: String,
        /// The file's columns.
        available: Vec<String>,
    },
    /// A term cannot be estimated from these observations.
    #[error("{file}: {why}")]
    NotObservable {
        /// File.
        file: PathBuf,
        /// The explanation, naming the term.
        why: String,
    },
    /// Values too large to fit, located.
    #[error("{file}: {why}")]
    Values {
        /// File.
        file: PathBuf,
        /// The explanation, naming the line.
        why: String,
    },
    /// Not enough observations.
    #[error("{file}: {source}")]
    Fit {
        /// File.
        file: PathBuf,
        /// The cause.
        source: FitError,
    },
    /// A bad `--predict-at`, `--curve` or `--compare`.
    #[error("{0}")]
    Request(String),
}

/// A prediction at a named point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointPrediction {
    /// The point (every model variable).
    pub at: Point,
    /// The prediction.
    pub prediction: Prediction,
}

/// A prediction curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The variable swept.
    pub variable: String,
    /// The other variables' values.
    pub hold: Point,
    /// `(value of the variable, prediction)`.
    pub points: Vec<(f64, Prediction)>,
    /// The range of the variable in the observations (the calibrated range).
    pub observed: (f64, f64),
}

/// The partial F test against a reduced model.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The reduced model.
    pub reduced: String,
    /// Its fit's AIC.
    pub reduced_aic: f64,
    /// The test.
    pub test: PartialF,
}

/// Backward elimination.
#[derive(Debug, Clone, PartialEq)]
pub struct EliminationReport {
    /// The model before elimination.
    pub start: String,
    /// Steps in order.
    pub steps: Vec<Step>,
    /// Terms kept only because a kept term contains them.
    pub protected: Vec<(String, f64)>,
}

/// Hold-out validation.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Holdout {
    /// Every k-th observation was held out.
    pub every: usize,
    /// Observations fitted.
    pub n_train: usize,
    /// Observations held out.
    pub n_test: usize,
    /// RMS of (observed - predicted) over the held-out observations.
    pub rms_error: f64,
    /// Largest |observed - predicted|.
    pub max_abs_error: f64,
    /// RMS the training fit predicts for new observations: sqrt(mean(sigma2 + x'Cx)).
    pub predicted_rms: f64,
}

/// Everything `calflash fit` reports.
#[derive(Debug, Clone)]
pub struct Regression {
    /// The observations' file.
    pub file: PathBuf,
    /// The model fitted (after elimination, if any).
    pub formula: Formula,
    /// File line of each observation.
    pub lines: Vec<u64>,
    /// The fit.
    pub fit: Fit,
    /// Runs tests of the residual signs: in data order, then along each variable.
    pub runs: Vec<(String, RunsTest)>,
    /// Things a person should look at.
    pub warnings: Vec<String>,
    /// Predictions at requested points.
    pub predictions: Vec<PointPrediction>,
    /// The requested curve.
    pub curve: Option<Curve>,
    /// The partial F test.
    pub comparison: Option<Comparison>,
    /// Backward elimination.
    pub elimination: Option<EliminationReport>,
    /// Hold-out validation.
    pub holdout: Option<Holdout>,
}

fn fit_design(
    d: &Design,
    formula: &Formula,
    table: &Table,
    opts: &Options,
) -> Result<Fit, RegressionError> {
    fit(&d.x, &d.y, d.names.clone(), d.intercept, opts).map_err(|e| match e {
        FitError::RankDeficient {
            column,
            combination,
        } => RegressionError::NotObservable {
            file: table.path.clone(),
            why: formula.explain_rank_deficiency(table, column, &combination),
        },
        e @ (FitError::NotFinite { .. } | FitError::Overflow { .. }) => RegressionError::Values {
            file: table.path.clone(),
            why: formula
                .explain_values(table, &e)
                .unwrap_or_else(|| e.to_string()),
        },
        source => RegressionError::Fit {
            file: table.path.clone(),
            source,
        },
    })
}

/// Reads the columns of `formula` (and `extra`), mapping a missing one to the term using it.
fn read(req: &Request, extra: &[String]) -> Result<Table, RegressionError> {
    let mut cols = req.formula.columns();
    for c in extra {
        if !cols.contains(c) {
            cols.push(c.clone());
        }
    }
    obs::read_columns(&req.file, &cols, req.format).map_err(|e| match e {
        ObsError::MissingColumn {
            path,
            name,
            available,
        } => {
            let term = if name == req.formula.response {
                "the response".to_string()
            } else {
                req.formula
                    .terms
                    .iter()
                    .find(|t| t.variables().contains(&name.as_str()))
                    .map_or_else(|| "the request".into(), |t| format!("term {t}"))
            };
            RegressionError::UnknownVariable {
                file: path,
                name,
                term,
                available,
            }
        }
        other => other.into(),
    })
}

fn model_row(formula: &Formula, point: &Point) -> Result<Vec<f64>, RegressionError> {
    let vars: Vec<String> = formula.columns().into_iter().skip(1).collect();
    for (name, _) in point {
        if !vars.contains(name) {
            return Err(RegressionError::Request(format!(
                "prediction point: `{name}` is not a variable of the model {formula}"
            )));
        }
    }
    for v in &vars {
        if !point.iter().any(|(n, _)| n == v) {
            return Err(RegressionError::Request(format!(
                "prediction point: give a value for `{v}` too (the model {formula} uses it)"
            )));
        }
    }
    let mut row = Vec::new();
    formula.row(
        |v| {
            point
                .iter()
                .find(|(n, _)| n == v)
                .map_or(f64::NAN, |(_, x)| *x)
        },
        &mut row,
    );
    Ok(row)
}

/// Fits and analyses.
///
/// # Errors
/// A [`RegressionError`] naming the file, line, column or term.
pub fn run(req: &Request) -> Result<Regression, RegressionError> {
    if let Some(reduced) = &req.compare {
        check_nested(reduced, &req.formula)?;
    }
    let extra: Vec<String> = req.compare.iter().flat_map(Formula::columns).collect();
    let table = read(req, &extra)?;
    let opts = &req.options;
    let mut formula = req.formula.clone();
    let mut elimination = None;
    if let Some(level) = req.backward {
        let d = formula.design(&table);
        // Check the full model first so that a term that cannot be estimated is named.
        fit_design(&d, &formula, &table, opts)?;
        let terms = formula.clone();
        let e = select::backward(
            &d.x,
            &d.y,
            &d.names,
            d.intercept,
            opts,
            level,
            |names, j| {
                let name = &names[j];
                if name == formula::INTERCEPT {
                    return false;
                }
                let Some(term) = terms.terms.iter().find(|t| &t.name() == name) else {
                    return false;
                };
                !terms
                    .terms
                    .iter()
                    .filter(|t| names.contains(&t.name()))
                    .any(|other| Formula::contains(other, term))
            },
        )
        .map_err(|source| RegressionError::Fit {
            file: table.path.clone(),
            source,
        })?;
        for s in &e.steps {
            formula = formula.without(&s.dropped);
        }
        elimination = Some(EliminationReport {
            start: req.formula.to_string(),
            steps: e.steps,
            protected: e.protected,
        });
    }
    // The design and the fit take one core: the inputs' orders for the runs tests are sorted
    // on the other.
    let inputs: Vec<String> = formula.columns().into_iter().skip(1).collect();
    let ((design, f), orders) = rayon::join(
        || {
            let design = formula.design(&table);
            let f = fit_design(&design, &formula, &table, opts);
            (design, f)
        },
        || {
            use rayon::prelude::*;
            inputs
                .par_iter()
                .map(|v| pattern::order_by(table.column(v).unwrap_or_default()))
                .collect::<Vec<_>>()
        },
    );
    let f = f?;
    let by_input = inputs
        .iter()
        .zip(&orders)
        .map(|(v, order)| (v.clone(), pattern::runs_test(&f.residuals, order)));
    let mut runs = vec![("data order".to_string(), {
        let order: Vec<usize> = (0..f.n).collect();
        pattern::runs_test(&f.residuals, &order)
    })];
    runs.extend(by_input);
    let warnings = warnings(&f, &runs);

    let predictions = req
        .predict_at
        .iter()
        .map(|p| {
            let row = model_row(&formula, p)?;
            Ok(PointPrediction {
                at: p.clone(),
                prediction: f.predict(&row),
            })
        })
        .collect::<Result<Vec<_>, RegressionError>>()?;

    let curve = req
        .curve
        .as_ref()
        .map(|c| curve(c, &formula, &table, &f))
        .transpose()?;

    let comparison = req
        .compare
        .as_ref()
        .map(|reduced| {
            check_nested(reduced, &formula)?;
            let d = reduced.design(&table);
            let rf = fit_design(&d, reduced, &table, opts)?;
            Ok::<_, RegressionError>(Comparison {
                reduced: reduced.to_string(),
                reduced_aic: rf.aic,
                test: select::partial_f(&f, &rf),
            })
        })
        .transpose()?;

    let holdout = req
        .holdout_every
        .map(|k| holdout(k, &design, &formula, &table, opts))
        .transpose()?;

    Ok(Regression {
        file: table.path.clone(),
        formula,
        lines: table.lines.clone(),
        fit: f,
        runs,
        warnings,
        predictions,
        curve,
        comparison,
        elimination,
        holdout,
    })
}

fn check_nested(reduced: &Formula, full: &Formula) -> Result<(), RegressionError> {
    if reduced.response != full.response
        || (reduced.intercept && !full.intercept)
        || reduced.terms.iter().any(|t| !full.terms.contains(t))
    {
        return Err(RegressionError::Request(format!(
            "--compare: {reduced} is not nested in {full} (same response, and only terms the \
             full model has)"
        )));
    }
    if reduced.width() == full.width() {
        return Err(RegressionError::Request(format!(
            "--compare: {reduced} is the same model as {full}"
        )));
    }
    Ok(())
}

fn warnings(f: &Fit, runs: &[(String, RunsTest)]) -> Vec<String> {
    let mut w = Vec::new();
    let collinear: Vec<String> = f
        .names
        .iter()
        .zip(&f.vif)
        .filter_map(|(n, v)| v.filter(|v| *v > 10.0).map(|v| format!("{n} {v:.3}")))
        .collect();
    if !collinear.is_empty() {
        w.push(format!(
            "near-collinearity: condition number {:.3e}; variance inflation factors above 10: {}",
            f.condition_number,
            collinear.join(", ")
        ));
    }
    for (order, t) in runs {
        if t.p < f.alpha && t.z < 0.0 {
            w.push(format!(
                "the residuals have a pattern along {order}: {} runs of one sign where {:.1} are \
                 expected (runs test z = {:.2}, p = {:.2e}); the model may lack a term",
                t.runs, t.expected, t.z, t.p
            ));
        }
    }
    if f.durbin_watson < 1.0 || f.durbin_watson > 3.0 {
        w.push(format!(
            "the residuals are correlated in data order (Durbin-Watson {:.2}; 2 means none): drift \
             during the test, or a missing term",
            f.durbin_watson
        ));
    }
    w
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn curve(
    spec: &CurveSpec,
    formula: &Formula,
    table: &Table,
    f: &Fit,
) -> Result<Curve, RegressionError> {
    let vars: Vec<String> = formula.columns().into_iter().skip(1).collect();
    if !vars.contains(&spec.variable) {
        return Err(RegressionError::Request(format!(
            "--curve: `{}` is not a variable of the model {formula}",
            spec.variable
        )));
    }
    if spec.points < 2 {
        return Err(RegressionError::Request(
            "--curve: at least 2 points".into(),
        ));
    }
    let hold: Point = vars
        .iter()
        .filter(|v| **v != spec.variable)
        .map(|v| {
            let given = spec.hold.iter().find(|(n, _)| n == v).map(|(_, x)| *x);
            (
                v.clone(),
                given.unwrap_or_else(|| mean(table.column(v).unwrap_or_default())),
            )
        })
        .collect();
    let col = table.column(&spec.variable).unwrap_or_default();
    let observed = col
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    let points = (0..spec.points)
        .map(|i| {
            let x = spec.from + (spec.to - spec.from) * i as f64 / (spec.points - 1) as f64;
            let mut at = hold.clone();
            at.push((spec.variable.clone(), x));
            Ok((x, f.predict(&model_row(formula, &at)?)))
        })
        .collect::<Result<Vec<_>, RegressionError>>()?;
    Ok(Curve {
        variable: spec.variable.clone(),
        hold,
        points,
        observed,
    })
}

fn holdout(
    k: usize,
    design: &Design,
    formula: &Formula,
    table: &Table,
    opts: &Options,
) -> Result<Holdout, RegressionError> {
    if k < 2 {
        return Err(RegressionError::Request(
            "--holdout-every: at least 2".into(),
        ));
    }
    let n = design.y.len();
    let train: Vec<usize> = (0..n).filter(|i| (i + 1) % k != 0).collect();
    let test: Vec<usize> = (0..n).filter(|i| (i + 1) % k == 0).collect();
    if test.is_empty() {
        return Err(RegressionError::Request(format!(
            "--holdout-every {k}: only {n} observations, none held out"
        )));
    }
    let sub = table.select(&train);
    let d = formula.design(&sub);
    let f = fit_design(&d, formula, &sub, opts)?;
    let mut sq = 0.0;
    let mut max_abs: f64 = 0.0;
    let mut pred_var = 0.0;
    for &i in &test {
        let row: Vec<f64> = design.x.row(i).iter().copied().collect();
        let p = f.predict(&row);
        let e = design.y[i] - p.value;
        sq += e * e;
        max_abs = max_abs.max(e.abs());
        pred_var += p.observation_variance;
    }
    let m = test.len() as f64;
    Ok(Holdout {
        every: k,
        n_train: train.len(),
        n_test: test.len(),
        rms_error: (sq / m).sqrt(),
        max_abs_error: max_abs,
        predicted_rms: (pred_var / m).sqrt(),
    })
}
