//! The regression engine. It knows nothing of sensors: design matrices in, least-squares fits
//! with their inference and diagnostics out.

pub mod decompose;
pub mod dist;
pub mod influence;
pub mod ols;
pub mod pattern;
pub mod select;

pub use influence::Influence;
pub use ols::{Fit, FitError, Options, Prediction, fit};
