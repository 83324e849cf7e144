//! Observations or a plan the triad and IMU workflows cannot use.

use crate::columns as col;

/// Observations or a plan the triad and IMU workflows cannot use, in words naming the column,
/// the line, the option or the plan item that would fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TriadError {
    /// The file lacks reference or output columns the sensor kind needs.
    #[error(
        "missing the column{} {} (reference f_* in m/s^2, w_* in rad/s; outputs a_*, g_* in counts); the file has: {found}",
        if missing.len() > 1 { "s" } else { "" },
        missing.join(", ")
    )]
    MissingColumns {
        /// The columns missing.
        missing: Vec<String>,
        /// The file's columns, listed.
        found: String,
    },
    /// An observation whose Earth rate is not known.
    #[error(
        "line {line}: {source}; --latitude needs the columns {} for still positions",
        col::H.join(" ")
    )]
    EarthRate {
        /// The file's line.
        line: u64,
        /// Why.
        source: crate::earth::EarthError,
    },
    /// `--thermal table` on temperatures along a ramp.
    #[error(
        "--thermal table: the temperatures are spread from {lo:.1} to {hi:.1} C, as along a ramp, not held at setpoints (each reading within 1 C of its setpoint, the setpoints at least 3 C apart); give --thermal continuous for a model that follows the temperature wherever the observations fall"
    )]
    NotSetpoints {
        /// The lowest temperature, C.
        lo: f64,
        /// The highest, C.
        hi: f64,
    },
    /// A continuous temperature model with a supply voltage that varies.
    #[error(
        "the supply voltage varies: a triad's or an IMU's continuous temperature model does not follow the voltage (a single axis' does); hold the supply at one voltage along the ramp, or take the observations at a few exact temperature and voltage setpoints"
    )]
    VoltageVaries,
    /// `--still-ramp` with `--latitude`.
    #[error(
        "--still-ramp with --latitude: the still pose's heading is not known, so neither is the Earth's rate it senses; leave --latitude out (the gyro biases absorb it)"
    )]
    StillRampWithLatitude,
    /// A sensitivity matrix that cannot be inverted.
    #[error("the fitted sensitivity matrix is singular: the plan does not separate the axes")]
    SingularSensitivity,
    /// The joint fit of sensitivity and lever arm that does not converge.
    #[error(
        "{output} at {at}: the fit of the sensitivity and lever arm did not settle in {steps} steps; the plan may not separate them (spin the unit at several rates and hold it still in several positions)"
    )]
    NotSettled {
        /// The output axis.
        output: String,
        /// The table point.
        at: String,
        /// The steps taken.
        steps: usize,
    },
    /// A reference input that never changes.
    #[error(
        "{input} is constant over the observations: the plan gives the triad no input along it"
    )]
    ConstantInput {
        /// The reference column.
        input: String,
    },
}
