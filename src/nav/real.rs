//! The scalar the navigation runs on: `f32` on a round, `f64` on the host. Its sines, cosines
//! and powers are the same code on every target (the host's `std` would otherwise take the
//! platform's own), so the device's filter and the same code on the host give the same bits:
//! `libm` for `f64`, and for `f32` the sine and cosine below (`libm`'s `sincosf` works in
//! double precision, which the Cortex-M4F does in software: 2,000 instructions a call).

use nalgebra::{Quaternion, RealField, UnitQuaternion, Vector3};

/// A scalar the navigation runs on.
pub trait Real: RealField + Copy {
    /// `(sin x, cos x)`, from `libm`.
    fn sin_cos_libm(self) -> (Self, Self);
    /// `self^e`, from `libm`.
    fn powf_libm(self, e: Self) -> Self;
    /// The square root, correctly rounded: `crate::sqrt::sqrtf` for `f32` (the FPU's on the
    /// Cortex-M4F), `libm`'s for `f64` (nalgebra's own takes the platform's with `std`).
    fn sqrt_libm(self) -> Self;
    /// `atan2(self, x)`, from `libm`.
    fn atan2_libm(self, x: Self) -> Self;
    /// `e^self`, from `libm`.
    fn exp_libm(self) -> Self;
    /// This value as an `f64`.
    fn to_f64(self) -> f64;
}

/// `(sin x, cos x)` in single precision: `x` reduced to `[-pi/4, pi/4]` by multiples of
/// `pi/2` (Cody and Waite's three-part constant), then Cephes' minimax polynomials (within
/// 2 ulp of the true values for `|x|` up to 10^4, `tests` below).
fn sin_cos_f32(x: f32) -> (f32, f32) {
    const DP1: f32 = 1.570_312_5;
    const DP2: f32 = 4.837_513e-4;
    const DP3: f32 = 7.549_79e-8;
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let j = libm::roundf(x * core::f32::consts::FRAC_2_PI);
    let y = ((x - j * DP1) - j * DP2) - j * DP3;
    let z = y * y;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * y + y;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    // The quadrant, from j modulo 4 (j is an integer within i32 for |x| < 3e9).
    let q = if j.abs() < 2.0e9 { (j as i32) & 3 } else { 0 };
    match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

impl Real for f32 {
    fn sin_cos_libm(self) -> (Self, Self) {
        sin_cos_f32(self)
    }
    fn powf_libm(self, e: Self) -> Self {
        libm::powf(self, e)
    }
    fn atan2_libm(self, x: Self) -> Self {
        libm::atan2f(self, x)
    }
    fn exp_libm(self) -> Self {
        libm::expf(self)
    }
    fn sqrt_libm(self) -> Self {
        crate::sqrt::sqrtf(self)
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
    fn exp_libm(self) -> Self {
        libm::exp(self)
    }
    fn sqrt_libm(self) -> Self {
        libm::sqrt(self)
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// The count `n` (microseconds, samples) as a `T`: the value `n as f64` converted to `T`
/// gives, but below 2^24 by single precision's own conversion (exact there), so that a
/// Cortex-M4F, whose FPU has no double precision, converts it in one instruction instead of
/// two calls into software.
#[must_use]
#[inline]
pub fn from_count<T: Real>(n: u64) -> T {
    match u32::try_from(n) {
        Ok(small) if small < 1 << 24 => nalgebra::convert::<f32, T>(small as f32),
        _ => nalgebra::convert::<f64, T>(n as f64),
    }
}

/// The rotation by the rotation vector `v` (axis times angle, rad).
#[must_use]
pub fn rotation<T: Real>(v: &Vector3<T>) -> UnitQuaternion<T> {
    let angle = v.norm_squared().sqrt_libm();
    if angle <= T::zero() || !angle.is_finite() {
        return UnitQuaternion::identity();
    }
    let half: T = nalgebra::convert(0.5);
    let (s, c) = (angle * half).sin_cos_libm();
    UnitQuaternion::new_unchecked(Quaternion::from_parts(c, v * (s / angle)))
}

/// `q` scaled to unit length.
#[must_use]
pub fn normalised<T: Real>(q: Quaternion<T>) -> UnitQuaternion<T> {
    let n = q.coords.norm_squared().sqrt_libm();
    UnitQuaternion::new_unchecked(q / n)
}

/// The smallest rotation that takes the direction of `from` to that of `to` (a half turn
/// about an axis across `from` when they are opposite; none when either is zero).
#[must_use]
pub fn rotation_between<T: Real>(from: &Vector3<T>, to: &Vector3<T>) -> UnitQuaternion<T> {
    let (a, b) = (
        from.norm_squared().sqrt_libm(),
        to.norm_squared().sqrt_libm(),
    );
    if a <= T::zero() || b <= T::zero() {
        return UnitQuaternion::identity();
    }
    // The half-angle form, without trigonometry: q ~ (|a||b| + a.b, a x b), the first term
    // as |a x b|^2 / (|a||b| - a.b) when the two nearly oppose (no cancellation).
    let axis = from.cross(to);
    let dot = from.dot(to);
    let w = if dot >= T::zero() {
        a * b + dot
    } else {
        axis.norm_squared() / (a * b - dot)
    };
    let scale = a * b;
    if w * w + axis.norm_squared() > scale * scale * nalgebra::convert::<f64, T>(1e-12) {
        return normalised(Quaternion::from_parts(w, axis));
    }
    // Opposite: any axis across `from`.
    let across = if from.x.abs() < from.y.abs().max(from.z.abs()) {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let axis = from.cross(&across);
    rotation(&(axis * (T::pi() / axis.norm_squared().sqrt_libm())))
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
    fn the_f32_sine_and_cosine_are_within_two_ulp() {
        let mut worst = 0.0f64;
        let mut x = -1.0e4f32;
        while x < 1.0e4 {
            let (s, c) = sin_cos_f32(x);
            let (ts, tc) = (f64::from(x).sin(), f64::from(x).cos());
            for (got, want) in [(s, ts), (c, tc)] {
                let ulp = f64::from(f32::EPSILON) * want.abs().max(2f64.powi(-10));
                worst = worst.max((f64::from(got) - want).abs() / ulp);
            }
            x += 0.013_7;
        }
        // 1.11 ulp at the last run.
        assert!(worst < 2.0, "{worst} ulp");
        for x in [
            0.0f32,
            1e-20,
            -1e-20,
            0.5,
            core::f32::consts::FRAC_PI_2,
            core::f32::consts::PI,
        ] {
            let (s, c) = sin_cos_f32(x);
            assert!((f64::from(s) - f64::from(x).sin()).abs() < 2e-7, "{x}");
            assert!((f64::from(c) - f64::from(x).cos()).abs() < 2e-7, "{x}");
        }
        assert!(sin_cos_f32(f32::NAN).0.is_nan());
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
