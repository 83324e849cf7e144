//! Model comparison and selection: the partial F test between nested models and backward
//! elimination of terms that are not significant.

use nalgebra::DMatrix;

use super::dist;
use super::ols::{Fit, FitError, Options, fit};

/// The partial F test of a reduced model against a full model that contains it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PartialF {
    /// The statistic.
    pub f: f64,
    /// Numerator degrees of freedom: the terms the reduced model lacks.
    pub df_num: usize,
    /// Denominator degrees of freedom: the full model's residual dof.
    pub df_den: usize,
    /// Its p-value: small means the extra terms matter.
    pub p: f64,
}

/// The partial F test; `reduced` must be nested in `full` (the caller checks the terms).
#[must_use]
pub fn partial_f(full: &Fit, reduced: &Fit) -> PartialF {
    let df_num = reduced.dof - full.dof;
    let df_den = full.dof;
    let f = (reduced.rss - full.rss) / df_num as f64 / (full.rss / df_den as f64);
    PartialF {
        f,
        df_num,
        df_den,
        p: dist::f_upper(f, df_num as f64, df_den as f64),
    }
}

/// The Wald test that the coefficients of `terms` are all zero, from `fit`'s own covariance
/// (for least squares the same statistic as the partial F test of dropping them; for a fit
/// whose covariance is a sandwich estimate, the test that remains valid). `None` when a term
/// is missing or their covariance is singular.
#[must_use]
pub fn wald(fit: &Fit, terms: &[String]) -> Option<PartialF> {
    let idx: Vec<usize> = terms
        .iter()
        .map(|t| fit.names.iter().position(|n| n == t))
        .collect::<Option<_>>()?;
    let q = idx.len();
    let b = nalgebra::DVector::from_iterator(q, idx.iter().map(|&i| fit.coefficients[i]));
    let c = DMatrix::from_fn(q, q, |r, k| fit.covariance[(idx[r], idx[k])]);
    let solved = c.cholesky()?.solve(&b);
    let f = b.dot(&solved) / q as f64;
    Some(PartialF {
        f,
        df_num: q,
        df_den: fit.dof,
        p: dist::f_upper(f, q as f64, fit.dof as f64),
    })
}

/// One step of backward elimination.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Step {
    /// The term dropped.
    pub dropped: String,
    /// Its p-value in the model it was dropped from.
    pub p_value: f64,
    /// The model's AIC before and after.
    pub aic_before: f64,
    /// AIC after the drop.
    pub aic_after: f64,
}

/// The result of backward elimination.
#[derive(Debug, Clone)]
pub struct Elimination {
    /// The steps, in order.
    pub steps: Vec<Step>,
    /// Terms that could have been dropped by significance alone but were kept because a kept
    /// term contains them (hierarchy), with their p-values.
    pub protected: Vec<(String, f64)>,
    /// The final fit.
    pub fit: Fit,
}

/// Drops, one at a time, the droppable term with the largest p-value above `level`, refitting
/// after each drop, until every droppable term is significant. `droppable(names, j)` says
/// whether term `j` of the current model may go (the intercept and terms that others contain
/// usually may not).
///
/// # Errors
/// A [`FitError`] from any of the fits.
pub fn backward(
    x: &DMatrix<f64>,
    y: &[f64],
    names: &[String],
    intercept: bool,
    opts: &Options,
    level: f64,
    droppable: impl Fn(&[String], usize) -> bool,
) -> Result<Elimination, FitError> {
    let mut active: Vec<usize> = (0..names.len()).collect();
    let mut steps = Vec::new();
    loop {
        let cur_names: Vec<String> = active.iter().map(|&j| names[j].clone()).collect();
        let xa = x.select_columns(&active);
        let f = fit(&xa, y, cur_names.clone(), intercept, opts)?;
        let worst = (0..active.len())
            .filter(|&j| droppable(&cur_names, j))
            .filter(|&j| f.p_values[j] > level)
            .max_by(|&a, &b| f.p_values[a].total_cmp(&f.p_values[b]));
        let Some(j) = worst else {
            let protected = (0..active.len())
                .filter(|&j| {
                    !droppable(&cur_names, j) && f.p_values[j] > level && cur_names[j] != "1"
                })
                .map(|j| (cur_names[j].clone(), f.p_values[j]))
                .collect();
            return Ok(Elimination {
                steps,
                protected,
                fit: f,
            });
        };
        let aic_before = f.aic;
        let mut next = active.clone();
        next.remove(j);
        let xa = x.select_columns(&next);
        let nn: Vec<String> = next.iter().map(|&k| names[k].clone()).collect();
        let after = fit(&xa, y, nn, intercept, opts)?;
        steps.push(Step {
            dropped: cur_names[j].clone(),
            p_value: f.p_values[j],
            aic_before,
            aic_after: after.aic,
        });
        active = next;
    }
}
