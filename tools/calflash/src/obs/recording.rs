//! Raw IMU recordings: a timestamp and three ADC counts per line for each sensor, as
//! whitespace-separated text (the layout of the Xsens MTi test data) or CSV; separate
//! accelerometer and gyro files, or one file of seven columns (t, ax, ay, az, gx, gy, gz).
//! Lines starting with `#` and a leading header line of names are skipped.
//!
//! Every error names the file and line (and the field); timestamps must increase; gaps (a step
//! longer than 1.5 sampling periods) are reported, as are samples at the converter's rails,
//! which are kept but marked so that no fit uses them.

use std::path::{Path, PathBuf};

use spincal::model::Rails;

/// A failure to read a recording.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Not UTF-8 text.
    #[error(
        "{path}:{line}: not text (a binary file?); expected a timestamp and three counts per line"
    )]
    NotText {
        /// File.
        path: PathBuf,
        /// Line.
        line: usize,
    },
    /// A line with the wrong number of fields.
    #[error("{path}:{line}: {found} fields; expected {expected}")]
    Fields {
        /// File.
        path: PathBuf,
        /// Line.
        line: usize,
        /// Fields found.
        found: usize,
        /// What was expected.
        expected: String,
    },
    /// A field that is not a number.
    #[error("{path}:{line}: field {field} ({what}) is `{text}`; expected a number")]
    Number {
        /// File.
        path: PathBuf,
        /// Line.
        line: usize,
        /// 1-based field.
        field: usize,
        /// Its meaning.
        what: &'static str,
        /// The text.
        text: String,
    },
    /// Time going backwards or standing still.
    #[error(
        "{path}:{line}: timestamp {t} s is not after the previous line's {prev} s; timestamps must increase"
    )]
    NotIncreasing {
        /// File.
        path: PathBuf,
        /// Line.
        line: usize,
        /// This timestamp.
        t: f64,
        /// The previous one.
        prev: f64,
    },
    /// The two files disagree.
    #[error(
        "{gyro}:{line}: {what}; the accelerometer file {acc} and the gyro file must hold the same samples, line for line"
    )]
    Mismatch {
        /// Accelerometer file.
        acc: PathBuf,
        /// Gyro file.
        gyro: PathBuf,
        /// Line (of the gyro file).
        line: usize,
        /// What differs.
        what: String,
    },
    /// Nothing in the file.
    #[error("{path}: no samples; expected a timestamp and three counts per line")]
    Empty {
        /// File.
        path: PathBuf,
    },
}

/// A step in time longer than 1.5 sampling periods: samples were dropped.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Gap {
    /// Line of the first sample after the gap.
    pub line: usize,
    /// Time before the gap, s.
    pub from: f64,
    /// Time after it, s.
    pub to: f64,
    /// Samples missing, about.
    pub missing: usize,
}

/// A raw IMU recording.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Where it came from (one or two files).
    pub source: String,
    /// Timestamps, s, increasing.
    pub t: Vec<f64>,
    /// Accelerometer counts.
    pub acc: Vec<[f64; 3]>,
    /// Gyro counts.
    pub gyro: Vec<[f64; 3]>,
    /// Line in the (accelerometer) file of each sample.
    pub line: Vec<usize>,
    /// Samples with an axis at or beyond a rail (any sensor).
    pub saturated: Vec<bool>,
    /// How many were saturated, accelerometer and gyro.
    pub saturated_count: (usize, usize),
    /// Gaps in the timestamps.
    pub gaps: Vec<Gap>,
    /// Median sampling period, s.
    pub period: f64,
}

impl Recording {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Sampling rate, Hz.
    #[must_use]
    pub fn rate(&self) -> f64 {
        1.0 / self.period
    }
}

struct Rows {
    t: Vec<f64>,
    v: Vec<Vec<f64>>,
    line: Vec<usize>,
}

const NAMES: [&str; 7] = [
    "timestamp",
    "x count",
    "y count",
    "z count",
    "gyro x count",
    "gyro y count",
    "gyro z count",
];

fn read_rows(path: &Path, widths: &[usize]) -> Result<Rows, RecordingError> {
    let bytes = std::fs::read(path).map_err(|source| RecordingError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let text = std::str::from_utf8(&bytes).map_err(|e| RecordingError::NotText {
        path: path.to_path_buf(),
        line: bytes[..e.valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count()
            + 1,
    })?;
    let text = match text.strip_prefix('\u{feff}') {
        Some(rest) => {
            super::note_bom(path);
            rest
        }
        None => text,
    };
    let mut rows = Rows {
        t: Vec::new(),
        v: Vec::new(),
        line: Vec::new(),
    };
    let mut width = None;
    let mut seen_data = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let s = raw.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = if s.contains(',') {
            s.split(',').map(str::trim).collect()
        } else {
            s.split_ascii_whitespace().collect()
        };
        // A header line of names before the first sample.
        if !seen_data
            && fields.first().is_some_and(|f| f.parse::<f64>().is_err())
            && fields.iter().any(|f| f.chars().any(char::is_alphabetic))
        {
            continue;
        }
        seen_data = true;
        let w = *width.get_or_insert(fields.len());
        if fields.len() != w || !widths.contains(&w) {
            let expected = if fields.len() != w {
                format!("{w}, as on the first sample line")
            } else if widths == [7] {
                "7 (timestamp, accelerometer x, y, z, gyro x, y, z counts), or give the gyro file too".into()
            } else {
                "4 (timestamp, x, y, z counts)".into()
            };
            return Err(RecordingError::Fields {
                path: path.to_path_buf(),
                line,
                found: fields.len(),
                expected,
            });
        }
        let mut vals = Vec::with_capacity(w - 1);
        for (k, f) in fields.iter().enumerate() {
            let x: f64 = f
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite())
                .ok_or_else(|| RecordingError::Number {
                    path: path.to_path_buf(),
                    line,
                    field: k + 1,
                    what: NAMES[k.min(6)],
                    text: super::shorten(f),
                })?;
            if k == 0 {
                if let Some(&prev) = rows.t.last()
                    && x <= prev
                {
                    return Err(RecordingError::NotIncreasing {
                        path: path.to_path_buf(),
                        line,
                        t: x,
                        prev,
                    });
                }
                rows.t.push(x);
            } else {
                vals.push(x);
            }
        }
        rows.v.push(vals);
        rows.line.push(line);
    }
    if rows.t.is_empty() {
        return Err(RecordingError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(rows)
}

struct Parsed {
    t: Vec<f64>,
    acc: Vec<[f64; 3]>,
    gyro: Vec<[f64; 3]>,
    line: Vec<usize>,
    source: String,
}

fn triple(v: &[f64], from: usize) -> [f64; 3] {
    [v[from], v[from + 1], v[from + 2]]
}

/// Reads a recording: `acc` with seven columns, or `acc` and `gyro` with four each. Samples at or
/// beyond `rails` are marked saturated.
///
/// # Errors
/// A [`RecordingError`] naming the file and line.
pub fn read(acc: &Path, gyro: Option<&Path>, rails: Rails) -> Result<Recording, RecordingError> {
    let Parsed {
        t,
        acc: a,
        gyro: g,
        line,
        source,
    } = match gyro {
        None => {
            let r = read_rows(acc, &[7])?;
            let a = r.v.iter().map(|v| triple(v, 0)).collect();
            let g = r.v.iter().map(|v| triple(v, 3)).collect();
            Parsed {
                t: r.t,
                acc: a,
                gyro: g,
                line: r.line,
                source: acc.display().to_string(),
            }
        }
        Some(gp) => {
            let ra = read_rows(acc, &[4])?;
            let rg = read_rows(gp, &[4])?;
            let mismatch = |line: usize, what: String| RecordingError::Mismatch {
                acc: acc.to_path_buf(),
                gyro: gp.to_path_buf(),
                line,
                what,
            };
            if ra.t.len() != rg.t.len() {
                let line = rg
                    .line
                    .get(ra.t.len().min(rg.t.len()))
                    .or(rg.line.last())
                    .copied()
                    .unwrap_or(1);
                return Err(mismatch(
                    line,
                    format!(
                        "{} gyro samples against {} accelerometer samples",
                        rg.t.len(),
                        ra.t.len()
                    ),
                ));
            }
            let tol = 1e-6 * ra.t.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            if let Some(k) = (0..ra.t.len()).find(|&k| (ra.t[k] - rg.t[k]).abs() > tol) {
                return Err(mismatch(
                    rg.line[k],
                    format!(
                        "timestamp {} s where the accelerometer's is {} s",
                        rg.t[k], ra.t[k]
                    ),
                ));
            }
            let a = ra.v.iter().map(|v| triple(v, 0)).collect();
            let g = rg.v.iter().map(|v| triple(v, 0)).collect();
            Parsed {
                t: ra.t,
                acc: a,
                gyro: g,
                line: ra.line,
                source: format!("{} + {}", acc.display(), gp.display()),
            }
        }
    };
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let period = if steps.is_empty() {
        f64::NAN
    } else {
        let mid = steps.len() / 2;
        *steps.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let gaps = t
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] - w[0] > 1.5 * period)
        .map(|(k, w)| Gap {
            line: line[k + 1],
            from: w[0],
            to: w[1],
            missing: ((w[1] - w[0]) / period).round() as usize - 1,
        })
        .collect();
    let at_rail = |s: &[f64; 3]| {
        s.iter()
            .any(|x| *x <= f64::from(rails.lo) || *x >= f64::from(rails.hi))
    };
    let sa: Vec<bool> = a.iter().map(at_rail).collect();
    let sg: Vec<bool> = g.iter().map(at_rail).collect();
    let saturated_count = (
        sa.iter().filter(|x| **x).count(),
        sg.iter().filter(|x| **x).count(),
    );
    let saturated = sa.iter().zip(&sg).map(|(x, y)| *x || *y).collect();
    Ok(Recording {
        source,
        t,
        acc: a,
        gyro: g,
        line,
        saturated,
        saturated_count,
        gaps,
        period,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_both_layouts_and_reports_gaps_and_rails() {
        let d = tempfile::tempdir().unwrap();
        let a = write(
            d.path(),
            "a.txt",
            "# rest\n0.00 1 2 3\n0.01 1 2 3\n0.02 0 2 3\n0.05 1 2 3\n",
        );
        let g = write(
            d.path(),
            "g.txt",
            "0.00 5 6 7\n0.01 5 6 7\n0.02 5 6 7\n0.05 5 6 65535\n",
        );
        let r = read(&a, Some(&g), Rails::unsigned(16)).unwrap();
        assert_eq!(r.len(), 4);
        assert_eq!(r.gyro[3], [5.0, 6.0, 65535.0]);
        assert_eq!(r.saturated, [false, false, true, true]);
        assert_eq!(r.saturated_count, (1, 1));
        assert_eq!(
            r.gaps,
            [Gap {
                line: 5,
                from: 0.02,
                to: 0.05,
                missing: 2
            }]
        );
        let one = write(
            d.path(),
            "imu.csv",
            "t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n",
        );
        let r = read(&one, None, Rails::unsigned(16)).unwrap();
        assert_eq!((r.acc[1], r.gyro[1]), ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]));
    }

    #[test]
    fn bad_input_names_file_line_and_field() {
        let d = tempfile::tempdir().unwrap();
        let rails = Rails::unsigned(16);
        let msg = |a: &Path, g: Option<&Path>| read(a, g, rails).unwrap_err().to_string();
        let back = write(d.path(), "back.txt", "0.00 1 2 3\n0.02 1 2 3\n0.01 1 2 3\n");
        assert_eq!(
            msg(&back, Some(&back)),
            format!(
                "{}:3: timestamp 0.01 s is not after the previous line's 0.02 s; timestamps must increase",
                back.display()
            )
        );
        let word = write(d.path(), "word.txt", "0.00 1 2 3\n0.01 1 x 3\n");
        assert_eq!(
            msg(&word, Some(&word)),
            format!(
                "{}:2: field 3 (y count) is `x`; expected a number",
                word.display()
            )
        );
        let short = write(d.path(), "short.txt", "0.00 1 2 3\n0.01 1 2\n");
        assert_eq!(
            msg(&short, Some(&short)),
            format!(
                "{}:2: 3 fields; expected 4, as on the first sample line",
                short.display()
            )
        );
        let other = write(d.path(), "other.txt", "0.00 1 2 3\n0.015 1 2 3\n");
        let ok = write(d.path(), "ok.txt", "0.00 1 2 3\n0.01 1 2 3\n");
        assert_eq!(
            msg(&ok, Some(&other)),
            format!(
                "{}:2: timestamp 0.015 s where the accelerometer's is 0.01 s; the accelerometer file {} and the gyro file must hold the same samples, line for line",
                other.display(),
                ok.display()
            )
        );
        assert_eq!(
            msg(&ok, None),
            format!(
                "{}:1: 4 fields; expected 7 (timestamp, accelerometer x, y, z, gyro x, y, z counts), or give the gyro file too",
                ok.display()
            )
        );
        let empty = write(d.path(), "empty.txt", "# nothing\n");
        assert_eq!(
            msg(&empty, Some(&ok)),
            format!(
                "{}: no samples; expected a timestamp and three counts per line",
                empty.display()
            )
        );
    }
}
