//! The calibration record: what `calflash calibrate --json` writes (schema
//! `calflash.calibration/1`) and `calflash compare` reads. It carries the forward fits with
//! their covariances per table point and output axis, the decisions, the acceptance summary and
//! the blob itself.

use serde::{Deserialize, Serialize};

pub mod signature;
pub mod stated;

pub use signature::{RecordSignature, Signer, Trust, TrustError, Untrusted};

use super::{Calibrated, Finding, Verdict};

/// The schema identifier.
pub const SCHEMA: &str = "calflash.calibration/1";

/// A record that is not as `calflash` wrote it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Unsealed {
    /// No seal: written by hand, or before records were sealed.
    #[error(
        "the record has no seal (written by hand, or by a calflash before records were sealed): calibrate again to make a sealed record"
    )]
    Missing,
    /// A field that contradicts the record's own blob.
    #[error("field `{field}`: {why}: the record was changed after calflash wrote it")]
    Field {
        /// The field.
        field: String,
        /// What it says against the blob.
        why: String,
    },
    /// The seal does not match.
    #[error(
        "its seal does not match its content: a field (a coefficient, a covariance, a finding, the verdict) was changed after calflash wrote it"
    )]
    Broken,
}

/// One forward fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisRecord {
    /// Output column.
    pub output: String,
    /// Model formula.
    pub model: String,
    /// Term names.
    pub terms: Vec<String>,
    /// Coefficients (counts per unit of each term).
    pub coefficients: Vec<f64>,
    /// Standard errors.
    pub std_errors: Vec<f64>,
    /// Covariance, rows in the order of `terms`.
    pub covariance: Vec<Vec<f64>>,
    /// Residual variance (counts^2).
    pub sigma2: f64,
    /// Residual degrees of freedom.
    pub dof: usize,
    /// Observations.
    pub n: usize,
    /// Residual noise in SI units.
    pub noise: f64,
    /// Worst inversion error of the device's correction, SI.
    pub inversion_error: f64,
    /// When the data chose the terms and dropped some: the terms of the model before the
    /// choice, whose covariance ([`stated_covariance`](Self::stated_covariance)) states the
    /// error (`sensor::AxisFit::stated_fit`); empty when the fit's own do.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stated_terms: Vec<String>,
    /// Their covariance, rows in the order of `stated_terms`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stated_covariance: Vec<Vec<f64>>,
}

impl AxisRecord {
    /// The terms and covariance that state this axis' error: the model before the choice of
    /// terms when it dropped some, else the fit's own.
    #[must_use]
    pub fn stated(&self) -> (&[String], &[Vec<f64>]) {
        if self.stated_terms.is_empty() {
            (&self.terms, &self.covariance)
        } else {
            (&self.stated_terms, &self.stated_covariance)
        }
    }
}

/// One table point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointRecord {
    /// Temperature setpoint, if the table has a temperature axis.
    pub temp: Option<f64>,
    /// Voltage setpoint.
    pub volt: Option<f64>,
    /// Fits per output axis.
    pub axes: Vec<AxisRecord>,
}

/// A calibration record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// `calflash.calibration/1`.
    pub schema: String,
    /// Unit serial.
    pub serial: String,
    /// `single`, `triad` or `imu`.
    pub sensor: String,
    /// The converter's codes (`unsigned16`, `signed16`, ... or `LO:HI`).
    #[serde(default)]
    pub codes: String,
    /// The container the device takes the samples in (`u16`, `i16`, `i32`), as the blob
    /// states.
    #[serde(default)]
    pub sample_format: String,
    /// Seconds since 1970.
    pub created_unix_s: u64,
    /// The observation file.
    pub data_file: String,
    /// First 16 bytes of its SHA-256, hex.
    pub data_hash: String,
    /// Tool version.
    pub tool_version: String,
    /// The overall verdict.
    pub verdict: Verdict,
    /// The acceptance checks.
    pub findings: Vec<Finding>,
    /// Model choices.
    pub notes: Vec<String>,
    /// Tests with decisions: name, F, p, kept, detail.
    pub decisions: Vec<serde_json::Value>,
    /// The table points.
    pub points: Vec<PointRecord>,
    /// Largest f32-versus-f64 difference of the device's correction.
    pub device_error: f64,
    /// The blob, hex.
    pub blob: String,
    /// The record's seal: the SHA-256 (hex) of the record as `calflash` wrote it, every field
    /// but this one ([`Record::sealed`]). A record changed after it was written (a coefficient,
    /// a covariance, the verdict) no longer matches its seal and is refused where it is taken
    /// as evidence (stage two, the flight's prior, `compare`).
    #[serde(default)]
    pub seal: String,
    /// The seal signed by the station's key ([`Record::signed`]): what a reader that trusts
    /// that station takes as proof the record is as it wrote it (a seal alone can be
    /// recomputed by anyone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signature: Option<RecordSignature>,
    /// The station whose Earth rate was a known input of the gyro fits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub earth: Option<crate::earth::Station>,
    /// The production lot the unit was calibrated in (`calibrate --lot`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lot: Option<String>,
    /// The calibration judged over a mission (`calibrate --mission`): per output the predicted
    /// error along the flight, the share beyond the calibrated range, the left-out terms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mission: Option<serde_json::Value>,
    /// A two-stage calibration (`calibrate --stage-one`): per sensor, its stage-one record and
    /// whether its bias and scale factor held in assembly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stages: Option<serde_json::Value>,
}

/// The points a record holds: the table's; for a continuous temperature model, the model at
/// every multiple of 5 C in the calibrated range (and its ends when it holds none), so that
/// two records of one unit meet at common temperatures whatever their device's series or
/// table.
fn model_points(c: &Calibrated) -> Vec<super::PointFit> {
    let Some(first) = c.thermal.first() else {
        return c.points.clone();
    };
    let (lo, hi) = (first.scale.lo, first.scale.hi);
    let mut temps: Vec<f64> = ((lo / 5.0).ceil() as i64..=(hi / 5.0).floor() as i64)
        .map(|k| 5.0 * k as f64)
        .collect();
    if temps.is_empty() {
        temps = vec![lo, hi];
    }
    // Per axis, the largest over the device's points.
    let worst = |of: fn(&super::PointFit) -> &Vec<f64>| -> Vec<f64> {
        (0..c.thermal.len())
            .map(|k| {
                c.points
                    .iter()
                    .filter_map(|p| of(p).get(k).copied())
                    .fold(0.0, f64::max)
            })
            .collect()
    };
    let noise = worst(|p| &p.noise);
    let inversion = worst(|p| &p.inversion_error);
    temps
        .iter()
        .map(|t| super::PointFit {
            temp: Some(*t),
            volt: None,
            axes: c.thermal.iter().map(|tf| tf.at(*t)).collect(),
            inversion_error: inversion.clone(),
            noise: noise.clone(),
        })
        .collect()
}

/// Bytes as lower-case hex (how a record writes its data hash).
#[must_use]
pub fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Lower- or upper-case hex as bytes; `None` for anything else (an odd length, another
/// character).
#[must_use]
pub fn unhex(text: &str) -> Option<Vec<u8>> {
    let t = text.as_bytes();
    if !t.len().is_multiple_of(2) {
        return None;
    }
    t.chunks_exact(2)
        .map(|pair| {
            let s = std::str::from_utf8(pair).ok()?;
            u8::from_str_radix(s, 16).ok()
        })
        .collect()
}

impl Record {
    /// The record of a calibration made from `data_file`.
    #[must_use]
    pub fn new(c: &Calibrated, data_file: &str) -> Self {
        let id = &c.data.identity;
        let sensor = match c.data.sensor {
            spincal::model::Sensor::Single { .. } => "single",
            spincal::model::Sensor::Triad { .. } => "triad",
            spincal::model::Sensor::Imu { .. } => "imu",
        };
        let rails = c.data.sensor.rails();
        Self {
            schema: SCHEMA.into(),
            serial: id.serial.as_str().into(),
            sensor: sensor.into(),
            codes: crate::obs::codes::name(rails),
            sample_format: rails.format.name().into(),
            created_unix_s: id.created_unix_s,
            data_file: data_file.into(),
            data_hash: hex(&id.data_hash),
            tool_version: format!("{}.{}.{}", id.tool_version[0], id.tool_version[1], id.tool_version[2]),
            verdict: c.verdict(),
            findings: c.findings.clone(),
            notes: c.notes.clone(),
            decisions: c
                .decisions
                .iter()
                .map(|d| {
                    serde_json::json!({"name": d.name, "f": d.test.f, "df_num": d.test.df_num, "df_den": d.test.df_den, "p": d.test.p, "kept": d.kept, "detail": d.detail})
                })
                .collect(),
            points: model_points(c)
                .iter()
                .map(|p| PointRecord {
                    temp: p.temp,
                    volt: p.volt,
                    axes: p
                        .axes
                        .iter()
                        .enumerate()
                        .map(|(k, a)| AxisRecord {
                            output: a.output.clone(),
                            model: a.formula.to_string(),
                            terms: a.fit.names.clone(),
                            coefficients: a.fit.coefficients.clone(),
                            std_errors: a.fit.std_errors.clone(),
                            covariance: a.fit.covariance.row_iter().map(|r| r.iter().copied().collect()).collect(),
                            sigma2: a.fit.sigma2,
                            dof: a.fit.dof,
                            n: a.fit.n,
                            noise: p.noise[k],
                            inversion_error: p.inversion_error[k],
                            stated_terms: a.full.as_ref().map_or_else(Vec::new, |f| f.names.clone()),
                            stated_covariance: a.full.as_ref().map_or_else(Vec::new, |f| {
                                f.covariance.row_iter().map(|r| r.iter().copied().collect()).collect()
                            }),
                        })
                        .collect(),
                })
                .collect(),
            device_error: c.device_error,
            blob: hex(&c.blob),
            seal: String::new(),
            signature: None,
            earth: c.earth,
            lot: None,
            mission: c
                .mission
                .as_ref()
                .and_then(|m| serde_json::to_value(m).ok()),
            stages: c
                .stages
                .as_ref()
                .and_then(|s| serde_json::to_value(s).ok()),
        }
    }

    /// This record with its seal: to be set last, when every other field is final. A
    /// signature it carried is dropped (it signed another seal).
    #[must_use]
    pub fn sealed(mut self) -> Self {
        self.seal = self.content_seal();
        self.signature = None;
        self
    }

    /// The SHA-256 of the record with its seal empty, as `serde_json` writes it (the fields in
    /// their declared order; a float as its shortest round-tripping decimal, so a record read
    /// back and written again gives the same bytes).
    fn content_seal(&self) -> String {
        use sha2::Digest as _;
        let mut open = self.clone();
        open.seal.clear();
        open.signature = None;
        let bytes = serde_json::to_vec(&open).unwrap_or_default();
        hex(&sha2::Sha256::digest(&bytes))
    }

    /// Whether this record is as `calflash` wrote it: its seal matches its content, and the
    /// verdict and the temperature points agree with the blob it carries.
    ///
    /// # Errors
    /// [`Unsealed`], naming the field that does not match where it can be named.
    pub fn check_seal(&self) -> Result<(), Unsealed> {
        self.check_sealed()?;
        self.check_blob()
    }

    /// Whether the coefficients are the ones the record's own blob was made from (a single
    /// axis' record; others pass): a record re-sealed by hand passes its seal, not this.
    ///
    /// # Errors
    /// [`Unsealed::Field`] naming the coefficients and where they part from the blob.
    pub fn check_blob(&self) -> Result<(), Unsealed> {
        match self
            .calibration()
            .and_then(|cal| self.single_blob_mismatch(&cal))
        {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The seal and the fields the blob contradicts, without [`Record::check_blob`].
    pub(super) fn check_sealed(&self) -> Result<(), Unsealed> {
        if let Some(cal) = self.calibration() {
            let data = cal.data();
            if data.identity.fit_rejected && self.verdict != Verdict::Reject {
                return Err(Unsealed::Field {
                    field: "verdict".into(),
                    why: format!(
                        "the record says {}, while its blob was written from a fit judged REJECT",
                        self.verdict.word()
                    ),
                });
            }
            let env = &data.environment;
            let span = env.temperature_span;
            let table = matches!(
                env.temperature_model,
                spincal::model::TemperatureModel::Table
            ) && !env.temperatures.is_empty();
            for (i, p) in self.points.iter().enumerate() {
                let Some(t) = p.temp else { continue };
                let inside = f64::from(span.lo) - 1e-3 <= t && t <= f64::from(span.hi) + 1e-3;
                let breakpoint = !table
                    || env
                        .temperatures
                        .iter()
                        .any(|&b| (f64::from(b) - t).abs() <= 1e-3 * t.abs().max(1.0));
                if !(inside && breakpoint) {
                    return Err(Unsealed::Field {
                        field: format!("points[{i}].temp"),
                        why: format!(
                            "{t} C is not a temperature point of its blob (calibrated {} to {} C)",
                            span.lo, span.hi
                        ),
                    });
                }
            }
        }
        if self.seal.is_empty() {
            return Err(Unsealed::Missing);
        }
        if self.seal != self.content_seal() {
            return Err(Unsealed::Broken);
        }
        Ok(())
    }

    /// A single axis' record whose coefficients its own blob does not carry: at inputs across
    /// the calibrated range, the codes the record's forward polynomial gives are corrected by
    /// the blob, and the polynomial of what the blob returns must give the codes back (within
    /// the device's stated inversion error, f32 rounding and a twentieth of a count). A blob
    /// pasted from another calibration, or a coefficient edited, is named. Not checked: points
    /// with supply-voltage terms, and points with a kink term where the blob is not a table
    /// over temperature alone (the kink's breakpoint is read from the blob's table).
    fn single_blob_mismatch(&self, cal: &spincal::model::Calibration) -> Option<Unsealed> {
        use crate::sensor::single::{KINK, coefficients::own_of};
        let data = cal.data();
        let spincal::model::Sensor::Single {
            rails,
            channel,
            sets,
            ..
        } = &data.sensor
        else {
            return None;
        };
        let env = &data.environment;
        let mut corrector = spincal::correct::AnyCorrector::new(cal, 1.0).ok()?;
        for (i, p) in self.points.iter().enumerate() {
            let Some(axis) = p.axes.first() else { continue };
            if axis.terms.len() != axis.coefficients.len()
                || axis
                    .terms
                    .iter()
                    .any(|t| t.contains(crate::sensor::thermal::VOLT))
            {
                continue;
            }
            let mut own = own_of(&axis.terms, &axis.coefficients, 0.0);
            if axis.terms.iter().any(|t| t == KINK) && own.ca != 0.0 {
                // The breakpoint bp (input units) is where the blob's table puts its kink:
                // `own(bp) - center` counts, at the table's point of this temperature.
                let table = matches!(
                    env.temperature_model,
                    spincal::model::TemperatureModel::Table
                ) && env.voltages.is_empty();
                let at = if env.temperatures.is_empty() {
                    Some(0)
                } else {
                    p.temp.and_then(|t| {
                        env.temperatures
                            .iter()
                            .position(|&b| (f64::from(b) - t).abs() <= 1e-3 * t.abs().max(1.0))
                    })
                };
                let (true, Some(set)) = (table, at.and_then(|k| sets.get(k))) else {
                    continue;
                };
                let kink = f64::from(set.axis.asymmetry_break) + f64::from(channel.center);
                let mut bp = 0.0;
                for _ in 0..50 {
                    own.bp = bp;
                    let g = own.output(bp) - kink;
                    let h = 1e-6 * (1.0 + bp.abs());
                    own.bp = bp + h;
                    let slope = (own.output(bp + h) - kink - g) / h;
                    if slope.is_nan() || slope == 0.0 {
                        break;
                    }
                    bp -= g / slope;
                }
                own.bp = bp;
            }
            corrector.set_environment(
                p.temp.map_or(f32::NAN, |t| t as f32),
                p.volt.map_or(f32::NAN, |v| v as f32),
            );
            let (lo, hi) = (f64::from(channel.range.lo), f64::from(channel.range.hi));
            for k in 0..=20 {
                let x = lo + (hi - lo) * f64::from(k) / 20.0;
                let code = own.output(x).round();
                if !(f64::from(rails.lo)..=f64::from(rails.hi)).contains(&code) {
                    continue;
                }
                let c = corrector.correct(&[code as i32])?;
                let read = f64::from(c.values[0]);
                let apart = (own.output(read) - code).abs();
                let allowed = own.slope.abs() * 2.0 * (axis.inversion_error + self.device_error)
                    + 1e-5 * code.abs()
                    + 0.05;
                // NaN (a blob that corrects to nothing) is a mismatch too.
                if apart.is_nan() || apart > allowed {
                    return Some(Unsealed::Field {
                        field: format!("points[{i}].axes[0].coefficients"),
                        why: format!(
                            "at input {x:.6} they give code {code}, which the record's own blob corrects to {read:.6}: {apart:.2} counts from what the coefficients say (at most {allowed:.2} allowed), so the blob is not the one these coefficients make"
                        ),
                    });
                }
            }
        }
        None
    }

    /// The calibration inside the record's blob (signed or not).
    #[must_use]
    pub fn calibration(&self) -> Option<spincal::model::Calibration> {
        let bytes = self.blob_bytes();
        spincal::blob::decode(&bytes).ok().or_else(|| {
            let (inner, _) = spincal::signed::split(&bytes).ok()?;
            spincal::blob::decode(inner).ok()
        })
    }

    /// The blob's bytes.
    #[must_use]
    pub fn blob_bytes(&self) -> Vec<u8> {
        (0..self.blob.len() / 2)
            .filter_map(|i| u8::from_str_radix(&self.blob[2 * i..2 * i + 2], 16).ok())
            .collect()
    }
}
