//! Reading observations: a header row naming the columns, then one observation per row, as CSV
//! or as whitespace-separated text. Only the columns a fit needs are kept, as `f64`, so a file of
//! millions of rows streams through in one pass. Every error names the file, the line and the
//! column.

pub mod codes;
pub(crate) mod fields;
pub mod recording;
mod rows;
pub mod timing;

// The parts of reading a recording file, at the paths they have always had.
pub use recording::{header, layout, mat};
pub mod units;

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use rows::Layout;

/// How a file separates its fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Decide from the header line: a comma means CSV, otherwise whitespace.
    Auto,
    /// Comma-separated values with a header row (quoting as RFC 4180).
    Csv,
    /// Fields separated by runs of spaces or tabs, with a header row.
    Whitespace,
}

/// A failure to read observations.
#[derive(Debug, thiserror::Error)]
pub enum ObsError {
    /// The file cannot be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Bytes that are not UTF-8 text (or a NUL byte).
    #[error("{path}:{line}: not text (a binary file?); expected UTF-8 text with a header row")]
    NotText {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: u64,
    },
    /// A line of the head (comments, header) too long to be one.
    #[error(
        "{path}:{line}: longer than {max} bytes without a line end (a binary file?); expected a \
         header row naming the columns"
    )]
    LineTooLong {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The longest line read.
        max: usize,
    },
    /// No header row.
    #[error(
        "{path}: the file is empty; expected a header row naming the columns, then observations"
    )]
    Empty {
        /// File.
        path: PathBuf,
    },
    /// A header and no observations.
    #[error("{path}: the header has no observations under it")]
    NoRows {
        /// File.
        path: PathBuf,
    },
    /// More rows than any calibration or recording is read with: an endless stream (a FIFO)
    /// or a mistaken file is refused, not read until the memory runs out.
    #[error(
        "{path}: more than {max} rows: read no further (1,000 s of a 10 kHz recording is 10^7); split the file, or decimate it"
    )]
    TooManyRows {
        /// File.
        path: PathBuf,
        /// The bound.
        max: usize,
    },
    /// Two columns with one name.
    #[error("{path}:{line}: the column name `{name}` appears twice in the header")]
    DuplicateColumn {
        /// File.
        path: PathBuf,
        /// Header line.
        line: u64,
        /// The name.
        name: String,
    },
    /// A column the model needs is not in the header.
    #[error("{path}: no column `{name}`; the header has: {}", available.join(", "))]
    MissingColumn {
        /// File.
        path: PathBuf,
        /// The missing name.
        name: String,
        /// The header's names.
        available: Vec<String>,
    },
    /// A row with another number of fields than the header.
    #[error("{path}:{line}: {found} fields, but the header has {expected}")]
    Ragged {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Fields found.
        found: usize,
        /// Fields in the header.
        expected: usize,
    },
    /// A cell that is not a number.
    #[error("{path}:{line}:{column}: `{text}` in column `{name}` is not a number")]
    NotNumber {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// 1-based field number.
        column: usize,
        /// Column name.
        name: String,
        /// The cell.
        text: String,
    },
    /// NaN or infinity.
    #[error(
        "{path}:{line}:{column}: `{text}` in column `{name}` is not a finite number; remove the observation or fix the value"
    )]
    NotFinite {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// 1-based field number.
        column: usize,
        /// Column name.
        name: String,
        /// The cell.
        text: String,
    },
}

/// The columns a fit asked for, one value per observation.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The file they came from.
    pub path: PathBuf,
    /// The column names, as asked for.
    pub names: Vec<String>,
    /// The columns, in the order of `names`.
    pub columns: Vec<Vec<f64>>,
    /// The 1-based file line of each observation.
    pub lines: Vec<u64>,
}

impl Table {
    /// Appends the rows of `other`, whose columns are this table's (by name); its lines are
    /// its file's.
    ///
    /// # Panics
    /// When `other` lacks one of this table's columns.
    pub fn append(&mut self, other: &Table) {
        for (name, column) in self.names.iter().zip(self.columns.iter_mut()) {
            let theirs = other
                .column(name)
                .unwrap_or_else(|| panic!("appended table lacks the column {name}"));
            column.extend_from_slice(theirs);
        }
        self.lines.extend_from_slice(&other.lines);
    }

    /// Adds a derived column.
    pub fn push_column(&mut self, name: &str, values: Vec<f64>) {
        debug_assert_eq!(values.len(), self.len());
        self.names.push(name.into());
        self.columns.push(values);
    }

    /// Replaces the values of the column `name`, or adds it.
    pub fn set_column(&mut self, name: &str, values: Vec<f64>) {
        match self.names.iter().position(|n| n == name) {
            Some(i) => self.columns[i] = values,
            None => self.push_column(name, values),
        }
    }

    /// Number of observations.
    #[must_use]
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// True when there are no observations.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// The column named `name`.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// True when the table has the column `name` and it takes more than one value.
    #[must_use]
    pub fn varies(&self, name: &str) -> bool {
        self.column(name)
            .is_some_and(|v| v.iter().any(|x| *x != v[0]))
    }

    /// The observations at the given indices, in that order.
    #[must_use]
    pub fn select(&self, rows: &[usize]) -> Self {
        Self {
            path: self.path.clone(),
            names: self.names.clone(),
            columns: self
                .columns
                .iter()
                .map(|c| rows.iter().map(|&i| c[i]).collect())
                .collect(),
            lines: rows.iter().map(|&i| self.lines[i]).collect(),
        }
    }
}

/// A name reduced to its letters and digits, lower case, as names are compared (`Acc_X` and
/// `accx`, `m/s^2` and `ms2`).
pub(crate) fn squash(name: &str) -> String {
    name.chars()
        .filter(char::is_ascii_alphanumeric)
        .map(|c| c.to_ascii_lowercase())
        .collect()
}

/// A cell as an error message quotes it: at most 40 characters (a line of megabytes without a
/// separator is one cell).
pub(crate) fn shorten(text: &str) -> String {
    if text.chars().count() <= 40 {
        text.to_string()
    } else {
        let head: String = text.chars().take(40).collect();
        format!("{head}... ({} bytes)", text.len())
    }
}

/// Says, once per file, that the UTF-8 byte-order mark it starts with is ignored (editors on
/// some systems write one; it is invisible, and would otherwise stick to the first name).
pub(crate) fn note_bom(path: &Path) {
    use std::sync::Mutex;
    static NOTED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    if let Ok(mut noted) = NOTED.lock()
        && !noted.iter().any(|p| p == path)
    {
        eprintln!(
            "calflash: note: {} starts with a UTF-8 byte-order mark; it is ignored",
            path.display()
        );
        noted.push(path.to_path_buf());
    }
}

/// Skips a UTF-8 byte-order mark at the start of `reader`.
fn skip_bom(path: &Path, reader: &mut BufReader<File>) -> Result<(), ObsError> {
    if reader
        .fill_buf()
        .map_err(io(path))?
        .starts_with(b"\xef\xbb\xbf")
    {
        reader.consume(3);
        note_bom(path);
    }
    Ok(())
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ObsError + '_ {
    move |source| ObsError::Io {
        path: path.into(),
        source,
    }
}

/// The column names of the file's header row.
///
/// # Errors
/// As [`read_columns`].
pub fn header(path: &Path, format: Format) -> Result<Vec<String>, ObsError> {
    let file = File::open(path).map_err(io(path))?;
    let mut reader = BufReader::new(file);
    skip_bom(path, &mut reader)?;
    let format = match format {
        Format::Auto => sniff(path, &mut reader)?,
        f => f,
    };
    let mut line = 0u64;
    let mut buf = Vec::new();
    loop {
        buf.clear();
        if fields::read_head_line(&mut reader, &mut buf).map_err(io(path))? == 0 {
            return Err(ObsError::Empty { path: path.into() });
        }
        line += 1;
        if fields::too_long(&buf) {
            return Err(ObsError::LineTooLong {
                path: path.into(),
                line,
                max: fields::LONGEST_HEAD_LINE,
            });
        }
        let text = std::str::from_utf8(&buf)
            .ok()
            .filter(|_| !buf.contains(&0))
            .ok_or(ObsError::NotText {
                path: path.into(),
                line,
            })?
            .trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        return Ok(match format {
            Format::Csv => text
                .split(',')
                .map(|s| s.trim().trim_matches('"').to_string())
                .collect(),
            _ => text.split_whitespace().map(str::to_string).collect(),
        });
    }
}

/// The most rows an observation file or a recording is read with (the flight's logs have
/// their own bound, `--max-samples`).
pub const MAX_ROWS: usize = 10_000_000;

/// Reads the `wanted` columns of the file at `path`.
///
/// # Errors
/// An [`ObsError`] naming the file, line and column.
pub fn read_columns(path: &Path, wanted: &[String], format: Format) -> Result<Table, ObsError> {
    let file = File::open(path).map_err(io(path))?;
    let mut reader = BufReader::with_capacity(1 << 16, file);
    skip_bom(path, &mut reader)?;
    let format = match format {
        Format::Auto => sniff(path, &mut reader)?,
        f => f,
    };
    read_text(path, reader, wanted, format == Format::Csv)
}

/// The header (the first line that is neither blank nor a comment), then the rows, parsed a
/// block of lines at a time on every core.
fn read_text(
    path: &Path,
    mut reader: BufReader<File>,
    wanted: &[String],
    comma: bool,
) -> Result<Table, ObsError> {
    let mut buf = Vec::new();
    let mut line = 0u64;
    let header = loop {
        buf.clear();
        if fields::read_head_line(&mut reader, &mut buf).map_err(io(path))? == 0 {
            return Err(ObsError::Empty { path: path.into() });
        }
        line += 1;
        if fields::too_long(&buf) {
            return Err(ObsError::LineTooLong {
                path: path.into(),
                line,
                max: fields::LONGEST_HEAD_LINE,
            });
        }
        let text = std::str::from_utf8(&buf)
            .ok()
            .filter(|_| !buf.contains(&0))
            .ok_or(ObsError::NotText {
                path: path.into(),
                line,
            })?
            .trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        break header_names(text, comma);
    };
    let layout = Layout::new(path, wanted, &header, line, comma)?;
    let mut table = Table {
        path: path.into(),
        names: wanted.to_vec(),
        columns: vec![Vec::new(); wanted.len()],
        lines: Vec::new(),
    };
    fields::parse_blocks(
        &mut reader,
        line,
        |block, before| layout.parse(block, before),
        |part| {
            if table.lines.len() + part.lines.len() > MAX_ROWS {
                return Err(ObsError::TooManyRows {
                    path: path.into(),
                    max: MAX_ROWS,
                });
            }
            for (column, values) in table.columns.iter_mut().zip(part.columns) {
                column.extend(values);
            }
            table.lines.extend(part.lines);
            Ok(())
        },
        io(path),
    )?;
    if table.is_empty() {
        return Err(ObsError::NoRows { path: path.into() });
    }
    Ok(table)
}

/// The names of a header line: CSV fields (quoted as RFC 4180 allows) or whitespace-separated.
fn header_names(text: &str, comma: bool) -> Vec<String> {
    if !comma {
        return text.split_whitespace().map(str::to_string).collect();
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut record = csv::StringRecord::new();
    match reader.read_record(&mut record) {
        Ok(true) => record.iter().map(str::to_string).collect(),
        _ => text.split(',').map(|s| s.trim().to_string()).collect(),
    }
}

/// Reads lines until the first that is neither empty nor a comment, without consuming any.
fn sniff(path: &Path, reader: &mut BufReader<File>) -> Result<Format, ObsError> {
    let buf = reader.fill_buf().map_err(io(path))?;
    let text = String::from_utf8_lossy(&buf[..buf.len().min(64 * 1024)]);
    let header = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    Ok(if header.contains(',') {
        Format::Csv
    } else {
        Format::Whitespace
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, content: &[u8]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, content).unwrap();
        (dir, p)
    }

    fn want(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn csv_and_whitespace_read_the_same() {
        let (_d, csv) = write(
            "a.csv",
            b"# comment\nrate, volts ,temp\n1,2.5,20\n\n-3,4e-3,21\n",
        );
        let (_e, ws) = write(
            "a.txt",
            b"rate volts\ttemp\n1   2.5 20\n# skipped\n-3 4e-3 21\n",
        );
        for (p, lines) in [(csv, [3, 5]), (ws, [2, 4])] {
            let t = read_columns(&p, &want(&["volts", "rate"]), Format::Auto).unwrap();
            assert_eq!(t.columns, vec![vec![2.5, 4e-3], vec![1.0, -3.0]]);
            assert_eq!(t.lines, lines, "{}", p.display());
        }
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let cases: [(&[u8], &str); 9] = [
            (b"", "is empty"),
            (b"a,b\n", "no observations"),
            (b"a,b\n1,2\n3\n", ":3: 1 fields, but the header has 2"),
            (b"a,b\n1,x\n", ":2:2: `x` in column `b` is not a number"),
            (
                b"a,b\n1,NaN\n",
                ":2:2: `NaN` in column `b` is not a finite number",
            ),
            (b"a,b\n1,inf\n", "not a finite number"),
            (b"a,c\n1,2\n", "no column `b`; the header has: a, c"),
            (b"a,a,b\n1,2,3\n", "`a` appears twice"),
            (b"a,b\n1,\x00\x01\n", ":2: not text"),
        ];
        for (content, expected) in cases {
            let (_d, p) = write("x.csv", content);
            let e = read_columns(&p, &want(&["a", "b"]), Format::Auto).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains(expected), "{msg}");
            assert!(msg.starts_with(&p.display().to_string()), "{msg}");
        }
        let (_d, p) = write(
            "bin.dat",
            &[0x89, b'P', b'N', b'G', 0, 0xff, 0xfe, b'\n', 1, 2],
        );
        let e = read_columns(&p, &want(&["a"]), Format::Auto).unwrap_err();
        assert!(e.to_string().contains(":1: not text"), "{e}");
        let e =
            read_columns(Path::new("/nonexistent/x.csv"), &want(&["a"]), Format::Auto).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/x.csv: "), "{e}");
    }
}
