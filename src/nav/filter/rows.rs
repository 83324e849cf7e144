//! The sensitivity rows of the measurements the filter takes (a velocity, a GNSS antenna's
//! position, a late fix's, the barometer's height) and their predicted values.

use nalgebra::Vector3;

use super::{ErrorFilter, StateVector, index, skew};
use crate::nav::real::Real;

impl<T: Real> ErrorFilter<T> {
    /// The estimate's velocity sensitivity row for the level-frame axis `axis` (0 east, 1
    /// north, 2 up), with the innovation `measured - v` for a measured velocity.
    #[must_use]
    pub fn velocity_row(axis: usize) -> StateVector<T> {
        let mut h = StateVector::zeros();
        if let Some(x) = h.get_mut(index::VELOCITY + axis) {
            *x = T::one();
        }
        h
    }

    /// The sensitivity row of an antenna at `lever` (body axes, m, from the unit) along the
    /// level-frame axis `axis`, and the antenna's estimated position on that axis.
    #[must_use]
    pub fn antenna_row(&self, lever: &Vector3<T>, axis: usize) -> (StateVector<T>, T) {
        let arm = self.estimate.nav.attitude() * lever;
        let at = self.estimate.nav.p + arm;
        let mut h = StateVector::zeros();
        if let Some(x) = h.get_mut(index::POSITION + axis) {
            *x = T::one();
        }
        // p_true + C_true l = p + dp + C l + psi x (C l): -[(C l) x] psi.
        let m = -skew(&arm);
        for j in 0..3 {
            if let (Some(x), Some(v)) = (h.get_mut(index::ATTITUDE + j), m.get((axis, j))) {
                *x = *v;
            }
        }
        (h, at.get(axis).copied().unwrap_or_else(T::zero))
    }

    /// A GNSS fix's sensitivity row along the level-frame axis `axis` for an antenna at
    /// `lever` and the fix's predicted value there: the antenna's position
    /// ([`antenna_row`](Self::antenna_row)) plus the receiver's estimated error.
    #[must_use]
    pub fn fix_row(&self, lever: &Vector3<T>, axis: usize) -> (StateVector<T>, T) {
        let (mut h, at) = self.antenna_row(lever, axis);
        if let Some(x) = h.get_mut(index::RECEIVER + axis) {
            *x = T::one();
        }
        let e = self
            .estimate
            .receiver
            .get(axis)
            .copied()
            .unwrap_or_else(T::zero);
        (h, at + e)
    }

    /// The sensitivity row of a velocity measured `back` s ago (a late fix's) along the
    /// level-frame axis `axis`: the errors then were the errors now less `back` times their
    /// rate (`dv(t - back) = dv - back F_v dx`). The rate carries the attitude's error through
    /// the specific force: a shell decelerating at 3 g with its attitude 50 mrad off sees its
    /// velocity's rate 1.5 m/s^2 wrong, 0.12 m/s over an 80 ms latency, which a fix's own
    /// 0.1 m/s would otherwise blame on the velocity now.
    #[must_use]
    pub fn velocity_row_back(&self, axis: usize, back: T) -> StateVector<T> {
        let mut h = Self::velocity_row(axis);
        if axis < 3 {
            h -= self.velocity_rates.row(axis).transpose() * back;
        }
        h
    }

    /// [`fix_row`](Self::fix_row) for a fix `back` s ago: the position's error then was the
    /// error now less `back` times the velocity's.
    #[must_use]
    pub fn fix_row_back(&self, lever: &Vector3<T>, axis: usize, back: T) -> (StateVector<T>, T) {
        let (mut h, at) = self.fix_row(lever, axis);
        if let Some(x) = h.get_mut(index::VELOCITY + axis) {
            *x -= back;
        }
        (h, at)
    }

    /// The barometer's sensitivity row and its predicted reading (height of the unit plus the
    /// barometer's bias, m above the origin).
    #[must_use]
    pub fn baro_row(&self) -> (StateVector<T>, T) {
        let mut h = StateVector::zeros();
        for i in [index::POSITION + 2, index::BARO] {
            if let Some(x) = h.get_mut(i) {
                *x = T::one();
            }
        }
        (h, self.estimate.nav.p.z + self.estimate.sensors.baro_bias)
    }
}
