//! What the IMU corrector says about its own outputs: the variance that quantisation and
//! noise give one corrected sample at rest, and the 1-sigma calibration error of each output
//! (from the covariance factors the blob carries).

use super::super::factor_norm;
use super::super::sample::Sample;
use super::ImuCorrector;
use crate::model::rotation;
use crate::model::{IMU_FEATURES, ImuCovariance, ImuOutputCovariance};

/// The accelerometer features of [`IMU_FEATURES`](crate::model::IMU_FEATURES) that do not
/// vanish at rest: the bias, the sensitivity row and the nonlinear terms (the lever arm's
/// gradient is zero without a spin).
pub const REST_FEATURES: [usize; 8] = [0, 1, 2, 3, 7, 8, 9, 10];

/// Elements of a packed upper triangle over [`REST_FEATURES`].
const REST_BLOCK: usize = REST_FEATURES.len() * (REST_FEATURES.len() + 1) / 2;

/// The nonlinear terms' features of what an axis senses, `x`, in the order of
/// [`IMU_FEATURES`](crate::model::IMU_FEATURES): `x^2, |x|, x^3, x |x|`.
fn nonlinear_features(x: f32) -> [f32; 4] {
    let (a, s) = (libm::fabsf(x), x * x);
    [s, a, s * x, x * a]
}

impl<S: Sample> ImuCorrector<'_, S> {
    /// Per output, the variance that quantisation adds to one corrected sample:
    /// `sum_j M_ij^2 / 12` (a code is uniform over its width).
    #[must_use]
    pub fn quantisation_variance(&self) -> [f32; 6] {
        let row = |m: &[f32; 3]| m.iter().map(|x| x * x).sum::<f32>() / 12.0;
        let [a0, a1, a2] = &self.accel.m;
        let [g0, g1, g2] = &self.gyro.m;
        [row(a0), row(a1), row(a2), row(g0), row(g1), row(g2)]
    }

    /// Per output, the variance of one corrected sample of a unit at rest whose outputs carry
    /// noise of variance `own` per sample (white noise and quantisation,
    /// [`quantisation_variance`](Self::quantisation_variance)): the accelerometer's with the
    /// tangential lever term of the gyro noise's backward difference (`2 var` per rate, through
    /// the coefficients that fold in the sample rate), the gyro's with the g-sensitivity of the
    /// accelerometer noise.
    #[must_use]
    pub fn sample_variance(&self, own: &[f32; 6]) -> [f32; 6] {
        let v = *own;
        let [a0, a1, a2, g0, g1, g2] = v;
        let (accel, gyro) = ([a0, a1, a2], [g0, g1, g2]);
        let through = |row: &[f32; 3], var: &[f32; 3], k: f32| -> f32 {
            row.iter().zip(var).map(|(c, v)| c * c * v * k).sum()
        };
        let mut out = v;
        for (i, o) in out.iter_mut().enumerate() {
            *o += match i {
                0..3 => self
                    .terms
                    .tangential
                    .get(i)
                    .map_or(0.0, |t| through(t, &gyro, 2.0)),
                _ => self
                    .neg_g
                    .get(i - 3)
                    .map_or(0.0, |g| through(g, &accel, 1.0)),
            };
        }
        out
    }

    /// The 1-sigma calibration error of each output of a corrected sample `values`
    /// (`[ax, ay, az, wx, wy, wz]`, as [`correct`](Self::correct) gave them) at the current
    /// environment: bias, sensitivity and misalignment, lever arm, g-sensitivity and g-squared
    /// terms, over the features of [`IMU_FEATURES`](crate::model::IMU_FEATURES) (the
    /// tangential term is left out of them: it is a small part of the spin's at any rate a
    /// round spins up at). `None` when the calibration has no covariance factors. With an
    /// [`Overlay`](super::Overlay), each refined bias's variance stands in for the factory bias's own.
    #[must_use]
    pub fn sigma(&self, values: &[f32; 6]) -> Option<[f32; 6]> {
        let (mut norms, own) = self.factor_norms(values)?;
        if let Some(overlay) = &self.overlay {
            for ((n, b), v) in norms.iter_mut().zip(own).zip(overlay.variance) {
                *n = libm::sqrtf((*n * *n - b * b).max(0.0) + v);
            }
        }
        Some(norms)
    }

    /// The accelerometer error's features at rest (no spin) under the specific force `f`, per
    /// axis `i`: `[1, f_0, f_1, f_2, x_i^2, |x_i|, x_i^3, x_i |x_i|]` with `x_i = n_i . f`, the
    /// features of
    /// [`IMU_FEATURES`](crate::model::IMU_FEATURES) that do not vanish at rest
    /// ([`REST_FEATURES`] picks them). The axis' error is their dot product with its
    /// parameters' error.
    #[must_use]
    pub fn accel_rest_features(&self, f: &[f32; 3]) -> [[f32; REST_FEATURES.len()]; 3] {
        let [na, _] = &self.directions;
        core::array::from_fn(|i| {
            let x = na.get(i).map_or(0.0, |n| rotation::dot(n, f));
            let [s, a, c, o] = nonlinear_features(x);
            [1.0, f[0], f[1], f[2], s, a, c, o]
        })
    }

    /// Per accelerometer axis, the covariance of its parameters' error over the features of
    /// [`accel_rest_features`](Self::accel_rest_features) (from the factor `L`: `L L'`
    /// restricted to [`REST_FEATURES`]), packed upper triangle row by row (`00 01 .. 04 11 ..
    /// 44`). `None` without covariance factors.
    #[must_use]
    pub fn accel_rest_covariance(&self) -> Option<[[f32; REST_BLOCK]; 3]> {
        let ImuCovariance { accel, .. } = self.covariance.as_ref()?;
        Some(core::array::from_fn(|axis| {
            let packed = accel.get(axis).map_or(&[][..], |a| a.as_flattened());
            let l = |i: usize, j: usize| {
                if j <= i {
                    packed.get(i * (i + 1) / 2 + j).copied().unwrap_or(0.0)
                } else {
                    0.0
                }
            };
            let mut out = [0.0f32; REST_BLOCK];
            let mut k = 0;
            for (a, &fa) in REST_FEATURES.iter().enumerate() {
                for &fb in REST_FEATURES.iter().skip(a) {
                    let c: f32 = (0..=fa.min(fb)).map(|m| l(fa, m) * l(fb, m)).sum();
                    if let Some(o) = out.get_mut(k) {
                        *o = c;
                    }
                    k += 1;
                }
            }
            out
        }))
    }

    /// Per output of the corrected sample `values`, the factory calibration's error variance
    /// (whatever the overlay) and its bias's own part. `None` without covariance factors.
    #[must_use]
    pub fn factory_variances(&self, values: &[f32; 6]) -> Option<([f32; 6], [f32; 6])> {
        let (norms, own) = self.factor_norms(values)?;
        Some((norms.map(|x| x * x), own.map(|x| x * x)))
    }

    /// Per output of the corrected sample `values` (`[ax, ay, az, wx, wy, wz]`), the features
    /// of its calibration error ([`IMU_FEATURES`](crate::model::IMU_FEATURES)): the output's
    /// error is their dot product with its parameters' error, whose covariance the factor of
    /// [`covariance_factors`](Self::covariance_factors) holds. The tangential lever term is
    /// left out (a small part of the spin's at any rate a round spins up at).
    #[must_use]
    pub fn error_features(&self, values: &[f32; 6]) -> [[f32; IMU_FEATURES]; 6] {
        let [f0, f1, f2, w0, w1, w2] = *values;
        let (f, w) = ([f0, f1, f2], [w0, w1, w2]);
        let [na, ng] = &self.directions;
        let zero = [0.0; 3];
        let accel = |i: usize| -> [f32; IMU_FEATURES] {
            let (Some(n), Some(r)) = (na.get(i), self.lever.get(i)) else {
                return [0.0; IMU_FEATURES];
            };
            let at = rotation::force_at(&f, &w, &zero, r);
            let [g0, g1, g2] = rotation::lever_gradient(n, &w, &zero);
            let x = rotation::dot(n, &at);
            let [a0, a1, a2] = at;
            let [s, a, c, o] = nonlinear_features(x);
            [1.0, a0, a1, a2, g0, g1, g2, s, a, c, o]
        };
        let [h0, h1, h2] = self.g_sensitivity(zero, &f).map(|x| -x);
        let sensed_rate = [w0 + h0, w1 + h1, w2 + h2];
        let gyro = |i: usize| -> [f32; IMU_FEATURES] {
            let x = ng.get(i).map_or(0.0, |n| rotation::dot(n, &sensed_rate));
            let [s, a, c, o] = nonlinear_features(x);
            [1.0, w0, w1, w2, f0, f1, f2, s, a, c, o]
        };
        [accel(0), accel(1), accel(2), gyro(0), gyro(1), gyro(2)]
    }

    /// The covariance factors at the current environment (the factory's, whatever the
    /// overlay); `None` when the calibration has none.
    #[must_use]
    pub fn covariance_factors(&self) -> Option<&ImuCovariance> {
        self.covariance.as_ref()
    }

    /// The factory 1-sigma of each output and of its bias alone.
    fn factor_norms(&self, values: &[f32; 6]) -> Option<([f32; 6], [f32; 6])> {
        let ImuCovariance {
            accel: ca,
            gyro: cg,
        } = self.covariance.as_ref()?;
        let [e0, e1, e2, e3, e4, e5] = self.error_features(values);
        let [a0, a1, a2] = ca;
        let [g0, g1, g2] = cg;
        let own = |l: &ImuOutputCovariance| l.as_flattened().first().map_or(0.0, |x| x.abs());
        Some((
            [
                factor_norm(a0.as_flattened(), &e0),
                factor_norm(a1.as_flattened(), &e1),
                factor_norm(a2.as_flattened(), &e2),
                factor_norm(g0.as_flattened(), &e3),
                factor_norm(g1.as_flattened(), &e4),
                factor_norm(g2.as_flattened(), &e5),
            ],
            [own(a0), own(a1), own(a2), own(g0), own(g1), own(g2)],
        ))
    }
}
