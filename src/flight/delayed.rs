//! The flight filter on a delayed horizon ([`DelayedFlight`]).

use heapless::Deque;
use nalgebra::Vector3;

use super::run::{FlightFilter, GnssFix};
use crate::flight::FlightConfig;
use crate::nav::{Interval, Navigation, Real};

/// One held sample: its instant (us), specific force, rate, doubts.
#[derive(Debug, Clone, Copy)]
struct Held<T: Real> {
    t_us: u64,
    f: Vector3<T>,
    w: Vector3<T>,
    doubted: [bool; 2],
}

/// Fixes held at once: a 20 Hz receiver over a 400 ms horizon.
const FIXES: usize = 8;
/// Pressures held at once: a 50 Hz barometer over a 320 ms horizon (one over more goes to the
/// filter early, which holds it until its instant).
const PRESSURES: usize = 16;

/// The flight filter on a delayed horizon: the samples are held for the receiver's latency, so
/// that each fix is taken at its own instant, as navigation filters do with late measurements
/// (PX4's EKF2 runs its filter on a buffered, delayed horizon).
///
/// A fix 80 ms late describes a shell that has since turned, slowed and, at 1,600 rad/s,
/// rolled 130 radians. [`FlightFilter`] alone takes it at the sample where it arrives and
/// moves the prediction back with the errors' rates over the last covariance step: a linear
/// guess that holds for a rocket and breaks on a spinning shell (the independent simulator's
/// 105 mm shell: its track within 3 sigma on 8 % of epochs, against 100 % on the horizon;
/// `host-tests/tests/flight_round.rs`). [`DelayedFlight`]
/// gives the filter the samples `horizon` late instead, and each fix, each pressure, just
/// before the first sample after its instant: the filter then sees no latency at all.
///
/// The estimate is the horizon's age. The round's verdict (the sensor errors, their shift)
/// does not need it sooner; [`DelayedFlight::navigation_now`] carries the navigation to the
/// newest sample when something does. The buffer is `N` samples (40 bytes each in `f32`):
/// 256 hold 128 ms at 2 kHz. When the horizon is longer than the buffer holds, the oldest
/// sample goes to the filter early and a fix older than it is taken late, as without the
/// horizon ([`FlightFilter::gnss`]).
///
/// ```
/// use nalgebra::Vector3;
/// use spincal::flight::{Aiding, DelayedFlight, FlightConfig, Geodetic, GnssFix, Phase};
/// use spincal::nav::{NavNoise, SensorErrors};
///
/// let noise = NavNoise { accel_white: 1e-3, gyro_white: 1e-4, accel_walk: 1e-4,
///                        gyro_walk: 1e-5, scale_walk: 1e-6, baro_walk: 0.1,
///                        receiver_sigma: Vector3::zeros(), receiver_tau: 60.0 };
/// let prior = SensorErrors { accel_bias: Vector3::repeat(0.05), gyro_bias: Vector3::repeat(0.005),
///                            accel_scale: Vector3::repeat(1e-3), gyro_scale: Vector3::repeat(1e-3),
///                            baro_bias: 5.0 };
/// let mut config = FlightConfig::<f32>::new((0.0, 0.05), noise, prior);
/// let origin = Geodetic { latitude: 45.0, longitude: 7.0, height: 300.0 };
/// config.origin = Some(origin);
/// config.gnss_latency_us = 80_000; // the horizon: fixes come up to 80 ms after their instant
/// // 256 samples: 128 ms at 2 kHz.
/// let mut flight = DelayedFlight::<f32, 256>::new(config);
/// let (f, w) = (Vector3::new(9.806, 0.0, 0.0), Vector3::zeros());
/// let taken = |flight: &DelayedFlight<f32, 256>| {
///     flight.filter().stats().taken[Aiding::Position as usize]
/// };
/// for k in 0..=600u64 {
///     flight.sample(k * 500, &f, &w, [false, false]);
/// }
/// // At 0.30 s the filter is at 0.22 s; the fix for 0.26 s arrives and waits for it.
/// assert_eq!(flight.filter().now_us(), Some(220_000));
/// flight.gnss(&GnssFix { t_us: 260_000, position: origin, velocity: Some([0.0; 3]),
///                        satellites: 9 });
/// assert_eq!(taken(&flight), 0);
/// for k in 601..=680u64 {
///     flight.sample(k * 500, &f, &w, [false, false]);
/// }
/// // The filter has reached 0.26 s: the fix was taken at its own instant.
/// assert_eq!(flight.filter().phase(), Phase::Pad);
/// assert_eq!(taken(&flight), 3); // east, north, up
/// flight.flush();
/// assert_eq!(flight.filter().now_us(), Some(340_000));
/// assert!(flight.filter().overlay().is_some());
/// ```
#[derive(Debug, Clone)]
pub struct DelayedFlight<T: Real, const N: usize> {
    filter: FlightFilter<T>,
    horizon_us: u64,
    samples: Deque<Held<T>, N>,
    fixes: Deque<GnssFix, FIXES>,
    pressures: Deque<(u64, T), PRESSURES>,
}

impl<T: Real, const N: usize> DelayedFlight<T, N> {
    /// [`new`](Self::new), once [`FlightConfig::check`] passes.
    ///
    /// # Errors
    /// The first field of `config` the filter cannot run with, named.
    pub fn try_new(config: FlightConfig<T>) -> Result<Self, crate::flight::ConfigFault> {
        config.check()?;
        Ok(Self::new(config))
    }

    /// A filter set up by `config`, run [`FlightConfig::gnss_latency_us`] behind the samples
    /// (the filter inside takes each fix at its instant: its own latency is zero).
    #[must_use]
    pub fn new(config: FlightConfig<T>) -> Self {
        let horizon_us = u64::from(config.gnss_latency_us);
        let mut inner = config;
        inner.gnss_latency_us = 0;
        Self {
            filter: FlightFilter::new(inner),
            horizon_us,
            samples: Deque::new(),
            fixes: Deque::new(),
            pressures: Deque::new(),
        }
    }

    /// The filter, at the horizon's age: its phase, estimate, covariance, statistics, overlay.
    #[must_use]
    pub fn filter(&self) -> &FlightFilter<T> {
        &self.filter
    }

    /// How far behind the newest sample the filter runs, us.
    #[must_use]
    pub fn horizon_us(&self) -> u64 {
        self.horizon_us
    }

    /// One corrected sample (as [`FlightFilter::sample`]): held, and the samples now older than
    /// the horizon given to the filter.
    pub fn sample(&mut self, t_us: u64, f: &Vector3<T>, w: &Vector3<T>, doubted: [bool; 2]) {
        let held = Held {
            t_us,
            f: *f,
            w: *w,
            doubted,
        };
        if let Err(held) = self.samples.push_back(held) {
            // Full: the oldest goes now, whatever its age.
            self.release_one();
            let _ = self.samples.push_back(held);
        }
        let due = t_us.saturating_sub(self.horizon_us);
        while self.samples.front().is_some_and(|s| s.t_us <= due) {
            self.release_one();
        }
    }

    /// A GNSS fix as it arrives: held until the filter's samples reach its instant (one whose
    /// instant the filter has passed goes to it now, and is taken late).
    pub fn gnss(&mut self, fix: &GnssFix) {
        let front = self.samples.front().map(|s| s.t_us);
        if let Some(now) = hold(&mut self.fixes, *fix, |f| f.t_us, front) {
            self.filter.gnss(&now);
        }
    }

    /// A static pressure (Pa) read at `t_us` (as [`FlightFilter::pressure`]): held until the
    /// filter's samples reach it.
    pub fn pressure(&mut self, t_us: u64, pa: T) {
        let front = self.samples.front().map(|s| s.t_us);
        if let Some((t, pa)) = hold(&mut self.pressures, (t_us, pa), |p| p.0, front) {
            self.filter.pressure(t, pa);
        }
    }

    /// Gives the filter everything held: the end of the flight, or before reading an estimate
    /// that must be the newest.
    pub fn flush(&mut self) {
        while !self.samples.is_empty() {
            self.release_one();
        }
        while let Some(fix) = self.fixes.pop_front() {
            self.filter.gnss(&fix);
        }
        while let Some((t, pa)) = self.pressures.pop_front() {
            self.filter.pressure(t, pa);
        }
    }

    /// The filter's navigation carried through the held samples to the newest one (its sensor
    /// errors taken out as the filter knows them, a doubted reading replaced by the last trusted
    /// one). In
    /// bounded time: one strapdown step per held sample.
    #[must_use]
    pub fn navigation_now(&self) -> Navigation<T> {
        let mut last = self.filter.now_us();
        self.filter
            .error_filter()
            .carried(self.samples.iter().map(|s| {
                let dt = last.map_or(0, |t| s.t_us.saturating_sub(t));
                last = Some(s.t_us);
                (
                    s.f,
                    s.w,
                    Interval::micros(crate::nav::real::from_count(dt)),
                    s.doubted,
                )
            }))
    }

    /// The oldest held sample to the filter, after the fixes and pressures of instants before
    /// it.
    fn release_one(&mut self) {
        let Some(s) = self.samples.pop_front() else {
            return;
        };
        while let Some(fix) = due(&mut self.fixes, |f| f.t_us, s.t_us) {
            self.filter.gnss(&fix);
        }
        while let Some((t, pa)) = due(&mut self.pressures, |p| p.0, s.t_us) {
            self.filter.pressure(t, pa);
        }
        self.filter.sample(s.t_us, &s.f, &s.w, s.doubted);
    }
}

/// Holds `event` (its instant `t`) in `queue` until the filter's samples reach it, the
/// oldest held sample being at `front`; what must go to the filter now instead: the event
/// itself when the filter has passed its instant (or it is older than the last held), or the
/// oldest held one when the queue is full.
fn hold<E: Copy, const M: usize>(
    queue: &mut Deque<E, M>,
    event: E,
    t: impl Fn(&E) -> u64,
    front: Option<u64>,
) -> Option<E> {
    let passed =
        front.is_none_or(|f| t(&event) < f) || queue.back().is_some_and(|b| t(&event) < t(b));
    if passed {
        return Some(event);
    }
    match queue.push_back(event) {
        Ok(()) => None,
        Err(event) => {
            let oldest = queue.pop_front();
            let _ = queue.push_back(event);
            oldest
        }
    }
}

/// The oldest event of `queue` whose instant `t` is not after `until`, taken out.
fn due<E: Copy, const M: usize>(
    queue: &mut Deque<E, M>,
    t: impl Fn(&E) -> u64,
    until: u64,
) -> Option<E> {
    if queue.front().is_some_and(|e| t(e) <= until) {
        queue.pop_front()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::Geodetic;

    fn config() -> FlightConfig<f64> {
        let mut config = crate::flight::config::example::<f64>();
        config.heading = (0.0, 0.05);
        config.noise.receiver_sigma = Vector3::zeros();
        config.origin = Some(Geodetic {
            latitude: 45.0,
            longitude: 7.0,
            height: 300.0,
        });
        config.gnss_latency_us = 50_000;
        config
    }

    /// The navigation carried through the held samples is the navigation the filter reaches
    /// when they are given to it.
    #[test]
    fn the_navigation_now_is_where_the_filter_gets_with_the_held_samples() {
        let mut flight = DelayedFlight::<f64, 200>::new(config());
        for k in 0..1000u64 {
            // Levelled at rest, then launched: in flight, with no fix, an epoch only steps
            // the covariance (on the pad it would also take a zero velocity).
            let f = if k < 600 {
                Vector3::new(9.8, 0.0, 0.0)
            } else {
                Vector3::new(30.0, 0.3, -0.2)
            };
            let w = Vector3::new(0.1, -0.2, 0.05) * (k as f64 * 1e-3).sin();
            flight.sample(k * 500, &f, &w, [false, k > 800 && k % 37 == 5]);
        }
        assert_eq!(flight.filter().now_us(), Some(449_500));
        assert_eq!(flight.filter().phase(), crate::flight::Phase::Flight);
        let now = flight.navigation_now();
        flight.flush();
        let mut then = flight.filter().estimate().nav;
        let _ = then.flush(&flight.filter().error_filter().earth);
        assert!((now.p - then.p).norm() < 1e-12, "{:?} {:?}", now.p, then.p);
        assert!((now.v - then.v).norm() < 1e-12, "{:?} {:?}", now.v, then.v);
        assert!(now.attitude().angle_to(&then.attitude()) < 1e-12);
        // Moving: the held samples changed the navigation.
        assert!(now.v.norm() > 1.0, "{:?}", now.v);
    }

    /// A buffer shorter than the horizon gives the oldest sample to the filter when it is
    /// full: the filter is never more than the buffer's `N` samples behind.
    #[test]
    fn a_full_buffer_gives_its_oldest_sample_to_the_filter() {
        let mut flight = DelayedFlight::<f64, 10>::new(config());
        for k in 0..100u64 {
            flight.sample(
                k * 500,
                &Vector3::new(9.8, 0.0, 0.0),
                &Vector3::zeros(),
                [false; 2],
            );
        }
        assert_eq!(flight.filter().now_us(), Some(89 * 500));
    }
}
