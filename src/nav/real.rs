//! The scalar the navigation runs on: `f32` on a round, `f64` on the host. Its sines, cosines
//! and powers come from `libm` on every target, so the device's filter and the same code on
//! the host give the same bits (the host's `std` would otherwise take the platform's own).

use nalgebra::{Quaternion, RealField, UnitQuaternion, Vector3};

/// A scalar the navigation runs on.
pub trait Real: RealField + Copy {
    /// `(sin x, cos x)`, from `libm`.
    fn sin_cos_libm(self) -> (Self, Self);
    /// `self^e`, from `libm`.
    fn powf_libm(self, e: Self) -> Self;
    /// `atan2(self, x)`, from `libm`.
    fn atan2_libm(self, x: Self) -> Self;
    /// This value as an `f64`.
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    fn sin_cos_libm(self) -> (Self, Self) {
        libm::sincosf(self)
    }
    fn powf_libm(self, e: Self) -> Self {
        libm::powf(self, e)
    }
    fn atan2_libm(self, x: Self) -> Self {
        libm::atan2f(self, x)
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Real for f64 {
    fn sin_cos_libm(self) -> (Self, Self) {
        libm::sincos(self)
    }
    fn powf_libm(self, e: Self) -> Self {
        libm::pow(self, e)
    }
    fn atan2_libm(self, x: Self) -> Self {
        libm::atan2(self, x)
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// The rotation by the rotation vector `v` (axis times angle, rad).
#[must_use]
pub fn rotation<T: Real>(v: &Vector3<T>) -> UnitQuaternion<T> {
    let angle = v.norm();
    if angle <= T::zero() || !angle.is_finite() {
        return UnitQuaternion::identity();
    }
    let half: T = nalgebra::convert(0.5);
    let (s, c) = (angle * half).sin_cos_libm();
    UnitQuaternion::new_unchecked(Quaternion::from_parts(c, v * (s / angle)))
}

/// The smallest rotation that takes the direction of `from` to that of `to` (a half turn
/// about an axis across `from` when they are opposite; none when either is zero).
#[must_use]
pub fn rotation_between<T: Real>(from: &Vector3<T>, to: &Vector3<T>) -> UnitQuaternion<T> {
    let (a, b) = (from.norm(), to.norm());
    if a <= T::zero() || b <= T::zero() {
        return UnitQuaternion::identity();
    }
    let axis = from.cross(to);
    let sin = axis.norm();
    let angle = sin.atan2_libm(from.dot(to));
    if sin > T::zero() {
        return rotation(&(axis * (angle / sin)));
    }
    if angle <= T::zero() {
        return UnitQuaternion::identity();
    }
    // Opposite: any axis across `from`.
    let across = if from.x.abs() < from.y.abs().max(from.z.abs()) {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let axis = from.cross(&across);
    rotation(&(axis * (T::pi() / axis.norm())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_matches_nalgebra() {
        for v in [
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::new(1e-9, 0.0, 0.0),
            Vector3::new(3.0, 1.0, -2.0),
        ] {
            let a = rotation(&v);
            let b = UnitQuaternion::from_scaled_axis(v);
            assert!(a.angle_to(&b) < 1e-12, "{v}");
        }
        assert_eq!(
            rotation(&Vector3::<f32>::zeros()),
            UnitQuaternion::identity()
        );
    }

    #[test]
    fn rotation_between_takes_one_direction_to_the_other() {
        let z = Vector3::z();
        for v in [
            Vector3::new(0.3, -0.2, 9.0),
            Vector3::new(9.8, 0.0, 0.0),
            Vector3::new(0.0, 0.0, -9.8),
            Vector3::new(1e-3, 0.0, -9.8),
            Vector3::new(0.0, 0.0, 2.0),
        ] {
            let q = rotation_between(&v, &z);
            assert!((q * v.normalize() - z).norm() < 1e-12, "{v}");
        }
    }
}
