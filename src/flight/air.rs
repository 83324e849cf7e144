//! The barometer's height: the standard atmosphere's troposphere (pressure altitude) and its
//! speed of sound, the same on the host and the round.

use crate::nav::Real;

/// Standard gravity, m/s^2.
pub const G0: f64 = 9.806_65;
const T0: f64 = 288.15;
const LAPSE: f64 = 0.0065;
const P0: f64 = 101_325.0;
const R_AIR: f64 = 287.052_87;
const GAMMA: f64 = 1.4;
const TROPOPAUSE_T: f64 = 216.65;

fn c<T: Real>(x: f64) -> T {
    nalgebra::convert(x)
}

/// Pressure altitude of the standard atmosphere's troposphere, m, for a static pressure `pa`
/// in pascals.
#[must_use]
pub fn pressure_height<T: Real>(pa: T) -> T {
    c::<T>(T0 / LAPSE) * (T::one() - (pa / c(P0)).powf_libm(c(R_AIR * LAPSE / G0)))
}

/// The standard atmosphere's speed of sound at `height` m above sea level, m/s (the
/// troposphere's lapse down to the tropopause's temperature).
#[must_use]
pub fn speed_of_sound<T: Real>(height: T) -> T {
    let t = (c::<T>(T0) - c::<T>(LAPSE) * height).max(c(TROPOPAUSE_T));
    (c::<T>(GAMMA * R_AIR) * t).sqrt_libm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_troposphere_matches_its_table() {
        // US Standard Atmosphere 1976: 89,875 Pa at 1 km (geopotential), 340.29 m/s at sea
        // level, 295.07 m/s above the tropopause.
        assert!((pressure_height(89_874.6_f64) - 1000.0).abs() < 0.5);
        assert!(pressure_height(101_325.0_f64).abs() < 1e-9);
        assert!((speed_of_sound(0.0_f64) - 340.29).abs() < 0.01);
        assert!((speed_of_sound(15_000.0_f64) - 295.07).abs() < 0.01);
        assert!((pressure_height(89_874.6_f32) - 1000.0).abs() < 0.5);
    }
}
