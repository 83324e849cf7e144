//! The flight filter's run: levelling at rest, zero-velocity updates on the pad, the launch,
//! then the strapdown navigation in two speeds (the roll and the de-spun increments at the
//! IMU's rate, the attitude, velocity and position at most every
//! [`FlightConfig::navigation_interval_us`] and at every covariance step), the covariance
//! stepped at most every [`FlightConfig::covariance_interval_us`], and the GNSS and barometer
//! updates as they come.

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::air;
use super::config::FlightConfig;
use super::line::LaunchChange;
use super::origin::{Geodetic, Origin};
use super::stats::{Aiding, FlightStats, MAX_FIX_AGE_US, MAX_SAMPLE_GAP_US};
use super::verdict::{Opening, TERMS, Verdict};
use crate::nav::filter::{Doubt, Estimate, index};

mod update;
use crate::nav::{
    Earth, ErrorFilter, Interval, Navigation, Prior, Real, SensorErrors, StateMatrix, StateVector,
};

/// One GNSS fix.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GnssFix {
    /// The instant it describes on the IMU's clock (the samples' `t_us`), us, before the
    /// receiver's latency.
    pub t_us: u64,
    /// The antenna's position.
    pub position: Geodetic,
    /// The antenna's velocity (east, north, up at the antenna's own position, as receivers
    /// give it, m/s), when the receiver gives one: the filter turns it into the level frame.
    pub velocity: Option<[f32; 3]>,
    /// Satellites in the solution.
    pub satellites: u8,
}

/// Where the flight filter is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Averaging the rest to level the unit (or waiting for the origin).
    Levelling,
    /// Levelled, on the pad: navigating with zero-velocity updates.
    Pad,
    /// Launched: navigating with GNSS and barometer updates.
    Flight,
}

/// The in-flight GNSS- and barometer-aided filter over the corrected samples (see the
/// [module docs](super)).
#[derive(Debug, Clone)]
pub struct FlightFilter<T: Real> {
    config: FlightConfig<T>,
    origin: Option<Origin>,
    phase: Phase,
    filter: ErrorFilter<T>,
    /// The prior's variances (it is diagonal: 88 bytes in f32, not 1,936).
    prior: StateVector<T>,
    rest: (Vector3<T>, u32, u64),
    now_us: Option<u64>,
    last_epoch_us: u64,
    /// The navigation's velocity after the last epoch's updates, and its rate of change over
    /// the interval before this epoch (level frame): a fix's velocity is predicted at its own
    /// instant, `back` before the epoch that takes it.
    pace: (Vector3<T>, Vector3<T>),
    launch_us: Option<u64>,
    /// The largest specific force squared since the launch, until the setback ends.
    setback_peak: T,
    setback_end_us: Option<u64>,
    fix: Option<GnssFix>,
    last_fix: Option<Geodetic>,
    pressure: Option<(u64, T)>,
    pad_pressure: (T, u32),
    baro_reference: Option<T>,
    last_baro_us: Option<u64>,
    stats: FlightStats,
    /// The sensor terms' estimate and covariance just after the launch's shift was last
    /// opened (the end of the setback), and the variance the openings hold open then: what the
    /// round's verdict tests against.
    opening: Option<(
        SVector<T, TERMS>,
        SMatrix<T, TERMS, TERMS>,
        SVector<T, TERMS>,
    )>,
    /// The sensor terms' variances before the first opening (the launch).
    before_launch: SVector<T, TERMS>,
}

fn c<T: Real>(x: f64) -> T {
    nalgebra::convert(x)
}

/// A velocity 1-sigma (m/s) beyond which the navigation has lost track: the next fix with a
/// velocity puts it back ([`FlightStats::navigation_resets`]).
pub const LOST_VELOCITY: f64 = 30.0;

fn micros<T: Real>(us: u64) -> T {
    // Exact for differences below 2^24 us in f32: a flight's steps and ages.
    crate::nav::real::from_count::<T>(us) * c(1e-6)
}

impl<T: Real> FlightFilter<T> {
    /// A filter set up by `config`, levelling from its first sample, once
    /// [`FlightConfig::check`] passes.
    ///
    /// # Errors
    /// The first field of `config` the filter cannot run with, named.
    pub fn try_new(config: FlightConfig<T>) -> Result<Self, super::ConfigFault> {
        config.check()?;
        Ok(Self::new(config))
    }

    /// A filter set up by `config`, levelling from its first sample. The config is taken as
    /// it is ([`try_new`](Self::try_new) checks it first): an implausible origin is dropped
    /// (the first good fix becomes the origin), anything else not finite reaches the
    /// covariance.
    #[must_use]
    pub fn new(config: FlightConfig<T>) -> Self {
        let prior = Self::prior(&config);
        let origin = config
            .origin
            .filter(Geodetic::is_plausible)
            .map(Origin::new);
        Self {
            filter: ErrorFilter::new(
                Estimate {
                    nav: Self::navigation(&config, UnitQuaternion::identity()),
                    sensors: SensorErrors::default(),
                    receiver: Vector3::zeros(),
                },
                &Prior {
                    covariance: StateMatrix::from_diagonal(&prior),
                },
                Earth::new(T::zero(), T::zero()),
                config.noise,
            ),
            config,
            origin,
            phase: Phase::Levelling,
            prior,
            rest: (Vector3::zeros(), 0, 0),
            now_us: None,
            last_epoch_us: 0,
            pace: (Vector3::zeros(), Vector3::zeros()),
            launch_us: None,
            setback_peak: T::zero(),
            setback_end_us: None,
            fix: None,
            last_fix: None,
            pressure: None,
            pad_pressure: (T::zero(), 0),
            baro_reference: None,
            last_baro_us: None,
            stats: FlightStats::default(),
            opening: None,
            before_launch: SVector::zeros(),
        }
    }

    /// The navigation at rest with attitude `q`, about `config`'s spin axis, at its
    /// lower rate.
    fn navigation(config: &FlightConfig<T>, q: UnitQuaternion<T>) -> Navigation<T> {
        Navigation::at_rest(q, config.spin_axis)
            .with_interval(micros(u64::from(config.navigation_interval_us)))
    }

    /// The prior covariance: the sensor errors' from the set-up, position as the GNSS knows
    /// the pad, velocity at rest, the tilt as the accelerometer biases leave it, the heading's.
    fn prior(config: &FlightConfig<T>) -> StateVector<T> {
        let mut d = Self::sensor_variances(&config.sensor_sigma);
        let s = &config.sensor_sigma;
        let mut put = |at: usize, v: &Vector3<T>| {
            for (i, x) in v.iter().enumerate() {
                if let Some(slot) = d.get_mut(at + i) {
                    *slot = *x * *x;
                }
            }
        };
        let g: T = c(air::G0);
        let tilt = s.accel_bias.amax() / g;
        let h = config.gnss_sigma.0;
        put(index::POSITION, &Vector3::new(h, h, T::one()));
        put(index::VELOCITY, &Vector3::repeat(c(1e-2)));
        let tilt = (tilt * tilt + c(1e-6)).sqrt();
        put(index::ATTITUDE, &Vector3::new(tilt, tilt, config.heading.1));
        put(index::RECEIVER, &config.noise.receiver_sigma);
        StateVector::from(d)
    }

    /// The variances of sensor errors of 1-sigma `s`, in their places among the states.
    fn sensor_variances(s: &SensorErrors<T>) -> [T; crate::nav::STATES] {
        let mut d = [T::zero(); crate::nav::STATES];
        let mut put = |at: usize, v: &Vector3<T>| {
            for (i, x) in v.iter().enumerate() {
                if let Some(slot) = d.get_mut(at + i) {
                    *slot = *x * *x;
                }
            }
        };
        put(index::ACCEL_BIAS, &s.accel_bias);
        put(index::GYRO_BIAS, &s.gyro_bias);
        put(index::ACCEL_SCALE, &s.accel_scale);
        put(index::GYRO_SCALE, &s.gyro_scale);
        if let Some(slot) = d.get_mut(index::BARO) {
            *slot = s.baro_bias * s.baro_bias;
        }
        d
    }

    /// Where the filter is.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The counts since the start.
    #[must_use]
    pub fn stats(&self) -> &FlightStats {
        &self.stats
    }

    /// The navigation and sensor-error estimate (meaningful from [`Phase::Pad`] on).
    #[must_use]
    pub fn estimate(&self) -> &Estimate<T> {
        &self.filter.estimate
    }

    /// The error covariance.
    #[must_use]
    pub fn covariance(&self) -> &StateMatrix<T> {
        &self.filter.covariance
    }

    /// The launch point, once known.
    #[must_use]
    pub fn origin(&self) -> Option<Geodetic> {
        self.origin.map(|o| o.geodetic())
    }

    /// The instant of the launch on the samples' clock, us, once detected.
    #[must_use]
    pub fn launch_us(&self) -> Option<u64> {
        self.launch_us
    }

    /// The end of the setback on the samples' clock, us, once seen: the first trusted sample
    /// after the launch whose specific force is under a tenth of the largest since the launch
    /// (a shell's muzzle exit, a rocket's burn-out).
    #[must_use]
    pub fn setback_end_us(&self) -> Option<u64> {
        self.setback_end_us
    }

    /// The instant of the last sample taken, us.
    #[must_use]
    pub fn now_us(&self) -> Option<u64> {
        self.now_us
    }

    /// The error-state filter inside (its estimate, covariance, Earth and noise).
    #[must_use]
    pub fn error_filter(&self) -> &ErrorFilter<T> {
        &self.filter
    }

    /// One corrected sample at `t_us` on the IMU's clock: specific force (m/s^2) and rate
    /// (rad/s), body axes, and whether the corrector's flags (or the codes at their rails)
    /// leave the accelerometer's and the gyro's readings in doubt.
    pub fn sample(&mut self, t_us: u64, f: &Vector3<T>, w: &Vector3<T>, doubted: [bool; 2]) {
        let dt_us = match self.now_us {
            Some(prev) if t_us <= prev => {
                self.stats.time_faults += 1;
                return;
            }
            Some(prev) => t_us - prev,
            None => 0,
        };
        self.now_us = Some(t_us);
        let gap = dt_us > MAX_SAMPLE_GAP_US;
        let finite = f.iter().chain(w.iter()).all(|x| x.is_finite());
        let doubted = [doubted[0] || gap || !finite, doubted[1] || gap || !finite];
        if gap {
            self.stats.time_faults += 1;
        }
        if self.phase == Phase::Levelling {
            self.level(t_us, f, doubted);
            return;
        }
        if doubted[0] || doubted[1] {
            self.stats.doubted += 1;
        }
        let (df, dw) = self.config.doubt;
        let (f, w) = if finite {
            (*f, *w)
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        self.filter.sample(
            &f,
            &w,
            Interval::micros(crate::nav::real::from_count(dt_us)),
            (doubted[0] || doubted[1]).then_some(Doubt::of(doubted, df, dw)),
        );
        if self.phase == Phase::Pad
            && f.norm_squared() > self.config.launch_force * self.config.launch_force
        {
            self.phase = Phase::Flight;
            self.launch_us = Some(t_us);
            self.open_shift();
            self.baro_reference = Some(air::pressure_height(if self.pad_pressure.1 > 0 {
                self.pad_pressure.0 / c(f64::from(self.pad_pressure.1))
            } else {
                self.pressure.map_or(c(101_325.0), |p| p.1)
            }));
            self.pressure = None;
        }
        if self.phase == Phase::Flight && self.setback_end_us.is_none() {
            let f2 = f.norm_squared();
            if f2 > self.setback_peak {
                self.setback_peak = f2;
            }
            if !doubted[0] && f2 * c(100.0) < self.setback_peak {
                self.setback_end_us = Some(t_us);
                self.open_shift();
            }
        }
        let fix_due = self
            .fix
            .is_some_and(|x| x.t_us + u64::from(self.config.gnss_latency_us) <= t_us);
        let baro_due = self.phase == Phase::Flight && self.pressure.is_some_and(|p| p.0 <= t_us);
        let since = t_us.saturating_sub(self.last_epoch_us);
        let pad_due = self.phase == Phase::Pad && since >= u64::from(self.config.pad_interval_us);
        let step_due = since >= u64::from(self.config.covariance_interval_us);
        if fix_due || baro_due || pad_due || step_due {
            self.epoch(t_us, fix_due, baro_due);
        }
    }

    /// Lets the sensor errors move by the launch's shift: their variances gain
    /// [`FlightConfig::launch_shift`]'s. Done at the launch and again at the end of the
    /// setback, so that a shift at any instant through the setback is free after it: opened
    /// only at the launch, a sensor that shifts at muzzle exit would be pinned at its old value
    /// by what the in-bore samples (thousands of g, no saturation) told the filter through the
    /// velocity they built.
    ///
    /// The covariance is stepped first over the samples navigated since the last step, so
    /// that the shift is added after what they built (a whole setback falls inside one step).
    fn open_shift(&mut self) {
        self.filter.covariance_step();
        let variances = Self::sensor_variances(&self.config.launch_shift);
        let shift: SVector<T, TERMS> = SVector::from_iterator(
            variances
                .iter()
                .skip(index::ACCEL_BIAS)
                .copied()
                .chain(core::iter::repeat(T::zero())),
        );
        let now = self.term_covariance().diagonal();
        // What is still open of the earlier openings: the variance above the launch's, at
        // most what they opened (the samples between may have taught some of it).
        let open = match &self.opening {
            None => {
                self.before_launch = now;
                SVector::zeros()
            }
            Some((_, _, opened)) => now.zip_zip_map(&self.before_launch, opened, |p, b, o| {
                (p - b).max(T::zero()).min(o)
            }),
        };
        for (i, v) in variances.iter().enumerate() {
            if let Some(p) = self.filter.covariance.get_mut((i, i)) {
                *p += *v;
            }
        }
        self.opening = Some((self.terms(), self.term_covariance(), open + shift));
    }

    /// The sensor terms' covariance, in [`TERM_NAMES`](super::verdict::TERM_NAMES)' order.
    fn term_covariance(&self) -> SMatrix<T, TERMS, TERMS> {
        self.filter
            .covariance
            .fixed_view::<TERMS, TERMS>(index::ACCEL_BIAS, index::ACCEL_BIAS)
            .into_owned()
    }

    /// The sensor terms' estimate, in [`TERM_NAMES`](super::verdict::TERM_NAMES)' order.
    fn terms(&self) -> SVector<T, TERMS> {
        let s = &self.filter.estimate.sensors;
        SVector::from_iterator(
            s.accel_bias
                .iter()
                .chain(s.gyro_bias.iter())
                .chain(s.accel_scale.iter())
                .chain(s.gyro_scale.iter())
                .copied(),
        )
    }

    /// The round's verdict on its calibration now ([`super::verdict`]), with its stated prior
    /// alone: [`Word::NotYet`] before the launch's shift is opened.
    ///
    /// [`Word::NotYet`]: super::verdict::Word::NotYet
    #[must_use]
    pub fn verdict(&self) -> Verdict {
        self.verdict_given(None)
    }

    /// The round's verdict, "nothing shifted" carrying the calibration's own change of line
    /// into the flight (`change`, [`LaunchChange::of`] the calibration's factors over the
    /// flight's lines) when given.
    #[must_use]
    pub fn verdict_given(&self, change: Option<&LaunchChange>) -> Verdict {
        let Some((m, pi, open)) = &self.opening else {
            return Verdict::not_yet(&self.stats);
        };
        let wide = |v: T| v.to_f64();
        let opening = Opening {
            estimate: m.map(wide),
            covariance: pi.map(wide),
            shift: open.map(wide),
        };
        let p = self.term_covariance().map(wide);
        opening.judge(&self.terms().map(wide), &p, &self.stats, change)
    }

    /// Averages the rest; levels the unit once it has rested long enough and the origin is
    /// known. A doubted sample restarts the average.
    fn level(&mut self, t_us: u64, f: &Vector3<T>, doubted: [bool; 2]) {
        if doubted[0] || doubted[1] {
            self.rest = (Vector3::zeros(), 0, t_us);
            return;
        }
        if self.rest.1 == 0 {
            self.rest.2 = t_us;
        }
        self.rest.0 += f;
        self.rest.1 += 1;
        let Some(origin) = self.origin else {
            return;
        };
        if t_us - self.rest.2 < u64::from(self.config.level_us) {
            return;
        }
        let mean = self.rest.0 / c::<T>(f64::from(self.rest.1));
        let up = crate::nav::real::rotation_between(&mean, &Vector3::z());
        let q = crate::nav::real::rotation(&(Vector3::z() * self.config.heading.0)) * up;
        let at = origin.geodetic();
        self.filter = ErrorFilter::new(
            Estimate {
                nav: Self::navigation(&self.config, q),
                sensors: SensorErrors::default(),
                receiver: Vector3::zeros(),
            },
            &Prior {
                covariance: StateMatrix::from_diagonal(&self.prior),
            },
            Earth::new(c::<T>(at.latitude.to_radians()), c(at.height)),
            self.config.noise,
        );
        self.phase = Phase::Pad;
        self.last_epoch_us = t_us;
    }

    /// A GNSS fix, held until the samples reach the instant it describes.
    pub fn gnss(&mut self, fix: &GnssFix) {
        let velocity_ok = fix
            .velocity
            .is_none_or(|v| v.iter().all(|x| x.is_finite() && x.abs() < 1e4));
        if !fix.position.is_plausible() || !velocity_ok {
            self.stats.gnss_invalid += 1;
            return;
        }
        if fix.satellites < self.config.min_satellites {
            self.stats.gnss_few_satellites += 1;
            return;
        }
        let now = self.now_us.unwrap_or(fix.t_us);
        if fix.t_us + MAX_FIX_AGE_US < now.max(self.last_epoch_us) {
            self.stats.gnss_stale += 1;
            return;
        }
        if fix.t_us > now + MAX_FIX_AGE_US {
            self.stats.gnss_future += 1;
            return;
        }
        if self.last_fix == Some(fix.position) {
            self.stats.gnss_repeated += 1;
            return;
        }
        self.last_fix = Some(fix.position);
        if self.origin.is_none() {
            self.origin = Some(Origin::new(fix.position));
        }
        if self.phase == Phase::Levelling {
            return;
        }
        if self.fix.replace(*fix).is_some() {
            self.stats.gnss_dropped += 1;
        }
    }

    /// A static pressure (Pa) read at `t_us`: averaged on the pad as the height's reference,
    /// an update in flight (at most one per [`FlightConfig::baro_interval_us`]).
    pub fn pressure(&mut self, t_us: u64, pa: T) {
        if !pa.is_finite() || pa < c(1_000.0) || pa > c(120_000.0) {
            self.stats.baro_invalid += 1;
            return;
        }
        if self.phase != Phase::Flight {
            self.pad_pressure.0 += pa;
            self.pad_pressure.1 += 1;
            self.pressure = Some((t_us, pa));
            return;
        }
        let interval = u64::from(self.config.baro_interval_us);
        if self.last_baro_us.is_some_and(|t| t_us < t + interval) {
            return;
        }
        self.pressure = Some((t_us, pa));
    }

    /// A covariance step and the updates due at `t_us`, then the feedback.
    fn epoch(&mut self, t_us: u64, fix_due: bool, baro_due: bool) {
        let since: T = micros(t_us.saturating_sub(self.last_epoch_us));
        self.last_epoch_us = t_us;
        self.stats.epochs += 1;
        // The step ends the navigation's lower-rate interval: the velocity is now's.
        self.filter.covariance_step();
        let v = self.filter.estimate.nav.v;
        if since > T::zero() {
            self.pace.1 = (v - self.pace.0) / since;
        }
        if self.phase == Phase::Pad {
            for axis in 0..3 {
                self.take_velocity(Aiding::Pad, axis, T::zero(), c(1e-4));
                let (h, at) = self.filter.antenna_row(&Vector3::zeros(), axis);
                self.take(Aiding::Pad, &h, -at, c(1e-4));
            }
        }
        if fix_due {
            if let (Some(fix), Some(origin)) = (self.fix.take(), self.origin) {
                self.gnss_update(&fix, &origin, t_us);
            }
        }
        if baro_due {
            if let (Some((t, pa)), Some(reference)) = (self.pressure.take(), self.baro_reference) {
                self.baro_update(t, pa, reference);
            }
        }
        self.filter.feedback();
        self.pace.0 = self.filter.estimate.nav.v;
        self.check();
    }

    /// A covariance that is no longer one (a NaN, an infinity, a negative variance) goes
    /// back to the prior, counted; an estimate that is no longer finite levels again.
    fn check(&mut self) {
        let p = &self.filter.covariance;
        // A zero variance is one: a state the set-up leaves out (the receiver's error of a
        // receiver that errs white) is known exactly to be zero.
        let broken =
            p.iter().any(|x| !x.is_finite()) || p.diagonal().iter().any(|d| *d < T::zero());
        if broken {
            self.stats.resets += 1;
            self.filter.covariance = StateMatrix::from_diagonal(&self.prior);
        }
        let e = &self.filter.estimate;
        let lost = e.nav.p.iter().chain(e.nav.v.iter()).any(|x| !x.is_finite())
            || !e.nav.attitude().coords.iter().all(|x| x.is_finite());
        if lost {
            self.stats.resets += 1;
            self.phase = Phase::Levelling;
            self.rest = (Vector3::zeros(), 0, 0);
        }
    }
}
