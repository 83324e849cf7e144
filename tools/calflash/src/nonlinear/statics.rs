//! Static-interval detection: a sample is still when the variance of the accelerometer over a
//! window centred on it is small. The measure is the norm of the three per-axis variances (as
//! in Tedaldi et al., ICRA 2014); the threshold is a multiple of the same measure over the
//! initial rest, and the multiple is searched for the best accelerometer fit by the caller.

use std::ops::Range;

/// Per-sample still measure: the norm of the per-axis variances of `acc` over a window of
/// `window` samples centred on the sample (shortened at the ends). O(n) with prefix sums.
#[must_use]
pub fn measure(acc: &[[f64; 3]], window: usize) -> Vec<f64> {
    let n = acc.len();
    if n == 0 {
        return Vec::new();
    }
    let half = window / 2;
    // Prefix sums about the first sample, to keep the sums small.
    let origin = acc[0];
    let mut s1 = vec![[0.0f64; 3]; n + 1];
    let mut s2 = vec![[0.0f64; 3]; n + 1];
    for (k, a) in acc.iter().enumerate() {
        for j in 0..3 {
            let x = a[j] - origin[j];
            s1[k + 1][j] = s1[k][j] + x;
            s2[k + 1][j] = s2[k][j] + x * x;
        }
    }
    (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(half), (k + half + 1).min(n));
            let m = (hi - lo) as f64;
            let v: [f64; 3] = std::array::from_fn(|j| {
                let mean = (s1[hi][j] - s1[lo][j]) / m;
                ((s2[hi][j] - s2[lo][j]) / m - mean * mean).max(0.0)
            });
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        })
        .collect()
}

/// The same measure over a whole span (the initial rest): the norm of its per-axis variances.
#[must_use]
pub fn rest_level(acc: &[[f64; 3]]) -> f64 {
    let n = acc.len() as f64;
    let v: [f64; 3] = std::array::from_fn(|j| {
        let mean = acc.iter().map(|a| a[j]).sum::<f64>() / n;
        acc.iter().map(|a| (a[j] - mean).powi(2)).sum::<f64>() / n
    });
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Runs of at least `min_len` samples whose measure is below `threshold` and which are not
/// `excluded` (saturated).
#[must_use]
pub fn intervals(
    measure: &[f64],
    excluded: &[bool],
    threshold: f64,
    min_len: usize,
) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for k in 0..=measure.len() {
        let still = k < measure.len()
            && measure[k] < threshold
            && !excluded.get(k).copied().unwrap_or(false);
        match (still, start) {
            (true, None) => start = Some(k),
            (false, Some(s)) => {
                if k - s >= min_len {
                    out.push(s..k);
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

/// Mean of `x` over `r`.
#[must_use]
pub fn mean(x: &[[f64; 3]], r: &Range<usize>) -> [f64; 3] {
    let n = r.len() as f64;
    std::array::from_fn(|j| x[r.clone()].iter().map(|a| a[j]).sum::<f64>() / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_still_runs_of_a_synthetic_signal() {
        // Still, moving, still, with a little noise throughout.
        let mut acc = Vec::new();
        let mut seed = 1u64;
        let mut noise = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 33) as f64 / f64::from(1u32 << 31) - 0.5) * 2.0
        };
        for k in 0..3000 {
            let moving = (1000..1500).contains(&k);
            let base = if moving {
                500.0 * (f64::from(k) * 0.05).sin()
            } else {
                0.0
            };
            acc.push([base + noise(), 400.0 + noise(), -base + noise()]);
        }
        let m = measure(&acc, 101);
        let level = rest_level(&acc[..800]);
        let found = intervals(&m, &vec![false; acc.len()], 4.0 * level, 100);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!(
            found[0].start == 0 && (940..=1000).contains(&found[0].end),
            "{found:?}"
        );
        assert!(
            (1500..=1560).contains(&found[1].start) && found[1].end == 3000,
            "{found:?}"
        );
        // Excluded samples split a run.
        let mut ex = vec![false; acc.len()];
        ex[2000] = true;
        assert_eq!(intervals(&m, &ex, 4.0 * level, 100).len(), 3);
    }
}
