//! What `calflash flight` reads: the IMU's samples (raw codes through the unit's own
//! correction, or physical values), the GNSS fixes and the barometer, each checked and named
//! by file, line and column when it cannot be read.

use std::path::Path;

use spincal::correct::AnyCorrector;
use spincal::model::Calibration;

use crate::mission::Profile;

mod aiding;
pub use aiding::{NO_FIX_MARKER, baro, gnss};

/// The IMU's samples, corrected: time (s), specific force (m/s^2) and rate (rad/s) in body
/// axes, and whether the corrector flagged the sample.
#[derive(Debug, Clone, Default)]
pub struct ImuSeries {
    /// Times, s.
    pub t: Vec<f64>,
    /// Specific force, m/s^2.
    pub f: Vec<[f64; 3]>,
    /// Rate, rad/s.
    pub w: Vec<[f64; 3]>,
    /// Per sample, whether the accelerometers' and the gyros' readings cannot be vouched for
    /// (`spincal::flight::doubted`): a code at its rails (that sensor only), uncorrected or a
    /// rate step (both), beyond the calibrated range with neither at its rails (both). A
    /// temperature or voltage beyond the calibrated span is corrected at its edge: the
    /// calibration's own uncertainty, not a lost sample.
    pub flagged: Vec<[bool; 2]>,
    /// The recording's median temperature, C, when it logs one.
    pub temperature: Option<f64>,
}

/// A GNSS fix in the file's terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fix {
    /// Time, s (the IMU's clock).
    pub t: f64,
    /// Latitude and longitude, degrees.
    pub lat_lon: (f64, f64),
    /// Height above the ellipsoid, m, when logged.
    pub height: Option<f64>,
    /// Velocity east, north, up, m/s, when logged.
    pub velocity: Option<[f64; 3]>,
    /// Satellites the receiver used, when logged.
    pub satellites: Option<f64>,
}

/// What the GNSS file held beside its usable fixes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FixCounts {
    /// Rows read.
    pub rows: usize,
    /// Rows without a fix (a "no fix" marker, fewer than four satellites).
    pub no_fix: usize,
    /// Rows repeating the previous fix's position and time, or its position exactly (a
    /// receiver holding its last fix).
    pub repeated: usize,
    /// The longest hold: from the fix held to its last repeat, s (`None` without one).
    pub longest_hold: Option<(f64, f64)>,
}

/// A barometer reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pressure {
    /// Time, s.
    pub t: f64,
    /// Static pressure, Pa.
    pub pa: f64,
}

/// A file that cannot be read as what it should be.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file could not be opened or read.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// A CSV it cannot parse.
    #[error("{file}: {source}")]
    Csv {
        /// The file.
        file: String,
        /// Why.
        source: csv::Error,
    },
    /// A column it needs is missing.
    #[error("{file}: no column `{column}` in the header ({expected})")]
    NoColumn {
        /// The file.
        file: String,
        /// The column.
        column: String,
        /// What the file should hold.
        expected: &'static str,
    },
    /// A field that is not what it should be.
    #[error("{file} line {line}, column `{column}`: `{text}` {why}")]
    Field {
        /// The file.
        file: String,
        /// Its line, from 1.
        line: u64,
        /// The column.
        column: String,
        /// What was there.
        text: String,
        /// What was expected.
        why: &'static str,
    },
    /// Time running backwards or standing still (a logger's clock that stuck).
    #[error(
        "{file} line {line}: time {t} s is not after the line above's {before} s (time must increase: a repeated time is a logger's clock that stuck)"
    )]
    Backwards {
        /// The file.
        file: String,
        /// Its line.
        line: u64,
        /// Its time.
        t: f64,
        /// The time before.
        before: f64,
    },
    /// The corrector refused the calibration.
    #[error("{0}")]
    Corrector(String),
    /// A column in a unit other than the one expected.
    #[error("{file}: {what}")]
    Unit {
        /// The file.
        file: String,
        /// What was found and what to do.
        what: String,
    },
    /// More rows than the bound: an endless or mistaken file is refused, not read until the
    /// memory runs out.
    #[error(
        "{file}: more than {max} rows: read no further (1,000 s of a 10 kHz log is 10^7); give --max-samples N to read a longer record"
    )]
    TooLong {
        /// The file.
        file: String,
        /// The bound.
        max: usize,
    },
}

/// The rows `calflash flight` reads of one file unless `--max-samples` says more.
pub const MAX_ROWS: usize = 10_000_000;

/// The longest line read, bytes.
const MAX_LINE: usize = 1 << 20;

/// A header-led CSV with named columns: its reader and the index of each column asked for.
pub(super) struct Table {
    file: String,
    reader: csv::Reader<crate::files::LineBound<std::fs::File>>,
    header: Vec<String>,
    /// The most rows read.
    max_rows: usize,
}

impl Table {
    fn open(path: &Path, max_rows: usize) -> Result<Self, InputError> {
        let file = path.display().to_string();
        let inner = std::fs::File::open(path).map_err(|source| InputError::Io {
            file: file.clone(),
            source,
        })?;
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .flexible(false)
            .from_reader(crate::files::LineBound::new(inner, MAX_LINE));
        let header = reader
            .headers()
            .map_err(|source| InputError::Csv {
                file: file.clone(),
                source,
            })?
            .iter()
            .map(str::to_string)
            .collect();
        Ok(Self {
            file,
            reader,
            header,
            max_rows,
        })
    }

    /// The first of `names` in the header, exactly as written, else in any case (so `T`, a
    /// temperature, is not taken for `t`).
    fn column(&self, names: &[&str]) -> Option<usize> {
        names
            .iter()
            .find_map(|n| self.header.iter().position(|h| h == n))
            .or_else(|| {
                names.iter().find_map(|n| {
                    (n.len() > 1)
                        .then(|| self.header.iter().position(|h| h.eq_ignore_ascii_case(n)))
                        .flatten()
                })
            })
    }

    fn need(&self, names: &[&str], expected: &'static str) -> Result<usize, InputError> {
        self.column(names).ok_or_else(|| InputError::NoColumn {
            file: self.file.clone(),
            column: names.first().copied().unwrap_or_default().to_string(),
            expected,
        })
    }

    /// Each row's line and the numbers in `columns` (`None` for an empty field).
    fn rows(
        &mut self,
        columns: &[usize],
        mut each: impl FnMut(u64, &[Option<f64>]) -> Result<(), InputError>,
    ) -> Result<(), InputError> {
        let mut record = csv::StringRecord::new();
        let mut values = vec![None; columns.len()];
        let mut count = 0usize;
        loop {
            let more = self
                .reader
                .read_record(&mut record)
                .map_err(|source| InputError::Csv {
                    file: self.file.clone(),
                    source,
                })?;
            if !more {
                return Ok(());
            }
            count += 1;
            if count > self.max_rows {
                return Err(InputError::TooLong {
                    file: self.file.clone(),
                    max: self.max_rows,
                });
            }
            let line = record.position().map_or(0, csv::Position::line);
            for (v, &c) in values.iter_mut().zip(columns) {
                let text = record.get(c).unwrap_or_default();
                *v = if text.is_empty() {
                    None
                } else {
                    Some(
                        text.parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite())
                            .ok_or_else(|| InputError::Field {
                                file: self.file.clone(),
                                line,
                                column: self.header.get(c).cloned().unwrap_or_default(),
                                text: text.chars().take(40).collect(),
                                why: "is not a finite number",
                            })?,
                    )
                };
            }
            each(line, &values)?;
        }
    }
}

/// Raw codes (`t`, `a_x a_y a_z g_x g_y g_z`, optionally `temp`) through the unit's own
/// correction, each sample at its temperature.
///
/// # Errors
/// An unreadable file, a missing column, a field that is not a number, time running back.
pub fn corrected(path: &Path, cal: &Calibration, max_rows: usize) -> Result<ImuSeries, InputError> {
    use crate::columns as col;
    let mut table = Table::open(path, max_rows)?;
    let codes = "t and the raw codes a_x a_y a_z g_x g_y g_z (as simulate --flight writes them)";
    let mut cols = vec![table.need(&["t", "time", "ts"], codes)?];
    for name in col::A.iter().chain(&col::GYRO) {
        cols.push(table.need(&[name], codes)?);
    }
    let temp = table.column(&["temp"]);
    cols.extend(temp);
    let mut raw: Vec<(u64, Vec<f64>)> = Vec::new();
    let file = table.file.clone();
    let names: Vec<String> = cols
        .iter()
        .map(|&c| table.header.get(c).cloned().unwrap_or_default())
        .collect();
    table.rows(&cols, |line, v| {
        let mut row = Vec::with_capacity(v.len());
        for (x, name) in v.iter().zip(&names) {
            row.push(x.ok_or_else(|| InputError::Field {
                file: file.clone(),
                line,
                column: name.clone(),
                text: String::new(),
                why: "is empty; expected a number",
            })?);
        }
        raw.push((line, row));
        Ok(())
    })?;
    let rate = median_rate(raw.iter().map(|(_, r)| r[0]));
    let mut corrector = AnyCorrector::new(cal, rate as f32)
        .map_err(|e| InputError::Corrector(format!("{file}: {e}")))?;
    let env = &cal.data().environment;
    let mid = |s: spincal::model::Span| 0.5 * (s.lo + s.hi);
    let volt = mid(env.voltage_span);
    let rails = match &cal.data().sensor {
        spincal::model::Sensor::Imu {
            accel_rails,
            gyro_rails,
            ..
        } => (*accel_rails, *gyro_rails),
        _ => {
            return Err(InputError::Corrector(format!(
                "{file}: the calibration is not an IMU's"
            )));
        }
    };
    let mut series = ImuSeries::default();
    let mut last_t = f64::NEG_INFINITY;
    let mut last_temp = f32::NAN;
    for (line, row) in &raw {
        let t = row[0];
        if t <= last_t {
            return Err(InputError::Backwards {
                file,
                line: *line,
                t,
                before: last_t,
            });
        }
        let temp = row.get(7).map_or(mid(env.temperature_span), |x| *x as f32);
        // A new environment restarts the rate derivative: follow the temperature in steps.
        if last_temp.is_nan() || (temp - last_temp).abs() >= TEMPERATURE_STEP {
            corrector.set_environment(temp, volt);
            last_temp = temp;
        }
        let c: Vec<i32> = row[1..7].iter().map(|x| x.round() as i32).collect();
        let Some(o) = corrector.correct(&c) else {
            return Err(InputError::Corrector(format!(
                "{file}: the calibration does not correct an IMU's six codes"
            )));
        };
        let v = o.values.map(f64::from);
        series.t.push(t);
        series.f.push([v[0], v[1], v[2]]);
        series.w.push([v[3], v[4], v[5]]);
        let codes: [i32; 6] = [c[0], c[1], c[2], c[3], c[4], c[5]];
        series
            .flagged
            .push(spincal::flight::doubted(&codes, o.flags, rails.0, rails.1));
        last_t = t;
    }
    if temp.is_some() {
        let mut logged: Vec<f64> = raw.iter().filter_map(|(_, r)| r.get(7).copied()).collect();
        let mid = logged.len() / 2;
        if !logged.is_empty() {
            let (_, m, _) = logged.select_nth_unstable_by(mid, f64::total_cmp);
            series.temperature = Some(*m);
        }
    }
    Ok(series)
}

/// The temperature change, C, after which a recording's samples are corrected at the new
/// temperature (each change restarts the corrector's rate derivative, flagging a sample).
const TEMPERATURE_STEP: f32 = 0.1;

/// The median sampling rate of increasing times, Hz (1000 when it cannot tell).
pub fn median_rate(t: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = t.collect();
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 1000.0;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    1.0 / *m
}

/// Physical values from a mission-profile reader (as `selfcal` and `mission` take them):
/// nothing flagged, as the log has no flags.
#[must_use]
pub fn physical(p: &Profile) -> ImuSeries {
    let n = p.len();
    ImuSeries {
        t: p.t.clone(),
        f: p.f.clone().unwrap_or_else(|| vec![[0.0; 3]; n]),
        w: p.w.clone().unwrap_or_else(|| vec![[0.0; 3]; n]),
        flagged: vec![[false; 2]; n],
        temperature: None,
    }
}
