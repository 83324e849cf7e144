//! The round's flight loop: its [`FlightFilter`] on the corrected samples, and the flight's
//! lines ([`FlightLines`]) gathered beside it from the end of the setback on, so that the
//! round's verdict holds "nothing shifted" to the calibration's own error over its own flight
//! ([`LaunchChange`]).

use nalgebra::Vector3;

use super::line::{FlightLines, LaunchChange, OUTPUTS};
use super::report::FlightReport;
use super::run::FlightFilter;
use crate::model::{IMU_FEATURES, ImuCovariance};
use crate::nav::Real;

/// The round's flight loop's state.
#[derive(Debug, Clone)]
pub struct Round<T: Real> {
    /// The filter.
    pub filter: FlightFilter<T>,
    /// The flight's lines.
    pub lines: FlightLines,
}

impl<T: Real> Round<T> {
    /// A round flying `filter`.
    #[must_use]
    pub fn new(filter: FlightFilter<T>) -> Self {
        Self {
            filter,
            lines: FlightLines::default(),
        }
    }

    /// One corrected sample at `t_us` (`ax ay az gx gy gz`, which sensors are in doubt);
    /// `features` gives the corrector's error features there (`error_features`), asked for only
    /// when the lines take the sample (every sample after the setback).
    pub fn sample(
        &mut self,
        t_us: u64,
        values: &[f32; OUTPUTS],
        doubted: [bool; 2],
        features: impl FnOnce() -> [[f32; IMU_FEATURES]; OUTPUTS],
    ) {
        let c = |x: f32| -> T { nalgebra::convert(f64::from(x)) };
        let [ax, ay, az, gx, gy, gz] = *values;
        self.filter.sample(
            t_us,
            &Vector3::new(c(ax), c(ay), c(az)),
            &Vector3::new(c(gx), c(gy), c(gz)),
            doubted,
        );
        if self.filter.setback_end_us().is_some() {
            self.lines.add(values, &features(), doubted);
        }
    }

    /// The snapshot, its verdict carrying the calibration's change of line over the flight
    /// when the calibration carries covariance `factors`.
    #[must_use]
    pub fn report(&self, factors: Option<&ImuCovariance>) -> FlightReport {
        let change = factors.map(|f| LaunchChange::of(f, &self.lines));
        self.filter.report_given(change.as_ref())
    }
}
