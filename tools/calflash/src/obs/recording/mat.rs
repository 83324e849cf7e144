//! Recordings kept as MATLAB `.mat` (level 5) files, read with the `matfile` crate: one numeric
//! matrix of a timestamp and the counts (or the counts alone), one row or one column a sample,
//! as a text file's lines; or variables by their recognised names (`t`/`time`/`time_ms`...,
//! `acc`/`accel`, `gyro`/`omega`, each N x 3). In messages a sample's "line" is its row.

use std::path::Path;

use matfile::{Array, MatFile, NumericData};

use super::RecordingError;
use super::layout::{Holds, Keep, Preamble, Rows};
use crate::obs::squash;

/// The most a `.mat` recording holds (1 GiB: an hour of six axes at 10 kHz in doubles is
/// 2 GB as text and 1.2 GB here, so longer recordings are split or kept as text). The file is
/// parsed whole; the arrays a compressed file expands to are not bounded beyond this.
pub const MAX_MAT: u64 = 1 << 30;

/// True when `path` names a `.mat` file.
#[must_use]
pub fn is_mat(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"))
}

/// An array's values as `f64`, column-major, or `None` for complex data.
fn values(a: &Array) -> Option<Vec<f64>> {
    fn real<T: Copy + Into<f64>>(r: &[T], i: &Option<Vec<T>>) -> Option<Vec<f64>> {
        i.is_none().then(|| r.iter().map(|x| (*x).into()).collect())
    }
    match a.data() {
        NumericData::Int8 { real: r, imag: i } => real(r, i),
        NumericData::UInt8 { real: r, imag: i } => real(r, i),
        NumericData::Int16 { real: r, imag: i } => real(r, i),
        NumericData::UInt16 { real: r, imag: i } => real(r, i),
        NumericData::Int32 { real: r, imag: i } => real(r, i),
        NumericData::UInt32 { real: r, imag: i } => real(r, i),
        NumericData::Single { real: r, imag: i } => real(r, i),
        NumericData::Double { real: r, imag: i } => real(r, i),
        #[allow(clippy::cast_precision_loss)]
        NumericData::Int64 { real: r, imag: i } => {
            i.is_none().then(|| r.iter().map(|x| *x as f64).collect())
        }
        #[allow(clippy::cast_precision_loss)]
        NumericData::UInt64 { real: r, imag: i } => {
            i.is_none().then(|| r.iter().map(|x| *x as f64).collect())
        }
    }
}

/// A 2-D array as rows of `width` values: a sample a row (N x width) or a column
/// (width x N, as MATLAB code often stores them).
fn rows_of(a: &Array, width: usize) -> Option<Vec<Vec<f64>>> {
    let v = values(a)?;
    let &[r, c] = a.size().as_slice() else {
        return None;
    };
    if c == width && r != width {
        // Column-major N x width: element (i, j) at j * r + i.
        Some(
            (0..r)
                .map(|i| (0..width).map(|j| v[j * r + i]).collect())
                .collect(),
        )
    } else if r == width {
        Some((0..c).map(|i| v[i * r..(i + 1) * r].to_vec()).collect())
    } else {
        None
    }
}

/// Reads a `.mat` recording of what `holds` says, keeping `keep`, as [`super::layout::read`]
/// reads text.
///
/// # Errors
/// The file cannot be read or parsed, or holds no matrix of the expected shape: the message
/// lists the arrays it has.
pub fn read(path: &Path, holds: Holds, keep: Keep) -> Result<Rows, RecordingError> {
    let io = |source| RecordingError::Io {
        path: path.to_path_buf(),
        source,
    };
    if !std::fs::metadata(path).map_err(io)?.is_file() {
        return Err(RecordingError::Mat {
            path: path.to_path_buf(),
            what: "not a regular file: a MATLAB file is read whole, so it is taken from a file (a stream or a device is read as text, a line at a time)".into(),
        });
    }
    let bytes = crate::files::read_bounded(path, MAX_MAT, "a MATLAB recording").map_err(|e| {
        match e {
            crate::files::Error::Read { source, .. } => io(source),
            other => RecordingError::Mat {
                path: path.to_path_buf(),
                what: format!(
                    "{} (a MATLAB file is read whole; split the recording or save it as text, which is read a line at a time)",
                    other.to_string().trim_start_matches(&format!("{}: ", path.display()))
                ),
            },
        }
    })?;
    let mat = MatFile::parse(bytes.as_slice()).map_err(|e| RecordingError::Mat {
        path: path.to_path_buf(),
        what: format!("not a MATLAB level-5 file that can be read ({e})"),
    })?;
    let n = match holds {
        Holds::Both => 6,
        Holds::One => 3,
    };
    let listing = || {
        mat.arrays()
            .iter()
            .map(|a| format!("{} {:?}", a.name(), a.size()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    // One matrix of the timestamp and the counts, or of the counts; two that could be are
    // not chosen between silently.
    let fits = |a: &&matfile::Array| rows_of(a, n + 1).is_some() || rows_of(a, n).is_some();
    let candidates: Vec<&matfile::Array> = mat.arrays().iter().filter(fits).collect();
    if candidates.len() > 1 {
        return Err(RecordingError::Mat {
            path: path.to_path_buf(),
            what: format!(
                "{} matrices could be the recording ({}): keep one per file, so that none is \
                 picked without a word",
                candidates.len(),
                candidates
                    .iter()
                    .map(|a| format!("{} {:?}", a.name(), a.size()))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    }
    let whole = candidates.first().and_then(|a| {
        rows_of(a, n + 1)
            .map(|r| (Some(1.0), r))
            .or_else(|| rows_of(a, n).map(|r| (None, r)))
    });
    let (t, samples): (Option<Vec<f64>>, Vec<Vec<f64>>) = match whole {
        Some((Some(_), rows)) => (
            Some(rows.iter().map(|r| r[0]).collect()),
            rows.into_iter().map(|r| r[1..].to_vec()).collect(),
        ),
        Some((None, rows)) => (None, rows),
        None => by_name(&mat, holds).ok_or_else(|| RecordingError::Mat {
            path: path.to_path_buf(),
            what: format!(
                "no matrix of {} or {n} columns (a timestamp and the counts, or the counts) and no \
                 variables named t, acc and gyro; the file holds: {}",
                n + 1,
                listing()
            ),
        })?,
    };
    let kept: Vec<usize> = match (holds, keep) {
        (Holds::Both, Keep::Accel) => (0..3).collect(),
        (Holds::Both, Keep::Gyro) => (3..6).collect(),
        _ => (0..n).collect(),
    };
    let mut triads = vec![Vec::with_capacity(samples.len()); kept.len() / 3];
    for (k, s) in samples.iter().enumerate() {
        for (m, triad) in triads.iter_mut().enumerate() {
            let v = [s[kept[3 * m]], s[kept[3 * m + 1]], s[kept[3 * m + 2]]];
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                return Err(RecordingError::Number {
                    path: path.to_path_buf(),
                    line: k + 1,
                    field: kept[3 * m + j] + 1 + usize::from(t.is_some()),
                    what: "count",
                    text: format!("{}", v[j]),
                });
            }
            triad.push(v);
        }
    }
    if samples.is_empty() {
        return Err(RecordingError::Empty {
            path: path.to_path_buf(),
        });
    }
    if let Some(t) = &t
        && let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1])
    {
        return Err(RecordingError::NotIncreasing {
            path: path.to_path_buf(),
            line: k + 1,
            t: t[k],
            prev: t[k - 1],
        });
    }
    let first = usize::from(t.is_some());
    Ok(Rows {
        counter: false,
        // A MAT file's time is read in the unit its variable's name gives (t, time_ms).
        t_stated: true,
        line: (1..=samples.len())
            .map(|k| u32::try_from(k).unwrap_or(u32::MAX))
            .collect(),
        t,
        triads,
        fields: kept.iter().map(|j| j + 1 + first).collect(),
        units: vec![None; kept.len()],
        header: None,
        sensor: None,
        temp: None,
        preamble: Preamble::default(),
    })
}

/// The samples from variables named by their meaning: a time vector (seconds, or the unit its
/// name states), the accelerometer's and the gyro's N x 3 matrices.
#[allow(clippy::type_complexity)]
fn by_name(mat: &MatFile, holds: Holds) -> Option<(Option<Vec<f64>>, Vec<Vec<f64>>)> {
    let find = |names: &[&str]| {
        mat.arrays()
            .iter()
            .find(|a| names.contains(&squash(a.name()).as_str()))
            .and_then(|a| rows_of(a, 3))
    };
    let acc = find(&["acc", "accel", "accelerometer", "a", "rawa"]);
    let gyro = find(&["gyro", "gyr", "gyroscope", "omega", "w", "g"]);
    let rows: Vec<Vec<f64>> = match holds {
        Holds::Both => {
            let (a, g) = (acc?, gyro?);
            if a.len() != g.len() {
                return None;
            }
            a.into_iter()
                .zip(g)
                .map(|(a, g)| a.into_iter().chain(g).collect())
                .collect()
        }
        Holds::One => acc.or(gyro)?,
    };
    let t = mat.arrays().iter().find_map(|a| {
        let scale = match squash(a.name()).as_str() {
            "t" | "time" | "timestamp" | "ts" | "times" => 1.0,
            "tms" | "timems" => 1e-3,
            "tus" | "timeus" => 1e-6,
            "tns" | "timens" => 1e-9,
            _ => return None,
        };
        let v = values(a)?;
        (v.len() == rows.len()).then(|| v.into_iter().map(|x| x * scale).collect())
    });
    Some((t, rows))
}
