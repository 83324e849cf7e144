//! Building the device's calibration: identity, environment spans and breakpoints, the blob
//! written with the firmware crate's encoder, and a check of the device's f32 correction
//! against the same correction in f64.

use std::path::Path;

use spincal::blob;
use spincal::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector};
use spincal::model::{
    AxisNonlinearity, BoundedVec, Calibration, CalibrationData, Environment, Identity, ImuSet,
    Quantity, Sensor, Serial, SingleSet, Span, TemperatureModel, TriadSet, rotation,
};

use super::invert::linearize;
use super::table::Layout;
use super::thermal::device::{DeviceSet, clenshaw_rows};
use super::{Options, PointFit, WorkflowError};
use crate::columns as col;
use crate::obs::Table;

/// The SI unit of a quantity.
#[must_use]
pub fn unit(q: Quantity) -> &'static str {
    match q {
        Quantity::Acceleration => "m/s^2",
        Quantity::AngularRate => "rad/s",
    }
}

/// A calibration beyond what the device holds, or a series it cannot take.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DeviceLimitError {
    /// More table points than coefficient sets.
    #[error("the table has {points} points; the device holds at most {max}")]
    Points {
        /// Table points.
        points: usize,
        /// Sets the device holds.
        max: usize,
    },
    /// More setpoints of one kind than the device holds.
    #[error("{count} {what} setpoints; the device holds at most {max}")]
    Setpoints {
        /// Setpoints.
        count: usize,
        /// Their column (`temp`, `volt`).
        what: String,
        /// The most the device holds.
        max: usize,
    },
    /// A temperature series built for another kind of sensor.
    #[error("the calibration's temperature series is not for this sensor")]
    SeriesNotForSensor,
}

/// `why`, in the file `path`.
fn beyond(path: &Path, why: DeviceLimitError) -> WorkflowError {
    WorkflowError::DeviceLimit {
        path: path.to_path_buf(),
        source: why,
    }
}

pub(crate) fn too_many(path: &Path, n: usize) -> WorkflowError {
    beyond(
        path,
        DeviceLimitError::Points {
            points: n,
            max: spincal::model::MAX_SETS,
        },
    )
}

/// A serial number the device cannot store.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "--serial `{0}`: the device stores 1 to {cap} printable ASCII characters",
    cap = spincal::model::SERIAL_CAPACITY
)]
pub struct SerialError(pub String);

/// A serial number the device can store.
///
/// # Errors
/// What is wrong with it.
pub fn serial(text: &str) -> Result<Serial, SerialError> {
    Serial::parse(text).ok_or_else(|| SerialError(text.to_string()))
}

/// The unit's identity: serial, now, the data's hash, this tool's version.
///
/// # Errors
/// A serial the device cannot store.
pub fn identity(opts: &Options) -> Result<Identity, WorkflowError> {
    let serial = serial(&opts.serial)?;
    let hash = super::data_hash(&[opts.file.as_path()])?;
    Ok(new_identity(serial, opts.created, hash, false))
}

/// A calibration's identity: the unit's `serial`, made at `created` (now when `None`) from
/// data whose hash is `data_hash`, by this tool's version; `fit_rejected` when the blob is
/// forced out of a rejected fit.
#[must_use]
pub fn new_identity(
    serial: Serial,
    created: Option<u64>,
    data_hash: [u8; 16],
    fit_rejected: bool,
) -> Identity {
    let v = |s: &str| s.parse::<u16>().unwrap_or(0);
    let mut version = env!("CARGO_PKG_VERSION").split('.');
    Identity {
        serial,
        created_unix_s: created.unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs())
        }),
        data_hash,
        tool_version: [
            v(version.next().unwrap_or("0")),
            v(version.next().unwrap_or("0")),
            v(version.next().unwrap_or("0")),
        ],
        fit_rejected,
    }
}

/// Why a calibration does not become a blob the device reads back.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BlobError {
    /// Validation refused it.
    #[error("the calibration is not valid for the device: {0}")]
    Invalid(spincal::Error),
    /// The encoder refused it.
    #[error("cannot write the blob: {0}")]
    Encode(spincal::Error),
    /// The bytes do not decode.
    #[error("the written blob does not read back: {0}")]
    ReadBack(spincal::Error),
}

/// Validates and encodes `data`, and decodes the blob back as the device does: the bytes and
/// the device's calibration.
///
/// # Errors
/// A [`BlobError`].
pub fn encode_checked(data: &CalibrationData) -> Result<(Vec<u8>, Calibration), BlobError> {
    let cal = Calibration::new(data.clone()).map_err(BlobError::Invalid)?;
    let mut buf = vec![0u8; blob::MAX_BLOB_LEN];
    let n = blob::encode(&cal, &mut buf).map_err(BlobError::Encode)?;
    buf.truncate(n);
    let back = blob::decode(&buf).map_err(BlobError::ReadBack)?;
    Ok((buf, back))
}

/// Calibrated spans (observed, or the options' when a column is absent) and breakpoints.
///
/// # Errors
/// More breakpoints than the device holds.
pub fn environment(
    table: &Table,
    layout: &Layout,
    opts: &Options,
) -> Result<Environment, WorkflowError> {
    let span = |name: &str, default: Span| match table.column(name) {
        Some(c) => Span::new(
            c.iter().copied().fold(f64::INFINITY, f64::min) as f32,
            c.iter().copied().fold(f64::NEG_INFINITY, f64::max) as f32,
        ),
        None => default,
    };
    fn points<const N: usize>(
        v: &[f64],
        what: &str,
        opts: &Options,
    ) -> Result<BoundedVec<f32, N>, WorkflowError> {
        let f: Vec<f32> = v.iter().map(|x| *x as f32).collect();
        BoundedVec::from_slice(&f).ok_or_else(|| {
            beyond(
                &opts.file,
                DeviceLimitError::Setpoints {
                    count: v.len(),
                    what: what.to_string(),
                    max: N,
                },
            )
        })
    }
    Ok(Environment {
        temperature_span: span(col::TEMP, opts.temp_span),
        voltage_span: span(col::VOLT, opts.volt_span),
        temperatures: points(&layout.temps, "temperature", opts)?,
        voltages: points(&layout.volts, "voltage", opts)?,
        temperature_model: spincal::model::TemperatureModel::Table,
    })
}

fn f64_triad(set: &TriadSet, v: [f64; 3]) -> [f64; 3] {
    let u: [f64; 3] =
        std::array::from_fn(|j| linearize(&set.axes[j].to_array().map(f64::from), v[j]));
    std::array::from_fn(|i| {
        f64::from(set.offset[i])
            + (0..3)
                .map(|j| f64::from(set.matrix[i][j]) * u[j])
                .sum::<f64>()
    })
}

/// The single-axis set the device uses at table point `k` (temperature and voltage `at`): the
/// stored set, or for a temperature series its sum at that temperature in f64 after the blend
/// along voltage (`spincal::model::TemperatureModel`); `None` when the series does not have a
/// set per term and voltage point.
/// A kind of set as a row of numbers, and back.
type Row<T> = (fn(&T) -> Vec<f64>, fn(&[f64]) -> T);

/// The set the device uses at `(t, volt)`: table point `k`'s as stored, or a series summed
/// by Clenshaw in f64 (each coefficient through its row of numbers, `flat` and `back`);
/// `None` when the series does not have the environment's shape.
fn set_at<T: Copy>(
    env: &Environment,
    sets: &[T],
    k: usize,
    (t, volt): (f32, f32),
    (flat, back): Row<T>,
) -> Option<T> {
    let TemperatureModel::Chebyshev(n) = env.temperature_model else {
        return sets.get(k).copied();
    };
    let (n, nv) = (usize::from(n), env.voltage_points());
    if sets.len() != n * nv {
        return None;
    }
    let (v0, v1, w) = match env.voltages.iter().position(|v| *v >= volt) {
        _ if nv == 1 => (0, 0, 0.0),
        Some(0) => (0, 0, 0.0),
        Some(i) => {
            let (a, b) = (f64::from(env.voltages[i - 1]), f64::from(env.voltages[i]));
            (i - 1, i, (f64::from(volt) - a) / (b - a))
        }
        None => (nv - 1, nv - 1, 0.0),
    };
    let span = &env.temperature_span;
    let x = ((f64::from(t) - 0.5 * (f64::from(span.lo) + f64::from(span.hi)))
        / (0.5 * (f64::from(span.hi) - f64::from(span.lo))))
    .clamp(-1.0, 1.0);
    let terms: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let (a, b) = (flat(&sets[k * nv + v0]), flat(&sets[k * nv + v1]));
            a.iter().zip(&b).map(|(a, b)| a + (b - a) * w).collect()
        })
        .collect();
    let rows: Vec<&[f64]> = terms.iter().map(|r| &r[..]).collect();
    Some(back(&clenshaw_rows(&rows, x)))
}

/// A single axis' set as numbers, and back.
const SINGLE_ROW: Row<SingleSet> = (
    |s| DeviceSet::from_set(s).to_array().to_vec(),
    |v| DeviceSet::from_array(std::array::from_fn(|i| v[i]), 0.0).set(),
);

/// A triad's set as numbers: per axis its five nonlinear terms, then the matrix by rows, then
/// the offsets.
#[must_use]
pub fn triad_row(t: &TriadSet) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::with_capacity(27);
    for a in &t.axes {
        v.extend(
            [
                a.quadratic,
                a.cubic,
                a.odd_quadratic,
                a.asymmetry,
                a.asymmetry_break,
            ]
            .map(f64::from),
        );
    }
    v.extend(t.matrix.as_flattened().iter().map(|x| f64::from(*x)));
    v.extend(t.offset.map(f64::from));
    v
}

/// [`triad_row`]'s inverse.
#[must_use]
pub fn triad_of_row(v: &[f64]) -> TriadSet {
    TriadSet {
        axes: std::array::from_fn(|i| {
            let a = &v[5 * i..5 * i + 5];
            AxisNonlinearity {
                quadratic: a[0] as f32,
                cubic: a[1] as f32,
                odd_quadratic: a[2] as f32,
                asymmetry: a[3] as f32,
                asymmetry_break: a[4] as f32,
            }
        }),
        matrix: std::array::from_fn(|i| std::array::from_fn(|j| v[15 + 3 * i + j] as f32)),
        offset: std::array::from_fn(|i| v[24 + i] as f32),
    }
}

/// An IMU's set as numbers: the accelerometer's and the gyro's [`triad_row`], then the
/// g-sensitivity by rows.
fn imu_row(s: &ImuSet) -> Vec<f64> {
    let mut v = triad_row(&s.accel);
    v.extend(triad_row(&s.gyro));
    v.extend(s.g_sensitivity.as_flattened().iter().map(|x| f64::from(*x)));
    v
}

fn imu_of_row(v: &[f64]) -> ImuSet {
    ImuSet {
        accel: triad_of_row(&v[..27]),
        gyro: triad_of_row(&v[27..54]),
        g_sensitivity: std::array::from_fn(|i| std::array::from_fn(|j| v[54 + 3 * i + j] as f32)),
    }
}

/// The sample rate the device's correction is checked at, Hz: a unit whose lever feedback is
/// not bounded there is refused.
const CHECK_RATE_HZ: f32 = 1000.0;

/// A calibration made into a blob and checked ([`build_or_reject`]).
#[derive(Debug)]
pub struct Built {
    /// The blob; empty when the device refused the calibration.
    pub blob: Vec<u8>,
    /// Each output's largest f32 error (SI); empty without a blob.
    pub output_errors: Vec<f64>,
    /// The REJECT finding when the device refused it.
    pub refused: Option<super::Finding>,
}

/// [`build_and_check`], but a calibration the device's validation refuses (a coefficient set
/// that can overflow single precision inside the rails, a lever arm beyond its bound: a unit
/// too nonlinear for the device's correction form) is a judgement, not a failure: no blob, no
/// f32 errors, and the REJECT finding that says why, so that the record keeps the fit.
///
/// # Errors
/// As [`build_and_check`], but for the device's validation.
pub fn build_or_reject(
    path: &Path,
    data: &CalibrationData,
    points: &[PointFit],
) -> Result<Built, WorkflowError> {
    match build_and_check(path, data, points) {
        Ok((blob, output_errors)) => Ok(Built {
            blob,
            output_errors,
            refused: None,
        }),
        Err(WorkflowError::Blob {
            source: BlobError::Invalid(why),
            ..
        }) => Ok(Built {
            blob: Vec::new(),
            output_errors: Vec::new(),
            refused: Some(super::Finding {
                verdict: super::Verdict::Reject,
                text: format!(
                    "the device cannot hold this calibration: {why}: the unit is too nonlinear for the device's correction form (the record keeps the fit; no blob is made)"
                ),
            }),
        }),
        Err(e) => Err(e),
    }
}

/// Validates and encodes `data`, decodes the blob back as the device does, and runs the
/// device's f32 correction at each table point over codes spanning the calibrated range,
/// against the same stored coefficients evaluated in f64. Returns the blob and the largest
/// difference of each output (SI).
///
/// # Errors
/// When the calibration does not validate (a coefficient the device cannot hold).
pub fn build_and_check(
    path: &Path,
    data: &CalibrationData,
    points: &[PointFit],
) -> Result<(Vec<u8>, Vec<f64>), WorkflowError> {
    let (buf, back) = encode_checked(data).map_err(|source| WorkflowError::Blob {
        path: path.to_path_buf(),
        source,
    })?;
    let env = &data.environment;
    let mut worst = vec![0.0f64; points.first().map_or(0, |p| p.axes.len())];
    let mut note = |j: usize, e: f64| {
        if let Some(w) = worst.get_mut(j) {
            *w = w.max(e);
        }
    };
    let at = |p: &PointFit| {
        (
            p.temp.map_or(
                0.5 * (env.temperature_span.lo + env.temperature_span.hi),
                |t| t as f32,
            ),
            p.volt
                .map_or(0.5 * (env.voltage_span.lo + env.voltage_span.hi), |v| {
                    v as f32
                }),
        )
    };
    let not_this = || beyond(path, DeviceLimitError::SeriesNotForSensor);
    match &data.sensor {
        Sensor::Single { channel, sets, .. } => {
            let mut c = AnyAxisCorrector::new(&back)?;
            for (k, p) in points.iter().enumerate() {
                let (t, v) = at(p);
                let set = set_at(env, sets, k, (t, v), SINGLE_ROW).ok_or_else(not_this)?;
                let set = &set;
                c.set_environment(t, v);
                let f = &p.axes[0];
                let own = |x: f64| f.coef("1") + f.coef(col::INPUT) * x;
                let (a, b) = (
                    own(f64::from(channel.range.lo)),
                    own(f64::from(channel.range.hi)),
                );
                for k in 0..=500 {
                    let code = (a + (b - a) * f64::from(k) / 500.0).round() as i32;
                    let dev = f64::from(c.correct(code).values[0]);
                    let v = f64::from(code) - f64::from(channel.center);
                    let host = f64::from(set.offset)
                        + f64::from(set.scale) * linearize(&set.axis.to_array().map(f64::from), v);
                    note(0, (dev - host).abs());
                }
            }
        }
        Sensor::Triad { channels, sets, .. } => {
            let mut c = AnyTriadCorrector::new(&back)?;
            for (k, p) in points.iter().enumerate() {
                let (t, v) = at(p);
                let set = &set_at(env, sets, k, (t, v), (triad_row, triad_of_row))
                    .ok_or_else(not_this)?;
                c.set_environment(t, v);
                for k in 0..500u32 {
                    let code: [i32; 3] =
                        std::array::from_fn(|j| sample_code(&channels[j], &p.axes[j], k, j));
                    let dev = c.correct(code).values;
                    let host = f64_triad(
                        set,
                        std::array::from_fn(|j| f64::from(code[j]) - f64::from(channels[j].center)),
                    );
                    for j in 0..3 {
                        note(j, (f64::from(dev[j]) - host[j]).abs());
                    }
                }
            }
        }
        Sensor::Imu {
            accel, gyro, sets, ..
        } => {
            // A unit whose lever feedback is bounded only below 1 kHz cannot run on the
            // device at any rate a round samples at: the device cannot hold it.
            let mut c = AnyImuCorrector::new(&back, CHECK_RATE_HZ).map_err(|e| match e {
                spincal::Error::CorrectorUnboundedFeedback { .. } => WorkflowError::Blob {
                    path: path.to_path_buf(),
                    source: BlobError::Invalid(e),
                },
                e => e.into(),
            })?;
            for (k, p) in points.iter().enumerate() {
                let (t, v) = at(p);
                let set =
                    &set_at(env, sets, k, (t, v), (imu_row, imu_of_row)).ok_or_else(not_this)?;
                c.set_environment(t, v);
                for k in 0..500u32 {
                    c.reset();
                    let ca: [i32; 3] =
                        std::array::from_fn(|j| sample_code(&accel[j], &p.axes[j], k, j));
                    let cg: [i32; 3] =
                        std::array::from_fn(|j| sample_code(&gyro[j], &p.axes[j + 3], k, j + 3));
                    // A steady rate: the second sample has a known rate difference of zero and
                    // the previous lever term of the same rate, so it is the fixed point.
                    let raw = [ca[0], ca[1], ca[2], cg[0], cg[1], cg[2]];
                    let _ = c.correct(raw);
                    let dev = c.correct(raw).values;
                    let a = f64_triad(
                        &set.accel,
                        std::array::from_fn(|j| f64::from(ca[j]) - f64::from(accel[j].center)),
                    );
                    let ws = f64_triad(
                        &set.gyro,
                        std::array::from_fn(|j| f64::from(cg[j]) - f64::from(gyro[j].center)),
                    );
                    let (a_ref, w) = imu_f64(data, set, a, ws);
                    for j in 0..3 {
                        note(j, (f64::from(dev[j]) - a_ref[j]).abs());
                        note(j + 3, (f64::from(dev[j + 3]) - w[j]).abs());
                    }
                }
            }
        }
    }
    Ok((buf, worst))
}

/// The IMU correction in f64 for a steady rate (no rate difference): the reference-point force
/// and the rate for sensor-domain force `a` and gyro output `ws`, the lever term solved to its
/// fixed point (`spincal::model::rotation`).
fn imu_f64(
    data: &CalibrationData,
    set: &spincal::model::ImuSet,
    a: [f64; 3],
    ws: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let g = set.g_sensitivity.map(|r| r.map(f64::from));
    let rate = |x: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| ws[i] - (0..3).map(|j| g[i][j] * x[j]).sum::<f64>())
    };
    let terms = match &data.sensor {
        Sensor::Imu {
            lever_arm: Some(r), ..
        } => rotation::LeverTerms::new(
            &set.accel.matrix.map(|row| row.map(f64::from)),
            &r.map(|row| row.map(f64::from)),
            1.0,
        ),
        _ => None,
    };
    let Some(terms) = terms else {
        return (a, rate(a));
    };
    let mut e = [0.0; 3];
    for _ in 0..20 {
        e = terms.eval(&rate(std::array::from_fn(|j| a[j] - e[j])), &[0.0; 3]);
    }
    let w = rate(std::array::from_fn(|j| a[j] - e[j]));
    (std::array::from_fn(|j| a[j] - e[j]), w)
}

/// A code for axis `j` of sample `k`: spread over the calibrated range by a low-discrepancy
/// sequence, so that combinations of the three axes are covered.
fn sample_code(ch: &spincal::model::Channel, fit: &super::AxisFit, k: u32, j: usize) -> i32 {
    let frac = (f64::from(k)
        * [
            0.618_034, 0.754_878, 0.569_840, 0.830_990, 0.475_528, 0.690_983,
        ][j % 6])
        .fract();
    let x = f64::from(ch.range.lo) + (f64::from(ch.range.hi) - f64::from(ch.range.lo)) * frac;
    (f64::from(ch.center) + fit.coef(&fit.own) * x).round() as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_beyond_the_device_names_the_file_and_the_limit() {
        let e = too_many(Path::new("obs.csv"), 99);
        assert!(matches!(
            &e,
            WorkflowError::DeviceLimit {
                source: DeviceLimitError::Points { points: 99, .. },
                ..
            }
        ));
        assert_eq!(
            e.to_string(),
            format!(
                "obs.csv: the table has 99 points; the device holds at most {}",
                spincal::model::MAX_SETS
            )
        );
        assert_eq!(serial("U 1\u{7f}"), Err(SerialError("U 1\u{7f}".into())));
    }
}
