//! Sensor workflows: from observations to the coefficient set the device applies, with the
//! evidence to accept or reject the unit.
//!
//! Every workflow fits the forward model (what the sensor outputs for a known input) per output
//! axis and per table point with the regression engine, keeps only the terms the data support,
//! derives the device's correction, measures how far that correction is from the exact
//! inverse over the calibrated range, and builds a `spincal` calibration.

mod acceptance;
pub mod accuracy;
pub mod blob;
pub mod compare;
pub mod covariance;
pub mod finding;
pub mod hysteresis;
pub mod invert;
pub mod lever;
mod noise;
pub mod record;
pub mod selfcal;
pub mod single;
pub mod stages;
pub mod table;
pub mod thermal;
pub mod threshold;
pub mod triad;
use noise::noise_reference;
pub use noise::{NoiseReference, NoiseSource};

pub use finding::{Finding, Verdict};
use std::path::{Path, PathBuf};

use spincal::model::{CalibrationData, Rails, Span};

use crate::formula::{Formula, FormulaError};
use crate::obs::{Format, ObsError};
use crate::stats::Fit;
use crate::stats::select::PartialF;

pub use acceptance::RailsError;
pub(crate) use acceptance::{exclude_beyond_rails, findings};

/// A workflow that cannot run on these observations, in words naming the file, the column,
/// the term or the table point.
#[derive(Debug, thiserror::Error)]
pub enum WorkflowError {
    /// Reading failed.
    #[error(transparent)]
    Obs(#[from] ObsError),
    /// A formula does not parse.
    #[error(transparent)]
    Formula(#[from] FormulaError),
    /// A serial the device cannot store.
    #[error(transparent)]
    Serial(#[from] blob::SerialError),
    /// A recording that cannot be read.
    #[error(transparent)]
    Recording(#[from] crate::obs::recording::RecordingError),
    /// A fit inside the backward elimination of terms that fails.
    #[error(transparent)]
    Selection(crate::stats::FitError),
    /// The device's corrector refuses the calibration.
    #[error(transparent)]
    Device(#[from] spincal::Error),
    /// The calibration does not become a blob the device reads back.
    #[error("{}: {source}", path.display())]
    Blob {
        /// The observations.
        path: PathBuf,
        /// Why.
        source: blob::BlobError,
    },
    /// Temperature and voltage setpoints that are not a full grid.
    #[error("{}: {source}", path.display())]
    Grid {
        /// The observations.
        path: PathBuf,
        /// Which setpoint has none.
        source: table::GridError,
    },
    /// A temperature (or supply voltage) column a model cannot follow.
    #[error("{}: {source}", path.display())]
    Temperatures {
        /// The observations.
        path: PathBuf,
        /// What is wrong with it, and where.
        source: thermal::data::ColumnError,
    },
    /// The device's temperature form cannot be chosen.
    #[error("{}: {source}", path.display())]
    DeviceTemperature {
        /// The observations.
        path: PathBuf,
        /// Why.
        source: thermal::device::ChooseError,
    },
    /// A still ramp that cannot be tied to the bench.
    #[error("{}: {source}", path.display())]
    StillRamp {
        /// The recording or the bench observations.
        path: PathBuf,
        /// Why.
        source: triad::still::StillRampError,
    },
    /// Outputs at or beyond the ADC rails that leave nothing to fit.
    #[error("{}: {source}", path.display())]
    Rails {
        /// The observations.
        path: PathBuf,
        /// Why.
        source: acceptance::RailsError,
    },
    /// A fit that fails, explained in the model's terms: the terms that are collinear in these
    /// observations, too few observations, values that overflow.
    #[error("{}: {explanation}", path.display())]
    Fit {
        /// The observations.
        path: PathBuf,
        /// Where and why, in the formula's and the file's words.
        explanation: String,
        /// The regression engine's error.
        source: crate::stats::FitError,
    },
    /// A weighted fit whose sandwich covariance is not positive definite.
    #[error("{}: at {at}: the weighted fit's covariance is not positive definite", path.display())]
    WeightedCovariance {
        /// The observations.
        path: PathBuf,
        /// Where the fit is (the table point).
        at: String,
    },
    /// A covariance the device's factor cannot be taken of.
    #[error("{}: {outputs} at {at}: {source}", path.display())]
    Covariance {
        /// The observations.
        path: PathBuf,
        /// The outputs whose covariance it is.
        outputs: String,
        /// The table point.
        at: String,
        /// Why.
        source: covariance::CovarianceError,
    },
    /// Observations or a plan the triad and IMU workflows cannot use.
    #[error("{}: {source}", path.display())]
    Triad {
        /// The observations (or the still ramp's recording).
        path: PathBuf,
        /// Why.
        source: triad::TriadError,
    },
    /// A calibration beyond what the device holds.
    #[error("{}: {source}", path.display())]
    DeviceLimit {
        /// The observations.
        path: PathBuf,
        /// What.
        source: blob::DeviceLimitError,
    },
    /// Observations or a model the single-axis workflow cannot use.
    #[error(transparent)]
    Single(#[from] single::SingleError),
    /// A stage-one record stage two cannot take.
    #[error(transparent)]
    StageOne(#[from] stages::StageOneError),
    /// Stage-two observations that do not meet the stage-one records.
    #[error("{}: {source}", path.display())]
    StageTwo {
        /// The observations.
        path: PathBuf,
        /// Why.
        source: stages::StageTwoError,
    },
}

impl WorkflowError {
    pub(crate) fn triad(path: &Path, source: triad::TriadError) -> Self {
        Self::Triad {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Options shared by the workflows.
#[derive(Debug, Clone)]
pub struct Options {
    /// The observations.
    pub file: PathBuf,
    /// Their format.
    pub format: Format,
    /// Unit serial number.
    pub serial: String,
    /// Significance level for term selection and tests.
    pub alpha: f64,
    /// ADC rails of every channel.
    pub rails: Rails,
    /// Temperature span when the data have no temperature column.
    pub temp_span: Span,
    /// Voltage span when the data have no voltage column.
    pub volt_span: Span,
    /// Keep every preset term (no backward elimination).
    pub keep_all_terms: bool,
    /// An IMU's correction without the nonlinear terms, even where the data show them
    /// (`calibrate --linear`): their estimate then widens the stated error.
    pub linear: bool,
    /// The nonlinear terms were asked for (`calibrate --nonlinear`): a plan that cannot
    /// estimate one is an error. Otherwise (an IMU's default) a term the plan cannot estimate
    /// is left out of the candidates, said in a note.
    pub nonlinear_required: bool,
    /// Asymmetry: `None` to decide from the test, `Some(true)` to keep, `Some(false)` to drop.
    pub asymmetry: Option<bool>,
    /// Asymmetry breakpoint (SI).
    pub breakpoint: f64,
    /// A model formula instead of the preset (single axis only).
    pub model: Option<String>,
    /// Acceptance: the largest residual noise, SI units (per axis), if specified.
    pub max_noise: Option<f64>,
    /// Creation time, seconds since 1970 (now if `None`).
    pub created: Option<u64>,
    /// The station, when the Earth's rate is a known input of the gyro fits
    /// (`crate::earth`).
    pub earth: Option<crate::earth::Station>,
    /// How the coefficients vary with temperature.
    pub thermal: Thermal,
    /// The order of every coefficient's temperature polynomial, instead of choosing each from
    /// the data.
    pub thermal_order: Option<u32>,
    /// A triad's or an IMU's recording at rest in one pose while the temperature sweeps,
    /// calibrated with the file's bench run at one temperature (`triad::still`).
    pub still_ramp: Option<PathBuf>,
}

/// How the coefficients vary with temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Thermal {
    /// A table of separate fits when the temperatures fall into well-filled setpoints, the
    /// continuous model otherwise.
    #[default]
    Auto,
    /// A separate fit at each temperature setpoint.
    Table,
    /// Every coefficient a polynomial in the temperature (`sensor::thermal`).
    Continuous,
}

impl Options {
    /// Defaults for a file.
    #[must_use]
    pub fn new(file: impl Into<PathBuf>, serial: &str) -> Self {
        Self {
            file: file.into(),
            format: Format::Auto,
            serial: serial.into(),
            alpha: 0.05,
            rails: Rails::unsigned(16),
            temp_span: Span::new(20.0, 30.0),
            volt_span: Span::new(0.0, 100.0),
            keep_all_terms: false,
            linear: false,
            nonlinear_required: false,
            asymmetry: None,
            breakpoint: 0.0,
            model: None,
            max_noise: None,
            created: None,
            earth: None,
            thermal: Thermal::Auto,
            thermal_order: None,
            still_ramp: None,
        }
    }
}

/// One fitted forward regression.
#[derive(Debug, Clone)]
pub struct AxisFit {
    /// The output column.
    pub output: String,
    /// The term of the axis' own reference input (its coefficient is the scale factor).
    pub own: String,
    /// The model.
    pub formula: Formula,
    /// The fit.
    pub fit: Fit,
    /// The fit's input values (the own-axis reference input) per observation, for figures.
    pub input: Vec<f64>,
    /// The sweep direction per observation, when the data have one.
    pub dir: Option<Vec<f64>>,
    /// File lines of the observations.
    pub lines: Vec<u64>,
    /// The noise of the observations estimated without the model's form, to hold the fit's
    /// residual noise against (`None` without replicates or rows at rest enough for one).
    pub noise_reference: Option<NoiseReference>,
    /// When the data chose the terms and some were dropped: the fit of the model before the
    /// choice at the same point, whose covariance is the stated error's
    /// ([`stated_fit`](Self::stated_fit)).
    pub full: Option<Box<Fit>>,
}

impl AxisFit {
    /// Fits `formula` over `table` with the regression statistics at level `alpha`; `own` is
    /// the axis' reference input column. A failure is an error about `path` that says where
    /// (`where_`, a table point) and why: the rank deficiency explained (prefixed with the
    /// response when `name_response`), or too few observations for the model.
    ///
    /// # Errors
    /// The fit's, as above.
    pub fn fit(
        formula: &Formula,
        table: &crate::obs::Table,
        own: &str,
        alpha: f64,
        at: (&Path, &str),
        name_response: bool,
    ) -> Result<Self, WorkflowError> {
        Self::fit_weighted(formula, table, own, alpha, at, name_response, None)
    }

    /// [`fit`](Self::fit) by weighted least squares when `weights` are given (one per
    /// observation, mean 1): sampling weights that even out where the observations crowd, not
    /// precisions, so the coefficients' covariance is the sandwich
    /// `s^2 (X'WX)^-1 X'W^2X (X'WX)^-1` with `s^2` the unweighted residual variance; the
    /// residuals and fitted values stay in the response's units, and `rss` is the weighted sum
    /// the fit minimised (the partial F tests between weighted fits compare it).
    ///
    /// # Errors
    /// As [`fit`](Self::fit).
    pub fn fit_weighted(
        formula: &Formula,
        table: &crate::obs::Table,
        own: &str,
        alpha: f64,
        (path, where_): (&Path, &str),
        name_response: bool,
        weights: Option<&[f64]>,
    ) -> Result<Self, WorkflowError> {
        use crate::stats::{self, FitError};
        let d = formula.design(table);
        let opts = stats::Options {
            alpha,
            ..stats::Options::default()
        };
        // The rows scaled by the square roots of the weights (the design itself unweighted).
        let scaled = weights.map(|w| {
            let mut x = d.x.clone();
            for (mut row, wi) in x.row_iter_mut().zip(w) {
                row *= wi.sqrt();
            }
            let y: Vec<f64> = d.y.iter().zip(w).map(|(v, wi)| v * wi.sqrt()).collect();
            (x, y)
        });
        let (x, y) = scaled
            .as_ref()
            .map_or((&d.x, &d.y[..]), |(x, y)| (x, &y[..]));
        let fit = stats::fit(x, y, d.names, d.intercept, &opts).map_err(|e| {
            let explanation = match &e {
                FitError::RankDeficient {
                    column,
                    combination,
                } => {
                    let why = formula.explain_rank_deficiency(table, *column, combination);
                    let who = if name_response {
                        format!("{} ", formula.response)
                    } else {
                        String::new()
                    };
                    format!("{who}at {where_}: {why}")
                }
                FitError::TooFewObservations { n, p } => format!(
                    "{where_} has {n} observations; the model {formula} ({p} terms) needs at least {}",
                    p + 1
                ),
                FitError::NotFinite { .. } | FitError::Overflow { .. } => formula
                    .explain_values(table, &e)
                    .unwrap_or_else(|| e.to_string()),
            };
            WorkflowError::Fit {
                path: path.to_path_buf(),
                explanation,
                source: e,
            }
        })?;
        let fit = match weights {
            Some(w) => {
                let beta = nalgebra::DVector::from_column_slice(&fit.coefficients);
                let fitted: Vec<f64> = (&d.x * beta).iter().copied().collect();
                let residuals: Vec<f64> = d.y.iter().zip(&fitted).map(|(a, b)| a - b).collect();
                let sigma2 = residuals.iter().map(|e| e * e).sum::<f64>() / fit.dof as f64;
                let bread = fit.unscaled_covariance();
                // X'W^2X: the weighted rows weighted once more.
                let mut xw = x.clone();
                for (mut row, wi) in xw.row_iter_mut().zip(w) {
                    row *= wi.sqrt();
                }
                let sandwich = &bread * xw.tr_mul(&xw) * &bread;
                // Var(e_i) / s^2 = 1 - 2 h_i + x_i' S x_i, h_i the weighted fit's leverage and S
                // the (unscaled) sandwich: the residuals' own variances, for the outlier test.
                let variance: Vec<f64> =
                    d.x.row_iter()
                        .zip(&fit.influence.leverage)
                        .map(|(row, h)| {
                            let q = (row * &sandwich * row.transpose())[(0, 0)];
                            (1.0 - 2.0 * h + q).max(f64::EPSILON)
                        })
                        .collect();
                let mut f = fit.with_covariance(sigma2, &sandwich).ok_or_else(|| {
                    WorkflowError::WeightedCovariance {
                        path: path.to_path_buf(),
                        at: where_.into(),
                    }
                })?;
                // The weighted residual sum of squares stays: it is what the partial F tests
                // between weighted fits compare.
                f.influence
                    .restudentize(&residuals, &variance, sigma2, fit.dof);
                f.fitted = fitted;
                f.residuals = residuals;
                f
            }
            None => fit,
        };
        Ok(Self {
            output: formula.response.clone(),
            own: own.into(),
            formula: formula.clone(),
            input: table.column(own).unwrap_or_default().to_vec(),
            dir: None,
            lines: table.lines.clone(),
            noise_reference: noise_reference((&d.x, &d.y), table),
            fit,
            full: None,
        })
    }

    /// The fit whose covariance states this axis' error: the model before the data chose its
    /// terms, when it dropped some, else the fit itself. A term dropped as not significant is
    /// not known to be zero: the correction leaves it out, and the stated error keeps its
    /// uncertainty (the model before the choice's covariance is the chosen one's plus each
    /// dropped term's variance through its alias, `C_R + A C_DD A'`); a term kept because it
    /// passed its test by chance is stated with the spread it has over every unit, not only
    /// over those where it passed. Over 120 independent units calibrated with the terms chosen,
    /// the 95 % intervals covered 0.92 (accelerometers) and 0.87 (gyros) with the chosen
    /// model's own covariance.
    #[must_use]
    pub fn stated_fit(&self) -> &Fit {
        self.full.as_deref().unwrap_or(&self.fit)
    }

    /// The coefficient of a term, 0 when the model lacks it.
    #[must_use]
    pub fn coef(&self, term: &str) -> f64 {
        self.index(term).map_or(0.0, |i| self.fit.coefficients[i])
    }

    /// The position of a term.
    #[must_use]
    pub fn index(&self, term: &str) -> Option<usize> {
        self.fit.names.iter().position(|n| n == term)
    }
}

/// The fits and the correction at one table point.
#[derive(Debug, Clone)]
pub struct PointFit {
    /// Temperature setpoint.
    pub temp: Option<f64>,
    /// Voltage setpoint.
    pub volt: Option<f64>,
    /// One fit per output axis.
    pub axes: Vec<AxisFit>,
    /// Worst inversion error per output axis over the calibrated range, SI.
    pub inversion_error: Vec<f64>,
    /// Residual noise per output axis in SI (residual sigma over the scale factor).
    pub noise: Vec<f64>,
}

/// A test with a decision.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// What was tested.
    pub name: String,
    /// The test.
    pub test: PartialF,
    /// The effect size in words (slopes, offset) for the report.
    pub detail: String,
    /// Whether the term is kept in the device model.
    pub kept: bool,
    /// The figure: residuals of the model without the term against the input, by group, in
    /// the input's unit (each residual count over the scale factor).
    pub figure: Vec<(String, Vec<(f64, f64)>)>,
}

/// The outcome of a calibration workflow.
#[derive(Debug, Clone)]
pub struct Calibrated {
    /// The calibration for the device.
    pub data: CalibrationData,
    /// The blob.
    pub blob: Vec<u8>,
    /// Per table point, the fits and the correction.
    pub points: Vec<PointFit>,
    /// The table's temperature breakpoints.
    pub temps: Vec<f64>,
    /// The table's voltage breakpoints.
    pub volts: Vec<f64>,
    /// Index of the reference point.
    pub reference: usize,
    /// Model choices and decisions, in words (preset expansion, terms dropped).
    pub notes: Vec<String>,
    /// Tests with decisions (asymmetry, hysteresis).
    pub decisions: Vec<Decision>,
    /// The asymmetry breakpoint used (single axis).
    pub breakpoint: f64,
    /// Per output axis, the calibrated input range (SI).
    pub ranges: Vec<Span>,
    /// Units of the inputs per output axis.
    pub units: Vec<&'static str>,
    /// Largest difference between the device's f32 correction and the f64 correction, SI.
    pub device_error: f64,
    /// The acceptance summary.
    pub findings: Vec<Finding>,
    /// The station whose Earth rate the gyro fits took as known, if any.
    pub earth: Option<crate::earth::Station>,
    /// The continuous temperature model the device's table or series was made from, one per
    /// output axis (in `points`' axis order); empty without one.
    pub thermal: Vec<thermal::ThermalFit>,
    /// The observations as fitted (with the references the workflow added), every point.
    pub table: crate::obs::Table,
    /// The calibration judged over a mission (`calibrate --mission`).
    pub mission: Option<crate::mission::judged::Judged>,
    /// A two-stage calibration's check between the stages (`sensor::stages`).
    pub stages: Option<stages::Check>,
}

impl Calibrated {
    /// The overall verdict: the worst finding.
    #[must_use]
    pub fn verdict(&self) -> Verdict {
        self.findings
            .iter()
            .map(|f| f.verdict)
            .max()
            .unwrap_or(Verdict::Accept)
    }
}

/// First 16 bytes of the SHA-256 of the files' bytes, in order (the calibration's
/// `data_hash`).
///
/// # Errors
/// The read error.
pub fn data_hash(paths: &[&Path]) -> Result<[u8; 16], ObsError> {
    use sha2::Digest as _;
    let mut h = sha2::Sha256::new();
    for path in paths {
        // Streamed: the hash of a file of any size in constant memory.
        let io = |source| ObsError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut f = std::fs::File::open(path).map_err(io)?;
        std::io::copy(&mut f, &mut h).map_err(io)?;
    }
    let mut out = [0u8; 16];
    out.copy_from_slice(&h.finalize()[..16]);
    Ok(out)
}

#[cfg(test)]
mod tests;
