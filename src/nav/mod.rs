//! In flight: strapdown navigation on the corrected samples and the error-state Kalman filter
//! that checks the calibration against GNSS and a barometer (source text: "Kalman filtering can
//! be used for in-flight calibration via known reference signals; for example, a global
//! positioning system (GPS) receiver can provide useful information").
//!
//! Generic over the scalar: the host runs it in `f64` as the reference, a round in `f32`. It
//! writes nothing but its own state.

pub mod earth;
mod estimate;
pub mod filter;
pub mod real;
pub mod strapdown;

pub use earth::Earth;
pub use filter::{ErrorFilter, NavNoise, Prior, STATES, SensorErrors, StateMatrix, StateVector};
pub use real::Real;
pub use strapdown::{Interval, Navigation, Step, Swept};
