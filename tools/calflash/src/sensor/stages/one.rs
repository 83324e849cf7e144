//! Stage one carried into stage two: each sensor's own single-axis calibration
//! (`calibrate --sensor single-accel|single-gyro --json`), read back as the forward polynomial
//! the device would apply, with its covariance, at each of the record's temperature points.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use spincal::model::{Quantity, Sensor, Span};

use crate::columns as col;
use crate::sensor::Verdict;
use crate::sensor::invert::Own;
use crate::sensor::record::{self, Record, Trust};
use crate::sensor::single::KINK;

/// The own-axis terms stage one carries into the unit, in the order of [`Point::c`]: bias,
/// scale factor, g-squared, cubic, odd-quadratic, asymmetry (about 0).
pub const TERMS: [&str; 6] = [
    "1",
    col::INPUT,
    "input^2",
    "input^3",
    "input:abs(input)",
    KINK,
];

/// The IMU's outputs in the order `--stage-one` lists their records.
pub const OUTPUTS: [&str; 6] = ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"];

/// One temperature point of a sensor's stage-one calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// The temperature, C (`None`: the record has no temperature axis).
    pub temp: Option<f64>,
    /// The coefficients of [`TERMS`] (counts per SI power; 0 for a term the record lacks).
    pub c: [f64; 6],
    /// Their covariance (zero rows for a term the record lacks).
    pub cov: [[f64; 6]; 6],
}

/// One sensor's stage-one calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor1 {
    /// The record's file.
    pub file: PathBuf,
    /// The sensor's own serial.
    pub serial: String,
    /// Acceleration or angular rate.
    pub quantity: Quantity,
    /// Its calibrated input range (SI).
    pub range: Span,
    /// Its calibrated temperature span, C.
    pub temps: Span,
    /// The points, by rising temperature.
    pub points: Vec<Point>,
    /// Terms the record has that stage two does not carry (cross-axis terms: the unit's
    /// misalignment takes their place).
    pub left: Vec<String>,
    /// Who signed the record.
    pub signed_by: record::Signer,
}

/// A stage-one record stage two cannot take, naming the file and what each side says.
#[derive(Debug, thiserror::Error)]
pub enum StageOneError {
    /// `--stage-one` does not name six records.
    #[error(
        "--stage-one: six records are expected, one per sensor in the order a_x,a_y,a_z,g_x,g_y,g_z; {given} given: {missing} missing"
    )]
    Count {
        /// How many were given.
        given: usize,
        /// The outputs without one.
        missing: String,
    },
    /// Unreadable or not a calibration record.
    #[error("{}: {why}", path.display())]
    Unreadable {
        /// The record.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// Not a single-axis record.
    #[error("{} ({output}): a `{sensor}` record; stage one is a single sensor's (`calibrate --sensor single-accel|single-gyro`)", path.display())]
    NotSingle {
        /// The record.
        path: PathBuf,
        /// The output it was given for.
        output: &'static str,
        /// What it is.
        sensor: String,
    },
    /// An accelerometer's record for a gyro output or the reverse.
    #[error("{} ({output}): the record is of {found} (in {found_unit}); {output} is {wanted} (in {wanted_unit})", path.display())]
    Kind {
        /// The record.
        path: PathBuf,
        /// The output it was given for.
        output: &'static str,
        /// What the record is of.
        found: &'static str,
        /// Its unit.
        found_unit: &'static str,
        /// What the output is.
        wanted: &'static str,
        /// Its unit.
        wanted_unit: &'static str,
    },
    /// A record whose calibration was rejected.
    #[error("{} ({output}): stage one of sensor {serial} was judged REJECT; calibrate the sensor again (or replace it) before assembly", path.display())]
    Rejected {
        /// The record.
        path: PathBuf,
        /// The output.
        output: &'static str,
        /// The sensor's serial.
        serial: String,
    },
    /// A record changed after it was written.
    #[error("{} ({output}): {why}", path.display())]
    Edited {
        /// The record.
        path: PathBuf,
        /// The output it was given for.
        output: &'static str,
        /// What does not match: its seal or its signature.
        why: crate::sensor::record::TrustError,
    },
    /// A record with a supply-voltage axis.
    #[error("{} ({output}): the record has a supply-voltage table; stage two carries temperature points only", path.display())]
    Voltage {
        /// The record.
        path: PathBuf,
        /// The output.
        output: &'static str,
    },
    /// The same record (or sensor) twice.
    #[error("{} ({output}) and {} ({other}) are the same sensor {serial}", path.display(), other_path.display())]
    Twice {
        /// The record.
        path: PathBuf,
        /// The output.
        output: &'static str,
        /// The other record.
        other_path: PathBuf,
        /// Its output.
        other: &'static str,
        /// The serial.
        serial: String,
    },
}

fn unreadable(path: &Path, why: impl ToString) -> StageOneError {
    StageOneError::Unreadable {
        path: path.to_path_buf(),
        why: why.to_string(),
    }
}

fn quantity_words(q: Quantity) -> (&'static str, &'static str) {
    let what = match q {
        Quantity::Acceleration => "an accelerometer",
        Quantity::AngularRate => "a gyro",
    };
    (what, crate::sensor::blob::unit(q))
}

/// Reads the record of output `k` ([`OUTPUTS`]), taken when `trust` takes its signature.
///
/// # Errors
/// [`StageOneError`], naming the file.
pub fn read(path: &Path, k: usize, trust: &Trust) -> Result<Sensor1, StageOneError> {
    let text = crate::files::read_json_text(path, "a stage-one record")
        .map_err(|e| unreadable(path, e))?;
    from_text(&text, path, k, trust)
}

/// The record `text` of output `k`, read from `path` (a file, or the unit history's words for
/// where it is), taken when its seal holds and `trust` takes its signature.
///
/// # Errors
/// [`StageOneError`], naming `path`.
pub fn from_text(
    text: &str,
    path: &Path,
    k: usize,
    trust: &Trust,
) -> Result<Sensor1, StageOneError> {
    let output = OUTPUTS[k];
    let rec: Record = serde_json::from_str(text)
        .map_err(|e| unreadable(path, format!("not a calibration record ({e})")))?;
    if rec.schema != record::SCHEMA {
        return Err(unreadable(
            path,
            format!("schema `{}`; `{}` is expected", rec.schema, record::SCHEMA),
        ));
    }
    if rec.sensor != "single" {
        return Err(StageOneError::NotSingle {
            path: path.to_path_buf(),
            output,
            sensor: rec.sensor,
        });
    }
    if rec.verdict == Verdict::Reject {
        return Err(StageOneError::Rejected {
            path: path.to_path_buf(),
            output,
            serial: rec.serial,
        });
    }
    let signed_by = rec
        .check_trusted(trust)
        .map_err(|why| StageOneError::Edited {
            path: path.to_path_buf(),
            output,
            why,
        })?;
    let cal = rec
        .calibration()
        .ok_or_else(|| unreadable(path, "its blob does not decode"))?;
    let data = cal.data();
    let Sensor::Single {
        quantity, channel, ..
    } = data.sensor
    else {
        return Err(unreadable(path, "its blob is not a single axis'"));
    };
    let wanted = if k < 3 {
        Quantity::Acceleration
    } else {
        Quantity::AngularRate
    };
    if quantity != wanted {
        let (found, found_unit) = quantity_words(quantity);
        let (wanted, wanted_unit) = quantity_words(wanted);
        return Err(StageOneError::Kind {
            path: path.to_path_buf(),
            output,
            found,
            found_unit,
            wanted,
            wanted_unit,
        });
    }
    if rec.points.iter().any(|p| p.volt.is_some()) {
        return Err(StageOneError::Voltage {
            path: path.to_path_buf(),
            output,
        });
    }
    let mut left = Vec::new();
    let mut points = Vec::new();
    for p in &rec.points {
        let axis = p
            .axes
            .first()
            .ok_or_else(|| unreadable(path, "a point without a fit"))?;
        let at = |t: &str| axis.terms.iter().position(|n| n == t);
        for t in &axis.terms {
            if !TERMS.contains(&t.as_str()) && !left.contains(t) {
                left.push(t.clone());
            }
        }
        let idx: [Option<usize>; 6] = TERMS.map(at);
        if idx[0].is_none() || idx[1].is_none() {
            return Err(unreadable(
                path,
                "a fit without the bias `1` and the scale factor `input`",
            ));
        }
        let n = axis.terms.len();
        if axis.coefficients.len() != n
            || axis.covariance.len() != n
            || axis.covariance.iter().any(|r| r.len() != n)
        {
            return Err(unreadable(
                path,
                "coefficients and covariance of different sizes",
            ));
        }
        let c = idx.map(|i| i.map_or(0.0, |i| axis.coefficients[i]));
        let cov = std::array::from_fn(|r| {
            std::array::from_fn(|s| match (idx[r], idx[s]) {
                (Some(i), Some(j)) => axis.covariance[i][j],
                _ => 0.0,
            })
        });
        if !c
            .iter()
            .chain(cov.as_flattened())
            .all(|v: &f64| v.is_finite())
            || c[1] == 0.0
        {
            return Err(unreadable(path, "coefficients that are not finite numbers"));
        }
        points.push(Point {
            temp: p.temp,
            c,
            cov,
        });
    }
    if points.is_empty() {
        return Err(unreadable(path, "no points"));
    }
    points.sort_by(|a, b| a.temp.unwrap_or(0.0).total_cmp(&b.temp.unwrap_or(0.0)));
    let env = &data.environment;
    Ok(Sensor1 {
        file: path.to_path_buf(),
        serial: rec.serial,
        quantity,
        range: channel.range,
        temps: env.temperature_span,
        points,
        left,
        signed_by,
    })
}

/// Reads the six records `paths`, in the order of [`OUTPUTS`], each taken when `trust` takes
/// its signature.
///
/// # Errors
/// [`StageOneError`]: a count other than six, a record that does not fit its output, the same
/// sensor twice.
pub fn read_all(paths: &[PathBuf], trust: &Trust) -> Result<Vec<Sensor1>, StageOneError> {
    read_all_with(paths, |p, k| read(p, k, trust))
}

/// [`read_all`] with each record read by `read_one` (from a file or from the unit history).
///
/// # Errors
/// As [`read_all`], and `read_one`'s.
pub fn read_all_with(
    paths: &[PathBuf],
    read_one: impl Fn(&Path, usize) -> Result<Sensor1, StageOneError>,
) -> Result<Vec<Sensor1>, StageOneError> {
    if paths.len() != 6 {
        let missing = if paths.len() < 6 {
            OUTPUTS[paths.len()..].join(", ")
        } else {
            format!("none ({} too many)", paths.len() - 6)
        };
        return Err(StageOneError::Count {
            given: paths.len(),
            missing,
        });
    }
    let sensors: Vec<Sensor1> = paths
        .iter()
        .enumerate()
        .map(|(k, p)| read_one(p, k))
        .collect::<Result<_, _>>()?;
    for (k, s) in sensors.iter().enumerate() {
        if let Some((j, o)) = sensors[..k]
            .iter()
            .enumerate()
            .find(|(_, o)| o.serial == s.serial)
        {
            return Err(StageOneError::Twice {
                path: s.file.clone(),
                output: OUTPUTS[k],
                other_path: o.file.clone(),
                other: OUTPUTS[j],
                serial: s.serial.clone(),
            });
        }
    }
    Ok(sensors)
}

impl Sensor1 {
    /// The weights of the points at temperature `t` (the device's linear interpolation between
    /// the neighbouring points, held at the ends): `(point, weight)` pairs.
    #[must_use]
    pub fn weights(&self, t: Option<f64>) -> Vec<(usize, f64)> {
        let n = self.points.len();
        let temp = |k: usize| self.points[k].temp.unwrap_or(0.0);
        match t {
            _ if n == 1 => vec![(0, 1.0)],
            None => vec![(0, 1.0)],
            Some(t) if t <= temp(0) => vec![(0, 1.0)],
            Some(t) if t >= temp(n - 1) => vec![(n - 1, 1.0)],
            Some(t) => {
                let k = (1..n).find(|k| temp(*k) >= t).unwrap_or(n - 1);
                let w = (t - temp(k - 1)) / (temp(k) - temp(k - 1));
                vec![(k - 1, 1.0 - w), (k, w)]
            }
        }
    }

    /// The coefficients at temperature `t`, with `delta` added to the flat coefficient
    /// `(point, term)` when given (a derivative's step).
    #[must_use]
    pub fn at(&self, t: Option<f64>, delta: Option<(usize, usize, f64)>) -> [f64; 6] {
        let mut c = [0.0; 6];
        for (k, w) in self.weights(t) {
            for (j, cj) in c.iter_mut().enumerate() {
                let d = match delta {
                    Some((p, q, h)) if p == k && q == j => h,
                    _ => 0.0,
                };
                *cj += w * (self.points[k].c[j] + d);
            }
        }
        c
    }

    /// The covariance of all the points' coefficients, point-major (the points are separate
    /// fits: independent).
    #[must_use]
    pub fn covariance(&self) -> DMatrix<f64> {
        let n = 6 * self.points.len();
        DMatrix::from_fn(n, n, |r, s| {
            if r / 6 == s / 6 {
                self.points[r / 6].cov[r % 6][s % 6]
            } else {
                0.0
            }
        })
    }
}

/// The own-axis polynomial of coefficients `c` ([`TERMS`]).
#[must_use]
pub fn own(c: &[f64; 6]) -> Own {
    Own {
        bias: c[0],
        slope: c[1],
        c2: c[2],
        c3: c[3],
        coq: c[4],
        ca: c[5],
        bp: 0.0,
    }
}
