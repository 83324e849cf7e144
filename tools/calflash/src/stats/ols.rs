//! Ordinary least squares by Householder QR, with the statistics of a regression package.
//!
//! Solve, factor and diagnose are kept apart: the columns are scaled to unit length, factored
//! `X D^-1 = Q R`, and everything else (coefficients, covariance, leverage, influence) comes
//! from `Q` and `R^-1` without ever forming `X'X`. Every diagnostic is closed form, O(n p) or
//! O(n p^2): no leave-one-out refits.

use nalgebra::{DMatrix, DVector};

use super::dist;
use super::influence::{self, Influence};

mod collinearity;
use collinearity::{condition_number, rank_deficient, variance_inflation};

/// Options of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Significance level for confidence intervals, outlier and influence thresholds.
    pub alpha: f64,
    /// A column whose part independent of the columns before it is smaller than this fraction
    /// of its length is rank deficient.
    pub rank_tolerance: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            alpha: 0.05,
            rank_tolerance: 1e-10,
        }
    }
}

/// Why a model cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// Not more observations than terms: no residual degree of freedom.
    #[error("{n} observations cannot fit {p} terms: at least {} are needed for one residual degree of freedom", p + 1)]
    TooFewObservations {
        /// Observations.
        n: usize,
        /// Terms.
        p: usize,
    },
    /// A column that the columns before it explain (to the rank tolerance).
    #[error("column {column} is a linear combination of the columns before it")]
    RankDeficient {
        /// The column index.
        column: usize,
        /// Its approximation by earlier columns: `(index, coefficient)`.
        combination: Vec<(usize, f64)>,
    },
    /// NaN or infinity in the data: in model column `column` (`None`: the response) of
    /// observation `row`.
    #[error("observation {row} holds a value that is not finite")]
    NotFinite {
        /// The observation (0-based).
        row: usize,
        /// The model column, or `None` for the response.
        column: Option<usize>,
    },
    /// Finite data whose sums of squares overflow: values near the largest `f64`.
    #[error("the sums of squares overflow; the largest value is at observation {row}")]
    Overflow {
        /// The observation holding the largest absolute value (0-based).
        row: usize,
    },
}

/// Everything a fit reports. Vectors over terms are in the order of `names`; vectors over
/// observations are in the order of the data.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Term names.
    pub names: Vec<String>,
    /// Whether the model has an intercept (R^2 is then centered).
    pub intercept: bool,
    /// Observations.
    pub n: usize,
    /// Terms.
    pub p: usize,
    /// Residual degrees of freedom, `n - p`.
    pub dof: usize,
    /// Significance level used for intervals and flags.
    pub alpha: f64,
    /// Coefficients.
    pub coefficients: Vec<f64>,
    /// Standard errors.
    pub std_errors: Vec<f64>,
    /// t statistics.
    pub t: Vec<f64>,
    /// Two-sided p-values.
    pub p_values: Vec<f64>,
    /// Lower ends of the `1 - alpha` confidence intervals.
    pub ci_lower: Vec<f64>,
    /// Upper ends.
    pub ci_upper: Vec<f64>,
    /// Covariance of the coefficients, `sigma2 (X'X)^-1`.
    pub covariance: DMatrix<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Residual variance `rss / dof`.
    pub sigma2: f64,
    /// Total sum of squares (about the mean with an intercept, about 0 without).
    pub tss: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// Adjusted R^2: `1 - (n - k) / (n - p) (1 - R^2)`, `k` = 1 with an intercept, else 0.
    pub adj_r2: f64,
    /// Model degrees of freedom, `p - k`.
    pub df_model: usize,
    /// F statistic of the model against the intercept alone (or against nothing).
    pub f: f64,
    /// Its p-value.
    pub f_p: f64,
    /// Gaussian log-likelihood at the estimate.
    pub log_likelihood: f64,
    /// Akaike information criterion, `-2 llf + 2 p`.
    pub aic: f64,
    /// Bayesian information criterion, `-2 llf + ln(n) p`.
    pub bic: f64,
    /// Ratio of the largest to the smallest singular value of the design matrix.
    pub condition_number: f64,
    /// Variance inflation factor of each term; `None` for the intercept.
    pub vif: Vec<Option<f64>>,
    /// Fitted values.
    pub fitted: Vec<f64>,
    /// Residuals.
    pub residuals: Vec<f64>,
    /// Per-observation influence measures.
    pub influence: Influence,
    /// Durbin-Watson statistic of the residuals in data order.
    pub durbin_watson: f64,
    /// `A` with `(X'X)^-1 = A A'` (upper triangular), for prediction variances.
    factor: DMatrix<f64>,
}

/// A prediction at one point of the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The fitted value.
    pub value: f64,
    /// Variance of the fitted value (the calibration's own error there): `x' C x`.
    pub variance: f64,
    /// Variance of a new observation there: `sigma2 + x' C x`.
    pub observation_variance: f64,
}

impl Fit {
    /// The prediction at a model row `x` (as built by the formula: intercept first).
    ///
    /// # Panics
    /// When `x` does not have `p` entries.
    #[must_use]
    pub fn predict(&self, x: &[f64]) -> Prediction {
        assert_eq!(x.len(), self.p, "a model row has one entry per term");
        let value = x.iter().zip(&self.coefficients).map(|(a, b)| a * b).sum();
        // A' x, then its squared length.
        let mut q = 0.0;
        for j in 0..self.factor.ncols() {
            let s: f64 = (0..self.p).map(|i| self.factor[(i, j)] * x[i]).sum();
            q += s * s;
        }
        let variance = self.sigma2 * q;
        Prediction {
            value,
            variance,
            observation_variance: self.sigma2 + variance,
        }
    }

    /// `(X'X)^-1`: the covariance of the coefficients per unit residual variance.
    #[must_use]
    pub fn unscaled_covariance(&self) -> DMatrix<f64> {
        &self.factor * self.factor.transpose()
    }

    /// The same fit with the coefficients' covariance `sigma2 unscaled` (a sandwich estimate,
    /// say) and the residual variance `sigma2`, with the standard errors, tests and intervals
    /// that follow; `None` when `unscaled` is not positive definite.
    #[must_use]
    pub fn with_covariance(&self, sigma2: f64, unscaled: &DMatrix<f64>) -> Option<Fit> {
        let factor = unscaled.clone().cholesky()?.l();
        let covariance = unscaled * sigma2;
        let std_errors: Vec<f64> = (0..self.p).map(|j| covariance[(j, j)].sqrt()).collect();
        let i = inference(&self.coefficients, &std_errors, self.alpha, self.dof);
        Some(Fit {
            t: i.t,
            p_values: i.p_values,
            ci_lower: i.ci_lower,
            ci_upper: i.ci_upper,
            std_errors,
            covariance,
            sigma2,
            factor,
            ..self.clone()
        })
    }

    /// The fit of linear combinations of the coefficients, `c = J b` (one row of `j` per new
    /// coefficient, named by `names`), with their covariance `J C J'`, standard errors, t
    /// statistics, p-values and intervals on this fit's degrees of freedom. The residuals,
    /// the goodness of fit and the influence measures stay this fit's (DFBETAS carried over to
    /// the new coefficients); a thermal model evaluated at one temperature is such a fit.
    ///
    /// # Panics
    /// When `j` does not have one column per coefficient and one row per name.
    #[must_use]
    pub fn combined(&self, names: Vec<String>, j: &DMatrix<f64>) -> Fit {
        assert_eq!(j.ncols(), self.p, "one column per coefficient");
        assert_eq!(j.nrows(), names.len(), "one row per new coefficient");
        let p = names.len();
        let beta = DVector::from_column_slice(&self.coefficients);
        let coefficients: Vec<f64> = (j * beta).iter().copied().collect();
        let factor = j * &self.factor;
        let covariance = &factor * factor.transpose() * self.sigma2;
        let std_errors: Vec<f64> = (0..p).map(|k| covariance[(k, k)].sqrt()).collect();
        let i = inference(&coefficients, &std_errors, self.alpha, self.dof);
        // DFBETAS_ij = (b_j - b_j(i)) / (s_(i) sqrt(C_jj)): the changes map through J, the
        // scale s_(i) is common to all coefficients.
        let mut influence = self.influence.clone();
        let old = &self.influence.dfbetas;
        influence.dfbetas = DMatrix::from_fn(old.nrows(), p, |i, k| {
            (0..self.p)
                .map(|m| old[(i, m)] * self.std_errors[m] * j[(k, m)])
                .sum::<f64>()
                / std_errors[k]
        });
        Fit {
            names,
            p,
            coefficients,
            std_errors,
            t: i.t,
            p_values: i.p_values,
            ci_lower: i.ci_lower,
            ci_upper: i.ci_upper,
            covariance,
            vif: vec![None; p],
            influence,
            factor,
            ..self.clone()
        }
    }
}

impl Fit {
    /// Other coefficients on this fit's observations: `names` with `coefficients` and their
    /// `covariance` composed elsewhere (a two-stage calibration: stage one's terms carried in,
    /// stage two's fitted), the residual variance `sigma2` in their units. The residuals and
    /// the goodness of fit stay this fit's; DFBETAS are not carried (zero); the variance
    /// inflation factors are unknown. `None` when the covariance is not positive definite.
    #[must_use]
    pub fn recomposed(
        &self,
        names: Vec<String>,
        coefficients: Vec<f64>,
        covariance: &DMatrix<f64>,
        sigma2: f64,
    ) -> Option<Fit> {
        let p = names.len();
        if coefficients.len() != p || covariance.nrows() != p || covariance.ncols() != p {
            return None;
        }
        let mut influence = self.influence.clone();
        influence.dfbetas = DMatrix::zeros(self.n, p);
        let base = Fit {
            names,
            p,
            coefficients,
            vif: vec![None; p],
            influence,
            ..self.clone()
        };
        base.with_covariance(sigma2, &(covariance / sigma2))
    }
}

/// The t statistics, two-sided p-values and `1 - alpha` intervals of coefficients with their
/// standard errors, on `dof` degrees of freedom.
struct Inference {
    t: Vec<f64>,
    p_values: Vec<f64>,
    ci_lower: Vec<f64>,
    ci_upper: Vec<f64>,
}

fn inference(coefficients: &[f64], std_errors: &[f64], alpha: f64, dof: usize) -> Inference {
    let t: Vec<f64> = coefficients
        .iter()
        .zip(std_errors)
        .map(|(b, s)| b / s)
        .collect();
    let crit = dist::t_upper_quantile(alpha / 2.0, dof as f64);
    let interval = |sign: f64| -> Vec<f64> {
        coefficients
            .iter()
            .zip(std_errors)
            .map(|(b, s)| b + sign * crit * s)
            .collect()
    };
    Inference {
        p_values: t
            .iter()
            .map(|&t| dist::t_two_sided(t, dof as f64))
            .collect(),
        ci_lower: interval(-1.0),
        ci_upper: interval(1.0),
        t,
    }
}

/// The observation holding the largest absolute value of the response or any column.
fn largest_row(x: &DMatrix<f64>, y: &[f64]) -> usize {
    let magnitude = |i: usize| {
        x.row(i)
            .iter()
            .chain(std::iter::once(&y[i]))
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    (0..y.len())
        .max_by(|&a, &b| magnitude(a).total_cmp(&magnitude(b)))
        .unwrap_or(0)
}

/// Fits `y = X b + e` by least squares: checks the data, factors `X`, solves for the
/// coefficients, then diagnoses the fit.
///
/// # Errors
/// [`FitError`] when there are not more observations than columns, a column is (numerically)
/// a combination of the columns before it, or the data are not finite.
pub fn fit(
    x: &DMatrix<f64>,
    y: &[f64],
    names: Vec<String>,
    intercept: bool,
    opts: &Options,
) -> Result<Fit, FitError> {
    check(x, y, &names)?;
    let factored = factor(x, opts)?;
    let solved = solve(&factored, x, y)?;
    let (n, p) = x.shape();
    let dof = n - p;
    let Inference {
        t,
        p_values,
        ci_lower,
        ci_upper,
    } = inference(&solved.coefficients, &solved.std_errors, opts.alpha, dof);
    let goodness = goodness(y, &solved, p, intercept);
    let condition_number = condition_number(&factored, x, y)?;
    let vif = variance_inflation(x, &solved.unscaled, intercept);
    let influence = influence::compute(
        &factored.q,
        &factored.factor,
        &solved.residuals,
        solved.rss,
        dof,
        p,
        opts.alpha,
    );
    let durbin_watson = solved
        .residuals
        .windows(2)
        .map(|w| (w[1] - w[0]).powi(2))
        .sum::<f64>()
        / solved.rss;
    Ok(Fit {
        names,
        intercept,
        n,
        p,
        dof,
        alpha: opts.alpha,
        coefficients: solved.coefficients,
        std_errors: solved.std_errors,
        t,
        p_values,
        ci_lower,
        ci_upper,
        covariance: solved.covariance,
        rss: solved.rss,
        sigma2: solved.sigma2,
        tss: goodness.tss,
        r2: goodness.r2,
        adj_r2: goodness.adj_r2,
        df_model: goodness.df_model,
        f: goodness.f,
        f_p: goodness.f_p,
        log_likelihood: goodness.log_likelihood,
        aic: goodness.aic,
        bic: goodness.bic,
        condition_number,
        vif,
        fitted: solved.fitted,
        residuals: solved.residuals,
        influence,
        durbin_watson,
        factor: factored.factor,
    })
}

/// Refuses data a fit cannot take: no more observations than columns, or a value that is not
/// finite (named by its row and column).
fn check(x: &DMatrix<f64>, y: &[f64], names: &[String]) -> Result<(), FitError> {
    let (n, p) = x.shape();
    assert_eq!(y.len(), n, "one response per row");
    assert_eq!(names.len(), p, "one name per column");
    if n <= p {
        return Err(FitError::TooFewObservations { n, p });
    }
    if let Some(row) = y.iter().position(|v| !v.is_finite()) {
        return Err(FitError::NotFinite { row, column: None });
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        // Column-major: element i is row i % n of column i / n.
        return Err(FitError::NotFinite {
            row: i % n,
            column: Some(i / n),
        });
    }
    Ok(())
}

/// `X` factored: its columns scaled to unit length, `X D^-1 = Q R`.
struct Factored {
    /// The column lengths `D`.
    norms: Vec<f64>,
    /// `Q` (n x p).
    q: DMatrix<f64>,
    /// `R` (p x p, upper triangular).
    r: DMatrix<f64>,
    /// `A = D^-1 R^-1`: the coefficients are `A Q'y`, their unscaled covariance `A A'`.
    factor: DMatrix<f64>,
}

/// Factors `X`, refusing a column that is (numerically) a combination of those before it.
fn factor(x: &DMatrix<f64>, opts: &Options) -> Result<Factored, FitError> {
    let p = x.ncols();
    // Scale the columns to unit length: the factorisation then sees the geometry, not units.
    let norms: Vec<f64> = x.column_iter().map(|c| c.norm()).collect();
    if let Some(j) = norms.iter().position(|&d| d == 0.0) {
        return Err(FitError::RankDeficient {
            column: j,
            combination: Vec::new(),
        });
    }
    let mut xs = x.clone();
    for (j, mut c) in xs.column_iter_mut().enumerate() {
        c /= norms[j];
    }
    let qr = xs.qr();
    let r = qr.r();
    for j in 0..p {
        if r[(j, j)].abs() < opts.rank_tolerance {
            return Err(rank_deficient(&r, &norms, j));
        }
    }
    let q = qr.q();
    // R^-1 (upper triangular), then A = D^-1 R^-1.
    let r_inv = r
        .clone()
        .solve_upper_triangular(&DMatrix::identity(p, p))
        .ok_or_else(|| rank_deficient(&r, &norms, p - 1))?;
    let mut factor = r_inv;
    for (i, mut row) in factor.row_iter_mut().enumerate() {
        row /= norms[i];
    }
    Ok(Factored {
        norms,
        q,
        r,
        factor,
    })
}

/// The least-squares solution and what follows from it alone.
struct Solved {
    coefficients: Vec<f64>,
    std_errors: Vec<f64>,
    covariance: DMatrix<f64>,
    /// `(X'X)^-1 = A A'`.
    unscaled: DMatrix<f64>,
    fitted: Vec<f64>,
    residuals: Vec<f64>,
    rss: f64,
    sigma2: f64,
}

/// Solves for the coefficients, `b = A Q'y`, and their covariance `sigma^2 A A'`.
fn solve(f: &Factored, x: &DMatrix<f64>, y: &[f64]) -> Result<Solved, FitError> {
    let (n, p) = x.shape();
    let qty = f.q.tr_mul(&DVector::from_column_slice(y));
    let beta = &f.factor * &qty;
    let coefficients: Vec<f64> = beta.iter().copied().collect();
    let fitted_v = x * &beta;
    let fitted: Vec<f64> = fitted_v.iter().copied().collect();
    let residuals: Vec<f64> = y.iter().zip(&fitted).map(|(a, b)| a - b).collect();
    let rss: f64 = residuals.iter().map(|e| e * e).sum();
    let sigma2 = rss / (n - p) as f64;
    let unscaled = &f.factor * f.factor.transpose();
    let covariance = &unscaled * sigma2;
    let std_errors: Vec<f64> = (0..p).map(|j| covariance[(j, j)].sqrt()).collect();
    if !sigma2.is_finite()
        || coefficients
            .iter()
            .chain(&std_errors)
            .any(|v| !v.is_finite())
    {
        return Err(FitError::Overflow {
            row: largest_row(x, y),
        });
    }
    Ok(Solved {
        coefficients,
        std_errors,
        covariance,
        unscaled,
        fitted,
        residuals,
        rss,
        sigma2,
    })
}

/// How well the model explains the data, as a regression package reports it.
struct Goodness {
    tss: f64,
    r2: f64,
    adj_r2: f64,
    df_model: usize,
    f: f64,
    f_p: f64,
    log_likelihood: f64,
    aic: f64,
    bic: f64,
}

/// R^2 (about the mean with an intercept, about zero without), the overall F-test, the Gaussian
/// log-likelihood and the information criteria.
fn goodness(y: &[f64], s: &Solved, p: usize, intercept: bool) -> Goodness {
    let n = y.len();
    let (rss, dof) = (s.rss, n - p);
    let k = usize::from(intercept);
    let tss = if intercept {
        let mean = y.iter().sum::<f64>() / n as f64;
        y.iter().map(|v| (v - mean) * (v - mean)).sum()
    } else {
        y.iter().map(|v| v * v).sum()
    };
    let r2 = 1.0 - rss / tss;
    let adj_r2 = 1.0 - (n - k) as f64 / dof as f64 * (1.0 - r2);
    let df_model = p - k;
    let (f, f_p) = if df_model == 0 {
        (f64::NAN, f64::NAN)
    } else {
        let f = (tss - rss) / df_model as f64 / s.sigma2;
        (f, dist::f_upper(f, df_model as f64, dof as f64))
    };
    let nf = n as f64;
    let log_likelihood = -nf / 2.0 * ((2.0 * std::f64::consts::PI).ln() + (rss / nf).ln() + 1.0);
    Goodness {
        tss,
        r2,
        adj_r2,
        df_model,
        f,
        f_p,
        log_likelihood,
        aic: -2.0 * log_likelihood + 2.0 * p as f64,
        bic: -2.0 * log_likelihood + nf.ln() * p as f64,
    }
}

#[cfg(test)]
mod tests;
