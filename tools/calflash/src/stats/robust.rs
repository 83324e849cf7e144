//! Robust location and scatter of a sample of points (a production lot's coefficients, one row
//! per unit): the orthogonalised Gnanadesikan-Kettenring estimate (Maronna and Zamar, 2002)
//! with one reweighting step, and the Mahalanobis distances from it. Deterministic, O(n p^2),
//! and it breaks down only when nearly half the points are outliers. Below [`min_points`]
//! points the scatter of `p` coefficients is not estimated: [`column_limits`] judges each
//! coefficient on its own (median and MAD) instead.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, SymmetricEigen};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The MAD of a normal sample is this times its standard deviation.
const MAD_NORMAL: f64 = 0.674_489_750_196_081_7;
/// Points whose squared distance is beyond this quantile of chi-square get no weight in the
/// reweighting step.
const REWEIGHT_QUANTILE: f64 = 0.975;

/// Why a robust scatter cannot be had.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RobustError {
    /// Too few points for `p` coefficients.
    #[error(
        "{n} units are too few for a robust covariance of {p} coefficients: it needs at least {needs}"
    )]
    TooFew {
        /// Points.
        n: usize,
        /// Coefficients.
        p: usize,
        /// Points needed.
        needs: usize,
    },
    /// A coefficient whose robust scale is zero (more than half the points share one value),
    /// or coefficients that are linear combinations of the others.
    #[error(
        "coefficient {column} has no spread across the lot (more than half the units share one value), or depends on the others"
    )]
    Degenerate {
        /// The column.
        column: usize,
    },
}

/// The fewest points for a robust scatter of `p` coefficients: five per coefficient (the usual
/// rule for high-breakdown estimators), and at least 10.
#[must_use]
pub const fn min_points(p: usize) -> usize {
    let n = 5 * p;
    if n < 10 { 10 } else { n }
}

/// The median of `v` (reordered).
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return hi;
    }
    let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    0.5 * (lo + hi)
}

/// Median and MAD (scaled to a normal's standard deviation) of `values`.
#[must_use]
pub fn median_mad(values: &[f64]) -> (f64, f64) {
    let mut v = values.to_vec();
    let m = median(&mut v);
    for x in &mut v {
        *x = (*x - m).abs();
    }
    (m, median(&mut v) / MAD_NORMAL)
}

fn mad(values: impl Iterator<Item = f64>, buf: &mut Vec<f64>) -> f64 {
    buf.clear();
    buf.extend(values);
    let m = median(buf);
    for x in buf.iter_mut() {
        *x = (*x - m).abs();
    }
    median(buf) / MAD_NORMAL
}

/// A robust centre and scatter, and what it takes to measure distances from them.
#[derive(Debug, Clone)]
pub struct Robust {
    /// The centre.
    pub centre: DVector<f64>,
    /// The scatter (covariance), consistent at the normal.
    pub scatter: DMatrix<f64>,
    /// Points that kept their weight in the reweighting step.
    pub kept: usize,
    chol: Cholesky<f64, Dyn>,
}

impl Robust {
    /// The squared Mahalanobis distance of `x` from the centre.
    #[must_use]
    pub fn distance2(&self, x: &DVector<f64>) -> f64 {
        let d = x - &self.centre;
        let z = self.chol.l().solve_lower_triangular(&d).unwrap_or(d);
        z.norm_squared()
    }

    /// The squared-distance limit that a point of the lot's distribution passes with
    /// probability `1 - alpha` (chi-square with `p` degrees of freedom).
    #[must_use]
    pub fn limit(&self, alpha: f64) -> f64 {
        super::dist::chi2_upper_quantile(alpha, self.centre.len() as f64)
    }
}

fn chi2_quantile(p: usize, q: f64) -> f64 {
    ChiSquared::new(p as f64).map_or(f64::NAN, |c| c.inverse_cdf(q))
}

/// The robust centre and scatter of the rows of `x` (n points, p coefficients).
///
/// # Errors
/// [`RobustError::TooFew`] below [`min_points`]; [`RobustError::Degenerate`] for a coefficient
/// without spread or coefficients that depend on each other.
pub fn estimate(x: &DMatrix<f64>) -> Result<Robust, RobustError> {
    let (n, p) = x.shape();
    if n < min_points(p) {
        return Err(RobustError::TooFew {
            n,
            p,
            needs: min_points(p),
        });
    }
    let mut buf = Vec::with_capacity(n);
    // 1. Each coefficient on its own robust scale.
    let scales: Vec<f64> = (0..p)
        .map(|j| mad(x.column(j).iter().copied(), &mut buf))
        .collect();
    if let Some(column) = scales.iter().position(|s| !(*s > 0.0 && s.is_finite())) {
        return Err(RobustError::Degenerate { column });
    }
    let y = DMatrix::from_fn(n, p, |i, j| x[(i, j)] / scales[j]);
    // 2. Pairwise robust covariances (Gnanadesikan-Kettenring), 3. made positive definite by
    // the eigenvectors (orthogonalisation).
    let mut u = DMatrix::<f64>::identity(p, p);
    for j in 0..p {
        for k in 0..j {
            let plus = mad((0..n).map(|i| y[(i, j)] + y[(i, k)]), &mut buf);
            let minus = mad((0..n).map(|i| y[(i, j)] - y[(i, k)]), &mut buf);
            let c = 0.25 * (plus * plus - minus * minus);
            u[(j, k)] = c;
            u[(k, j)] = c;
        }
    }
    let e = SymmetricEigen::new(u).eigenvectors;
    let z = &y * &e;
    // 4. Robust location and scale along each orthogonal direction.
    let mut loc = DVector::zeros(p);
    let mut var = DVector::zeros(p);
    for l in 0..p {
        let col: Vec<f64> = z.column(l).iter().copied().collect();
        let (m, s) = median_mad(&col);
        if !(s > 0.0 && s.is_finite()) {
            return Err(RobustError::Degenerate { column: l });
        }
        loc[l] = m;
        var[l] = s * s;
    }
    // Squared distances in those coordinates, then made consistent at the normal (their
    // median is chi-square's).
    let d2: Vec<f64> = (0..n)
        .map(|i| (0..p).map(|l| (z[(i, l)] - loc[l]).powi(2) / var[l]).sum())
        .collect();
    let factor = median(&mut d2.clone()) / chi2_quantile(p, 0.5);
    // 5. Reweighting: the mean and covariance of the points within the 97.5 % quantile.
    let cut = chi2_quantile(p, REWEIGHT_QUANTILE) * factor;
    let kept: Vec<usize> = (0..n).filter(|&i| d2[i] <= cut).collect();
    if kept.len() <= p {
        return Err(RobustError::Degenerate { column: 0 });
    }
    let mut centre = DVector::zeros(p);
    for &i in &kept {
        centre += x.row(i).transpose();
    }
    centre /= kept.len() as f64;
    let mut scatter = DMatrix::zeros(p, p);
    for &i in &kept {
        let d = x.row(i).transpose() - &centre;
        scatter += &d * d.transpose();
    }
    scatter /= (kept.len() - 1) as f64;
    let chol = Cholesky::new(scatter.clone()).ok_or(RobustError::Degenerate { column: 0 })?;
    let mut r = Robust {
        centre,
        scatter,
        kept: kept.len(),
        chol,
    };
    // Consistency of the reweighted scatter: the median distance is chi-square's.
    let mut d2: Vec<f64> = (0..n).map(|i| r.distance2(&x.row(i).transpose())).collect();
    let factor = median(&mut d2) / chi2_quantile(p, 0.5);
    if factor.is_finite() && factor > 0.0 {
        r.scatter *= factor;
        r.chol = Cholesky::new(r.scatter.clone()).ok_or(RobustError::Degenerate { column: 0 })?;
    }
    Ok(r)
}

/// Per-coefficient limits, for lots too small for a scatter: each coefficient's median and
/// MAD, and the robust z-score beyond which a unit is outside at the family-wise level
/// `alpha` over the `p` coefficients (Bonferroni), for a lot of `n` units.
#[derive(Debug, Clone)]
pub struct ColumnLimits {
    /// Medians.
    pub median: Vec<f64>,
    /// MADs scaled to standard deviations.
    pub scale: Vec<f64>,
    /// The |z| limit.
    pub z: f64,
}

/// [`ColumnLimits`] of the rows of `x` (n points) at the family-wise level `alpha`. The limit
/// is that of a prediction interval for one more point: Student's t with n - 1 degrees of
/// freedom, widened by sqrt(1 + 1/n), so that a handful of points, whose scale is uncertain,
/// do not call every new point outside.
#[must_use]
pub fn column_limits(x: &DMatrix<f64>, alpha: f64) -> ColumnLimits {
    let (n, p) = x.shape();
    let (median, scale) = (0..p)
        .map(|j| median_mad(&x.column(j).iter().copied().collect::<Vec<_>>()))
        .unzip();
    let upper = alpha / (2.0 * p.max(1) as f64);
    let z = if n >= 2 {
        super::dist::t_upper_quantile(upper, (n - 1) as f64) * (1.0 + 1.0 / n as f64).sqrt()
    } else {
        f64::INFINITY
    };
    ColumnLimits { median, scale, z }
}

impl ColumnLimits {
    /// The robust z-scores of `x` (0 where a coefficient has no spread and `x` sits on its
    /// median, infinite where it does not).
    #[must_use]
    pub fn scores(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.median.iter().zip(&self.scale))
            .map(|(v, (m, s))| {
                let d = v - m;
                if *s > 0.0 {
                    d / s
                } else if d == 0.0 {
                    0.0
                } else {
                    d.signum() * f64::INFINITY
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Correlated normal points (the second coefficient 0.8-correlated with the first, the
    /// third independent), on different scales.
    fn lot(n: usize, seed: u64) -> DMatrix<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let mut m = DMatrix::zeros(n, 3);
        for i in 0..n {
            let (a, b, c) = (g(), g(), g());
            m[(i, 0)] = 10.0 + 2.0 * a;
            m[(i, 1)] = -3.0 + 0.5 * (0.8 * a + 0.6 * b);
            m[(i, 2)] = 100.0 + 0.01 * c;
        }
        m
    }

    #[test]
    fn the_centre_and_scatter_of_a_clean_lot_match_the_classical_ones() {
        let x = lot(4000, 1);
        let r = estimate(&x).unwrap();
        assert!((r.centre[0] - 10.0).abs() < 0.1, "{}", r.centre);
        assert!((r.scatter[(0, 0)] - 4.0).abs() < 0.3, "{}", r.scatter);
        assert!((r.scatter[(0, 1)] - 0.8).abs() < 0.1, "{}", r.scatter);
        assert!((r.scatter[(2, 2)] - 1e-4).abs() < 1e-5, "{}", r.scatter);
        // About alpha of a clean lot is beyond the limit.
        let limit = r.limit(0.01);
        let out = (0..x.nrows())
            .filter(|&i| r.distance2(&x.row(i).transpose()) > limit)
            .count();
        assert!(
            (20..=65).contains(&out),
            "{out} of 4000 beyond the 1 % limit"
        );
    }

    #[test]
    fn a_tenth_of_the_lot_off_its_correlation_does_not_move_the_centre_and_is_named() {
        let mut x = lot(1000, 2);
        // 100 units that break the correlation of the first two coefficients, each within
        // its own coefficient's spread: per-coefficient limits cannot see them.
        for i in 0..100 {
            x[(i, 0)] = 10.0 + 3.0;
            x[(i, 1)] = -3.0 - 0.8;
        }
        let r = estimate(&x).unwrap();
        assert!((r.centre[0] - 10.0).abs() < 0.3, "{}", r.centre);
        let limit = r.limit(0.001);
        let flagged = (0..100)
            .filter(|&i| r.distance2(&x.row(i).transpose()) > limit)
            .count();
        assert_eq!(flagged, 100);
        let cols = column_limits(&x, 0.001);
        let by_column = (0..100)
            .filter(|&i| {
                let row: Vec<f64> = x.row(i).iter().copied().collect();
                cols.scores(&row).iter().any(|z| z.abs() > cols.z)
            })
            .count();
        assert_eq!(by_column, 0, "each coefficient alone looks normal");
    }

    #[test]
    fn too_few_units_and_degenerate_coefficients_are_named() {
        let x = lot(14, 3);
        assert_eq!(
            estimate(&x).unwrap_err(),
            RobustError::TooFew {
                n: 14,
                p: 3,
                needs: 15
            }
        );
        let mut x = lot(100, 3);
        for i in 0..100 {
            x[(i, 1)] = 5.0;
        }
        assert_eq!(
            estimate(&x).unwrap_err(),
            RobustError::Degenerate { column: 1 }
        );
        assert_eq!(median(&mut [3.0, 1.0, 2.0, 10.0]), 2.5);
        let (m, s) = median_mad(&[1.0, 2.0, 3.0, 4.0, 100.0]);
        assert_eq!(m, 3.0);
        assert!((s - 1.0 / MAD_NORMAL).abs() < 1e-12);
    }
}
