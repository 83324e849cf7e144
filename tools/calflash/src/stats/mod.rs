//! The regression engine, and the statistics of lots. It knows nothing of sensors: design
//! matrices in, least-squares fits with their inference and diagnostics out; samples of points
//! in, robust scatter and control charts out.

pub mod chart;
pub mod decompose;
pub mod dist;
pub mod influence;
pub mod multiple;
pub mod ols;
pub mod pattern;
pub mod pure_error;
pub mod robust;
pub mod select;

pub use influence::Influence;
pub use ols::{Fit, FitError, Options, Prediction, fit};
