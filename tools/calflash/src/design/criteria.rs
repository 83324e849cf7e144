//! What a plan's design matrix alone says about a fit before any data exists: the form of the
//! parameter covariance `(X'X)^-1` (times the noise variance), and the optimality criteria.
//!
//! With `M = X'X / n` (the information per observation) and `d(x) = n x' (X'X)^-1 x` the
//! standardized prediction variance:
//!
//! - D: `det(M)^(1/p)` (larger is better; D-efficiency of plan 1 against plan 2 is the ratio),
//! - A: `trace(M^-1) / p` (smaller is better),
//! - E: the smallest eigenvalue of `M` (larger is better),
//! - G: the largest `d(x)` over the operating region (at least `p`; G-efficiency `p / G`),
//! - I: the mean `d(x)` over the operating region (smaller is better).
//!
//! Everything comes from the SVD of `X` (never from inverting `X'X`).

use nalgebra::DMatrix;

/// A plan's criteria.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Criteria {
    /// Observations.
    pub n: usize,
    /// Parameters.
    pub p: usize,
    /// `det(M)^(1/p)`.
    pub d: f64,
    /// `trace(M^-1) / p`.
    pub a: f64,
    /// Smallest eigenvalue of `M`.
    pub e: f64,
    /// Largest standardized prediction variance over the region.
    pub g: f64,
    /// Mean standardized prediction variance over the region.
    pub i: f64,
    /// Condition number of `X` with its columns scaled to unit length.
    pub condition_number: f64,
    /// Variance inflation factor per column (`None` for the intercept).
    pub vif: Vec<Option<f64>>,
    /// `(X'X)^-1`: times the noise variance, the parameters' covariance.
    #[serde(skip)]
    pub unscaled_covariance: DMatrix<f64>,
}

/// The columns the plan cannot estimate: the first dependent column and its approximation by
/// the earlier ones.
#[derive(Debug, Clone, PartialEq)]
pub struct Dependent {
    /// The column.
    pub column: usize,
    /// `(earlier column, coefficient)` pairs that reproduce it.
    pub combination: Vec<(usize, f64)>,
}

/// The first column of `x` that the earlier ones reproduce (to a relative 1e-9), if any.
#[must_use]
pub fn first_dependent(x: &DMatrix<f64>) -> Option<Dependent> {
    let p = x.ncols();
    for j in 0..p {
        let col = x.column(j).into_owned();
        let norm = col.norm();
        if norm == 0.0 {
            return Some(Dependent {
                column: j,
                combination: Vec::new(),
            });
        }
        if j == 0 {
            continue;
        }
        let earlier = x.columns(0, j).into_owned();
        let Ok(svd) = crate::stats::decompose::svd(earlier.clone(), true, true) else {
            continue;
        };
        let Ok(coef) = svd.solve(&col, 1e-12 * svd.singular_values.max()) else {
            continue;
        };
        let resid = (&earlier * &coef - &col).norm();
        if resid <= 1e-9 * norm {
            let combination = coef
                .iter()
                .enumerate()
                .filter(|(_, c)| c.abs() > 1e-12)
                .map(|(k, c)| (k, *c))
                .collect();
            return Some(Dependent {
                column: j,
                combination,
            });
        }
    }
    None
}

/// Standardized prediction variances `n x'(X'X)^-1 x` of the rows of `region`.
#[must_use]
pub fn prediction_variance(unscaled: &DMatrix<f64>, n: usize, region: &DMatrix<f64>) -> Vec<f64> {
    (0..region.nrows())
        .map(|r| {
            let x = region.row(r).transpose();
            n as f64 * (x.transpose() * unscaled * &x)[(0, 0)]
        })
        .collect()
}

/// The criteria of design matrix `x` (rows: observations), with `region` the model rows of the
/// operating region (for G and I). `intercept` marks column 0 as the intercept (no VIF).
///
/// # Errors
/// The first column the plan cannot estimate.
pub fn evaluate(
    x: &DMatrix<f64>,
    region: &DMatrix<f64>,
    intercept: bool,
) -> Result<Criteria, Dependent> {
    let (n, p) = x.shape();
    if let Some(dep) = first_dependent(x) {
        return Err(dep);
    }
    // A plan's points are finite (plan items and files are checked): a failure here names the
    // first column that is not.
    let not_finite = || Dependent {
        column: (0..p)
            .find(|j| x.column(*j).iter().any(|v| !v.is_finite()))
            .unwrap_or(0),
        combination: Vec::new(),
    };
    let svd = crate::stats::decompose::svd(x.clone(), false, true).map_err(|_| not_finite())?;
    let v_t = svd.v_t.as_ref().ok_or_else(not_finite)?;
    let s = &svd.singular_values;
    let mut unscaled = DMatrix::zeros(p, p);
    for k in 0..p {
        let row = v_t.row(k);
        unscaled += (1.0 / (s[k] * s[k])) * row.transpose() * row;
    }
    let nf = n as f64;
    let log_det: f64 = s.iter().map(|v| 2.0 * v.ln()).sum::<f64>() - p as f64 * nf.ln();
    let d = (log_det / p as f64).exp();
    let a = nf * unscaled.trace() / p as f64;
    let e = s.min().powi(2) / nf;
    let pv = prediction_variance(&unscaled, n, region);
    let g = pv.iter().fold(0.0f64, |m, v| m.max(*v));
    let i = pv.iter().sum::<f64>() / pv.len().max(1) as f64;
    let mut scaled = x.clone();
    for mut c in scaled.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    let sv = crate::stats::decompose::singular_values(scaled).map_err(|_| not_finite())?;
    let condition_number = sv.max() / sv.min();
    let vif = (0..p)
        .map(|j| {
            if intercept && j == 0 {
                return None;
            }
            let col = x.column(j);
            let ss = if intercept {
                let mean = col.mean();
                col.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
            } else {
                col.iter().map(|v| v * v).sum()
            };
            Some(unscaled[(j, j)] * ss)
        })
        .collect();
    Ok(Criteria {
        n,
        p,
        d,
        a,
        e,
        g,
        i,
        condition_number,
        vif,
        unscaled_covariance: unscaled,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly(xs: &[f64], degree: usize) -> DMatrix<f64> {
        DMatrix::from_fn(xs.len(), degree + 1, |i, j| xs[i].powi(j as i32))
    }

    #[test]
    fn a_straight_line_at_the_ends_has_the_textbook_values() {
        // Half the points at each end of [-1, 1]: M = I, so D = A = E = 1 and d(x) = 1 + x^2.
        let x = poly(&[-1.0, 1.0, -1.0, 1.0], 1);
        let region = poly(
            &(0..=20)
                .map(|k| -1.0 + 0.1 * f64::from(k))
                .collect::<Vec<_>>(),
            1,
        );
        let c = evaluate(&x, &region, true).unwrap();
        for (v, w) in [
            (c.d, 1.0),
            (c.a, 1.0),
            (c.e, 1.0),
            (c.g, 2.0),
            (c.condition_number, 1.0),
        ] {
            assert!((v - w).abs() < 1e-12, "{c:?}");
        }
        // The mean of 1 + x^2 over the 21 grid points.
        let want = 1.0
            + (0..=20)
                .map(|k| (-1.0 + 0.1 * f64::from(k)).powi(2))
                .sum::<f64>()
                / 21.0;
        assert!((c.i - want).abs() < 1e-12);
        assert!((c.vif[1].unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_quadratic_on_two_levels_names_its_dependent_column() {
        let x = poly(&[-1.0, 1.0, -1.0, 1.0], 2);
        let dep = evaluate(&x, &x, true).unwrap_err();
        assert_eq!(dep.column, 2);
        assert_eq!(dep.combination.len(), 1);
        assert_eq!(dep.combination[0].0, 0);
        assert!((dep.combination[0].1 - 1.0).abs() < 1e-12);
    }
}
