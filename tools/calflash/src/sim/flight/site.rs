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

    /// The rotation from the flight's frame to east, north and up at latitude `lat` and
    /// longitude `lon` (degrees): the level frame at that point, turned from the site's by the
    /// distance over the Earth's radius (what a receiver there gives its velocity in).
    #[must_use]
    pub fn local_enu(&self, lat: f64, lon: f64) -> Matrix3<f64> {
        enu_from_ecef(lat, lon)
            * enu_from_ecef(self.latitude, self.longitude).transpose()
            * self.to_level()
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

/// The rotation from Earth-centred, Earth-fixed axes to east, north, up at geodetic latitude
/// `lat` and longitude `lon`, degrees.
#[must_use]
pub fn enu_from_ecef(lat: f64, lon: f64) -> Matrix3<f64> {
    let (sp, cp) = lat.to_radians().sin_cos();
    let (sl, cl) = lon.to_radians().sin_cos();
    Matrix3::new(-sl, cl, 0.0, -sp * cl, -sp * sl, cp, cp * cl, cp * sl, sp)
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
        assert!((site.local_enu(site.latitude, site.longitude) - site.to_level()).norm() < 1e-15);
        // 10 km east, the local up leans 1.6 mrad east of the site's.
        let (lat, lon, _) = site.geodetic(&Vector3::new(10_000.0, 0.0, 0.0));
        let up_there = site.local_enu(lat, lon).transpose() * Vector3::z();
        let lean = up_there.x.atan2(up_there.z);
        assert!((lean - 10_000.0 / 6.371e6).abs() < 2e-5, "{lean}");
        // What a receiver there says, taken back into the site's level frame by the flight
        // check, is the velocity in the site's frame.
        let v = Vector3::new(300.0, -20.0, 150.0);
        let fix = crate::nav::input::Fix {
            t: 0.0,
            lat_lon: (lat, lon),
            height: Some(0.0),
            velocity: Some((site.local_enu(lat, lon) * v).into()),
            satellites: None,
        };
        let back = crate::nav::frame::level_velocity(&fix, (site.latitude, site.longitude, 0.0));
        let back = Vector3::from(back.unwrap());
        assert!((back - site.to_level() * v).norm() < 1e-9, "{back}");
    }
}
