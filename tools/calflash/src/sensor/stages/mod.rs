//! Two stages of calibration (the source text: "calibrate the sensors before the assembly phase;
//! after assembly, calibration would focus on the estimation of misalignment and proximity
//! effects").
//!
//! Stage one is each sensor's own single-axis calibration ([`one`]): its bias, scale factor,
//! g-squared, cubic, odd-quadratic and asymmetry terms over its temperature points. Stage two
//! (`sensor::triad::stage_two`) reads the assembled unit's observations through each sensor's
//! stage-one polynomial, so that what is left is linear: per output,
//!
//! ```text
//! x_i = beta_i + m_i . F_i  [+ g'_i . f]        x_i = h_i^-1(out_i; T)   (SI)
//! ```
//!
//! with `m_i` the sensing direction scaled by `1 + ds_i` (misalignment and any scale change in
//! assembly), `beta_i` a bias change, `F_i` the force at the axis' lever arm (accelerometers)
//! and `g'_i` the g-sensitivity (gyros). The blob's forward model at each of stage one's
//! temperatures is `out_i = h_i(beta_i + m_i . F_i)`, expanded into the device's form. Its
//! covariance carries both stages: stage one's through the stage-two fit and the composition
//! (derivatives by central differences), stage two's own. [`check`] tests whether stage one
//! still holds for each sensor (`beta_i = 0`, `|m_i| = 1`).

pub mod check;
pub mod one;

use std::path::PathBuf;

pub use check::{Check, SensorCheck};
pub use one::{Sensor1, StageOneError};

/// Stage-two observations that do not meet the stage-one records.
#[derive(Debug, thiserror::Error)]
pub enum StageTwoError {
    /// The records name temperatures but the data have none.
    #[error(
        "the stage-one records hold temperature points ({temps}) but the data have no `temp` column: stage two needs the temperature of every observation"
    )]
    NoTemperature {
        /// The records' temperatures.
        temps: String,
    },
    /// An observation beyond a record's temperature span.
    #[error(
        "line {line}: temp {temp} C is outside the span stage one calibrated {output} over ({lo} to {hi} C, {})",
        record.display()
    )]
    TemperatureSpan {
        /// The file line.
        line: u64,
        /// The temperature.
        temp: f64,
        /// The output.
        output: &'static str,
        /// The record's span.
        lo: f32,
        /// Its top.
        hi: f32,
        /// The record.
        record: PathBuf,
    },
    /// An axis driven beyond the record's calibrated range.
    #[error(
        "{output}: the unit's plan drives the axis over {lo:.4} to {hi:.4} {unit}; stage one ({}) calibrated {rlo:.4} to {rhi:.4} {unit}: its nonlinear terms are not known there",
        record.display()
    )]
    Range {
        /// The output.
        output: &'static str,
        /// What stage two covers.
        lo: f64,
        /// Its top.
        hi: f64,
        /// What stage one covers.
        rlo: f32,
        /// Its top.
        rhi: f32,
        /// The unit.
        unit: &'static str,
        /// The record.
        record: PathBuf,
    },
    /// The six records share no temperature.
    #[error("the stage-one records' temperature spans do not overlap: {spans}")]
    Spans {
        /// Each record's span.
        spans: String,
    },
    /// A stage-one polynomial that cannot be inverted at an observation.
    #[error("line {line}: {output} = {code} is not an output stage one's polynomial reaches ({})", record.display())]
    NotInvertible {
        /// The file line.
        line: u64,
        /// The output.
        output: &'static str,
        /// The code.
        code: f64,
        /// The record.
        record: PathBuf,
    },
}
