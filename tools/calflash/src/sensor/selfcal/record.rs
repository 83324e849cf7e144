//! The record of a calibration without equipment (`calflash.selfcal/1`): what `selfcal`
//! writes as JSON, keeps in the unit history and `compare` reads back.

use super::DeviceCheck;
use super::acceptance::verdict;
use crate::nonlinear::selfcal::{Holdout, Options, QuadraticTest, SelfCal, Skipped, Trial};
use crate::obs::recording::{Gap, Recording};
use crate::obs::units::Sensor;
use crate::sensor::Verdict;

/// The record's schema.
pub const SCHEMA: &str = "calflash.selfcal/1";

/// The convention of the stored coefficients, for users applying them elsewhere.
pub const CONVENTION: &str = "raw counts r per axis (or SI values, as `inputs` says: then read `count` as that unit), v = r - center (counts); accelerometer a = M (v + q * v^2) + o in m/s^2, \
M upper triangular (m/s^2 per count), rows and columns in x, y, z order, q per axis (1/count), o in m/s^2; \
gyro w = G v in rad/s, G full 3x3 (rad/s per count) that also rotates the gyro axes into the body frame, \
center = the gyro bias in counts; body frame = accelerometer frame: x along the accelerometer's x axis, y in its x-y plane, z completing a right-handed frame. \
Matrices are row-major: M[i][j] multiplies v[j] into output i.";

/// Why a calibration of physical values has no blob.
pub const NO_BLOB: &str = "no blob: the values are physical (SI) and the device corrects converter \
codes; give --lsb ACCEL,GYRO (the value of one code, from the part's datasheet) to calibrate the \
codes and write one";

/// The record of one calibration without equipment.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SelfcalRecord<'a> {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// The unit's serial.
    pub serial: &'a str,
    /// ACCEPT, REVIEW or REJECT.
    #[serde(serialize_with = "word")]
    pub verdict: Verdict,
    /// Why it is not ACCEPT.
    pub notes: Vec<String>,
    /// [`CONVENTION`].
    pub convention: &'static str,
    /// The recording it came from.
    pub recording: RecordingSummary<'a>,
    /// The options of the fit.
    pub options: &'a Options,
    /// The still-detection thresholds tried.
    pub threshold_search: &'a [Trial],
    /// The threshold multiplier chosen.
    pub chosen_multiplier: f64,
    /// The poses found.
    pub poses: Vec<Pose>,
    /// The accelerometer's fit.
    pub accel: Accel<'a>,
    /// The gyro's fit.
    pub gyro: Gyro<'a>,
    /// What the files' values are.
    pub inputs: Inputs,
    /// The blob and the device's correction against the fit.
    pub device: Device,
}

/// Serialises a verdict as the reports print it (`ACCEPT`).
fn word<S: serde::Serializer>(v: &Verdict, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.word())
}

/// The recording, summarised.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RecordingSummary<'a> {
    /// Its files.
    pub source: &'a str,
    /// Samples.
    pub samples: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Gaps in the timestamps.
    pub gaps: &'a [Gap],
    /// Samples at the rails, per sensor.
    pub saturated: Saturated,
    /// The temperature column, when there is one.
    pub temperature: Option<Temperature<'a>>,
}

/// Samples at the rails.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Saturated {
    /// Of the accelerometer.
    pub accel: usize,
    /// Of the gyro.
    pub gyro: usize,
}

/// A temperature column's name, least, mean and largest value.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Temperature<'a> {
    /// Its name.
    pub column: &'a str,
    /// Least.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// Largest.
    pub max: f64,
}

impl<'a> Temperature<'a> {
    /// The recording's temperature column, when it has a non-empty one.
    #[must_use]
    pub fn of(rec: &'a Recording) -> Option<Self> {
        let (name, v) = rec.temperature.as_ref()?;
        if v.is_empty() {
            return None;
        }
        Some(Self {
            column: name,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            mean: v.iter().sum::<f64>() / v.len() as f64,
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// One pose the unit was held still in.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Pose {
    /// Its start after the recording's, s.
    pub from_s: f64,
    /// Its end, s.
    pub to_s: f64,
    /// Its first and last file lines.
    pub lines: [u32; 2],
    /// The accelerometer's mean counts.
    pub accel_mean_counts: [f64; 3],
    /// `|a| - g` of the fit there, m/s^2.
    pub residual_m_s2: f64,
}

/// The accelerometer's fit.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Accel<'a> {
    /// `center` of the convention, counts.
    pub center_counts: [f64; 3],
    /// `M`, m/s^2 per count.
    pub matrix_m_s2_per_count: [[f64; 3]; 3],
    /// `o`, m/s^2.
    pub offset_m_s2: [f64; 3],
    /// `q`, 1/count.
    pub quadratic_per_count: [f64; 3],
    /// The fitted parameters' names.
    pub terms: &'a [&'static str],
    /// Their values.
    pub parameters: &'a [f64],
    /// Their covariance (`None`: not all observable).
    pub covariance: Option<Vec<Vec<f64>>>,
    /// RMS of `|a| - g`, m/s^2.
    pub rms_m_s2: f64,
    /// Largest.
    pub max_m_s2: f64,
    /// The noise of one pose's `|a|`, m/s^2.
    pub sigma_m_s2: f64,
    /// Whether the quadratic terms are significant.
    pub quadratic_test: Option<QuadraticTest>,
    /// Poses left out, predicted.
    pub holdout: Holdout,
}

/// The gyro's fit.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Gyro<'a> {
    /// The bias, counts (the convention's `center`).
    pub bias_counts: [f64; 3],
    /// Its spread over the rests.
    pub bias_spread_counts: [f64; 3],
    /// Its RMS over the rests.
    pub bias_rms_counts: [f64; 3],
    /// `G`, rad/s per count.
    pub matrix_rad_s_per_count: [[f64; 3]; 3],
    /// The fitted parameters' names.
    pub terms: [&'static str; 9],
    /// Their covariance (`None`: not all observable).
    pub covariance: Option<Vec<Vec<f64>>>,
    /// RMS angle error of the gravity direction after each rotation, degrees.
    pub rms_deg: f64,
    /// Largest.
    pub max_deg: f64,
    /// The same as a device with the stored constant bias sees it between the poses' means,
    /// from the end of one pose to the start of the next (the reference tools' measure), degrees.
    pub constant_bias_rms_deg: f64,
    /// Each rotation.
    pub rotations: Vec<Rotation>,
    /// Rotations left out of the fit.
    pub skipped: &'a [Skipped],
    /// Poses the gyro turned through (0-based): left out of the bias.
    pub turning_poses: &'a [usize],
}

/// One rotation between poses.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Rotation {
    /// The pose it ends in.
    pub after_pose: usize,
    /// Angle error of the gravity direction it predicts, degrees.
    pub angle_error_deg: f64,
    /// The same as a device with the stored constant bias sees it between the poses' means,
    /// degrees.
    pub constant_bias_angle_error_deg: f64,
}

/// What the files' values are.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Inputs {
    /// The accelerometer's, in words.
    pub accel: String,
    /// The gyro's.
    pub gyro: String,
    /// The accelerometer file's unit.
    pub accel_file_unit: &'static str,
    /// The gyro file's.
    pub gyro_file_unit: &'static str,
    /// The value of one code, when given (`--lsb`).
    pub lsb: [Option<f64>; 2],
}

/// The blob and the device's correction of the recording against the fit.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
pub enum Device {
    /// Written and checked.
    Checked {
        /// Its bytes.
        blob_bytes: usize,
        /// Largest accelerometer difference at the poses, m/s^2.
        accel_f32_vs_f64_m_s2: f64,
        /// Largest gyro difference during the rotations, rad/s.
        gyro_f32_vs_f64_rad_s: f64,
        /// RMS of `|a| - g` from the device's corrected samples, m/s^2.
        accel_rms_m_s2: f64,
    },
    /// None (physical values).
    NotWritten {
        /// Always `null`.
        blob_bytes: Option<usize>,
        /// [`NO_BLOB`].
        not_written: &'static str,
    },
}

/// A matrix as rows.
fn rows(m: Option<&nalgebra::DMatrix<f64>>) -> Option<Vec<Vec<f64>>> {
    m.map(|m| {
        (0..m.nrows())
            .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
            .collect()
    })
}

/// RMS of angles (radians) in degrees.
#[must_use]
pub fn rms_deg(a: &[f64]) -> f64 {
    (a.iter().map(|x| x * x).sum::<f64>() / a.len().max(1) as f64)
        .sqrt()
        .to_degrees()
}

impl<'a> SelfcalRecord<'a> {
    /// The record of calibration `c` of unit `serial` from `rec`, with the device's check
    /// when a blob was made.
    #[must_use]
    pub fn new(
        c: &'a SelfCal,
        rec: &'a Recording,
        check: Option<&DeviceCheck>,
        serial: &'a str,
    ) -> Self {
        let (verdict, notes) = verdict(c, check);
        let t0 = rec.t[0];
        let poses = c
            .poses
            .iter()
            .zip(&c.pose_means)
            .zip(&c.accel.residuals)
            .map(|((r, m), e)| Pose {
                from_s: rec.t[r.start] - t0,
                to_s: rec.t[r.end - 1] - t0,
                lines: [rec.line[r.start], rec.line[r.end - 1]],
                accel_mean_counts: *m,
                residual_m_s2: *e,
            })
            .collect();
        let rotations = c
            .rotations
            .iter()
            .zip(&c.gyro.angles)
            .zip(&c.constant_bias_angles)
            .map(|((k, a), b)| Rotation {
                after_pose: *k,
                angle_error_deg: a.to_degrees(),
                constant_bias_angle_error_deg: b.to_degrees(),
            })
            .collect();
        let [accel_units, gyro_units] = &rec.units;
        Self {
            schema: SCHEMA,
            serial,
            verdict,
            notes,
            convention: CONVENTION,
            recording: RecordingSummary {
                source: &rec.source,
                samples: rec.len(),
                rate_hz: rec.rate(),
                gaps: &rec.gaps,
                saturated: Saturated {
                    accel: rec.saturated_count.0,
                    gyro: rec.saturated_count.1,
                },
                temperature: Temperature::of(rec),
            },
            options: &c.options,
            threshold_search: &c.trials,
            chosen_multiplier: c.trials[c.chosen].multiplier,
            poses,
            accel: Accel {
                center_counts: c.accel.model.center,
                matrix_m_s2_per_count: c.accel.model.matrix,
                offset_m_s2: c.accel.model.offset,
                quadratic_per_count: c.accel.model.quadratic,
                terms: &c.accel.terms,
                parameters: &c.accel.params,
                covariance: rows(c.accel.covariance.as_ref()),
                rms_m_s2: c.accel.rms(),
                max_m_s2: c.accel.max(),
                sigma_m_s2: c.accel.sigma(),
                quadratic_test: c.quadratic_test,
                holdout: c.holdout,
            },
            gyro: Gyro {
                bias_counts: c.gyro_bias,
                bias_spread_counts: c.gyro_bias_spread,
                bias_rms_counts: c.gyro_bias_rms,
                matrix_rad_s_per_count: c.gyro.matrix,
                terms: crate::nonlinear::rotation::TERMS,
                covariance: rows(c.gyro.covariance.as_ref()),
                rms_deg: c.gyro.rms_deg(),
                max_deg: c.gyro.max_deg(),
                constant_bias_rms_deg: rms_deg(&c.constant_bias_angles),
                rotations,
                skipped: &c.skipped,
                turning_poses: &c.turning_poses,
            },
            inputs: Inputs {
                accel: accel_units.describe(Sensor::Accel),
                gyro: gyro_units.describe(Sensor::Gyro),
                accel_file_unit: accel_units.file.name(),
                gyro_file_unit: gyro_units.file.name(),
                lsb: rec.units.map(|u| u.lsb),
            },
            device: check.map_or(
                Device::NotWritten {
                    blob_bytes: None,
                    not_written: NO_BLOB,
                },
                |check| Device::Checked {
                    blob_bytes: check.blob.len(),
                    accel_f32_vs_f64_m_s2: check.accel,
                    gyro_f32_vs_f64_rad_s: check.gyro,
                    accel_rms_m_s2: check.device_accel_rms,
                },
            ),
        }
    }
}
