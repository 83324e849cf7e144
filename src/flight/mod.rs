//! In flight, on the round: the GNSS- and barometer-aided error-state filter of [`crate::nav`]
//! run on the corrector's output, `no_std`, without allocation, in bounded time per call.
//!
//! A [`FlightFilter`] levels the unit from the rest it sees first (once it knows its origin,
//! given or from the first good fix), holds it on the pad with zero-velocity updates, detects
//! the launch by the specific force, and then navigates every sample (de-spun attitude with
//! the coning term, the level-frame force by the trapezoid, gravity and Coriolis), steps the
//! covariance at most every [`FlightConfig::covariance_interval_us`] over what the samples
//! integrated, and takes the GNSS fixes and the barometer's pressures as they come (gated,
//! counted in [`FlightStats`]). Its estimate of the residual biases goes to the corrector as
//! an [`Overlay`](crate::correct::Overlay) through [`FlightFilter::overlay`]: in RAM, never
//! written into the stored calibration (a new calibration still needs a signed blob).
//!
//! Its verdict on the calibration ([`FlightFilter::verdict`], [`verdict`]) tests each sensor
//! term's in-flight estimate against what it would be had nothing shifted at launch; with the
//! calibration's covariance, [`Round`] gathers the flight's own lines ([`line`](mod@line)) so that
//! "nothing shifted" is the calibration's own error carried into the flight.
//!
//! Generic over the scalar: `f32` on the Cortex-M4F; the host runs the same code in `f64` as
//! the reference, and the two agree on a flight to a small fraction of the 1-sigma
//! (`host-tests/tests/flight_device.rs`). Transcendentals come from `libm` on every target, so
//! the `f32` filter gives the same bits on the host and the device (the QEMU golden flight).
//!
//! What it refuses, and counts: fixes that are not a position on the Earth, from too few
//! satellites, repeated, stamped more than a second in the past or future; pressures outside
//! 1 .. 120 kPa, and the barometer near Mach 1; innovations beyond the gate; samples whose time
//! does not advance. Flagged samples and gaps are navigated on doubt (the last trusted reading
//! stands in, the covariance widens). A covariance that stops being one goes back to the
//! prior, counted in [`FlightStats::resets`]; nothing NaN reaches the overlay.
//!
//! ```
//! use nalgebra::Vector3;
//! use spincal::flight::{FlightConfig, FlightFilter, Geodetic, GnssFix, Phase};
//! use spincal::nav::{NavNoise, SensorErrors};
//!
//! // The receiver's position error wanders by 1.5 m (3 m in height) over 60 s.
//! let noise = NavNoise { accel_white: 1e-3, gyro_white: 1e-4, accel_walk: 1e-4,
//!                        gyro_walk: 1e-5, scale_walk: 1e-6, baro_walk: 0.1,
//!                        receiver_sigma: Vector3::new(1.5, 1.5, 3.0), receiver_tau: 60.0 };
//! let prior = SensorErrors { accel_bias: Vector3::repeat(0.05), gyro_bias: Vector3::repeat(0.005),
//!                            accel_scale: Vector3::repeat(1e-3), gyro_scale: Vector3::repeat(1e-3),
//!                            baro_bias: 5.0 };
//! let mut config = FlightConfig::<f32>::new((0.0, 0.05), noise, prior);
//! config.origin = Some(Geodetic { latitude: 45.0, longitude: 7.0, height: 300.0 });
//! let mut filter = FlightFilter::new(config);
//! // At 2 kHz, at rest, x up: the corrector's outputs (and whether each sensor is in doubt).
//! let (f, w) = (Vector3::new(9.806, 0.0, 0.0), Vector3::zeros());
//! for k in 0..1000u64 {
//!     filter.sample(k * 500, &f, &w, [false, false]);
//! }
//! filter.gnss(&GnssFix { t_us: 500_000, position: config.origin.unwrap(),
//!                        velocity: Some([0.0; 3]), satellites: 9 });
//! assert_eq!(filter.phase(), Phase::Pad);
//! assert!(filter.overlay().is_some());
//! ```

mod air;
mod config;
mod delayed;
mod doubt;
pub mod line;
mod origin;
mod overlay;
mod report;
mod round;
mod run;
mod stats;
pub mod verdict;

pub use air::{pressure_height, speed_of_sound};
pub use config::{ConfigFault, FlightConfig};
pub use delayed::DelayedFlight;
pub use doubt::doubted;
pub use line::{FlightLines, LaunchChange};
pub use origin::{Geodetic, Origin};
pub use report::FlightReport;
pub use round::Round;
pub use run::{FlightFilter, GnssFix, LOST_VELOCITY, Phase};
pub use stats::{Aiding, FlightStats, MAX_FIX_AGE_US, MAX_SAMPLE_GAP_US};
pub use verdict::{Verdict, Word};
