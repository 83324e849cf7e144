//! Many tests at once: Holm's step-down procedure, which keeps the chance of any false
//! rejection among `m` tests at most `alpha` (as Bonferroni does) while rejecting more.

/// Which of the p-values `p` Holm's procedure rejects at family-wise level `alpha`: sorted
/// ascending, the `k`-th smallest (from 0) is rejected while it is below `alpha / (m - k)`; the
/// first that is not stops it. NaN p-values are never rejected.
#[must_use]
pub fn holm(p: &[f64], alpha: f64) -> Vec<bool> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|a, b| p[*a].total_cmp(&p[*b]));
    let mut rejected = vec![false; m];
    for (k, &i) in order.iter().enumerate() {
        if p[i].is_nan() || p[i] >= alpha / (m - k) as f64 {
            break;
        }
        rejected[i] = true;
    }
    rejected
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holm_steps_down_and_stops_at_the_first_it_keeps() {
        // m = 4 at 0.05: thresholds 0.0125, 0.0167, 0.025, 0.05.
        assert_eq!(
            holm(&[0.01, 0.04, 0.012, 0.03], 0.05),
            [true, false, true, false]
        );
        // 0.03 is not below 0.025: 0.04, below its own 0.05, is kept with it.
        assert_eq!(
            holm(&[0.013, 0.001, 0.04, 0.03], 0.05),
            [true, true, false, false]
        );
        assert_eq!(holm(&[0.2, f64::NAN], 0.05), [false, false]);
        assert!(holm(&[], 0.05).is_empty());
        // Bonferroni would keep 0.02 of two; Holm rejects both.
        assert_eq!(holm(&[0.02, 0.001], 0.05), [true, true]);
    }
}
