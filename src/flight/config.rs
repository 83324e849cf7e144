//! What the flight filter is told before the flight: the launch point and heading, the spin
//! axis, the antenna's lever arm, the aiding sensors' noise, the sensor errors' prior and the
//! process noise, and how often it steps its covariance.

use nalgebra::Vector3;

use super::origin::Geodetic;
use crate::nav::{NavNoise, Real, SensorErrors};

/// The flight filter's set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightConfig<T: Real> {
    /// The launch point, when the fire control knows it; `None`: the first good GNSS fix
    /// becomes the origin (the filter waits for it before it levels).
    pub origin: Option<Geodetic>,
    /// The unit's heading at rest and its 1-sigma, rad: the turn about the vertical that,
    /// after the shortest rotation taking the specific force at rest to up (the levelling),
    /// gives the unit's attitude in the level frame (east, north, up). It is not the azimuth of
    /// the barrel or the rail (a 155 mm round in its tube is pi from it):
    /// [`heading_of_azimuth`](Self::heading_of_azimuth) turns the fire control's azimuth into
    /// it.
    pub heading: (T, T),
    /// The body axis the round spins about.
    pub spin_axis: Vector3<T>,
    /// The GNSS antenna from the IMU, body axes, m.
    pub lever: Vector3<T>,
    /// 1-sigma of a GNSS position, m: horizontal (each axis) and vertical.
    pub gnss_sigma: (T, T),
    /// 1-sigma of a GNSS velocity, m/s.
    pub gnss_velocity_sigma: T,
    /// How late the receiver's fixes arrive after the instant they describe, us.
    pub gnss_latency_us: u32,
    /// Fixes from fewer satellites are refused.
    pub min_satellites: u8,
    /// 1-sigma of a barometric height, m.
    pub baro_sigma: T,
    /// The static port's pressure coefficient, 1-sigma (a height error of `Cp v^2 / 2g`).
    pub baro_cp: T,
    /// The barometer is left out from this Mach number up.
    pub baro_mach: T,
    /// Shortest time between two barometer updates, us.
    pub baro_interval_us: u32,
    /// Innovations beyond this many sigma are refused (and counted).
    pub gate: T,
    /// Longest time between two covariance steps, us.
    pub covariance_interval_us: u32,
    /// Time between two zero-velocity updates on the pad, us.
    pub pad_interval_us: u32,
    /// Rest averaged before the filter levels the unit, us.
    pub level_us: u32,
    /// Specific force that marks the launch, m/s^2.
    pub launch_force: T,
    /// What a doubted sample may hide, 1-sigma: specific force (m/s^2) and rate (rad/s).
    pub doubt: (T, T),
    /// The process noise.
    pub noise: NavNoise<T>,
    /// The sensor errors' prior, 1-sigma each (the barometer's bias in m).
    pub sensor_sigma: SensorErrors<T>,
    /// How far the sensor errors may shift at the launch (setback, the spin-up), 1-sigma each:
    /// added to their variances when the launch is detected, so that what the pad taught
    /// does not pin them, and again at the end of the setback
    /// ([`FlightFilter::setback_end_us`](super::FlightFilter::setback_end_us)), so that what
    /// the in-bore samples taught does not pin a shift at muzzle exit either.
    pub launch_shift: SensorErrors<T>,
}

fn c<T: Real>(x: f64) -> T {
    nalgebra::convert(x)
}

impl<T: Real> FlightConfig<T> {
    /// The [`heading`](Self::heading) of a unit at rest whose body axis `axis` (the spin axis,
    /// in body axes) points at `azimuth` (rad, clockwise from north, as the fire control gives
    /// the line of fire), levelled on the specific force `f` it senses at rest (body axes). The
    /// axis must not point straight up (its azimuth is then undefined: `None`).
    #[must_use]
    pub fn heading_of_azimuth(f: &Vector3<T>, axis: &Vector3<T>, azimuth: T) -> Option<T> {
        let up = crate::nav::real::rotation_between(f, &Vector3::z());
        let levelled = up * axis;
        let across = levelled.x * levelled.x + levelled.y * levelled.y;
        if across <= c::<T>(1e-12) * levelled.norm_squared() {
            return None;
        }
        // Where the levelled axis points (from east, counter-clockwise) and where it should.
        let now = levelled.y.atan2_libm(levelled.x);
        let wanted = T::frac_pi_2() - azimuth;
        let turn = wanted - now;
        // Within -pi .. pi.
        let (s, c_) = turn.sin_cos_libm();
        Some(s.atan2_libm(c_))
    }

    /// The defaults of `calflash flight` with the heading, the noise and the prior given:
    /// GNSS 2.5 m / 5 m / 0.2 m/s, barometer 1.5 m with a port coefficient of 0.03 up to
    /// Mach 0.8 at 10 Hz, a 5-sigma gate, the covariance stepped at 100 Hz, zero-velocity
    /// updates at 20 Hz on the pad after 0.2 s of levelling, the launch at 2 g, the spin
    /// about the body x axis, and a launch shift as large as the prior.
    #[must_use]
    pub fn new(heading: (T, T), noise: NavNoise<T>, sensor_sigma: SensorErrors<T>) -> Self {
        Self {
            origin: None,
            heading,
            spin_axis: Vector3::x(),
            lever: Vector3::zeros(),
            gnss_sigma: (c(2.5), c(5.0)),
            gnss_velocity_sigma: c(0.2),
            gnss_latency_us: 0,
            min_satellites: 4,
            baro_sigma: c(1.5),
            baro_cp: c(0.03),
            baro_mach: c(0.8),
            baro_interval_us: 100_000,
            gate: c(5.0),
            covariance_interval_us: 10_000,
            pad_interval_us: 50_000,
            level_us: 200_000,
            launch_force: c(2.0 * super::air::G0),
            doubt: (c(1.0e5), c(100.0)),
            noise,
            sensor_sigma,
            launch_shift: sensor_sigma,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference rocket at rest (RocketPy's Calisto on its rail, 85 degrees up at azimuth
    /// 120, `../shared/data/reference-flights/rocket_calisto`): its truth's specific force at
    /// rest, and the heading its truth's attitude gives (-161.35 degrees, computed from the
    /// truth's quaternion in `calflash`'s reference-flights test).
    #[test]
    fn the_fire_controls_azimuth_gives_the_levelled_heading() {
        let f = Vector3::new(9.754_074_11, -0.603_424_357, -0.603_424_355);
        let h = FlightConfig::<f64>::heading_of_azimuth(&f, &Vector3::x(), 120f64.to_radians())
            .unwrap_or(f64::NAN);
        assert!(
            (h.to_degrees() + 161.350_75).abs() < 0.01,
            "{}",
            h.to_degrees()
        );
        // f32 as on the device.
        let f32_h = FlightConfig::<f32>::heading_of_azimuth(
            &f.map(|x| x as f32),
            &Vector3::x(),
            120f32.to_radians(),
        )
        .unwrap_or(f32::NAN);
        assert!((f64::from(f32_h) - h).abs() < 1e-5);
        // A unit lying level with x along the line of fire, north-east: the levelling leaves x
        // east, so the heading turns it 45 degrees back towards north.
        let level = FlightConfig::<f64>::heading_of_azimuth(
            &Vector3::new(0.0, 0.0, 9.8),
            &Vector3::x(),
            45f64.to_radians(),
        )
        .unwrap_or(f64::NAN);
        assert!(
            (level.to_degrees() - 45.0).abs() < 1e-9,
            "{}",
            level.to_degrees()
        );
        // Straight up: no azimuth.
        assert!(
            FlightConfig::<f64>::heading_of_azimuth(
                &Vector3::new(9.8, 0.0, 0.0),
                &Vector3::x(),
                0.0
            )
            .is_none()
        );
    }
}
