//! Control charts of one quantity over time: individuals (Shewhart X with the moving-range
//! sigma) and EWMA, with the points out of control marked. The centre line and sigma come from
//! a baseline, the first quarter of the points (at least 20, or all when fewer): the process as
//! it was, against which the later points are watched (a drift in the later points does not
//! move the limits that should catch it). Both are robust, so that a unit far out does not
//! widen the limits that should name it: the centre is the baseline's median, sigma its median
//! moving range over 0.954 (the median of `|X1 - X2|` for two normal values is
//! `0.6745 sqrt(2)` of their sigma).

/// Which chart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Individuals: each value against centre +- 3 sigma, sigma from the mean moving range.
    Individuals,
    /// Exponentially weighted moving average (lambda 0.2, limits at 3 of its sigma).
    Ewma,
}

/// EWMA weight of the newest value.
pub const EWMA_LAMBDA: f64 = 0.2;
/// Limits at this many sigma of the plotted statistic.
pub const SIGMAS: f64 = 3.0;
/// The median moving range of two normal values is this times their sigma: the normal's
/// quartile 0.674490 times sqrt(2).
const MEDIAN_MR: f64 = 0.674_489_750_196_081_7 * std::f64::consts::SQRT_2;

/// A chart: the plotted statistic per value, its limits, and the points beyond them.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Chart {
    /// Which chart.
    pub kind: Kind,
    /// The centre line (the median of the baseline).
    pub centre: f64,
    /// The process sigma (the baseline's median moving range / 0.954).
    pub sigma: f64,
    /// Points in the baseline (the first ones).
    pub baseline: usize,
    /// The plotted statistic (the values themselves, or the EWMA).
    pub plotted: Vec<f64>,
    /// Lower and upper limits per point (the EWMA's widen towards their steady value).
    pub limits: Vec<(f64, f64)>,
    /// Indices of the points beyond their limits.
    pub out_of_control: Vec<usize>,
}

/// The chart of `values` in time order; `None` for fewer than two values.
#[must_use]
pub fn chart(values: &[f64], kind: Kind) -> Option<Chart> {
    if values.len() < 2 {
        return None;
    }
    let baseline = (values.len() / 4).max(20).min(values.len());
    let base = &values[..baseline];
    let centre = median(base.to_vec());
    let ranges: Vec<f64> = base.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let sigma = median(ranges) / MEDIAN_MR;
    let (plotted, limits): (Vec<f64>, Vec<(f64, f64)>) = match kind {
        Kind::Individuals => values
            .iter()
            .map(|v| (*v, (centre - SIGMAS * sigma, centre + SIGMAS * sigma)))
            .unzip(),
        Kind::Ewma => {
            let l = EWMA_LAMBDA;
            let mut z = centre;
            values
                .iter()
                .enumerate()
                .map(|(t, v)| {
                    z = l * v + (1.0 - l) * z;
                    let widen = (1.0 - (1.0 - l).powi(2 * (t as i32 + 1))).max(0.0);
                    let half = SIGMAS * sigma * (l / (2.0 - l) * widen).sqrt();
                    (z, (centre - half, centre + half))
                })
                .unzip()
        }
    };
    let out_of_control = plotted
        .iter()
        .zip(&limits)
        .enumerate()
        .filter(|(_, (v, (lo, hi)))| *v < lo || *v > hi)
        .map(|(i, _)| i)
        .collect();
    Some(Chart {
        kind,
        centre,
        sigma,
        baseline,
        plotted,
        limits,
        out_of_control,
    })
}

/// The median of `v` (the mean of the middle two for an even count).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_in_the_process_is_out_of_control_and_a_stable_one_is_not() {
        // A deterministic, stable process: values cycle within +-1.
        let stable: Vec<f64> = (0..200)
            .map(|i| f64::from((i * 37) % 21 - 10) / 10.0)
            .collect();
        for kind in [Kind::Individuals, Kind::Ewma] {
            let c = chart(&stable, kind).unwrap();
            assert!(
                c.out_of_control.is_empty(),
                "{kind:?}: {:?}",
                c.out_of_control
            );
        }
        // The same, with a shift of 1.5 sigma from point 150 on: the EWMA sees it, the
        // individuals chart (3 sigma per point) mostly does not.
        let c0 = chart(&stable, Kind::Individuals).unwrap();
        let shifted: Vec<f64> = stable
            .iter()
            .enumerate()
            .map(|(i, v)| if i >= 150 { v + 1.5 * c0.sigma } else { *v })
            .collect();
        let ewma = chart(&shifted, Kind::Ewma).unwrap();
        assert!(!ewma.out_of_control.is_empty());
        assert!(
            ewma.out_of_control.iter().all(|&i| i >= 150),
            "{:?}",
            ewma.out_of_control
        );
        // One wild value: the individuals chart names it.
        let mut wild = stable.clone();
        wild[77] = 5.0;
        let ind = chart(&wild, Kind::Individuals).unwrap();
        assert_eq!(ind.out_of_control, vec![77]);
        assert!(chart(&[1.0], Kind::Ewma).is_none());
    }

    #[test]
    fn units_far_out_do_not_widen_the_limits_that_name_them() {
        // Eleven units alternating +-1, two at +10 and -10: the mean moving range (4.7) would
        // put the limits at +-12 and both in control; the median's (2) puts them at +-6.3.
        let mut v: Vec<f64> = (0..13)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        v[4] = 10.0;
        v[9] = -10.0;
        let c = chart(&v, Kind::Individuals).unwrap();
        assert!((c.sigma - 2.0 / MEDIAN_MR).abs() < 1e-12, "{c:?}");
        assert_eq!(c.centre, 1.0);
        assert_eq!(c.out_of_control, [4, 9]);
    }
}
