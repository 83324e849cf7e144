//! The Kalman filter over the drifting terms, under one prior.
//!
//! State: the accelerometer biases `b_a` (3) and the error `dg` of the assumed magnitude of
//! gravity, and the gyro biases `b_g` (3), all as the error of the corrected output (the
//! corrector subtracts a refined bias). At rest a window's mean gyro rate measures `b_g`
//! directly (Earth's rate, direction unknown, is part of the prior); the window's mean specific
//! force `m` measures the biases through its magnitude, `|m - b_a| = g0 + dg`, linearised about
//! the estimate (an extended Kalman step): one pose observes `b_a` along gravity only and keeps
//! the prior in the two directions across it, which tighten as the unit is turned.
//!
//! Beside the posterior the filter keeps each bias's prior-predictive variance (`spread`: the
//! prior plus every process noise added). For a linear Gaussian model the posterior mean `x` of
//! a bias then has the variance `spread - P` over the units the prior describes, which gives
//! the health check's per-axis statistic `x^2 / (spread - P)`, chi-square with one degree of
//! freedom when the calibration holds.

use super::OUTPUTS;

/// Offsets of the rows of a packed upper-triangular 4x4 matrix.
const ROW: [usize; 4] = [0, 4, 7, 9];

/// Index of element `(i, j)`, `i <= j`, of a packed symmetric 4x4 matrix.
#[inline]
fn at(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    ROW.get(i).copied().unwrap_or(0) + (j - i)
}

/// A variance ratio below which a direction counts as not observed by the data.
const OBSERVED: f32 = 1e-3;

/// The refined biases under one prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Filter {
    /// `[b_a0, b_a1, b_a2, dg]`.
    xa: [f32; 4],
    /// Their covariance, packed upper triangle (`00 01 02 03 11 12 13 22 23 33`).
    pa: [f32; 10],
    /// Gyro biases.
    xg: [f32; 3],
    /// Their variances (the gyro axes are measured apart and stay uncorrelated).
    pg: [f32; 3],
    /// Per bias (`ax ... wz`), the prior-predictive variance.
    spread: [f32; OUTPUTS],
}

impl Filter {
    /// Zero biases with the variances `prior` (per output) and the gravity error's variance.
    pub fn new(prior: &[f32; OUTPUTS], gravity_var: f32) -> Self {
        let [a0, a1, a2, g0, g1, g2] = *prior;
        let mut pa = [0.0; 10];
        for (i, v) in [a0, a1, a2, gravity_var].into_iter().enumerate() {
            if let Some(p) = pa.get_mut(at(i, i)) {
                *p = v;
            }
        }
        Self {
            xa: [0.0; 4],
            pa,
            xg: [0.0; 3],
            pg: [g0, g1, g2],
            spread: *prior,
        }
    }

    /// Adds the independent process noise `q` (variance per bias).
    pub fn add_noise(&mut self, q: &[f32; OUTPUTS]) {
        let [a0, a1, a2, g0, g1, g2] = *q;
        for (i, v) in [a0, a1, a2].into_iter().enumerate() {
            if let Some(p) = self.pa.get_mut(at(i, i)) {
                *p += v;
            }
        }
        for (p, v) in self.pg.iter_mut().zip([g0, g1, g2]) {
            *p += v;
        }
        for (s, v) in self.spread.iter_mut().zip(q) {
            *s += v;
        }
    }

    /// A window's mean gyro rate `mean` at rest, with the variance `r` of each mean.
    pub fn update_gyro(&mut self, mean: &[f32; 3], r: &[f32; 3]) {
        for ((x, p), (z, r)) in self.xg.iter_mut().zip(&mut self.pg).zip(mean.iter().zip(r)) {
            let s = *p + r;
            let k = *p / s;
            *x += k * (z - *x);
            *p *= r / s;
        }
    }

    /// A window's mean specific force `mean` at rest, with the variance `r` of each component
    /// of the mean, against the assumed magnitude of gravity `g0`.
    pub fn update_accel(&mut self, mean: &[f32; 3], r: &[f32; 3], g0: f32) {
        let [x0, x1, x2, dg] = self.xa;
        let [m0, m1, m2] = *mean;
        let a = [m0 - x0, m1 - x1, m2 - x2];
        let norm = libm::sqrtf(a.iter().map(|v| v * v).sum());
        if !(norm > 0.0 && norm.is_finite()) {
            return;
        }
        let u = a.map(|v| v / norm);
        // Measurement 0 = |m - b| - g0 - dg; its Jacobian h = [-u, -1].
        let h = [-u[0], -u[1], -u[2], -1.0];
        let mut ph = [0.0f32; 4];
        for (i, o) in ph.iter_mut().enumerate() {
            for (j, hj) in h.iter().enumerate() {
                *o += self.pa.get(at(i, j)).copied().unwrap_or(0.0) * hj;
            }
        }
        let noise: f32 = u.iter().zip(r).map(|(u, r)| u * u * r).sum();
        let s = h.iter().zip(&ph).map(|(h, p)| h * p).sum::<f32>() + noise;
        if s.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
            return;
        }
        let innovation = g0 + dg - norm;
        for (x, p) in self.xa.iter_mut().zip(&ph) {
            *x += p / s * innovation;
        }
        for i in 0..4 {
            for j in i..4 {
                if let (Some(p), Some(a), Some(b)) =
                    (self.pa.get_mut(at(i, j)), ph.get(i), ph.get(j))
                {
                    *p -= a * b / s;
                }
            }
        }
    }

    /// The refined biases `[ax, ay, az, wx, wy, wz]`.
    pub fn bias(&self) -> [f32; OUTPUTS] {
        let [a0, a1, a2, _] = self.xa;
        let [g0, g1, g2] = self.xg;
        [a0, a1, a2, g0, g1, g2]
    }

    /// Their variances.
    pub fn variance(&self) -> [f32; OUTPUTS] {
        let p = |i: usize| self.pa.get(at(i, i)).copied().unwrap_or(0.0);
        let [g0, g1, g2] = self.pg;
        [p(0), p(1), p(2), g0, g1, g2]
    }

    /// The accelerometer biases' covariance, packed upper triangle (`00 01 02 11 12 22`).
    pub fn accel_covariance(&self) -> [f32; 6] {
        let p = |i: usize, j: usize| self.pa.get(at(i, j)).copied().unwrap_or(0.0);
        [p(0, 0), p(0, 1), p(0, 2), p(1, 1), p(1, 2), p(2, 2)]
    }

    /// Each bias's prior-predictive variance: the prior and every process noise added.
    pub fn spread(&self) -> [f32; OUTPUTS] {
        self.spread
    }

    /// The gravity error's estimate and variance.
    pub fn gravity_error(&self) -> (f32, f32) {
        let [.., dg] = self.xa;
        (dg, self.pa.get(at(3, 3)).copied().unwrap_or(0.0))
    }

    /// The largest per-axis statistic `x^2 / (spread - P)` over the biases the data observe,
    /// and how many they are.
    pub fn statistic(&self) -> (f32, u8) {
        let mut worst = 0.0f32;
        let mut used = 0u8;
        for ((x, p), s) in self.bias().iter().zip(self.variance()).zip(&self.spread) {
            let v = s - p;
            if v > OBSERVED * s {
                worst = worst.max(x * x / v);
                used += 1;
            }
        }
        (worst, used)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_pose_observes_the_bias_along_gravity_only() {
        let prior = [1e-4, 1e-4, 1e-4, 1e-6, 1e-6, 1e-6];
        let mut f = Filter::new(&prior, 1e-8);
        // z up, a bias of 0.02 on z and 0.02 on x.
        for _ in 0..100 {
            f.update_accel(&[0.02, 0.0, 9.8 + 0.02], &[1e-6; 3], 9.8);
        }
        let [bx, by, bz, ..] = f.bias();
        assert!((bz - 0.02).abs() < 1e-3, "{bz}");
        assert!(bx.abs() < 1e-3 && by.abs() < 1e-3);
        let [vx, vy, vz, ..] = f.variance();
        assert!(vx > 0.99e-4 && vy > 0.99e-4, "prior kept across gravity");
        assert!(vz < 1e-6);
        // Turned on its side, x is observed too.
        for _ in 0..100 {
            f.update_accel(&[9.8 + 0.02, 0.0, 0.02], &[1e-6; 3], 9.8);
        }
        let [bx, _, bz, ..] = f.bias();
        assert!(
            (bx - 0.02).abs() < 2e-3 && (bz - 0.02).abs() < 2e-3,
            "{bx} {bz}"
        );
    }

    #[test]
    fn gyro_bias_and_its_statistic() {
        let prior = [1e-4, 1e-4, 1e-4, 1e-6, 1e-6, 1e-6];
        let mut f = Filter::new(&prior, 1e-8);
        // A shift of 6 sigma on the x gyro.
        for _ in 0..50 {
            f.update_gyro(&[6e-3, 0.0, 0.0], &[1e-8; 3]);
        }
        let (t, used) = f.statistic();
        assert_eq!(
            used, 3,
            "the three gyro biases are observed, the accelerometer not"
        );
        assert!((t - 36.0).abs() < 1.0, "{t}");
    }
}
