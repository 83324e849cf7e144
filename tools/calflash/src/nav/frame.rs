//! The flight's level frame at its origin: a fix's position and velocity in it, and the
//! barometer's heights.

use nalgebra::Vector3;

use super::input::{Fix, Pressure};
use crate::sim::flight::atmosphere;

/// Pressure altitude of the standard atmosphere's troposphere, m.
#[must_use]
pub fn pressure_height(pa: f64) -> f64 {
    const T0: f64 = 288.15;
    const L: f64 = 0.0065;
    const P0: f64 = 101_325.0;
    const R: f64 = 287.052_87;
    T0 / L * (1.0 - (pa / P0).powf(R * L / atmosphere::G0))
}

/// The pressure height of the pad: of the mean pressure read more than 0.1 s before the
/// launch `t_launch`, or of the first reading when none was.
#[must_use]
pub fn pad_height(baro: &[Pressure], t_launch: f64) -> f64 {
    let pad: Vec<f64> = baro
        .iter()
        .filter(|b| b.t < t_launch - 0.1)
        .map(|b| b.pa)
        .collect();
    let p = if pad.is_empty() {
        baro.first().map_or(101_325.0, |b| b.pa)
    } else {
        pad.iter().sum::<f64>() / pad.len() as f64
    };
    pressure_height(p)
}

/// A fix's position in the level frame of `origin`.
#[must_use]
pub fn level_position(fix: &Fix, origin: (f64, f64, f64)) -> [f64; 3] {
    let (e, n, u) = map_3d::geodetic2enu(
        fix.lat_lon.0.to_radians(),
        fix.lat_lon.1.to_radians(),
        fix.height.unwrap_or(origin.2),
        origin.0.to_radians(),
        origin.1.to_radians(),
        origin.2,
        map_3d::Ellipsoid::WGS84,
    );
    [e, n, u]
}

/// A fix's velocity in the level frame of `origin`: a receiver gives east, north and up at its
/// own position, whose axes turn from the origin's by the distance over the Earth's radius (1
/// mrad at 6 km: 0.5 m/s of a shell's 500 m/s).
#[must_use]
pub fn level_velocity(fix: &Fix, origin: (f64, f64, f64)) -> Option<[f64; 3]> {
    use crate::sim::flight::site::enu_from_ecef;
    let v = Vector3::from(fix.velocity?);
    let at_fix = enu_from_ecef(fix.lat_lon.0, fix.lat_lon.1);
    let at_origin = enu_from_ecef(origin.0, origin.1);
    Some((at_origin * at_fix.transpose() * v).into())
}
