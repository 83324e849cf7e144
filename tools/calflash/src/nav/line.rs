//! The straight line through one output's calibration error over a flight: the filter models
//! each output's error as `b + s u`, and the calibration's error `theta' phi` over the flight's
//! samples is that line plus what it leaves (its scatter about the line, [`Line::scatter`]). See [`super::prior`].

use nalgebra::{DMatrix, DVector};
use spincal::correct::AnyImuCorrector;
use spincal::model::IMU_FEATURES;

use super::input::ImuSeries;

/// Per output, the sums of the straight line through its error over the samples of `imu` from
/// `from` on that the filter navigates on, with `sizes[output]` regressors that `fill(output,
/// features, row)` writes from the device's error features at each sample.
pub(super) fn lines_over(
    corrector: &AnyImuCorrector<'_>,
    imu: &ImuSeries,
    from: usize,
    sizes: [usize; 6],
    fill: &impl Fn(usize, &[f32; IMU_FEATURES], &mut [f64]),
) -> [Line; 6] {
    let across = across_the_spin(imu, from);
    let mut lines: [Line; 6] = std::array::from_fn(|out| Line {
        across: across[out % 3],
        ..Line::new(sizes[out])
    });
    each_row(corrector, imu, from, sizes, fill, |_, out, value, row| {
        lines[out].add(value, row);
    });
    lines
}

/// Calls `visit(sample, output, value, row)` for each output of each sample of `imu` from
/// `from` on that the filter navigates on (its sensor not flagged), with the output's value
/// and the `sizes[output]` regressors `fill` writes from the device's error features there.
pub(super) fn each_row(
    corrector: &AnyImuCorrector<'_>,
    imu: &ImuSeries,
    from: usize,
    sizes: [usize; 6],
    fill: &impl Fn(usize, &[f32; IMU_FEATURES], &mut [f64]),
    mut visit: impl FnMut(usize, usize, f64, &[f64]),
) {
    let mut rows: [Vec<f64>; 6] = std::array::from_fn(|out| vec![0.0; sizes[out]]);
    for k in from..imu.t.len() {
        let (f, w) = (imu.f[k], imu.w[k]);
        let values = [f[0], f[1], f[2], w[0], w[1], w[2]];
        let features = corrector.error_features(&values.map(|x| x as f32));
        for (out, (row, phi)) in rows.iter_mut().zip(&features).enumerate() {
            if imu.flagged[k][out / 3] {
                continue;
            }
            fill(out, phi, row);
            visit(k, out, values[out], row);
        }
    }
}

/// A flight spins when its root mean square rate about its spin axis after launch exceeds this,
/// rad/s (16 revolutions a second).
pub const SPINNING: f64 = 100.0;

/// Per body axis, whether it lies across the spin of a flight that spins ([`SPINNING`]).
/// What such an axis senses turns with the roll, so its error over the flight is no line in
/// its own input: the line a regression would draw through it follows whatever drifts with
/// the spin's decay (the lever arm's error goes as the spin's square), and given to the filter
/// as a bias and a scale factor correlated at 0.8 it let the filter blame a transverse bias for
/// an axial shift (40 false SHIFTED in 50 flights). Its scale factor is taken at zero input
/// instead, and its bias is the error's mean over the flight beyond that scale factor: a
/// transverse gyro's misalignment towards the spin axis, known to 1e-5 rad, is a body-fixed
/// error of 0.015 rad/s at 1,500 rad/s, which the bias at zero input leaves out (the
/// transverse gyro biases' NEES was 5 to 7 over 50 flights with it left out).
pub(super) fn across_the_spin(imu: &ImuSeries, from: usize) -> [bool; 3] {
    let (k, rms) = super::launch::spin(imu, from);
    if rms <= SPINNING {
        return [false; 3];
    }
    std::array::from_fn(|i| i != k)
}

/// The sums of one output's straight line through `p` regressors: `n`, `sum u`, `sum u^2`,
/// and per regressor `sum r`, `sum u r`.
#[derive(Debug, Clone)]
pub(super) struct Line {
    /// The axis lies across a spin: its line's slope is the one at zero input and its bias the
    /// error's mean beyond it ([`across_the_spin`]).
    across: bool,
    n: f64,
    u: f64,
    uu: f64,
    r: DVector<f64>,
    ur: DVector<f64>,
    /// `sum r r'` (upper triangle).
    rr: DMatrix<f64>,
}

impl Line {
    pub(super) fn new(p: usize) -> Self {
        Self {
            across: false,
            n: 0.0,
            u: 0.0,
            uu: 0.0,
            r: DVector::zeros(p),
            ur: DVector::zeros(p),
            rr: DMatrix::zeros(p, p),
        }
    }

    pub(super) fn add(&mut self, u: f64, row: &[f64]) {
        self.n += 1.0;
        self.u += u;
        self.uu += u * u;
        for (j, x) in row.iter().enumerate() {
            self.r[j] += x;
            self.ur[j] += u * x;
            for (k, y) in row.iter().enumerate().skip(j) {
                self.rr[(j, k)] += x * y;
            }
        }
    }

    /// How many samples the line is through.
    pub(super) fn samples(&self) -> f64 {
        self.n
    }

    /// The scatter of the regressors about the line `a` ([`Line::through`]),
    /// `sum (r - a'[1 u]) (r - a'[1 u])'` (p x p).
    pub(super) fn scatter(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        let p = self.r.len();
        let rr = DMatrix::from_fn(p, p, |j, k| self.rr[(j.min(k), j.max(k))]);
        let b = DMatrix::from_fn(p, 2, |j, c| if c == 0 { self.r[j] } else { self.ur[j] });
        let g = DMatrix::from_row_slice(2, 2, &[self.n, self.u, self.u, self.uu]);
        &rr - &b * a - a.transpose() * b.transpose() + a.transpose() * g * a
    }

    /// The mean over the samples of the variance, under the parameters' covariance `q`, of the
    /// error about the line `a`: `tr(q S) / n` with `S` its [`Line::scatter`].
    #[cfg(test)]
    pub(super) fn residual(&self, a: &DMatrix<f64>, q: &DMatrix<f64>) -> f64 {
        if self.n < 1.0 {
            return 0.0;
        }
        ((q * self.scatter(a)).trace() / self.n).max(0.0)
    }

    /// `A` (2 x p), the map from the parameters' errors to the line's bias and slope (the
    /// slope from the centred sums, `S_ur / S_uu`). Without a spread of the input (or without
    /// samples), the line at zero input: `own[j]` says which regressor is the bias (0) and
    /// which the axis' own input (1).
    pub(super) fn through(&self, own: &[Option<usize>]) -> DMatrix<f64> {
        let p = self.r.len();
        let mut a = DMatrix::zeros(2, p);
        let mean = self.u / self.n.max(1.0);
        let spread = self.uu - self.n * mean * mean;
        if self.across && self.n >= 1.0 {
            for (j, o) in own.iter().enumerate() {
                let slope = if *o == Some(1) { 1.0 } else { 0.0 };
                a[(1, j)] = slope;
                a[(0, j)] = self.r[j] / self.n - slope * mean;
            }
        } else if self.n >= 2.0 && spread > 1e-9 * self.uu {
            for j in 0..p {
                let r_mean = self.r[j] / self.n;
                let slope = (self.ur[j] - self.n * mean * r_mean) / spread;
                a[(1, j)] = slope;
                a[(0, j)] = r_mean - slope * mean;
            }
        } else {
            for (j, o) in own.iter().enumerate() {
                if let Some(row) = o {
                    a[(*row, j)] = 1.0;
                }
            }
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::Line;
    use nalgebra::{DMatrix, DVector};

    /// A spin of 1,300 to 1,900 rad/s (one sample a rad/s), its line through regressors
    /// `1, u, u^2` (a bias, a scale factor and a g-squared term), the line's matrix with the
    /// first two its own, and the least-squares design `[1, u]` over the spin.
    fn spin_line() -> (Vec<f64>, Line, DMatrix<f64>, DMatrix<f64>) {
        let us: Vec<f64> = (0..=600).map(|k| 1300.0 + f64::from(k)).collect();
        let mut line = Line::new(3);
        for u in &us {
            line.add(*u, &[1.0, *u, u * u]);
        }
        let a = line.through(&[Some(0), Some(1), None]);
        let x = DMatrix::from_fn(us.len(), 2, |i, j| if j == 0 { 1.0 } else { us[i] });
        (us, line, a, x)
    }

    /// The line through a quadratic error over a spin of 1,300 to 1,900 rad/s: the same as a
    /// least-squares fit of `[1, u]` by SVD, and far from the error's own bias and slope at
    /// zero input.
    #[test]
    fn the_line_through_an_error_is_its_least_squares_fit_over_the_flight() {
        let (us, _, a, x) = spin_line();
        let svd = x.svd(true, true);
        for (j, r) in [|_: f64| 1.0, |u: f64| u, |u: f64| u * u]
            .iter()
            .enumerate()
        {
            let y = DVector::from_iterator(us.len(), us.iter().map(|u| r(*u)));
            let b = svd.solve(&y, 1e-12).unwrap();
            for row in 0..2 {
                let tol = 1e-9 * b[row].abs().max(1.0);
                assert!((a[(row, j)] - b[row]).abs() < tol, "{a} against {b} at {j}");
            }
        }
        // A g-squared error moves the line's slope by about 2 * 1600 and its bias by -1600^2.
        assert!((a[(1, 2)] - 3200.0).abs() < 1.0, "{a}");
        assert!(
            (a[(0, 2)] + 1600.0 * 1600.0).abs() < 0.02 * 1600.0 * 1600.0,
            "{a}"
        );
    }

    /// What the line leaves of a g-squared error over a spin of 1,300 to 1,900 rad/s: its
    /// variance about the line, averaged over the samples, is the mean square of the
    /// least-squares residual of `u^2` times the term's variance; a bias or a scale error
    /// leaves nothing.
    #[test]
    fn what_the_line_leaves_of_an_error_is_its_mean_squared_residual() {
        let (us, line, a, x) = spin_line();
        let y = DVector::from_iterator(us.len(), us.iter().map(|u| u * u));
        let b = x.clone().svd(true, true).solve(&y, 1e-12).unwrap();
        let mean_square = (&y - &x * b).norm_squared() / us.len() as f64;
        let sigma2 = 1e-16;
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![0.0, 0.0, sigma2]));
        let got = line.residual(&a, &q);
        let want = sigma2 * mean_square;
        assert!((got - want).abs() < 1e-6 * want, "{got} against {want}");
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 1e-6, 0.0]));
        assert!(line.residual(&a, &q) < 1e-9, "{}", line.residual(&a, &q));
    }

    #[test]
    fn without_a_spread_of_the_input_the_line_is_taken_at_zero_input() {
        let mut line = Line::new(3);
        for _ in 0..10 {
            line.add(2.0, &[1.0, 2.0, 4.0]);
        }
        let a = line.through(&[Some(0), Some(1), None]);
        assert_eq!(
            a,
            DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
        );
    }
}
