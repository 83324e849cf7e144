//! The Kalman filter over the drifting terms, under one prior.
//!
//! State: per accelerometer axis `a`, the error `theta_a` of its parameters over the features
//! that do not vanish at rest (`phi_a = [1, f_0, f_1, f_2, x_a^2]`:
//! [`ImuCorrector::accel_rest_features`](crate::correct::ImuCorrector::accel_rest_features)),
//! so that the axis' error at rest under the specific force `f` is `e_a = phi_a(f) . theta_a`:
//! the bias and the part that depends on the pose (scale, misalignment, g-squared) together,
//! with the covariance the calibration states (`accel_rest_covariance`); then the error `dg` of
//! the assumed magnitude of gravity; and the gyro biases `b_g` (3). All are errors of the
//! corrected output (the corrector subtracts a refined bias).
//!
//! At rest a window's mean gyro rate measures `b_g` directly (Earth's rate, direction unknown,
//! is part of the prior). The window's mean specific force `m` measures the accelerometer's
//! errors through its magnitude, `|m - e(m)| = g0 + dg`, linearised about the estimate (an
//! extended Kalman step with `h = -u_a phi_a(m)` per axis, `u` the unit vector of `m - e`): one
//! pose observes the error along gravity only; turning the unit observes other combinations of
//! the same parameters, so what a pose taught is carried to the next through their
//! correlations, not forgotten and not double-counted. The refined bias reported and applied is
//! the error at the present pose, `phi_a(m) . theta_a`, with the variance `phi' P phi`.
//!
//! Beside the posterior the filter keeps each parameter block's prior and the process noise
//! added (`spread`: the prior-predictive variance of each output's error at the present pose).
//! For a linear Gaussian model the posterior mean `x` of an error then has the variance
//! `spread - P` over the units the prior describes, which gives the health check's per-axis
//! statistic `x^2 / (spread - P)`, chi-square with one degree of freedom when the calibration
//! holds.

use super::OUTPUTS;

/// Accelerometer features at rest, per axis.
const FEATURES: usize = crate::correct::REST_FEATURES.len();

/// Accelerometer states: three axes' parameters, then the gravity error.
const NA: usize = 3 * FEATURES + 1;

/// The gravity error's index.
const DG: usize = NA - 1;

/// Elements of a packed upper-triangular `NA x NA` matrix.
const PACKED: usize = NA * (NA + 1) / 2;

/// Elements of a packed upper-triangular `FEATURES x FEATURES` block.
pub(super) const BLOCK: usize = FEATURES * (FEATURES + 1) / 2;

/// Index of element `(i, j)` of a packed symmetric `n x n` matrix (upper triangle, row by
/// row).
#[inline]
const fn packed(n: usize, i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    i * (2 * n - i + 1) / 2 + (j - i)
}

/// A variance ratio below which a direction counts as not observed by the data.
const OBSERVED: f32 = 1e-3;

/// The refined errors under one prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Filter {
    /// The accelerometer parameters' errors, axis by axis, then `dg`.
    xa: [f32; NA],
    /// Their covariance, packed upper triangle.
    pa: [f32; PACKED],
    /// The variance added to each axis' bias beyond its block's prior (ageing) and the process
    /// noise added so far (for the spread).
    walked: [f32; 3],
    /// Each accelerometer axis' prior-predictive variance at the present pose.
    accel_spread: [f32; 3],
    /// The features of the present pose.
    phi: [[f32; FEATURES]; 3],
    /// Gyro biases.
    xg: [f32; 3],
    /// Their variances (the gyro axes are measured apart and stay uncorrelated).
    pg: [f32; 3],
    /// The gyro biases' prior-predictive variances.
    gyro_spread: [f32; 3],
}

impl Filter {
    /// Zero errors: the accelerometer axes' parameter blocks with the covariances `accel`
    /// (packed, [`BLOCK`] each) and `extra` added to each bias's variance (ageing), the gyro
    /// biases with the variances `gyro`, the gravity error with `gravity_var`; `phi` the
    /// features of the first pose.
    pub fn new(
        accel: &[[f32; BLOCK]; 3],
        extra: &[f32; 3],
        gyro: &[f32; 3],
        gravity_var: f32,
        phi: &[[f32; FEATURES]; 3],
    ) -> Self {
        let mut prior = *accel;
        for (block, e) in prior.iter_mut().zip(extra) {
            if let Some(b) = block.get_mut(0) {
                *b += e;
            }
        }
        let mut pa = [0.0; PACKED];
        for (axis, block) in prior.iter().enumerate() {
            let base = axis * FEATURES;
            for i in 0..FEATURES {
                for j in i..FEATURES {
                    if let (Some(p), Some(v)) = (
                        pa.get_mut(packed(NA, base + i, base + j)),
                        block.get(packed(FEATURES, i, j)),
                    ) {
                        *p = *v;
                    }
                }
            }
        }
        if let Some(p) = pa.get_mut(packed(NA, DG, DG)) {
            *p = gravity_var;
        }
        Self {
            xa: [0.0; NA],
            pa,
            walked: *extra,
            accel_spread: {
                let [s0, s1, s2] = stated_at(accel, phi);
                let [e0, e1, e2] = *extra;
                [s0 + e0, s1 + e1, s2 + e2]
            },
            phi: *phi,
            xg: [0.0; 3],
            pg: *gyro,
            gyro_spread: *gyro,
        }
    }

    fn p(&self, i: usize, j: usize) -> f32 {
        self.pa.get(packed(NA, i, j)).copied().unwrap_or(0.0)
    }

    /// Adds the independent process noise `q` (variance per bias: each accelerometer axis'
    /// bias parameter, each gyro bias).
    pub fn add_noise(&mut self, q: &[f32; OUTPUTS]) {
        let [a0, a1, a2, g0, g1, g2] = *q;
        for (axis, v) in [a0, a1, a2].into_iter().enumerate() {
            let i = axis * FEATURES;
            if let Some(p) = self.pa.get_mut(packed(NA, i, i)) {
                *p += v;
            }
            if let Some(w) = self.walked.get_mut(axis) {
                *w += v;
            }
            if let Some(s) = self.accel_spread.get_mut(axis) {
                *s += v;
            }
        }
        self.add_gyro_noise(&[g0, g1, g2]);
    }

    /// Adds the independent process noise `q` to the gyro biases (a change of pose: the part
    /// of their stated error that depends on it).
    pub fn add_gyro_noise(&mut self, q: &[f32; 3]) {
        for ((p, s), v) in self.pg.iter_mut().zip(&mut self.gyro_spread).zip(q) {
            *p += v;
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

    /// The accelerometer axes' errors at the present pose.
    fn accel_error(&self) -> [f32; 3] {
        core::array::from_fn(|axis| {
            (0..FEATURES)
                .map(|k| {
                    let phi = self.phi.get(axis).and_then(|p| p.get(k)).copied();
                    phi.unwrap_or(0.0) * self.xa.get(axis * FEATURES + k).copied().unwrap_or(0.0)
                })
                .sum()
        })
    }

    /// A window's mean specific force `mean` at rest (features `phi` there), with the variance
    /// `r` of each component of the mean, against the assumed magnitude of gravity `g0`;
    /// `stated` is each axis' stated error variance at this pose (`phi' C phi` of the blocks'
    /// prior [`Filter::new`] had: [`stated_at`]), for the spread.
    pub fn update_accel(
        &mut self,
        mean: &[f32; 3],
        r: &[f32; 3],
        g0: f32,
        (phi, stated): (&[[f32; FEATURES]; 3], &[f32; 3]),
    ) {
        self.phi = *phi;
        let [s0, s1, s2] = *stated;
        let [w0, w1, w2] = self.walked;
        self.accel_spread = [s0 + w0, s1 + w1, s2 + w2];
        let [e0, e1, e2] = self.accel_error();
        let [m0, m1, m2] = *mean;
        let a = [m0 - e0, m1 - e1, m2 - e2];
        let norm = crate::sqrt::sqrtf(a.iter().map(|v| v * v).sum());
        if !(norm > 0.0 && norm.is_finite()) {
            return;
        }
        let u = a.map(|v| v / norm);
        // Measurement 0 = |m - e(m)| - g0 - dg; its Jacobian h = [-u_a phi_a ..., -1].
        let mut h = [0.0f32; NA];
        for (axis, (ua, pa)) in u.iter().zip(phi).enumerate() {
            for (k, f) in pa.iter().enumerate() {
                if let Some(o) = h.get_mut(axis * FEATURES + k) {
                    *o = -ua * f;
                }
            }
        }
        if let Some(o) = h.get_mut(DG) {
            *o = -1.0;
        }
        // P h row by row, one accumulator a row: the row's part left of the diagonal is its
        // column in the packed upper triangle (stride shrinking by one), the rest contiguous.
        let mut ph = [0.0f32; NA];
        for (i, o) in ph.iter_mut().enumerate() {
            let mut acc = 0.0;
            let mut at = i;
            for (j, hj) in h.iter().enumerate().take(i) {
                acc += self.pa.get(at).copied().unwrap_or(0.0) * hj;
                at += NA - j - 1;
            }
            let row = self.pa.get(at..at + NA - i).unwrap_or(&[]);
            for (p, hj) in row.iter().zip(h.iter().skip(i)) {
                acc += p * hj;
            }
            *o = acc;
        }
        let noise: f32 = u.iter().zip(r).map(|(u, r)| u * u * r).sum();
        let s = h.iter().zip(&ph).map(|(h, p)| h * p).sum::<f32>() + noise;
        if s.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
            return;
        }
        let dg = self.xa.get(DG).copied().unwrap_or(0.0);
        let innovation = g0 + dg - norm;
        for (x, p) in self.xa.iter_mut().zip(&ph) {
            *x += p / s * innovation;
        }
        // P - (P h)(P h)' / s, row by row over the packed upper triangle.
        let mut start = 0;
        for (i, a) in ph.iter().enumerate() {
            let len = NA - i;
            if let Some(row) = self.pa.get_mut(start..start + len) {
                for (p, b) in row.iter_mut().zip(ph.iter().skip(i)) {
                    *p -= a * b / s;
                }
                // Rounding must not make a variance negative.
                if let Some(d) = row.first_mut() {
                    *d = d.max(0.0);
                }
            }
            start += len;
        }
    }

    /// `phi_a' M phi_b` for the block `(a, b)` of the state covariance.
    fn form(&self, a: usize, b: usize) -> f32 {
        let (pa, pb) = (self.phi.get(a), self.phi.get(b));
        let mut sum = 0.0;
        for i in 0..FEATURES {
            for j in 0..FEATURES {
                let fi = pa.and_then(|p| p.get(i)).copied().unwrap_or(0.0);
                let fj = pb.and_then(|p| p.get(j)).copied().unwrap_or(0.0);
                sum += fi * self.p(a * FEATURES + i, b * FEATURES + j) * fj;
            }
        }
        sum
    }

    /// The refined biases `[ax, ay, az, wx, wy, wz]`: the accelerometer's at the present pose.
    pub fn bias(&self) -> [f32; OUTPUTS] {
        let [a0, a1, a2] = self.accel_error();
        let [g0, g1, g2] = self.xg;
        [a0, a1, a2, g0, g1, g2]
    }

    /// Their variances.
    pub fn variance(&self) -> [f32; OUTPUTS] {
        let [g0, g1, g2] = self.pg;
        [
            self.form(0, 0),
            self.form(1, 1),
            self.form(2, 2),
            g0,
            g1,
            g2,
        ]
    }

    /// The accelerometer biases' covariance at the present pose, packed upper triangle
    /// (`00 01 02 11 12 22`).
    pub fn accel_covariance(&self) -> [f32; 6] {
        [
            self.form(0, 0),
            self.form(0, 1),
            self.form(0, 2),
            self.form(1, 1),
            self.form(1, 2),
            self.form(2, 2),
        ]
    }

    /// Each bias's prior-predictive variance at the present pose: the prior and every process
    /// noise added.
    pub fn spread(&self) -> [f32; OUTPUTS] {
        let [a0, a1, a2] = self.accel_spread;
        let [g0, g1, g2] = self.gyro_spread;
        [a0, a1, a2, g0, g1, g2]
    }

    /// The gravity error's estimate and variance.
    pub fn gravity_error(&self) -> (f32, f32) {
        (self.xa.get(DG).copied().unwrap_or(0.0), self.p(DG, DG))
    }

    /// The largest per-axis statistic `x^2 / (spread - P)` over the biases the data observe,
    /// and how many they are.
    pub fn statistic(&self) -> (f32, u8) {
        let mut worst = 0.0f32;
        let mut used = 0u8;
        for ((x, p), s) in self.bias().iter().zip(self.variance()).zip(self.spread()) {
            let v = s - p;
            if v > OBSERVED * s {
                worst = worst.max(x * x / v);
                used += 1;
            }
        }
        (worst, used)
    }
}

/// Each axis' stated error variance under the features `phi`: `phi' C phi` of its block's
/// prior `C`.
pub(super) fn stated_at(prior: &[[f32; BLOCK]; 3], phi: &[[f32; FEATURES]; 3]) -> [f32; 3] {
    core::array::from_fn(|axis| {
        let (Some(block), Some(phi)) = (prior.get(axis), phi.get(axis)) else {
            return 0.0;
        };
        let mut sum = 0.0;
        for (i, fi) in phi.iter().enumerate() {
            for (j, fj) in phi.iter().enumerate() {
                sum += fi * block.get(packed(FEATURES, i, j)).copied().unwrap_or(0.0) * fj;
            }
        }
        sum
    })
}

#[cfg(test)]
#[expect(clippy::indexing_slicing, reason = "test arithmetic on fixed arrays")]
mod tests {
    use super::*;

    /// Biases of variance `b` and no other error: features of a pose `f`.
    fn bias_only(b: f32) -> [[f32; BLOCK]; 3] {
        let mut block = [0.0; BLOCK];
        block[0] = b;
        [block; 3]
    }

    fn phi(f: [f32; 3]) -> [[f32; FEATURES]; 3] {
        core::array::from_fn(|i| {
            [
                1.0,
                f[0],
                f[1],
                f[2],
                f[i] * f[i],
                f[i].abs(),
                f[i] * f[i] * f[i],
                f[i] * f[i].abs(),
            ]
        })
    }

    #[test]
    fn packing_is_row_by_row() {
        assert_eq!(packed(5, 0, 4), 4);
        assert_eq!(packed(5, 1, 1), 5);
        assert_eq!(packed(5, 4, 4), 14);
        assert_eq!(packed(5, 3, 1), packed(5, 1, 3));
        assert_eq!(packed(NA, NA - 1, NA - 1), PACKED - 1);
    }

    #[test]
    fn one_pose_observes_the_bias_along_gravity_only() {
        let z_up = [0.0, 0.0, 9.8];
        let mut f = Filter::new(&bias_only(1e-4), &[0.0; 3], &[1e-6; 3], 1e-8, &phi(z_up));
        // z up, a bias of 0.02 on z and 0.02 on x.
        let m = [0.02, 0.0, 9.8 + 0.02];
        for _ in 0..100 {
            f.update_accel(
                &m,
                &[1e-6; 3],
                9.8,
                (&phi(m), &stated_at(&bias_only(1e-4), &phi(m))),
            );
        }
        let [bx, by, bz, ..] = f.bias();
        assert!((bz - 0.02).abs() < 1e-3, "{bz}");
        assert!(bx.abs() < 1e-3 && by.abs() < 1e-3);
        let [vx, vy, vz, ..] = f.variance();
        assert!(vx > 0.99e-4 && vy > 0.99e-4, "prior kept across gravity");
        assert!(vz < 1e-6);
        // Turned on its side, x is observed too.
        let m = [9.8 + 0.02, 0.0, 0.02];
        for _ in 0..100 {
            f.update_accel(
                &m,
                &[1e-6; 3],
                9.8,
                (&phi(m), &stated_at(&bias_only(1e-4), &phi(m))),
            );
        }
        let [bx, _, bz, ..] = f.bias();
        assert!(
            (bx - 0.02).abs() < 2e-3 && (bz - 0.02).abs() < 2e-3,
            "{bx} {bz}"
        );
    }

    #[test]
    fn a_scale_error_seen_in_one_pose_is_not_taken_for_a_bias_in_the_next() {
        // z's error is mostly its own scale: 0.02 at z up is 0.002 of scale times 9.8.
        let mut block = [0.0; BLOCK];
        block[packed(FEATURES, 0, 0)] = 1e-8;
        block[packed(FEATURES, 3, 3)] = 4e-6;
        let mut f = Filter::new(
            &[block; 3],
            &[0.0; 3],
            &[1e-6; 3],
            1e-10,
            &phi([0.0, 0.0, 9.8]),
        );
        let m = [0.0, 0.0, 9.8 + 0.0196];
        for _ in 0..200 {
            f.update_accel(
                &m,
                &[1e-7; 3],
                9.8,
                (&phi(m), &stated_at(&[block; 3], &phi(m))),
            );
        }
        assert!((f.bias()[2] - 0.0196).abs() < 1e-3, "{:?}", f.bias());
        // On its side, z across gravity: its error there is its bias, about 0, not 0.0196.
        f.phi = phi([9.8, 0.0, 0.0]);
        assert!(f.bias()[2].abs() < 1e-3, "{:?}", f.bias());
        assert!(f.variance()[2] < 1e-7, "{:?}", f.variance());
    }

    #[test]
    fn gyro_bias_and_its_statistic() {
        let mut f = Filter::new(
            &bias_only(1e-4),
            &[0.0; 3],
            &[1e-6; 3],
            1e-8,
            &phi([0.0, 0.0, 9.8]),
        );
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
