//! What the flight filter tells the world: a snapshot of its estimate, its 1-sigma and its
//! counts, in `f32`, for the update protocol ([`crate::protocol::Request::ReadFlight`]).

use serde::{Deserialize, Serialize};

use super::line::LaunchChange;
use super::run::{FlightFilter, Phase};
use super::stats::FlightStats;
use super::verdict::Verdict;
use crate::nav::{Real, STATES};

/// A snapshot of the flight filter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightReport {
    /// Where the filter is.
    pub phase: Phase,
    /// The launch on the samples' clock, us, once detected.
    pub launch_us: Option<u64>,
    /// Position from the origin (east, north, up), m.
    pub position: [f32; 3],
    /// Velocity, m/s.
    pub velocity: [f32; 3],
    /// Attitude, body to level frame, `w, x, y, z`.
    pub attitude: [f32; 4],
    /// The sensor errors: accelerometer biases (m/s^2), gyro biases (rad/s), accelerometer
    /// and gyro scale factors, the barometer's bias (m).
    pub sensors: [f32; 13],
    /// 1-sigma of every error state (position, velocity, attitude, then the sensor errors in
    /// the order of `sensors`).
    pub sigma: [f32; STATES],
    /// The counts.
    pub stats: FlightStats,
    /// The round's verdict on its calibration ([`FlightFilter::verdict`]).
    pub verdict: Verdict,
}

fn f<T: Real>(x: T) -> f32 {
    x.to_f64() as f32
}

impl<T: Real> FlightFilter<T> {
    /// The snapshot of the filter now, its verdict on its stated prior alone.
    #[must_use]
    pub fn report(&self) -> FlightReport {
        self.report_given(None)
    }

    /// The snapshot, its verdict carrying the calibration's own change of line into the
    /// flight when given ([`FlightFilter::verdict_given`]).
    #[must_use]
    pub fn report_given(&self, change: Option<&LaunchChange>) -> FlightReport {
        let e = self.estimate();
        let s = &e.sensors;
        // The navigation now: the samples gathered since its last lower-rate step stepped.
        let mut nav = e.nav;
        let _ = nav.flush(&self.error_filter().earth);
        let q = nav.attitude();
        let mut sensors = [0.0; 13];
        let errors = s
            .accel_bias
            .iter()
            .chain(s.gyro_bias.iter())
            .chain(s.accel_scale.iter())
            .chain(s.gyro_scale.iter())
            .chain(core::iter::once(&s.baro_bias));
        for (o, x) in sensors.iter_mut().zip(errors) {
            *o = f(*x);
        }
        let mut sigma = [0.0; STATES];
        for (o, v) in sigma.iter_mut().zip(self.covariance().diagonal().iter()) {
            *o = f(v.max(T::zero()).sqrt());
        }
        FlightReport {
            phase: self.phase(),
            launch_us: self.launch_us(),
            position: [f(nav.p.x), f(nav.p.y), f(nav.p.z)],
            velocity: [f(nav.v.x), f(nav.v.y), f(nav.v.z)],
            attitude: [f(q.w), f(q.i), f(q.j), f(q.k)],
            sensors,
            sigma,
            stats: *self.stats(),
            verdict: self.verdict_given(change),
        }
    }
}
