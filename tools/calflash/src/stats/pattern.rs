//! Tests for pattern in residuals: the Wald-Wolfowitz runs test on their signs.
//!
//! Residuals of a right model, taken in order of an input, change sign at random; a curve left
//! in them (a missing `rate^2`, say) makes long runs of one sign.

use super::dist;

/// A runs test of residual signs in a given order.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RunsTest {
    /// Runs of one sign.
    pub runs: usize,
    /// Positive residuals.
    pub positive: usize,
    /// Negative residuals (zeros are left out).
    pub negative: usize,
    /// Expected runs for random signs.
    pub expected: f64,
    /// Normal statistic; negative means too few runs (a pattern).
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// The runs test of `residuals` taken in the order `order` (indices into `residuals`).
#[must_use]
pub fn runs_test(residuals: &[f64], order: &[usize]) -> RunsTest {
    let signs: Vec<bool> = order
        .iter()
        .map(|&i| residuals[i])
        .filter(|e| *e != 0.0)
        .map(|e| e > 0.0)
        .collect();
    let positive = signs.iter().filter(|s| **s).count();
    let negative = signs.len() - positive;
    let runs = if signs.is_empty() {
        0
    } else {
        1 + signs.windows(2).filter(|w| w[0] != w[1]).count()
    };
    let (np, nn) = (positive as f64, negative as f64);
    let n = np + nn;
    let expected = 2.0 * np * nn / n + 1.0;
    let var = (expected - 1.0) * (expected - 2.0) / (n - 1.0);
    let z = if var > 0.0 {
        (runs as f64 - expected) / var.sqrt()
    } else {
        f64::NAN
    };
    RunsTest {
        runs,
        positive,
        negative,
        expected,
        z,
        p: if z.is_nan() {
            f64::NAN
        } else {
            dist::normal_two_sided(z)
        },
    }
}

/// Indices that sort `values` ascending (stable, so ties keep data order).
#[must_use]
pub fn order_by(values: &[f64]) -> Vec<usize> {
    // Each value as an integer key in `f64::total_cmp`'s order, sorted with its index: ties
    // broken by index give the order of a stable sort, and sorting the pairs themselves reads
    // memory in order (an index sort that looks each value up jumps about the array).
    let key = |v: f64| {
        let b = v.to_bits() as i64;
        ((b ^ (((b >> 63) as u64) >> 1) as i64) as u64) ^ (1 << 63)
    };
    let mut pairs: Vec<(u64, usize)> = values
        .iter()
        .enumerate()
        .map(|(i, v)| (key(*v), i))
        .collect();
    pairs.sort_unstable();
    pairs.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_order_is_total_cmp_with_ties_by_index() {
        let v = [
            0.5,
            -0.0,
            f64::NAN,
            0.0,
            -1e300,
            0.5,
            f64::INFINITY,
            -f64::NAN,
            f64::NEG_INFINITY,
            1e-310,
        ];
        let mut want: Vec<usize> = (0..v.len()).collect();
        want.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        assert_eq!(order_by(&v), want);
    }

    #[test]
    fn alternating_and_curved_residuals() {
        let alt: Vec<f64> = (0..40)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let all: Vec<usize> = (0..40).collect();
        let t = runs_test(&alt, &all);
        assert_eq!((t.runs, t.positive, t.negative), (40, 20, 20));
        assert!(t.z > 5.0);
        // A parabola left in the residuals: one long negative run between two positive ones.
        let curve: Vec<f64> = (0..40)
            .map(|i| ((i as f64 - 19.5) / 10.0).powi(2) - 1.3)
            .collect();
        let t = runs_test(&curve, &all);
        assert_eq!(t.runs, 3);
        assert!(t.z < -4.0 && t.p < 1e-4, "{t:?}");
    }
}
