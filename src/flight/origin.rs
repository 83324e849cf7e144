//! Where the level frame is: a GNSS fix's position in the tangent plane of the launch point.
//!
//! Done in `f64` on every target: a latitude in `f32` holds 0.6 m at best, and the fixes come
//! at a few hertz, so the soft double arithmetic on the Cortex-M4F costs little.

use crate::nav::earth::{ECCENTRICITY2, SEMI_MAJOR};

/// A geodetic position: latitude and longitude (degrees, WGS 84) and height above the
/// ellipsoid (m).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Geodetic {
    /// Latitude, degrees north.
    pub latitude: f64,
    /// Longitude, degrees east.
    pub longitude: f64,
    /// Height above the ellipsoid, m.
    pub height: f64,
}

impl Geodetic {
    /// Whether it is a position on the Earth at all (finite, latitude within +-90 degrees,
    /// longitude within +-360, height within +-100 km).
    #[must_use]
    pub fn is_plausible(&self) -> bool {
        self.latitude.abs() <= 90.0 && self.longitude.abs() <= 360.0 && self.height.abs() <= 1e5
    }

    fn ecef(&self) -> [f64; 3] {
        let (sl, cl) = libm::sincos(self.latitude.to_radians());
        let (so, co) = libm::sincos(self.longitude.to_radians());
        let n = SEMI_MAJOR / libm::sqrt(1.0 - ECCENTRICITY2 * sl * sl);
        [
            (n + self.height) * cl * co,
            (n + self.height) * cl * so,
            (n * (1.0 - ECCENTRICITY2) + self.height) * sl,
        ]
    }
}

/// The launch point and the rotation from Earth-centred axes to its east, north, up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Origin {
    at: Geodetic,
    ecef: [f64; 3],
    /// Rows: east, north, up in Earth-centred axes.
    enu: [[f64; 3]; 3],
}

impl Origin {
    /// The level frame whose origin is `at`.
    #[must_use]
    pub fn new(at: Geodetic) -> Self {
        let (sl, cl) = libm::sincos(at.latitude.to_radians());
        let (so, co) = libm::sincos(at.longitude.to_radians());
        Self {
            at,
            ecef: at.ecef(),
            enu: [
                [-so, co, 0.0],
                [-sl * co, -sl * so, cl],
                [cl * co, cl * so, sl],
            ],
        }
    }

    /// The origin.
    #[must_use]
    pub fn geodetic(&self) -> Geodetic {
        self.at
    }

    /// `p`'s position in the level frame (east, north, up from the origin, m).
    #[must_use]
    pub fn local(&self, p: &Geodetic) -> [f64; 3] {
        let x = p.ecef();
        let d = [
            x[0] - self.ecef[0],
            x[1] - self.ecef[1],
            x[2] - self.ecef[2],
        ];
        self.enu
            .map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2])
    }

    /// A velocity given in east, north, up at `at` (as a receiver gives it, at its own
    /// position) in the level frame: the two frames differ by the turn of the vertical over
    /// the distance between them (1 mrad at 6 km).
    #[must_use]
    pub fn level_velocity(&self, at: &Geodetic, v: &[f32; 3]) -> [f64; 3] {
        let (sl, cl) = libm::sincos(at.latitude.to_radians());
        let (so, co) = libm::sincos(at.longitude.to_radians());
        // Earth-centred: east, north and up there, weighted by the velocity's components.
        let [e, n, u] = v.map(f64::from);
        let ecef = [
            -so * e - sl * co * n + cl * co * u,
            co * e - sl * so * n + cl * so * u,
            cl * n + sl * u,
        ];
        self.enu
            .map(|row| row[0] * ecef[0] + row[1] * ecef[1] + row[2] * ecef[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_north_and_up_lies_north_and_up_with_the_earths_curvature() {
        let o = Origin::new(Geodetic {
            latitude: 45.0,
            longitude: 7.0,
            height: 300.0,
        });
        // 0.01 degree of latitude is about 1111 m at 45 degrees.
        let p = o.local(&Geodetic {
            latitude: 45.01,
            longitude: 7.0,
            height: 300.0,
        });
        assert!(p[0].abs() < 1e-6 && (p[1] - 1111.5).abs() < 1.0, "{p:?}");
        // The tangent plane: the same height 1.1 km away lies d^2 / 2R below it.
        assert!((p[2] + p[1] * p[1] / (2.0 * 6.37e6)).abs() < 0.01, "{p:?}");
        let up = o.local(&Geodetic {
            height: 400.0,
            ..o.geodetic()
        });
        assert!(up[0].abs() < 1e-6 && up[1].abs() < 1e-6 && (up[2] - 100.0).abs() < 1e-6);
    }

    #[test]
    fn a_velocity_given_up_at_a_point_north_leans_north_in_the_level_frame() {
        let o = Origin::new(Geodetic {
            latitude: 45.0,
            longitude: 7.0,
            height: 300.0,
        });
        let at = o.geodetic();
        let same = o.level_velocity(&at, &[3.0, 4.0, 5.0]);
        assert!((same[0] - 3.0).abs() < 1e-6 && (same[1] - 4.0).abs() < 1e-6);
        // 0.054 degrees north (6 km): up there is 0.94 mrad north of up here.
        let north = Geodetic {
            latitude: 45.054,
            ..at
        };
        let v = o.level_velocity(&north, &[0.0, 0.0, 100.0]);
        let lean = v[1] / v[2];
        assert!((lean - 0.054f64.to_radians()).abs() < 1e-5, "{v:?}");
        assert!(v[0].abs() < 1e-9, "{v:?}");
    }
}
