//! What the flight filter counts: the measurements it took and refused, the inputs it could
//! not use and why, and the resets of its covariance.

use serde::{Deserialize, Serialize};

/// The kinds of measurement, as indices into [`FlightStats`]'s arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Aiding {
    /// On the pad: zero velocity and position.
    Pad = 0,
    /// GNSS position (one per axis).
    Position = 1,
    /// GNSS velocity (one per axis).
    Velocity = 2,
    /// Barometric height.
    Baro = 3,
}

/// The flight filter's counts since it started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightStats {
    /// Scalar measurements taken, per [`Aiding`].
    pub taken: [u32; 4],
    /// Scalar measurements refused at the gate, per [`Aiding`].
    pub refused: [u32; 4],
    /// Scalar measurements (taken or refused) whose innovation was inside its 95 % bounds
    /// (`|nu| <= 1.96 sigma`), per [`Aiding`].
    pub inside: [u32; 4],
    /// Sum of the normalised innovation squared (`nu^2 / s`) of those taken, per [`Aiding`].
    pub nis: [f32; 4],
    /// Fixes not a position on the Earth (NaN, out of range), or with a NaN velocity.
    pub gnss_invalid: u32,
    /// Fixes from too few satellites.
    pub gnss_few_satellites: u32,
    /// Fixes that describe an instant more than [`MAX_FIX_AGE_US`] before the filter's time.
    pub gnss_stale: u32,
    /// Fixes stamped more than [`MAX_FIX_AGE_US`] after the filter's time.
    pub gnss_future: u32,
    /// Fixes that repeat the previous one (a receiver holding its last solution).
    pub gnss_repeated: u32,
    /// Fixes replaced by a newer one before the samples reached them.
    pub gnss_dropped: u32,
    /// Pressures not finite or outside 1 kPa .. 120 kPa.
    pub baro_invalid: u32,
    /// Pressures left out near and beyond Mach 1.
    pub baro_transonic: u32,
    /// Samples navigated on doubt (flagged by the corrector).
    pub doubted: u32,
    /// Samples whose time did not advance, or that came after a gap of more than
    /// [`MAX_SAMPLE_GAP_US`] (navigated as doubted).
    pub time_faults: u32,
    /// Covariance steps (each followed by the updates due and the feedback).
    pub epochs: u32,
    /// Fixes that put the navigation back after it lost track (its velocity's 1-sigma over
    /// [`LOST_VELOCITY`](super::run::LOST_VELOCITY) m/s, as after a saturated setback).
    pub navigation_resets: u32,
    /// Covariance resets to the prior (a NaN, an infinity or a negative variance).
    pub resets: u32,
}

/// A fix older or newer than this against the filter's clock is refused, us.
pub const MAX_FIX_AGE_US: u64 = 1_000_000;

/// A sample later than this after the previous one counts as a gap, us.
pub const MAX_SAMPLE_GAP_US: u64 = 100_000;

impl FlightStats {
    /// Mean normalised innovation squared of the measurements of `kind` taken (1 when the
    /// filter's covariance is right), or `None` when none was.
    #[must_use]
    pub fn mean_nis(&self, kind: Aiding) -> Option<f32> {
        let k = kind as usize;
        let n = *self.taken.get(k)?;
        (n > 0).then(|| self.nis.get(k).copied().unwrap_or(0.0) / n as f32)
    }
}
