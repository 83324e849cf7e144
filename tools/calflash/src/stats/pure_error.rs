//! The noise of a fit's observations estimated without its model's form, so that a fit can be
//! held against it (the lack-of-fit test): the spread of replicates (rows whose regressors are
//! identical: pure error), or the residuals of a subset of the rows fitted alone with whatever
//! of the model those rows determine (a rank-revealing least squares). A model that misses a
//! term the other rows need leaves the subset's noise as it is and raises the whole fit's.

use nalgebra::{DMatrix, DVector};

/// The fewest degrees of freedom an estimate of the noise is taken from: below it the variance
/// ratio's test has no power.
pub const MIN_DOF: usize = 5;

/// A singular value below this fraction of the largest (columns scaled to unit length) is
/// taken as zero: that direction is not determined by the rows.
const RANK_TOLERANCE: f64 = 1e-9;

/// An estimate of the noise variance and its degrees of freedom.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// The variance, in the response's units squared.
    pub variance: f64,
    /// Its degrees of freedom.
    pub dof: usize,
}

/// The pure error of `x`'s replicated rows (rows equal in every regressor): the pooled spread
/// of `y` within each group of equal rows. `None` with fewer than [`MIN_DOF`] degrees of
/// freedom.
#[must_use]
pub fn replicates(x: &DMatrix<f64>, y: &[f64]) -> Option<Noise> {
    let mut order: Vec<usize> = (0..x.nrows()).collect();
    let row = |r: usize| x.row(r).iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let keys: Vec<Vec<u64>> = order.iter().map(|&r| row(r)).collect();
    order.sort_by(|a, b| keys[*a].cmp(&keys[*b]));
    let (mut ss, mut dof) = (0.0, 0usize);
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && keys[order[end]] == keys[order[start]] {
            end += 1;
        }
        let group = &order[start..end];
        if group.len() > 1 {
            let mean = group.iter().map(|&r| y[r]).sum::<f64>() / group.len() as f64;
            ss += group.iter().map(|&r| (y[r] - mean).powi(2)).sum::<f64>();
            dof += group.len() - 1;
        }
        start = end;
    }
    (dof >= MIN_DOF).then(|| Noise {
        variance: ss / dof as f64,
        dof,
    })
}

/// The residual variance of `rows` of `(x, y)` fitted alone by least squares in the directions
/// those rows determine (an SVD of the columns scaled to unit length; a column that is zero on
/// them drops out). `None` with fewer than [`MIN_DOF`] degrees of freedom left, or when the
/// decomposition fails.
#[must_use]
pub fn subset(x: &DMatrix<f64>, y: &[f64], rows: &[usize]) -> Option<Noise> {
    let p = x.ncols();
    if rows.len() < MIN_DOF + 1 {
        return None;
    }
    let mut sub = DMatrix::from_fn(rows.len(), p, |r, c| x[(rows[r], c)]);
    for mut col in sub.column_iter_mut() {
        let norm = col.norm();
        if norm > 0.0 {
            col /= norm;
        }
    }
    let b = DVector::from_iterator(rows.len(), rows.iter().map(|&r| y[r]));
    let svd = super::decompose::svd(sub, true, false).ok()?;
    let top = svd.singular_values.max();
    if top.is_nan() || top <= 0.0 {
        return None;
    }
    let u = svd.u.as_ref()?;
    let kept: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > RANK_TOLERANCE * top)
        .collect();
    // The residual is what the kept left singular vectors do not span.
    let mut fitted = DVector::zeros(rows.len());
    for &k in &kept {
        let uk = u.column(k);
        fitted += uk * uk.dot(&b);
    }
    let rss = (b - fitted).norm_squared();
    let dof = rows.len().checked_sub(kept.len())?;
    (dof >= MIN_DOF).then(|| Noise {
        variance: rss / dof as f64,
        dof,
    })
}

/// A fit's residual variance held against an estimate of the noise made without its model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LackOfFit {
    /// The fit's residual standard deviation over the noise's.
    pub ratio: f64,
    /// The variance ratio.
    pub f: f64,
    /// `P(F >= f)` when the model fits.
    pub p_value: f64,
}

/// The variance-ratio test of a fit's residual variance `sigma2` (`dof` degrees of freedom)
/// against `noise`.
#[must_use]
pub fn test(sigma2: f64, dof: usize, noise: &Noise) -> LackOfFit {
    let f = sigma2 / noise.variance;
    LackOfFit {
        ratio: f.sqrt(),
        f,
        p_value: super::dist::f_upper(f, dof as f64, noise.dof as f64),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// Rows `1, x, x2`: the first `rest` with `x2 = 0` (the term a misfit leaves out).
    fn data(n: usize, rest: usize, curve: f64, seed: u64) -> (DMatrix<f64>, Vec<f64>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let e = Normal::new(0.0, 0.01).unwrap();
        let x = DMatrix::from_fn(n, 3, |r, c| {
            let v = (r % 7) as f64 - 3.0;
            match c {
                0 => 1.0,
                1 => v,
                _ if r < rest => 0.0,
                _ => (r % 5) as f64,
            }
        });
        let y = (0..n)
            .map(|r| 2.0 + 0.5 * x[(r, 1)] + curve * x[(r, 2)] + e.sample(&mut rng))
            .collect();
        (x, y)
    }

    #[test]
    fn the_noise_of_a_subset_and_of_replicates_is_the_noise() {
        let (x, y) = data(400, 200, 0.3, 1);
        let rest: Vec<usize> = (0..200).collect();
        let s = subset(&x, &y, &rest).unwrap();
        // Only `1, x` are determined on the first 200 rows: 198 degrees of freedom.
        assert_eq!(s.dof, 198);
        assert!((s.variance.sqrt() / 0.01 - 1.0).abs() < 0.15, "{s:?}");
        let r = replicates(&x, &y).unwrap();
        assert!((r.variance.sqrt() / 0.01 - 1.0).abs() < 0.15, "{r:?}");
        assert!(r.dof > 300, "{r:?}");
    }

    #[test]
    fn a_model_without_a_needed_term_fails_the_test_and_with_it_passes() {
        let (x, y) = data(400, 200, 0.3, 2);
        let rest: Vec<usize> = (0..200).collect();
        let noise = subset(&x, &y, &rest).unwrap();
        let fit = |cols: usize| {
            let opts = crate::stats::Options::default();
            let names = ["1", "x", "x2"][..cols]
                .iter()
                .map(|s| s.to_string())
                .collect();
            crate::stats::fit(&x.columns(0, cols).into_owned(), &y, names, true, &opts).unwrap()
        };
        let (whole, missing) = (fit(3), fit(2));
        let good = test(whole.sigma2, whole.dof, &noise);
        assert!(good.p_value > 0.01 && good.ratio < 1.2, "{good:?}");
        let bad = test(missing.sigma2, missing.dof, &noise);
        assert!(bad.p_value < 1e-12 && bad.ratio > 10.0, "{bad:?}");
    }

    #[test]
    fn too_few_rows_give_no_estimate() {
        let (x, y) = data(40, 6, 0.0, 3);
        assert!(subset(&x, &y, &[0, 1, 2, 3, 4, 5]).is_none());
        let distinct = DMatrix::from_fn(10, 2, |r, c| if c == 0 { 1.0 } else { r as f64 });
        assert!(replicates(&distinct, &[0.0; 10]).is_none());
    }
}
