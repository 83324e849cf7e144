//! The sensor errors' prior: the calibration's own error, seen through the filter's model at
//! rest and over the flight, or a stated one for a unit whose calibration carries no
//! covariance.
//!
//! The filter models each output's error as a bias and a scale factor of what the axis senses,
//! `e = b + s u`. The calibration's error is more: per output the error of every parameter the
//! fit estimated (bias, sensitivity row, lever arm or g-sensitivity row, g-squared term; with
//! the record, the cubic and odd-quadratic terms too) times its feature at the sample
//! ([`IMU_FEATURES`]), `e = theta' phi`, with `theta ~ N(0, C)`. Over a flight the best
//! straight line through that error is `(b, s) = A theta` with `A = (U'U)^-1 U' Phi` (`U` the
//! rows `[1, u]` of the flight's samples, `Phi` their regressors), so its covariance is
//! `A C A'`; at rest the line is the bias and the sensitivity's own term. On a round spinning at
//! 1,500 rad/s a g-squared term known to 1e-8 per rad/s moves the roll gyro's line by 0.02 rad/s
//! at zero rate and 3e-5 in slope, and the axial accelerometer's misalignment error turns the
//! centripetal force across it into 0.13 m/s^2 along it: a prior taken at rest would state both
//! a few times too small. [`InFlight`] holds both lines, and the filter passes from the one to
//! the other at launch. The axes across a spin keep the line at rest
//! (a flight whose rate about its spin axis exceeds 100 rad/s RMS).

use nalgebra::DMatrix;
use spincal::correct::AnyImuCorrector;
use spincal::model::{Calibration, IMU_FEATURES, ImuOutputCovariance};
use spincal::nav::StateMatrix;
use spincal::nav::filter::index;

use super::input::{ImuSeries, median_rate};
use super::line::{Line, lines_over};
use super::unmodelled::Unmodelled;
use crate::sensor::record::stated::Regressor;
use crate::sensor::record::{PointRecord, Record};

/// A stated prior (1-sigma) for a unit whose calibration carries no covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatedPrior {
    /// Accelerometer bias, m/s^2.
    pub accel_bias: f64,
    /// Gyro bias, rad/s.
    pub gyro_bias: f64,
    /// Accelerometer scale factor.
    pub accel_scale: f64,
    /// Gyro scale factor.
    pub gyro_scale: f64,
}

impl Default for StatedPrior {
    /// A consumer MEMS unit's datasheet: 20 mg, 0.5 deg/s, 1 %, 1 %.
    fn default() -> Self {
        Self {
            accel_bias: 0.2,
            gyro_bias: 0.5f64.to_radians(),
            accel_scale: 0.01,
            gyro_scale: 0.01,
        }
    }
}

/// Where the prior came from.
#[derive(Debug, Clone, PartialEq)]
pub enum PriorSource {
    /// The calibration record's covariance of its whole model (named: the file or the unit
    /// history's record).
    Record(String),
    /// The blob's covariance factors: over every term the correction applies, the same
    /// covariance as the record's but for the terms the device does not carry (temperature
    /// curves between the table's points).
    Factors,
    /// Stated, because the calibration carries no covariance (or there is no calibration).
    Stated(StatedPrior),
}

/// Output names, in the corrector's order.
pub const OUTPUTS: [&str; 6] = ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"];

/// The sensor errors' prior from a calibration's covariance factors, at the flight's
/// temperature (the middle of the calibrated span when the recording logs none): per output the
/// covariance of the straight line through its calibration error over the samples of `imu`
/// from `from` on that the filter navigates on (see the module's page). `None` when the
/// calibration carries no covariance.
#[must_use]
pub fn calibration_prior(cal: &Calibration, imu: &ImuSeries, from: usize) -> Option<InFlight> {
    let corrector = corrector_at_flight(cal, imu)?;
    let factors = *corrector.covariance_factors()?;
    let fill = |_: usize, phi: &[f32; IMU_FEATURES], out: &mut [f64]| {
        out.copy_from_slice(&phi.map(f64::from));
    };
    let sizes = [IMU_FEATURES; 6];
    let lines = lines_over(&corrector, imu, from, sizes, &fill);
    let mut outputs = factors.accel.iter().chain(&factors.gyro);
    let mut prior = InFlight::default();
    let fits = std::array::from_fn(|out| {
        let mut own = vec![None; IMU_FEATURES];
        own[0] = Some(0);
        own[1 + out % 3] = Some(1);
        let q = outputs.next().map(covariance).unwrap_or_default();
        prior.set(out, &lines[out], &own, &q);
        (lines[out].through(&own), q)
    });
    prior.unmodelled = Unmodelled::over((&corrector, imu, from), (sizes, &fill), &lines, &fits);
    Some(prior)
}

/// What stops a record from giving the prior.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordPriorError {
    /// Another calibration's record.
    #[error("it is the record of another calibration (data {record}; the blob's {blob})")]
    Other {
        /// The record's data hash.
        record: String,
        /// The blob's.
        blob: String,
    },
    /// The record of another unit.
    #[error("it is the record of unit {record}; the blob is unit {blob}'s")]
    OtherUnit {
        /// The record's serial.
        record: String,
        /// The blob's.
        blob: String,
    },
    /// The record of another fit of the same data (another model, another day): its blob is
    /// not the blob given.
    #[error(
        "it is the record of another fit of the same data: its blob ({record}) is not the blob given ({blob}); give the record `calibrate --json` wrote with this blob"
    )]
    OtherFit {
        /// What the record's blob is (its calibration's creation time, or why it has none).
        record: String,
        /// The blob's creation time.
        blob: String,
    },
    /// Not an IMU's, or an output missing.
    #[error("it holds no fit of {0}")]
    Missing(&'static str),
    /// A term this prior cannot evaluate along a flight.
    #[error("{output}'s term `{term}` is not one the flight can evaluate")]
    Term {
        /// The output.
        output: &'static str,
        /// The term.
        term: String,
    },
    /// The calibration has no IMU corrector.
    #[error("the calibration does not correct an IMU")]
    NotImu,
}

/// Refuses a record that is not the blob's: another unit's (serial), another calibration's
/// (data hash), or another fit of the same data (the blob the record holds is not this one:
/// a record of a linear fit of the same file turned a SHIFTED flight into HELD). The blob is
/// compared as the calibration it carries, so a signed and an unsigned copy of one
/// calibration are one.
///
/// # Errors
/// The first of [`RecordPriorError::OtherUnit`], [`RecordPriorError::Other`] and
/// [`RecordPriorError::OtherFit`] that applies.
pub fn record_is_of(record: &Record, cal: &Calibration) -> Result<(), RecordPriorError> {
    let id = &cal.data().identity;
    if record.serial != id.serial.as_str() {
        return Err(RecordPriorError::OtherUnit {
            record: record.serial.clone(),
            blob: id.serial.as_str().to_string(),
        });
    }
    let hash = crate::sensor::record::hex(&id.data_hash);
    if !record.data_hash.eq_ignore_ascii_case(&hash) {
        return Err(RecordPriorError::Other {
            record: record.data_hash.clone(),
            blob: hash,
        });
    }
    let blob_made = format!("made at {} s", id.created_unix_s);
    let held = crate::sensor::record::unhex(&record.blob)
        .filter(|b| !b.is_empty())
        .ok_or_else(|| "none: the calibration was rejected".to_string())
        .and_then(|b| crate::signing::calibration(&b).map_err(|e| format!("unreadable: {e}")));
    match held {
        Ok(c) if c.data() == cal.data() => Ok(()),
        Ok(c) => Err(RecordPriorError::OtherFit {
            record: format!("made at {} s", c.data().identity.created_unix_s),
            blob: blob_made,
        }),
        Err(why) => Err(RecordPriorError::OtherFit {
            record: why,
            blob: blob_made,
        }),
    }
}

/// The sensor errors' prior from the calibration's record (`calibrate --json`): as
/// [`calibration_prior`], over the whole model each output's fit kept (cubic, odd-quadratic
/// and asymmetry terms included), at the record's table point nearest the flight's temperature.
///
/// # Errors
/// [`RecordPriorError`]: the record of another calibration, a missing output, a term the flight
/// cannot evaluate.
pub fn record_prior(
    record: &Record,
    cal: &Calibration,
    imu: &ImuSeries,
    from: usize,
) -> Result<InFlight, RecordPriorError> {
    record_is_of(record, cal)?;
    let corrector = corrector_at_flight(cal, imu).ok_or(RecordPriorError::NotImu)?;
    let at = imu.temperature.unwrap_or(f64::NAN);
    let point = record
        .points
        .iter()
        .min_by(|a, b| {
            let d = |p: &PointRecord| p.temp.map_or(0.0, |t| (t - at).abs());
            d(a).total_cmp(&d(b))
        })
        .ok_or(RecordPriorError::Missing("any output"))?;
    // Per output: its regressors, its sensitivity, its parameters' covariance in SI and which
    // regressors are the bias and the own input; then one pass over the flight for all six.
    let mut fits = Vec::with_capacity(OUTPUTS.len());
    for (out, name) in OUTPUTS.iter().enumerate() {
        let fit = point
            .axes
            .iter()
            .find(|a| a.output == *name)
            .ok_or(RecordPriorError::Missing(name))?;
        let own = if out < 3 {
            ["f_x", "f_y", "f_z"]
        } else {
            ["w_x", "w_y", "w_z"]
        }[out % 3];
        let (names, covariance) = fit.stated();
        let terms: Vec<Regressor> = names
            .iter()
            .map(|t| {
                Regressor::of(t, out).ok_or_else(|| RecordPriorError::Term {
                    output: name,
                    term: t.clone(),
                })
            })
            .collect::<Result<_, _>>()?;
        let slope = fit
            .terms
            .iter()
            .position(|t| t == own)
            .and_then(|k| fit.coefficients.get(k).copied())
            .filter(|s| s.abs() > 0.0)
            .ok_or(RecordPriorError::Missing(name))?;
        let n = terms.len();
        let q = DMatrix::from_fn(n, n, |i, j| {
            covariance
                .get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or(0.0)
                / (slope * slope)
        });
        let own_at: Vec<Option<usize>> = names
            .iter()
            .map(|t| match t.as_str() {
                "1" => Some(0),
                t if t == own => Some(1),
                _ => None,
            })
            .collect();
        fits.push((terms, slope, q, own_at));
    }
    let sizes = std::array::from_fn(|out| fits[out].0.len());
    let fill = |out: usize, phi: &[f32; IMU_FEATURES], row: &mut [f64]| {
        let (terms, slope, ..) = &fits[out];
        for (r, t) in row.iter_mut().zip(terms) {
            *r = t.value(phi, *slope);
        }
    };
    let lines = lines_over(&corrector, imu, from, sizes, &fill);
    let mut prior = InFlight::default();
    let lines_fits = std::array::from_fn(|out| {
        let (_, _, q, own_at) = &fits[out];
        prior.set(out, &lines[out], own_at, q);
        (lines[out].through(own_at), q.clone())
    });
    prior.unmodelled =
        Unmodelled::over((&corrector, imu, from), (sizes, &fill), &lines, &lines_fits);
    Ok(prior)
}

/// The corrector of `cal` at the flight's sample rate and temperature.
fn corrector_at_flight<'a>(cal: &'a Calibration, imu: &ImuSeries) -> Option<AnyImuCorrector<'a>> {
    let mut corrector =
        AnyImuCorrector::new(cal, median_rate(imu.t.iter().copied()) as f32).ok()?;
    let env = &cal.data().environment;
    let mid = |s: spincal::model::Span| 0.5 * (s.lo + s.hi);
    let temperature = imu
        .temperature
        .map_or(mid(env.temperature_span), |t| t as f32);
    corrector.set_environment(temperature, mid(env.voltage_span));
    Some(corrector)
}

/// The sensor errors' prior of a calibration for a flight: at rest (the line through each
/// output's error at zero input: its bias and its own sensitivity) and how the errors change
/// at launch, when the spin and the flight's forces move each output's line (see the module's
/// page). Both are linear in the calibration's parameter errors, so the flight's errors given
/// those at rest are Gaussian: per output `x_flight = (I + K) x_rest + w`, with `K = C P0^-1`
/// (`C` the covariance of the change with the errors at rest, `P0` theirs) and `w` independent
/// of covariance `D - K C'` (`D` the change's own). The filter applies it at launch, so that what
/// the pad teaches of the errors at rest is carried into the flight as far as it holds there.
#[derive(Debug, Clone, PartialEq)]
pub struct InFlight {
    /// Per output, `P0`, `C` and `D` (2 x 2 over its bias and scale factor).
    blocks: [[nalgebra::Matrix2<f64>; 3]; 6],
    /// What the filter's bias and scale factor do not model of the calibration's error.
    unmodelled: Unmodelled,
}

impl Default for InFlight {
    fn default() -> Self {
        Self {
            blocks: [[nalgebra::Matrix2::zeros(); 3]; 6],
            unmodelled: Unmodelled::default(),
        }
    }
}

impl InFlight {
    /// Output `out`'s blocks from its line over the flight and the covariance `q` of its
    /// parameters (`own` as [`Line::through`] takes it).
    fn set(&mut self, out: usize, line: &Line, own: &[Option<usize>], q: &DMatrix<f64>) {
        let at_rest = Line::new(own.len()).through(own);
        let change = line.through(own) - &at_rest;
        let m = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            let c = a * q * b.transpose();
            nalgebra::Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)])
        };
        self.blocks[out] = [
            m(&at_rest, &at_rest),
            m(&change, &at_rest),
            m(&change, &change),
        ];
    }

    /// What the filter's bias and scale factor do not model of the calibration's error over
    /// the flight.
    #[must_use]
    pub fn unmodelled(&self) -> &Unmodelled {
        &self.unmodelled
    }

    /// The prior at rest over the filter's states.
    #[must_use]
    pub fn at_rest(&self) -> StateMatrix<f64> {
        let mut p = StateMatrix::zeros();
        for (out, [p0, _, _]) in self.blocks.iter().enumerate() {
            let (b, s) = states(out);
            p[(b, b)] = p0[(0, 0)];
            p[(s, s)] = p0[(1, 1)];
            p[(b, s)] = p0[(0, 1)];
            p[(s, b)] = p0[(1, 0)];
        }
        p
    }

    /// The change at launch as the filter's transition `T` and added covariance `W` over its
    /// states. `open[6 + out]` marks an output whose scale factor starts open (the flight
    /// estimates it from a wide prior): its scale factor passes unchanged, and its bias is
    /// carried given its bias at rest alone.
    #[must_use]
    pub fn at_launch(&self, open: &[bool; 12]) -> (StateMatrix<f64>, StateMatrix<f64>) {
        let mut t = StateMatrix::identity();
        let mut w = StateMatrix::zeros();
        for (out, [p0, c, d]) in self.blocks.iter().enumerate() {
            let (b, s) = states(out);
            let (k, added) = if open[6 + out] {
                let k = if p0[(0, 0)] > 0.0 {
                    c[(0, 0)] / p0[(0, 0)]
                } else {
                    0.0
                };
                (
                    nalgebra::Matrix2::new(k, 0.0, 0.0, 0.0),
                    nalgebra::Matrix2::new(d[(0, 0)] - k * c[(0, 0)], 0.0, 0.0, 0.0),
                )
            } else {
                let inv = p0
                    .svd(true, true)
                    .pseudo_inverse(1e-12 * p0.abs().max())
                    .unwrap_or_else(|_| nalgebra::Matrix2::zeros());
                let k = c * inv;
                (k, d - k * c.transpose())
            };
            let added = (added + added.transpose()) * 0.5;
            let added = {
                let e = added.symmetric_eigen();
                let clamped = e.eigenvalues.map(|x| x.max(0.0));
                e.eigenvectors
                    * nalgebra::Matrix2::from_diagonal(&clamped)
                    * e.eigenvectors.transpose()
            };
            for (i, x) in [b, s].into_iter().enumerate() {
                for (j, y) in [b, s].into_iter().enumerate() {
                    t[(x, y)] += k[(i, j)];
                    w[(x, y)] = added[(i, j)];
                }
            }
        }
        (t, w)
    }
}

/// Output `out`'s bias and scale-factor states.
fn states(out: usize) -> (usize, usize) {
    let axis = out % 3;
    if out < 3 {
        (index::ACCEL_BIAS + axis, index::ACCEL_SCALE + axis)
    } else {
        (index::GYRO_BIAS + axis, index::GYRO_SCALE + axis)
    }
}

/// `L L'` of one output's packed factor (the round's own, as a matrix of this size).
fn covariance(factor: &ImuOutputCovariance) -> DMatrix<f64> {
    let c = spincal::flight::line::factor_covariance(factor);
    DMatrix::from_column_slice(IMU_FEATURES, IMU_FEATURES, c.as_slice())
}

/// A stated prior, the same at rest and in flight.
#[must_use]
pub fn stated_prior(s: &StatedPrior) -> InFlight {
    let mut prior = InFlight::default();
    for (out, block) in prior.blocks.iter_mut().enumerate() {
        let (b, k) = if out < 3 {
            (s.accel_bias, s.accel_scale)
        } else {
            (s.gyro_bias, s.gyro_scale)
        };
        block[0] = nalgebra::Matrix2::new(b * b, 0.0, 0.0, k * k);
    }
    prior
}
