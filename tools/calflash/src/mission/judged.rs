//! A calibration judged over a mission: each output's predicted error over the flight, the
//! dropped terms' price there, and the findings it adds.

use crate::sensor::finding::Finding;

/// One output over the mission.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Output {
    /// The output column.
    pub output: String,
    /// Its input's SI unit.
    pub unit: &'static str,
    /// Predicted RMS 1-sigma error over the flight's moments within the calibrated range, SI.
    pub rms: f64,
    /// The largest there.
    pub worst: f64,
    /// Share of the flight's time within the calibrated range.
    pub share_inside: f64,
    /// What is beyond, in words.
    pub beyond: String,
    /// Predicted 1-sigma error against time, `(s, SI, within the calibrated range)`.
    pub timeline: Vec<(f64, f64, bool)>,
    /// The requirement, SI, when given.
    pub requirement: Option<f64>,
}

/// A term the bench dropped, priced over the flight.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TermCost {
    /// The output.
    pub output: String,
    /// The term.
    pub term: String,
    /// Its estimate with the kept model, counts per unit of the term.
    pub estimate: f64,
    /// Its bench bound (upper confidence bound of `|b|`).
    pub bound: f64,
    /// Its worst contribution over the flight within the calibrated range, SI.
    pub worst: f64,
}

/// The calibration over a mission.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Judged {
    /// The profile.
    pub profile: String,
    /// Per output.
    pub outputs: Vec<Output>,
    /// The dropped terms, costliest first.
    pub terms: Vec<TermCost>,
    /// Variables the profile does not give (the bench's value assumed).
    pub assumed: Vec<String>,
    /// The findings it adds.
    pub findings: Vec<Finding>,
}
