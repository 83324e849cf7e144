//! The Earth's rate, the gyros' reference signal (source text: "the direction of true north
//! must be known so that effects attributable to earth rotation can be controlled"): a gyro on
//! a still fixture turns with the Earth, 7.29e-5 rad/s (15.04 deg/h) about its axis, and a
//! rate table adds the Earth's rate to its own. It belongs to the model under rotation
//! (`spincal::model::rotation`): `w` there is the inertial rate.
//!
//! A station knows its latitude, the heading of its fixture's reference mark (azimuth from
//! true north, clockwise seen from above) and, per still observation, which direction of the
//! unit lay along that mark (`h_x h_y h_z`, unit axes); the up direction is that of the
//! specific force. A turning observation (a rate table or centrifuge, averaged over whole
//! turns) keeps only the Earth rate's component along the turning axis, its vertical part.

use serde::{Deserialize, Serialize};

/// The Earth's rotation rate, rad/s (WGS 84).
pub const RATE: f64 = 7.292_115e-5;

/// Where the station stands.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Station {
    /// Geodetic latitude, degrees (north positive).
    pub latitude_deg: f64,
    /// Azimuth of the fixture's reference mark from true north, degrees, clockwise.
    pub heading_deg: f64,
}

/// An observation whose Earth rate cannot be known.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EarthError {
    /// A still observation with no specific force: no up direction.
    #[error("a still observation with no specific force has no up direction")]
    NoUp,
    /// A still observation without the fixture's reference mark (or with it vertical).
    #[error(
        "a still observation needs the direction of the fixture's reference mark in the unit's axes (h_x h_y h_z, horizontal)"
    )]
    NoMark,
    /// A turning observation whose axis is horizontal: the Earth's rate about it depends on
    /// the axis' azimuth.
    #[error(
        "a turning observation whose axis is horizontal has an Earth rate that depends on its azimuth"
    )]
    HorizontalAxis,
}

fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n > 0.0 && n.is_finite()).then(|| v.map(|x| x / n))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    spincal::model::rotation::cross(&a, &b)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    spincal::model::rotation::dot(&a, &b)
}

/// A station's latitude or fixture heading out of range, naming the option.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum StationError {
    /// Not finite, or beyond the poles.
    #[error("--latitude {0}: degrees from -90 to 90")]
    Latitude(f64),
    /// Not finite, or more than a turn.
    #[error("--heading {0}: degrees from -360 to 360")]
    Heading(f64),
}

impl Station {
    /// A station at `latitude_deg`, its fixture's mark at `heading_deg`.
    ///
    /// # Errors
    /// Values outside `[-90, 90]` and `[-360, 360]`, or not finite, naming the option.
    pub fn new(latitude_deg: f64, heading_deg: f64) -> Result<Self, StationError> {
        if !(latitude_deg.is_finite() && (-90.0..=90.0).contains(&latitude_deg)) {
            return Err(StationError::Latitude(latitude_deg));
        }
        if !(heading_deg.is_finite() && (-360.0..=360.0).contains(&heading_deg)) {
            return Err(StationError::Heading(heading_deg));
        }
        Ok(Self {
            latitude_deg,
            heading_deg,
        })
    }

    /// True north in the unit's axes for up `u` and the mark `h` (both unit, `h` horizontal).
    fn north(&self, u: [f64; 3], h: [f64; 3]) -> [f64; 3] {
        let psi = self.heading_deg.to_radians();
        let side = cross(u, h);
        std::array::from_fn(|k| h[k] * psi.cos() + side[k] * psi.sin())
    }

    /// The Earth's rate in the unit's axes for an observation with specific force `f`, table
    /// rate `w` and fixture mark `h` (zero when there is none).
    ///
    /// # Errors
    /// An [`EarthError`] when the observation does not say enough.
    pub fn rate_in_body(
        &self,
        f: [f64; 3],
        w: [f64; 3],
        h: [f64; 3],
    ) -> Result<[f64; 3], EarthError> {
        let phi = self.latitude_deg.to_radians();
        if let Some(axis) = unit(w) {
            // Turning: the horizontal part averages out; the vertical stays along the axis.
            let up_along = dot(f, axis);
            if up_along.abs() <= 1e-6 * dot(f, f).sqrt() {
                return Err(EarthError::HorizontalAxis);
            }
            let u = axis.map(|x| x * up_along.signum());
            return Ok(u.map(|x| RATE * phi.sin() * x));
        }
        let u = unit(f).ok_or(EarthError::NoUp)?;
        let along = dot(h, u);
        let h = unit(std::array::from_fn(|k| h[k] - along * u[k])).ok_or(EarthError::NoMark)?;
        let n = self.north(u, h);
        Ok(std::array::from_fn(|k| {
            RATE * (phi.cos() * n[k] + phi.sin() * u[k])
        }))
    }
}

/// The fixture's reference mark for a unit whose up direction is `u`: the unit axis most
/// nearly horizontal, made horizontal (how the plans lay their units on the fixture).
#[must_use]
pub fn mark_for(u: [f64; 3]) -> [f64; 3] {
    let k = (0..3)
        .min_by(|a, b| u[*a].abs().total_cmp(&u[*b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let along = dot(e, u);
    unit(std::array::from_fn(|j| e[j] - along * u[j])).unwrap_or(e)
}

/// `h` turned about `u` by `angle` radians.
#[must_use]
pub fn turn(h: [f64; 3], u: [f64; 3], angle: f64) -> [f64; 3] {
    let side = cross(u, h);
    std::array::from_fn(|k| h[k] * angle.cos() + side[k] * angle.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_a_level_fixture_the_earth_rate_is_north_and_up() {
        // z up, x along the mark pointing north (heading 0) at 45 degrees north.
        let s = Station::new(45.0, 0.0).unwrap();
        let e = s
            .rate_in_body([0.0, 0.0, 9.81], [0.0; 3], [1.0, 0.0, 0.0])
            .unwrap();
        let c = RATE * 45f64.to_radians().cos();
        assert!((e[0] - c).abs() < 1e-18 && e[1].abs() < 1e-18 && (e[2] - c).abs() < 1e-18);
        // The mark pointing east (heading 90): north is along the unit's y (up x east).
        let s = Station::new(45.0, 90.0).unwrap();
        let e = s
            .rate_in_body([0.0, 0.0, 9.81], [0.0; 3], [1.0, 0.0, 0.0])
            .unwrap();
        assert!(e[0].abs() < 1e-18 && (e[1] - c).abs() < 1e-18, "{e:?}");
        // Its magnitude is always the Earth's rate.
        let e = Station::new(-33.0, 17.0)
            .unwrap()
            .rate_in_body([1.0, -2.0, 0.5], [0.0; 3], [0.3, 0.1, -0.2])
            .unwrap();
        assert!((dot(e, e).sqrt() - RATE).abs() < 1e-18);
    }

    #[test]
    fn a_turning_table_keeps_the_vertical_part_and_a_still_unit_needs_its_mark() {
        let s = Station::new(30.0, 10.0).unwrap();
        let v = RATE * 0.5;
        // Spinning about the up axis, either sense.
        for w in [[0.0, 0.0, 5.0], [0.0, 0.0, -5.0]] {
            let e = s.rate_in_body([0.0, 0.0, 9.81], w, [0.0; 3]).unwrap();
            assert!((e[2] - v).abs() < 1e-18 && e[0] == 0.0);
        }
        // Upside down: up is -z.
        let e = s
            .rate_in_body([0.0, 0.0, -9.81], [0.0, 0.0, 5.0], [0.0; 3])
            .unwrap();
        assert!((e[2] + v).abs() < 1e-18);
        assert_eq!(
            s.rate_in_body([0.0, 0.0, 9.81], [5.0, 0.0, 0.0], [0.0; 3]),
            Err(EarthError::HorizontalAxis)
        );
        assert_eq!(
            s.rate_in_body([0.0, 0.0, 9.81], [0.0; 3], [0.0; 3]),
            Err(EarthError::NoMark)
        );
        assert_eq!(
            s.rate_in_body([0.0, 0.0, 9.81], [0.0; 3], [0.0, 0.0, 1.0]),
            Err(EarthError::NoMark)
        );
        assert_eq!(
            s.rate_in_body([0.0; 3], [0.0; 3], [1.0, 0.0, 0.0]),
            Err(EarthError::NoUp)
        );
        assert_eq!(Station::new(91.0, 0.0), Err(StationError::Latitude(91.0)));
        assert!(matches!(
            Station::new(0.0, f64::NAN),
            Err(StationError::Heading(h)) if h.is_nan()
        ));
        assert_eq!(
            StationError::Heading(400.0).to_string(),
            "--heading 400: degrees from -360 to 360"
        );
    }
}
