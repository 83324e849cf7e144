//! The covariance's step over an interval (the error model's matrices from the interval's
//! integrals, `Phi P Phi' + Q` on the navigation's rows) and the receiver's error's decay.

use nalgebra::{Matrix3, Vector3};

use super::{ErrorFilter, Integrals, NAV, NavRows, STATES, StateVector, Transition, index, skew};
use crate::nav::real::Real;

impl<T: Real> ErrorFilter<T> {
    /// Steps the covariance over the samples navigated since the last step; returns the
    /// transition (the smoother's).
    ///
    /// Only the navigation's nine rows of the error model are not zero (the sensor errors
    /// are random walks), so `Phi` differs from the identity in its first nine rows and
    /// `Phi P Phi'` changes only the first nine rows and columns of `P`: two 9 x 22 x 22
    /// products instead of two 22 x 22 x 22.
    pub fn covariance_step(&mut self) -> Transition<T> {
        use index::*;
        if let Some(s) = self.estimate.nav.flush(&self.earth) {
            self.acc.add(&s);
        }
        let a = self.acc;
        self.acc = Integrals::zero();
        let mut top = NavRows::<T>::zeros();
        for i in 0..NAV {
            if let Some(x) = top.get_mut((i, i)) {
                *x = T::one();
            }
        }
        if a.dt <= T::zero() {
            return Transition {
                top,
                receiver_decay: T::one(),
            };
        }
        let inv = T::one() / a.dt;
        let omega = self.earth.rate();
        let grad = self.earth.gravity_gradient(self.estimate.nav.p.z);
        let mut f = NavRows::<T>::zeros();
        let mut put = |r: usize, c: usize, m: Matrix3<T>| {
            f.fixed_view_mut::<3, 3>(r, c).copy_from(&m);
        };
        put(POSITION, VELOCITY, Matrix3::identity());
        put(VELOCITY, POSITION, Matrix3::from_diagonal(&grad));
        put(
            VELOCITY,
            VELOCITY,
            skew(&omega) * nalgebra::convert::<f64, T>(-2.0),
        );
        put(VELOCITY, ATTITUDE, -skew(&(a.f * inv)));
        put(VELOCITY, ACCEL_BIAS, -a.c * inv);
        put(VELOCITY, ACCEL_SCALE, -a.cf * inv);
        put(ATTITUDE, ATTITUDE, -skew(&omega));
        put(ATTITUDE, GYRO_BIAS, -a.c * inv);
        put(ATTITUDE, GYRO_SCALE, -a.cw * inv);
        self.velocity_rates = f.fixed_rows::<3>(VELOCITY).into_owned();
        // Phi = I + F dt + (F dt)^2 / 2, of which only the top rows are not the identity's.
        let fd = f * a.dt;
        let square = fd.fixed_columns::<NAV>(0) * fd;
        top += fd + square * nalgebra::convert::<f64, T>(0.5);
        let rows = top * self.covariance;
        self.covariance.fixed_rows_mut::<NAV>(0).copy_from(&rows);
        let columns = self.covariance * top.transpose();
        self.covariance
            .fixed_columns_mut::<NAV>(0)
            .copy_from(&columns);
        let n = &self.noise;
        let mut q = StateVector::<T>::zeros();
        let mut fill = |at: usize, len: usize, v: T| {
            for i in at..at + len {
                if let Some(x) = q.get_mut(i) {
                    *x = v;
                }
            }
        };
        fill(
            VELOCITY,
            3,
            n.accel_white * n.accel_white * a.dt + a.lost.0 * a.lost.0,
        );
        fill(
            ATTITUDE,
            3,
            n.gyro_white * n.gyro_white * a.dt + a.lost.1 * a.lost.1,
        );
        fill(ACCEL_BIAS, 3, n.accel_walk * n.accel_walk * a.dt);
        fill(GYRO_BIAS, 3, n.gyro_walk * n.gyro_walk * a.dt);
        fill(ACCEL_SCALE, 6, n.scale_walk * n.scale_walk * a.dt);
        fill(BARO, 1, n.baro_walk * n.baro_walk * a.dt);
        // The two products round the corner blocks differently: hold P symmetric.
        let half: T = nalgebra::convert(0.5);
        for i in 0..NAV {
            for j in i + 1..STATES {
                if let (Some(x), Some(y)) = (
                    self.covariance.get((i, j)).copied(),
                    self.covariance.get((j, i)).copied(),
                ) {
                    let m = (x + y) * half;
                    if let Some(v) = self.covariance.get_mut((i, j)) {
                        *v = m;
                    }
                    if let Some(v) = self.covariance.get_mut((j, i)) {
                        *v = m;
                    }
                }
            }
        }
        for (i, qi) in q.iter().enumerate() {
            if let Some(v) = self.covariance.get_mut((i, i)) {
                *v += *qi;
            }
        }
        let moved = top * self.dx;
        self.dx.fixed_rows_mut::<NAV>(0).copy_from(&moved);
        let receiver_decay = self.receiver_step(a.dt);
        Transition {
            top,
            receiver_decay,
        }
    }

    /// The receiver's error over `dt` s: its estimate and its rows and columns of the
    /// covariance decay by `phi = exp(-dt / tau)`, its variance gains `sigma^2 (1 - phi^2)`.
    /// Returns `phi`.
    fn receiver_step(&mut self, dt: T) -> T {
        let phi = self.noise.receiver_decay(dt);
        if self.noise.receiver_sigma == Vector3::zeros() {
            return phi;
        }
        let gain = T::one() - phi * phi;
        for (k, sigma) in self.noise.receiver_sigma.iter().enumerate() {
            let i = index::RECEIVER + k;
            for j in 0..STATES {
                if let Some(x) = self.covariance.get_mut((i, j)) {
                    *x *= phi;
                }
                if let Some(x) = self.covariance.get_mut((j, i)) {
                    *x *= phi;
                }
            }
            if let Some(x) = self.covariance.get_mut((i, i)) {
                *x += *sigma * *sigma * gain;
            }
            if let Some(x) = self.dx.get_mut(i) {
                *x *= phi;
            }
        }
        self.estimate.receiver *= phi;
        phi
    }
}
