//! A mission profile: what a unit feels at its reference point over a flight (specific force,
//! angular rate and angular acceleration in its axes, temperature, supply voltage), read from
//! a file with named columns and checked; its summary (ranges, time at each level, setback,
//! spin, vibration); and its weight on a model, the mean of `f(x_t) f(x_t)'` over the flight,
//! for designing and judging a calibration for that flight (DESIGN §10).

pub mod columns;
pub mod judge;
pub mod judged;
mod read;
pub mod summary;
pub mod weight;

use std::path::PathBuf;

pub use read::{MAX_SAMPLES, read, read_at_most};

/// The largest specific force a profile may hold, m/s^2 (about 100,000 g: beyond any gun).
pub const MAX_SPECIFIC_FORCE: f64 = 1.0e6;
/// The largest rate, rad/s (5,000 rev/s: beyond a rifle bullet's spin).
pub const MAX_RATE: f64 = 2.0 * std::f64::consts::PI * 5_000.0;
/// The largest angular acceleration an airframe makes, rad/s^2 (a shell's spin rises to
/// 2,000 rad/s over a few milliseconds in the bore: a few 1e5; at 100 Hz a jump of 10,000
/// rad/s from one sample to the next).
pub const MAX_ANGULAR_ACCELERATION: f64 = 1.0e6;
/// The largest rate of change of specific force, m/s^3 (a 30,000 g setback rising in 0.1 ms
/// is 3e9).
pub const MAX_JERK: f64 = 1.0e10;
/// Temperatures a unit can be at, C.
pub const TEMPERATURES: (f64, f64) = (-100.0, 200.0);
/// Supply voltages, V.
pub const VOLTAGES: (f64, f64) = (0.0, 1_000.0);

/// A mission profile, in SI.
#[derive(Debug, Clone)]
pub struct Profile {
    /// The file it was read from.
    pub source: PathBuf,
    /// Time, s, increasing.
    pub t: Vec<f64>,
    /// The file's line of each sample.
    pub line: Vec<u64>,
    /// Specific force, m/s^2, when the profile has it.
    pub f: Option<Vec<[f64; 3]>>,
    /// Angular rate, rad/s.
    pub w: Option<Vec<[f64; 3]>>,
    /// Angular acceleration, rad/s^2 (differentiated from the rates when the file has none).
    pub dw: Option<Vec<[f64; 3]>>,
    /// Temperature, C.
    pub temp: Option<Vec<f64>>,
    /// Supply voltage, V.
    pub volt: Option<Vec<f64>>,
    /// What was assumed or derived while reading, for the reader.
    pub notes: Vec<String>,
}

/// A quantity of a profile, as a model's variables name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Specific force along an axis.
    F(usize),
    /// Rate about an axis.
    W(usize),
    /// Angular acceleration about an axis.
    Dw(usize),
    /// Temperature.
    Temp,
    /// Supply voltage.
    Volt,
}

impl Quantity {
    /// The column name the observation files use (`crate::columns`).
    #[must_use]
    pub fn name(self) -> &'static str {
        use crate::columns as col;
        match self {
            Self::F(k) => col::F[k],
            Self::W(k) => col::W[k],
            Self::Dw(k) => col::DW[k],
            Self::Temp => col::TEMP,
            Self::Volt => col::VOLT,
        }
    }

    /// Every quantity.
    #[must_use]
    pub fn all() -> [Self; 11] {
        [
            Self::F(0),
            Self::F(1),
            Self::F(2),
            Self::W(0),
            Self::W(1),
            Self::W(2),
            Self::Dw(0),
            Self::Dw(1),
            Self::Dw(2),
            Self::Temp,
            Self::Volt,
        ]
    }
}

impl Profile {
    /// Samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The values of `q`, when the profile has them.
    #[must_use]
    pub fn series(&self, q: Quantity) -> Option<Vec<f64>> {
        let axis = |v: &Option<Vec<[f64; 3]>>, k: usize| {
            v.as_ref().map(|v| v.iter().map(|s| s[k]).collect())
        };
        match q {
            Quantity::F(k) => axis(&self.f, k),
            Quantity::W(k) => axis(&self.w, k),
            Quantity::Dw(k) => axis(&self.dw, k),
            Quantity::Temp => self.temp.clone(),
            Quantity::Volt => self.volt.clone(),
        }
    }

    /// The value of `q` at sample `i`, when the profile has it.
    #[must_use]
    pub fn value(&self, i: usize, q: Quantity) -> Option<f64> {
        match q {
            Quantity::F(k) => self.f.as_ref().map(|v| v[i][k]),
            Quantity::W(k) => self.w.as_ref().map(|v| v[i][k]),
            Quantity::Dw(k) => self.dw.as_ref().map(|v| v[i][k]),
            Quantity::Temp => self.temp.as_ref().map(|v| v[i]),
            Quantity::Volt => self.volt.as_ref().map(|v| v[i]),
        }
    }

    /// The time each sample stands for (half the steps to its neighbours), s: the weight of a
    /// sample in a time average, whatever the sampling.
    #[must_use]
    pub fn dwell(&self) -> Vec<f64> {
        let n = self.t.len();
        (0..n)
            .map(|i| {
                let lo = if i == 0 { self.t[0] } else { self.t[i - 1] };
                let hi = if i + 1 == n {
                    self.t[n - 1]
                } else {
                    self.t[i + 1]
                };
                0.5 * (hi - lo)
            })
            .collect()
    }

    /// The profile's duration, s.
    #[must_use]
    pub fn duration(&self) -> f64 {
        match (self.t.first(), self.t.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }
}

/// A profile that cannot be read or is not a flight.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MissionError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// `--mission-columns` that cannot be read.
    #[error(transparent)]
    Columns(#[from] columns::ColumnsError),
    /// A chosen column the header lacks.
    #[error("{path}: --mission-columns names `{name}` for {role}, but the header has {has}")]
    NoSuchColumn {
        /// The file.
        path: PathBuf,
        /// The column's name.
        name: String,
        /// Its role.
        role: String,
        /// The header's names.
        has: String,
    },
    /// Two columns for one role.
    #[error(
        "{path}: columns `{first}` and `{second}` both hold {role}; choose one with --mission-columns {role}=NAME"
    )]
    TwoColumns {
        /// The file.
        path: PathBuf,
        /// The role.
        role: String,
        /// The first column.
        first: String,
        /// The second.
        second: String,
    },
    /// No header at all.
    #[error(
        "{path}: empty; a mission profile is CSV with a header naming its columns (t, f_x, f_y, f_z, w_x, ...)"
    )]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// No time column.
    #[error(
        "{path}: no time column (t, ts, time, time_ms, ...); name it with --mission-columns t=NAME:s"
    )]
    NoTime {
        /// The file.
        path: PathBuf,
    },
    /// Neither specific force nor rate.
    #[error(
        "{path}: no specific force (f_x or ax ...) and no rate (w_x or gx ...) columns; the header has {has}"
    )]
    Nothing {
        /// The file.
        path: PathBuf,
        /// The header's names.
        has: String,
    },
    /// Part of a triad.
    #[error("{path}: {what} has {found} but not {missing}: a profile gives all three axes")]
    PartTriad {
        /// The file.
        path: PathBuf,
        /// What.
        what: &'static str,
        /// The axes found.
        found: String,
        /// The axes missing.
        missing: String,
    },
    /// A field that is not a number.
    #[error("{path}, line {line}, column `{column}`: `{text}` is not a finite number")]
    NotNumber {
        /// The file.
        path: PathBuf,
        /// Line.
        line: u64,
        /// The column.
        column: String,
        /// What is there.
        text: String,
    },
    /// A line with a different number of fields.
    #[error("{path}, line {line}: {found} fields where the header has {expected}")]
    Width {
        /// The file.
        path: PathBuf,
        /// Line.
        line: u64,
        /// Fields found.
        found: usize,
        /// The header's.
        expected: usize,
    },
    /// Time not increasing.
    #[error(
        "{path}, line {line}: time {} s is not after the previous sample's {} s (time must increase)", crate::report::terminal::num(*.t), crate::report::terminal::num(*.before)
    )]
    TimeBackwards {
        /// The file.
        path: PathBuf,
        /// Line.
        line: u64,
        /// The time.
        t: f64,
        /// The time before.
        before: f64,
    },
    /// A value no unit can feel.
    #[error(transparent)]
    Impossible(Box<Impossible>),
    /// A step no airframe makes.
    #[error(transparent)]
    Jump(Box<Jump>),
    /// Too few samples.
    #[error("{path}: {count} samples; a profile needs at least 2")]
    TooShort {
        /// The file.
        path: PathBuf,
        /// Samples.
        count: usize,
    },
    /// Rates and angular accelerations in units that disagree by a degree's factor.
    #[error(
        "{path}: the rates' own change over time is {ratio:.1} times the angular acceleration columns: {which}; state the unit with --mission-columns (wx=NAME:deg/s, ...) or convert the file"
    )]
    RateUnits {
        /// The file.
        path: PathBuf,
        /// d(w)/dt over dw, least squares over the samples.
        ratio: f64,
        /// Which is likely in degrees.
        which: &'static str,
    },
    /// Too many samples.
    #[error(
        "{path}: more than {max} samples; decimate the profile (a mission's moments need far fewer), or for `calflash flight` give --max-samples N"
    )]
    TooLong {
        /// The file.
        path: PathBuf,
        /// The most.
        max: usize,
    },
}

/// A value no unit can feel.
#[derive(Debug, thiserror::Error)]
#[error(
    "{path}, line {line}, column `{column}`: {value} {unit} is beyond what a flight can make ({limit}){hint}"
)]
pub struct Impossible {
    /// The file.
    pub path: PathBuf,
    /// Line.
    pub line: u64,
    /// The column.
    pub column: String,
    /// The value, SI.
    pub value: f64,
    /// Its unit.
    pub unit: &'static str,
    /// The limit, in words.
    pub limit: String,
    /// A hint about units.
    pub hint: String,
}

/// A step no airframe makes.
#[derive(Debug, thiserror::Error)]
#[error(
    "{path}, line {line}, column `{column}`: from {} to {} {unit} in {} s is {rate:.3e} {unit}/s, a jump no airframe makes (at most {limit:.0e})", crate::report::terminal::num(*.from), crate::report::terminal::num(*.to), crate::report::terminal::num(*.dt)
)]
pub struct Jump {
    /// The file.
    pub path: PathBuf,
    /// Line of the later sample.
    pub line: u64,
    /// The column.
    pub column: String,
    /// Value before, SI.
    pub from: f64,
    /// Value after.
    pub to: f64,
    /// The step, s.
    pub dt: f64,
    /// The rate of change.
    pub rate: f64,
    /// Its unit.
    pub unit: &'static str,
    /// The limit.
    pub limit: f64,
}
