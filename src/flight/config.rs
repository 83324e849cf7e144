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
    /// Longest time between two of the navigation's lower-rate steps (the attitude, velocity
    /// and position; the samples between are gathered at their own rate, the roll exact), us;
    /// zero: every sample. A covariance step ends one too.
    pub navigation_interval_us: u32,
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
    /// Mach 0.8 at 10 Hz, a 5-sigma gate, the covariance stepped at 100 Hz and with it the
    /// navigation's attitude, velocity and position, zero-velocity updates at 20 Hz
    /// on the pad after 0.2 s of levelling, the launch at 2 g, the spin about the body x axis,
    /// and a launch shift as large as the prior.
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
            navigation_interval_us: 10_000,
            pad_interval_us: 50_000,
            level_us: 200_000,
            launch_force: c(2.0 * super::air::G0),
            doubt: (c(1.0e5), c(100.0)),
            noise,
            sensor_sigma,
            launch_shift: sensor_sigma,
        }
    }

    /// Takes the calibration's own error at rest as the sensor errors' prior (each output's
    /// bias and scale factor, [`LaunchChange::at_rest_sigma`] of the blob's covariance
    /// `factors`) in place of a stated one; the barometer's stays.
    ///
    /// [`LaunchChange::at_rest_sigma`]: super::LaunchChange::at_rest_sigma
    pub fn take_calibration_prior(&mut self, factors: &crate::model::ImuCovariance) {
        let rest = super::LaunchChange::of(factors, &super::FlightLines::default()).at_rest_sigma();
        let s = &mut self.sensor_sigma;
        let slots = s
            .accel_bias
            .iter_mut()
            .chain(s.gyro_bias.iter_mut())
            .zip(s.accel_scale.iter_mut().chain(s.gyro_scale.iter_mut()));
        for ((bias, scale), (b, k)) in slots.zip(rest) {
            *bias = c(b);
            *scale = c(k);
        }
    }
}

/// A field of a [`FlightConfig`] the filter cannot run with: which, and what it must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigFault {
    /// The field, as the struct names it (`noise.gyro_white`, `gnss_sigma.1`).
    pub field: &'static str,
    /// What it must be.
    pub expected: &'static str,
}

impl core::fmt::Display for ConfigFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "flight config: {} must be {}", self.field, self.expected)
    }
}

const POSITIVE: &str = "finite and above zero";
const NOT_NEGATIVE: &str = "finite and not negative";

/// `Err` naming `field` unless `ok`.
fn need(ok: bool, field: &'static str, expected: &'static str) -> Result<(), ConfigFault> {
    if ok {
        Ok(())
    } else {
        Err(ConfigFault { field, expected })
    }
}

fn positive<T: Real>(x: T, field: &'static str) -> Result<(), ConfigFault> {
    need(x.is_finite() && x > T::zero(), field, POSITIVE)
}

fn not_negative<T: Real>(x: T, field: &'static str) -> Result<(), ConfigFault> {
    need(x.is_finite() && x >= T::zero(), field, NOT_NEGATIVE)
}

/// Each of a prior's (or a shift's) 1-sigmas finite and not negative; `names` in the order
/// accelerometer bias, gyro bias, accelerometer scale, gyro scale, barometer bias.
fn sigmas<T: Real>(s: &SensorErrors<T>, names: [&'static str; 5]) -> Result<(), ConfigFault> {
    let [ab, gb, as_, gs, bb] = names;
    let all = |v: &Vector3<T>| v.iter().all(|x| x.is_finite() && *x >= T::zero());
    need(all(&s.accel_bias), ab, NOT_NEGATIVE)?;
    need(all(&s.gyro_bias), gb, NOT_NEGATIVE)?;
    need(all(&s.accel_scale), as_, NOT_NEGATIVE)?;
    need(all(&s.gyro_scale), gs, NOT_NEGATIVE)?;
    not_negative(s.baro_bias, bb)
}

impl<T: Real> FlightConfig<T> {
    /// The first field the filter cannot run with, named: a NaN, an infinity or a negative
    /// 1-sigma would otherwise reach the covariance, which the filter would put back to a
    /// prior that is itself broken at every step; a zero 1-sigma of a fix divides by zero at
    /// its first update; a latency beyond [`MAX_FIX_AGE_US`](super::MAX_FIX_AGE_US) refuses
    /// every fix as stale; a launch force under 1 g launches on the pad.
    ///
    /// # Errors
    /// The first field that is not what it must be.
    pub fn check(&self) -> Result<(), ConfigFault> {
        if let Some(o) = self.origin {
            need(
                o.is_plausible(),
                "origin",
                "a position on the Earth (latitude within 90 degrees, longitude within 360, height within 100 km)",
            )?;
        }
        need(self.heading.0.is_finite(), "heading.0", "finite, rad")?;
        positive(self.heading.1, "heading.1")?;
        need(
            self.spin_axis.iter().all(|x| x.is_finite()) && self.spin_axis.norm() > T::zero(),
            "spin_axis",
            "a finite axis that is not zero",
        )?;
        need(
            self.lever.iter().all(|x| x.is_finite()) && self.lever.norm() < c(10.0),
            "lever",
            "finite and shorter than 10 m",
        )?;
        positive(self.gnss_sigma.0, "gnss_sigma.0")?;
        positive(self.gnss_sigma.1, "gnss_sigma.1")?;
        positive(self.gnss_velocity_sigma, "gnss_velocity_sigma")?;
        need(
            u64::from(self.gnss_latency_us) < super::MAX_FIX_AGE_US,
            "gnss_latency_us",
            "under 1,000,000 us (a fix older than a second is refused as stale)",
        )?;
        positive(self.baro_sigma, "baro_sigma")?;
        not_negative(self.baro_cp, "baro_cp")?;
        positive(self.baro_mach, "baro_mach")?;
        need(self.baro_interval_us > 0, "baro_interval_us", "above zero")?;
        positive(self.gate, "gate")?;
        need(
            self.covariance_interval_us > 0
                && u64::from(self.covariance_interval_us) <= super::MAX_SAMPLE_GAP_US,
            "covariance_interval_us",
            "1 .. 100,000 us",
        )?;
        need(
            u64::from(self.navigation_interval_us) <= super::MAX_SAMPLE_GAP_US,
            "navigation_interval_us",
            "0 .. 100,000 us",
        )?;
        need(self.pad_interval_us > 0, "pad_interval_us", "above zero")?;
        need(self.level_us > 0, "level_us", "above zero")?;
        need(
            self.launch_force.is_finite() && self.launch_force > c(super::air::G0),
            "launch_force",
            "finite and above 1 g (9.80665 m/s^2): at rest the unit senses 1 g",
        )?;
        not_negative(self.doubt.0, "doubt.0")?;
        not_negative(self.doubt.1, "doubt.1")?;
        let n = &self.noise;
        not_negative(n.accel_white, "noise.accel_white")?;
        not_negative(n.gyro_white, "noise.gyro_white")?;
        not_negative(n.accel_walk, "noise.accel_walk")?;
        not_negative(n.gyro_walk, "noise.gyro_walk")?;
        not_negative(n.scale_walk, "noise.scale_walk")?;
        not_negative(n.baro_walk, "noise.baro_walk")?;
        need(
            n.receiver_sigma
                .iter()
                .all(|x| x.is_finite() && *x >= T::zero()),
            "noise.receiver_sigma",
            NOT_NEGATIVE,
        )?;
        if n.receiver_sigma.iter().any(|x| *x > T::zero()) {
            positive(n.receiver_tau, "noise.receiver_tau")?;
        }
        sigmas(
            &self.sensor_sigma,
            [
                "sensor_sigma.accel_bias",
                "sensor_sigma.gyro_bias",
                "sensor_sigma.accel_scale",
                "sensor_sigma.gyro_scale",
                "sensor_sigma.baro_bias",
            ],
        )?;
        sigmas(
            &self.launch_shift,
            [
                "launch_shift.accel_bias",
                "launch_shift.gyro_bias",
                "launch_shift.accel_scale",
                "launch_shift.gyro_scale",
                "launch_shift.baro_bias",
            ],
        )
    }
}

/// A config the tests of the flight module start from: a MEMS unit's noise, its receiver
/// wandering by 1.5 m (3 m in height) over 60 s, a prior of 50 mm/s^2, 5 mrad/s and 1e-3.
#[cfg(test)]
pub(crate) fn example<T: Real>() -> FlightConfig<T> {
    let noise = NavNoise {
        accel_white: c(1e-3),
        gyro_white: c(1e-4),
        accel_walk: c(1e-4),
        gyro_walk: c(1e-5),
        scale_walk: c(1e-6),
        baro_walk: c(0.1),
        receiver_sigma: Vector3::new(c(1.5), c(1.5), c(3.0)),
        receiver_tau: c(60.0),
    };
    let prior = SensorErrors {
        accel_bias: Vector3::repeat(c(0.05)),
        gyro_bias: Vector3::repeat(c(0.005)),
        accel_scale: Vector3::repeat(c(1e-3)),
        gyro_scale: Vector3::repeat(c(1e-3)),
        baro_bias: c(5.0),
    };
    FlightConfig::new((c(0.3), c(0.05)), noise, prior)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> FlightConfig<f32> {
        example()
    }

    /// Each kind of field a filter cannot run with is named; the defaults pass.
    #[test]
    fn a_config_the_filter_cannot_run_with_is_named_by_its_field() {
        assert_eq!(good().check(), Ok(()));
        type Spoil = fn(&mut FlightConfig<f32>);
        let cases: [(&str, Spoil); 13] = [
            ("heading.1", |c| c.heading.1 = 0.0),
            ("heading.0", |c| c.heading.0 = f32::NAN),
            ("spin_axis", |c| c.spin_axis = Vector3::zeros()),
            ("gnss_sigma.1", |c| c.gnss_sigma.1 = -4.0),
            ("gnss_velocity_sigma", |c| c.gnss_velocity_sigma = 0.0),
            ("gnss_latency_us", |c| c.gnss_latency_us = 2_000_000),
            ("covariance_interval_us", |c| c.covariance_interval_us = 0),
            ("navigation_interval_us", |c| {
                c.navigation_interval_us = 200_000
            }),
            ("launch_force", |c| c.launch_force = 5.0),
            ("noise.gyro_white", |c| c.noise.gyro_white = f32::NAN),
            ("noise.receiver_tau", |c| c.noise.receiver_tau = 0.0),
            ("sensor_sigma.gyro_scale", |c| {
                c.sensor_sigma.gyro_scale.y = f32::INFINITY
            }),
            ("launch_shift.baro_bias", |c| {
                c.launch_shift.baro_bias = -1.0
            }),
        ];
        for (field, spoil) in cases {
            let mut c = good();
            spoil(&mut c);
            assert_eq!(c.check().map_err(|f| f.field), Err(field));
        }
        // A receiver that errs white needs no time constant.
        let mut white = good();
        white.noise.receiver_sigma = Vector3::zeros();
        white.noise.receiver_tau = 0.0;
        assert_eq!(white.check(), Ok(()));
        let mut far = good();
        far.origin = Some(Geodetic {
            latitude: 95.0,
            longitude: 0.0,
            height: 0.0,
        });
        assert_eq!(far.check().map_err(|f| f.field), Err("origin"));
    }

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
