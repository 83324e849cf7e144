//! Static-interval detection: a sample is still when the variance of the accelerometer over a
//! window centred on it is small. The measure is the norm of the three per-axis variances (as
//! in Tedaldi et al., ICRA 2014); the threshold is a multiple of the same measure over the
//! initial rest, and the multiple is searched for the best accelerometer fit by the caller.

use std::ops::Range;

/// The data's quantisation step on each axis: the smallest change between consecutive samples
/// (one count for raw codes; the logger's resolution for data in physical units), or 1 for an
/// axis that never changes.
#[must_use]
pub fn quantum(acc: &[[f64; 3]]) -> [f64; 3] {
    std::array::from_fn(|j| {
        let q = acc
            .windows(2)
            .map(|w| (w[1][j] - w[0][j]).abs())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        if q.is_finite() { q } else { 1.0 }
    })
}

/// The variance the quantisation adds to each axis, `q^2 / 12`: the floor under every
/// variance here, so that a run of identical codes is not infinitely quiet.
#[must_use]
pub fn floor(quantum: [f64; 3]) -> [f64; 3] {
    quantum.map(|q| q * q / 12.0)
}

/// Per-sample still measure: the norm of the per-axis variances of `acc` over a window of
/// `window` samples centred on the sample (shortened at the ends), each with the quantisation
/// `floor` added. O(n) with prefix sums.
#[must_use]
pub fn measure(acc: &[[f64; 3]], window: usize, floor: [f64; 3]) -> Vec<f64> {
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
                ((s2[hi][j] - s2[lo][j]) / m - mean * mean).max(0.0) + floor[j]
            });
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        })
        .collect()
}

/// The same measure over a whole span (the initial rest): the norm of its per-axis variances,
/// each with the quantisation `floor` added.
#[must_use]
pub fn rest_level(acc: &[[f64; 3]], floor: [f64; 3]) -> f64 {
    let v = variances(acc, floor);
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

/// When two still runs are one hold that noise split.
#[derive(Debug, Clone, Copy)]
pub struct Join<'a> {
    /// The accelerometer samples whose means are compared.
    pub acc: &'a [[f64; 3]],
    /// The longest stretch between them, samples.
    pub gap: usize,
    /// The largest difference of their means per axis.
    pub tol: [f64; 3],
    /// Samples where the gyro turned (a turn about the vertical leaves the accelerometer's
    /// means alike): never inside the stretch.
    pub turned: &'a [bool],
}

/// The still poses: runs of [`intervals`], with two runs joined as `join` says (only a short
/// stretch separates them, none of it excluded or turning, and their means agree): one hold
/// that noise split, not two poses. Runs shorter than `min_len` are then dropped.
#[must_use]
pub fn poses(
    measure: &[f64],
    excluded: &[bool],
    threshold: f64,
    min_len: usize,
    join: &Join<'_>,
) -> Vec<Range<usize>> {
    let Join {
        acc,
        gap,
        tol,
        turned,
    } = *join;
    let runs = intervals(measure, excluded, threshold, 1);
    let mut out: Vec<Range<usize>> = Vec::with_capacity(runs.len());
    for r in runs {
        if let Some(last) = out.last_mut()
            && r.start - last.end <= gap
            && !excluded[last.end..r.start].iter().any(|x| *x)
            && !turned
                .get(last.end..r.start)
                .is_some_and(|t| t.iter().any(|x| *x))
        {
            let (a, b) = (mean(acc, last), mean(acc, &r));
            if (0..3).all(|j| (a[j] - b[j]).abs() <= tol[j]) {
                last.end = r.end;
                continue;
            }
        }
        out.push(r);
    }
    out.retain(|r| r.len() >= min_len);
    out
}

/// Per-axis variances of `acc` (the initial rest's), each with the quantisation `floor`.
#[must_use]
pub fn variances(acc: &[[f64; 3]], floor: [f64; 3]) -> [f64; 3] {
    let n = acc.len() as f64;
    std::array::from_fn(|j| {
        let mean = acc.iter().map(|a| a[j]).sum::<f64>() / n;
        acc.iter().map(|a| (a[j] - mean).powi(2)).sum::<f64>() / n + floor[j]
    })
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
        let m = measure(&acc, 101, [0.0; 3]);
        let level = rest_level(&acc[..800], [0.0; 3]);
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

    #[test]
    fn identical_codes_are_as_quiet_as_their_quantisation() {
        // A quantised logger: one count of 0.038 m/s^2, a rest whose codes never change.
        let q = 0.0383;
        let still = vec![[0.0, 0.0, 9.81 / q * q]; 20];
        assert_eq!(
            quantum(&[[0.0, 1.0, 5.0], [0.0, 3.0, 5.5]]),
            [1.0, 2.0, 0.5]
        );
        let f = floor([q; 3]);
        let level = rest_level(&still, f);
        assert!(
            (level - 3f64.sqrt() * q * q / 12.0).abs() < 1e-15,
            "{level}"
        );
        // One count of flicker is a few times that, not infinitely more.
        let mut flicker = still.clone();
        flicker[10][0] = q;
        let ratio = rest_level(&flicker, f) / level;
        assert!((1.0..10.0).contains(&ratio), "{ratio}");
        assert!(measure(&still, 5, f).iter().all(|m| *m == level));
    }
}
