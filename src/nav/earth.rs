//! The Earth a round flies over, in a local level frame fixed to the Earth at the launch point
//! (east, north, up): the WGS-84 normal gravity with its fall-off with height and its tilt
//! toward the Earth's centre away from the origin, and the Earth's rate. The navigator and the
//! host's flight simulator share it, so a simulated flight and its navigation see one world.

use nalgebra::{RealField, Vector3};

use super::real::Real;

/// The Earth's rotation rate, rad/s (WGS 84).
pub const RATE: f64 = 7.292_115e-5;
/// The semi-major axis, m (WGS 84).
pub const SEMI_MAJOR: f64 = 6_378_137.0;
/// The flattening (WGS 84).
pub const FLATTENING: f64 = 1.0 / 298.257_223_563;
/// The first eccentricity squared (WGS 84).
pub const ECCENTRICITY2: f64 = 6.694_379_990_14e-3;
/// Normal gravity at the equator, m/s^2 (WGS 84).
pub const GRAVITY_EQUATOR: f64 = 9.780_325_335_9;
/// Somigliana's constant `k = b g_p / (a g_e) - 1` (WGS 84).
pub const SOMIGLIANA_K: f64 = 1.931_852_652_41e-3;
/// `m = w^2 a^2 b / GM` (WGS 84).
pub const GRAVITY_M: f64 = 3.449_786_003_08e-3;

/// The launch point: where the local level frame's origin is, with what the navigation asks
/// of it at every sample worked out once (the Earth's rate, the radii, the surface gravity).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Earth<T: RealField + Copy> {
    latitude: T,
    height: T,
    rate: Vector3<T>,
    radii: (T, T),
    surface_gravity: T,
    /// The fall-off with height `h`: `g(h) = g(0) (1 - k1 h + k2 h^2)`.
    falloff: (T, T),
}

fn c<T: RealField + Copy>(x: f64) -> T {
    nalgebra::convert(x)
}

impl<T: Real> Earth<T> {
    /// The origin at geodetic latitude `latitude` (rad) and `height` m above the ellipsoid.
    #[must_use]
    pub fn new(latitude: T, height: T) -> Self {
        let (s, cos) = latitude.sin_cos_libm();
        let w: T = c(RATE);
        let sin2 = s * s;
        let e2: T = c(ECCENTRICITY2);
        let w2 = T::one() - e2 * sin2;
        let a: T = c(SEMI_MAJOR);
        let n = a / w2.sqrt_libm();
        let m = a * (T::one() - e2) / (w2 * w2.sqrt_libm());
        let surface_gravity =
            c::<T>(GRAVITY_EQUATOR) * (T::one() + c::<T>(SOMIGLIANA_K) * sin2) / w2.sqrt_libm();
        let f: T = c(FLATTENING);
        let gm: T = c(GRAVITY_M);
        let two: T = c(2.0);
        Self {
            latitude,
            height,
            rate: Vector3::new(T::zero(), w * cos, w * s),
            radii: (m + height, n + height),
            surface_gravity,
            falloff: (
                two / a * (T::one() + f + gm - two * f * sin2),
                c::<T>(3.0) / (a * a),
            ),
        }
    }

    /// Geodetic latitude of the origin, rad.
    #[must_use]
    pub fn latitude(&self) -> T {
        self.latitude
    }

    /// Height of the origin above the ellipsoid, m.
    #[must_use]
    pub fn height(&self) -> T {
        self.height
    }

    /// The Earth's rate in the local level frame (east, north, up), rad/s.
    #[must_use]
    pub fn rate(&self) -> Vector3<T> {
        self.rate
    }

    /// The radii of curvature at the origin, m: along the meridian (north) and across it
    /// (east, the prime vertical).
    #[must_use]
    pub fn radii(&self) -> (T, T) {
        self.radii
    }

    /// The magnitude of normal gravity at height `h` m above the ellipsoid over the origin:
    /// Somigliana's formula and its second-order fall-off with height.
    #[must_use]
    pub fn normal_gravity(&self, h: T) -> T {
        let (k1, k2) = self.falloff;
        self.surface_gravity * (T::one() - k1 * h + k2 * h * h)
    }

    /// Gravity at `p` (m, east-north-up from the origin), m/s^2: down along the normal, tilted
    /// toward the Earth's centre by the horizontal distance over the radius of curvature.
    #[must_use]
    pub fn gravity(&self, p: &Vector3<T>) -> Vector3<T> {
        let g = self.normal_gravity(self.height + p.z);
        let (rn, re) = self.radii;
        Vector3::new(-g * p.x / re, -g * p.y / rn, -g)
    }

    /// The gradient of [`gravity`](Self::gravity) at height `h` above the origin: the diagonal
    /// `(-g/R_e, -g/R_n, 2g/R)` (a height error feeds back on itself: the vertical channel's
    /// instability).
    #[must_use]
    pub fn gravity_gradient(&self, h: T) -> Vector3<T> {
        let g = self.normal_gravity(self.height + h);
        let (rn, re) = self.radii;
        let r = (rn * re).sqrt_libm();
        Vector3::new(-g / re, -g / rn, c::<T>(2.0) * g / r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_gravity_matches_the_wgs84_tables() {
        // WGS 84 (NIMA TR8350.2): 9.7803253359 at the equator, 9.8321849378 at the poles.
        let at = |lat: f64| Earth::new(lat.to_radians(), 0.0);
        assert!((at(0.0).normal_gravity(0.0) - 9.780_325_335_9).abs() < 1e-9);
        assert!((at(90.0).normal_gravity(0.0) - 9.832_184_937_8).abs() < 1e-9);
        // The free-air gradient, about 3.086e-6 s^-2.
        let e = at(45.0);
        let grad = (e.normal_gravity(0.0) - e.normal_gravity(1000.0)) / 1000.0;
        assert!((grad - 3.086e-6).abs() < 0.01e-6, "{grad}");
        let f32_earth = Earth::<f32>::new(core::f32::consts::FRAC_PI_4, 0.0);
        assert!((f32_earth.normal_gravity(0.0) - e.normal_gravity(0.0) as f32).abs() < 1e-5);
    }

    #[test]
    fn gravity_tilts_toward_the_centre_and_the_rate_lies_in_the_meridian() {
        let e = Earth::new(0.7_f64, 100.0);
        let g = e.gravity(&Vector3::new(10_000.0, 0.0, 0.0));
        assert!(g.x < 0.0 && (g.x / g.z - 10_000.0 / e.radii().1).abs() < 1e-12);
        let w = e.rate();
        assert!((w.norm() - RATE).abs() < 1e-18 && w.x == 0.0);
    }
}
