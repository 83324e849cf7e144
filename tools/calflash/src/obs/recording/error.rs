//! Why a recording cannot be read: each names the file and, where there is one, the line.

use std::path::PathBuf;

/// A failure to read a recording.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// More rows than a recording is read with ([`crate::obs::MAX_ROWS`]).
    #[error(
        "{path}: more than {max} rows: read no further (1,000 s of a 10 kHz recording is 10^7); split the file, or decimate it"
    )]
    TooManyRows {
        /// File.
        path: PathBuf,
        /// The bound.
        max: usize,
    },
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
    /// A line of the head (preamble, header) too long to be one.
    #[error(
        "{path}:{line}: longer than {max} bytes without a line end (a binary file?); expected \
         a timestamp and three counts per line"
    )]
    LineTooLong {
        /// File.
        path: PathBuf,
        /// Line.
        line: usize,
        /// The longest line read.
        max: usize,
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
    /// Codes that show the recording is in another format than the one given.
    #[error(
        "{path}:{line}: {advice} (the first is {value}, field {field}; the format given is {format})"
    )]
    WrongCodes {
        /// File.
        path: PathBuf,
        /// Line of the first code beyond the rails.
        line: usize,
        /// Its 1-based field.
        field: usize,
        /// Its value.
        value: f64,
        /// The format given.
        format: String,
        /// What the codes look like, and the option to give.
        advice: String,
    },
    /// No timestamps and no rate.
    #[error(
        "{path}: no timestamp column and no sample rate: give --sample-rate HZ (or a preamble line `Fs,HZ`)"
    )]
    NoRate {
        /// File.
        path: PathBuf,
    },
    /// A stated rate that the timestamps or another statement contradict.
    #[error("{path}:{line}: {what}")]
    RateConflict {
        /// File.
        path: PathBuf,
        /// The line of the statement (the preamble's, or the first sample's).
        line: usize,
        /// What disagrees.
        what: String,
    },
    /// A MATLAB file that cannot be read as a recording.
    #[error("{path}: {what}")]
    Mat {
        /// File.
        path: PathBuf,
        /// What is wrong, and what the file holds.
        what: String,
    },
    /// Columns chosen by name that the header does not have.
    #[error("{path}:{line}: {what}")]
    Columns {
        /// File.
        path: PathBuf,
        /// The header's line (or the first sample's).
        line: usize,
        /// What is wrong.
        what: crate::obs::header::ColumnsError,
    },
    /// Units that disagree, or an LSB for codes.
    #[error("{path}:{line}: {what}")]
    Units {
        /// File.
        path: PathBuf,
        /// The header's line (or 1).
        line: usize,
        /// What disagrees.
        what: String,
    },
    /// Nothing in the file.
    #[error("{path}: no samples; expected a timestamp and three counts per line")]
    Empty {
        /// File.
        path: PathBuf,
    },
    /// Timestamps whose step no inertial sensor samples at: read in the wrong unit.
    #[error(
        "{path}: the timestamps step by {period:e} s ({rate:.3e} Hz), a rate no inertial sensor \
         samples at: are they in another unit? Name the column with it (t_ms, t_us, t_ns) or \
         give it: --columns t=NAME:ms (s, ms, us, ns)"
    )]
    ImplausibleRate {
        /// File.
        path: PathBuf,
        /// The median step as read, s.
        period: f64,
        /// Its rate, Hz.
        rate: f64,
    },
    /// One sample: no step in time, so no sample rate.
    #[error(
        "{path}: one sample; a recording needs at least two (and many more for any use) to have \
         a sample rate"
    )]
    OneSample {
        /// File.
        path: PathBuf,
    },
}
