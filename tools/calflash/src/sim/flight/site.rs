//! Where a flight is launched on the Earth: the launch point's latitude, longitude and height
//! and the azimuth of fire. With a site, a flight feels the WGS-84 normal gravity with its
//! tilt and fall-off and the Coriolis force of the turning Earth, and its unit senses the
//! Earth's rate, the same Earth ([`spincal::nav::Earth`]) the navigator uses; without one it
//! flies over a flat, still Earth (the linear-theory checks).
//!
//! The flight's frame is x downrange, y left, z up; the level frame east, north, up.

use nalgebra::{Matrix3, Vector3};
use spincal::nav::Earth;

/// A launch point and the azimuth of fire.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Height above the ellipsoid, m.
    pub height: f64,
    /// Azimuth of fire, degrees clockwise from north.
    pub azimuth: f64,
}

impl Site {
    /// The Earth of the navigator at this site.
    #[must_use]
    pub fn earth(&self) -> Earth<f64> {
        Earth::new(self.latitude.to_radians(), self.height)
    }

    /// The rotation from the flight's frame to the level frame (east, north, up).
    #[must_use]
    pub fn to_level(&self) -> Matrix3<f64> {
        let (s, c) = self.azimuth.to_radians().sin_cos();
        Matrix3::new(s, -c, 0.0, c, s, 0.0, 0.0, 0.0, 1.0)
    }

    /// Gravity at `r` (flight frame), m/s^2, in the flight frame.
    #[must_use]
    pub fn gravity(&self, r: &Vector3<f64>) -> Vector3<f64> {
        let m = self.to_level();
        m.transpose() * self.earth().gravity(&(m * r))
    }

    /// The Earth's rate in the flight frame, rad/s.
    #[must_use]
    pub fn rate(&self) -> Vector3<f64> {
        self.to_level().transpose() * self.earth().rate()
    }

    /// Latitude and longitude (degrees) and height (m) of `r` (flight frame).
    #[must_use]
    pub fn geodetic(&self, r: &Vector3<f64>) -> (f64, f64, f64) {
        let e = self.to_level() * r;
        let (lat, lon, h) = map_3d::enu2geodetic(
            e.x,
            e.y,
            e.z,
            self.latitude.to_radians(),
            self.longitude.to_radians(),
            self.height,
            map_3d::Ellipsoid::WGS84,
        );
        (lat.to_degrees(), lon.to_degrees(), h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downrange_points_along_the_azimuth_and_geodetic_positions_go_back_to_the_level_frame() {
        let site = Site {
            latitude: 39.39,
            longitude: -8.29,
            height: 100.0,
            azimuth: 90.0,
        };
        let east = site.to_level() * Vector3::x();
        assert!((east - Vector3::x()).norm() < 1e-12);
        let (lat, lon, h) = site.geodetic(&Vector3::new(5_000.0, 200.0, 3_000.0));
        let (e, n, u) = map_3d::geodetic2enu(
            lat.to_radians(),
            lon.to_radians(),
            h,
            site.latitude.to_radians(),
            site.longitude.to_radians(),
            site.height,
            map_3d::Ellipsoid::WGS84,
        );
        assert!(
            (e - 5_000.0).abs() < 1e-6 && (n - 200.0).abs() < 1e-6 && (u - 3_000.0).abs() < 1e-6
        );
        assert!((site.rate().norm() - spincal::nav::earth::RATE).abs() < 1e-18);
    }
}
