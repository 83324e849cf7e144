//! What the filter does not model of the calibration's error, and what it leaves in the
//! estimate of a term the flight alone determines.
//!
//! Over a flight each output's calibration error is its straight line in the output's input
//! (which the filter's bias and scale factor take, see [`super::prior`]) plus what the line
//! leaves, `r_t' theta`: a g-squared term's curvature, a lever arm's spin-squared drift along
//! the flight. That remainder has no mean over the flight and no slope in the input, so the
//! least-squares line (the truth an estimate is held to) holds none of it. The filter's
//! estimate of an opened term does not weigh the samples evenly (each by what it tells the
//! filter, given the navigation), so it carries some of it, `sum_t g_t r_t' theta`, for
//! weights `g_t` no formula gives. It is measured instead: the remainder's principal directions
//! under the calibration's covariance (independent, each a unit normal) are added to the
//! flight's samples one at a time and the pass flown again; the squares of what each moves the
//! opened terms by sum to the variance it adds to them. The bound it replaces, the remainder's
//! whole mean square, stated an axial bias's 1-sigma 2.7 times its error over 50 flights
//! (average NEES 0.40 where 1 is right).

use nalgebra::{DMatrix, DVector};
use spincal::correct::AnyImuCorrector;
use spincal::model::IMU_FEATURES;

use super::input::ImuSeries;
use super::line::{Line, each_row};

/// The most principal directions kept per output.
const MOST_DIRECTIONS: usize = 3;

/// A direction is kept while its share of the output's mean square remainder is at least this.
const SMALLEST_SHARE: f64 = 0.01;

/// Per output, the principal directions of its calibration error's remainder about its line
/// over the flight, each as its series over the flight's samples at one standard deviation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Unmodelled {
    /// The sample the series start at.
    from: usize,
    /// Per output, its directions' series (zero at a sample the filter does not navigate on).
    series: [Vec<Vec<f64>>; 6],
}

impl Unmodelled {
    /// The remainders of the calibration's error about the `lines` over the samples of `imu`
    /// from `from` on (the regressors as [`super::line::lines_over`] took them), per output
    /// with its line `a` ([`Line::through`]) and its parameters' covariance `q`.
    pub(super) fn over(
        (corrector, imu, from): (&AnyImuCorrector<'_>, &ImuSeries, usize),
        (sizes, fill): (
            [usize; 6],
            &impl Fn(usize, &[f32; IMU_FEATURES], &mut [f64]),
        ),
        lines: &[Line; 6],
        fits: &[(DMatrix<f64>, DMatrix<f64>); 6],
    ) -> Self {
        // Per output, each direction's parameters' error and the line it moves.
        let directions: [Vec<(DVector<f64>, DVector<f64>)>; 6] = std::array::from_fn(|out| {
            let (a, q) = &fits[out];
            principal(&lines[out], a, q)
                .into_iter()
                .map(|theta| {
                    let moved = a * &theta;
                    (theta, moved)
                })
                .collect()
        });
        let len = imu.t.len().saturating_sub(from);
        let mut series: [Vec<Vec<f64>>; 6] =
            std::array::from_fn(|out| vec![vec![0.0; len]; directions[out].len()]);
        each_row(corrector, imu, from, sizes, fill, |k, out, value, row| {
            for ((theta, line), s) in directions[out].iter().zip(&mut series[out]) {
                let on: f64 = row.iter().zip(theta.iter()).map(|(r, t)| r * t).sum();
                s[k - from] = on - line[0] - line[1] * value;
            }
        });
        Self { from, series }
    }

    /// Whether output `out` leaves anything about its line.
    #[must_use]
    pub fn leaves(&self, out: usize) -> bool {
        !self.series[out].is_empty()
    }

    /// Per term in the filter's order ([`super::verdict::TERMS`]), the variance the remainders
    /// of `outputs` add to a pass's estimate of the terms, where `fly` flies the pass on a
    /// flight's samples and gives its estimate, and `base` is its estimate on the flight's own.
    pub fn variance_in(
        &self,
        imu: &ImuSeries,
        outputs: &[usize],
        fly: impl Fn(&ImuSeries) -> [f64; 12] + Sync,
        base: &[f64; 12],
    ) -> [f64; 12] {
        use rayon::prelude::*;
        let tries: Vec<(usize, &Vec<f64>)> = outputs
            .iter()
            .flat_map(|&out| self.series[out].iter().map(move |s| (out, s)))
            .collect();
        let moved: Vec<[f64; 12]> = tries
            .par_iter()
            .map(|(out, s)| {
                let mut moved = imu.clone();
                for (k, e) in s.iter().enumerate() {
                    let k = self.from + k;
                    if *out < 3 {
                        moved.f[k][*out] += e;
                    } else {
                        moved.w[k][out - 3] += e;
                    }
                }
                let x = fly(&moved);
                std::array::from_fn(|i| x[i] - base[i])
            })
            .collect();
        std::array::from_fn(|i| moved.iter().map(|d| d[i] * d[i]).sum())
    }
}

/// The principal directions of one output's remainder about its line `a` under its
/// parameters' covariance `q`: with `q = L L'` and `S` the [`Line::scatter`] over `n`
/// samples, the eigenvectors `u` of `L' S L / n` carrying the most of its trace, as the
/// parameters' errors `L u` (each a unit normal's worth; the remainder's mean square along it
/// is its eigenvalue).
fn principal(line: &Line, a: &DMatrix<f64>, q: &DMatrix<f64>) -> Vec<DVector<f64>> {
    let n = line.samples();
    if n < 1.0 || q.nrows() == 0 {
        return Vec::new();
    }
    let qe = q.clone().symmetric_eigen();
    let root =
        &qe.eigenvectors * DMatrix::from_diagonal(&qe.eigenvalues.map(|x| x.max(0.0).sqrt()));
    let m = root.transpose() * line.scatter(a) * &root / n;
    let m = (&m + m.transpose()) * 0.5;
    let me = m.symmetric_eigen();
    let total: f64 = me.eigenvalues.iter().map(|x| x.max(0.0)).sum();
    if total <= 0.0 {
        return Vec::new();
    }
    let mut order: Vec<usize> = (0..me.eigenvalues.len()).collect();
    order.sort_by(|&i, &j| me.eigenvalues[j].total_cmp(&me.eigenvalues[i]));
    order
        .into_iter()
        .take(MOST_DIRECTIONS)
        .filter(|&i| me.eigenvalues[i] >= SMALLEST_SHARE * total)
        .map(|i| &root * me.eigenvectors.column(i))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{Unmodelled, principal};
    use crate::nav::input::ImuSeries;
    use crate::nav::line::Line;
    use nalgebra::{DMatrix, DVector};

    /// A pass that weighs the axial accelerometer's samples unevenly (more at the spin's low
    /// end) moves by the remainder's weighted sum, `(sum g r)' Q (sum g r)` in variance; one
    /// that weighs them evenly, by nothing (the remainder has no mean over the flight).
    #[test]
    fn what_a_pass_carries_of_the_remainder_is_its_weighted_sum() {
        let us: Vec<f64> = (0..=600).map(|k| 1300.0 + f64::from(k)).collect();
        let rows: Vec<[f64; 3]> = us.iter().map(|u| [1.0, *u, u * u]).collect();
        let mut line = Line::new(3);
        for (u, r) in us.iter().zip(&rows) {
            line.add(*u, r);
        }
        let a = line.through(&[Some(0), Some(1), None]);
        let q =
            DMatrix::from_row_slice(3, 3, &[1e-4, 0.0, 0.0, 0.0, 1e-8, 1e-13, 0.0, 1e-13, 4e-16]);
        let dirs = principal(&line, &a, &q);
        let series = dirs
            .iter()
            .map(|theta| {
                let moved = &a * theta;
                us.iter()
                    .zip(&rows)
                    .map(|(u, r)| {
                        r.iter().zip(theta.iter()).map(|(x, t)| x * t).sum::<f64>()
                            - moved[0]
                            - moved[1] * u
                    })
                    .collect()
            })
            .collect();
        let mut unmodelled = Unmodelled::default();
        unmodelled.series[0] = series;
        let imu = ImuSeries {
            t: us.iter().map(|u| u * 1e-3).collect(),
            f: us.iter().map(|u| [*u, 0.0, 0.0]).collect(),
            w: vec![[0.0; 3]; us.len()],
            flagged: vec![[false; 2]; us.len()],
            temperature: None,
        };
        let weights: Vec<f64> = (0..us.len()).map(|k| (-(k as f64) / 150.0).exp()).collect();
        let total: f64 = weights.iter().sum();
        let weighed = |imu: &ImuSeries| {
            let mean = imu
                .f
                .iter()
                .zip(&weights)
                .map(|(f, g)| f[0] * g)
                .sum::<f64>()
                / total;
            std::array::from_fn(|i| if i == 0 { mean } else { 0.0 })
        };
        let base = weighed(&imu);
        let got = unmodelled.variance_in(&imu, &[0], weighed, &base)[0];
        let sum = (0..3).fold(DVector::zeros(3), |acc: DVector<f64>, j| {
            let mut s = acc;
            s[j] = us
                .iter()
                .zip(&rows)
                .zip(&weights)
                .map(|((u, r), g)| g * (r[j] - a[(0, j)] - a[(1, j)] * u))
                .sum::<f64>()
                / total;
            s
        });
        let want = (sum.transpose() * &q * &sum)[(0, 0)];
        assert!(
            want > 0.0 && (got - want).abs() < 1e-6 * want,
            "{got} against {want}"
        );
        let even = |imu: &ImuSeries| {
            let mean = imu.f.iter().map(|f| f[0]).sum::<f64>() / imu.f.len() as f64;
            std::array::from_fn(|i| if i == 0 { mean } else { 0.0 })
        };
        let base = even(&imu);
        let flat = unmodelled.variance_in(&imu, &[0], even, &base)[0];
        assert!(flat < 1e-9 * want, "{flat} against {want}");
    }

    /// Over a spin of 1,300 to 1,900 rad/s, a bias, a scale factor and a g-squared term: the
    /// remainder is the g-squared term's alone, one direction, and its series' mean square is
    /// the line's mean square residual.
    #[test]
    fn a_g_squared_terms_remainder_is_one_direction_with_the_whole_mean_square() {
        let us: Vec<f64> = (0..=600).map(|k| 1300.0 + f64::from(k)).collect();
        let mut line = Line::new(3);
        for u in &us {
            line.add(*u, &[1.0, *u, u * u]);
        }
        let a = line.through(&[Some(0), Some(1), None]);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-4, 1e-8, 1e-16]));
        let dirs = principal(&line, &a, &q);
        assert_eq!(dirs.len(), 1, "{dirs:?}");
        let theta = &dirs[0];
        assert!(theta[2].abs() > 0.9e-8, "{theta}");
        let moved = &a * theta;
        let mean_square = us
            .iter()
            .map(|u| {
                let e = theta[0] + theta[1] * u + theta[2] * u * u - moved[0] - moved[1] * u;
                e * e
            })
            .sum::<f64>()
            / us.len() as f64;
        let want = line.residual(&a, &q);
        assert!(
            (mean_square - want).abs() < 1e-6 * want,
            "{mean_square} against {want}"
        );
    }
}
