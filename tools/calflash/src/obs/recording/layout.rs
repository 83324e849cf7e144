//! The text layout of one recording file: CSV or whitespace fields; before the samples, an
//! optional preamble of `key,value` lines (a logger's settings: the sample rate and the initial
//! rest are used, the others named as ignored) and an optional header naming the columns. A
//! header whose names are recognised (`t`, `time_us`, `ax`, `acc_x`, `gyro_z`, `wx`, ...) picks the
//! columns by name, in any order, with other columns beside them; otherwise the columns are
//! positional: an optional timestamp, then the counts. Timestamps are seconds, or ms, us or ns
//! when the header's name says so.

use crate::obs::fields::{MAX_FIELDS, Spans, number, split_bytes};
use crate::obs::squash;
use std::path::Path;

use super::RecordingError;
pub use super::header::Holds;
use super::header::{Chosen, Columns, ColumnsError, named, positional, timestamp};
use crate::obs::units::{Sensor, Unit};

/// A setting a preamble line gave, with its line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The value, in Hz or s.
    pub value: f64,
    /// The file line.
    pub line: usize,
}

/// What the preamble said.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Preamble {
    /// The sample rate, Hz (`Fs`, `rate`, `sample rate`, `frequency`).
    pub rate: Option<Setting>,
    /// The initial rest, s (`Initialization time`, `initial rest`, `rest`; absent when not
    /// above 0).
    pub rest: Option<Setting>,
    /// The keys read but not used.
    pub ignored: Vec<String>,
}

impl Preamble {
    /// Takes the setting `key` (any case, spaces and punctuation ignored) read at `here`.
    fn note(&mut self, key: String, here: Setting) {
        match squash(&key).as_str() {
            "fs" | "rate" | "samplerate" | "samplingrate" | "frequency" | "hz" => {
                self.rate = Some(here);
            }
            "initializationtime" | "initialrest" | "rest" | "inittime" => {
                self.rest = (here.value > 0.0).then_some(here);
            }
            _ => self.ignored.push(key),
        }
    }
}

/// Which triads of a file of both sensors to keep (a file of one keeps its one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// Accelerometer and gyro.
    Both,
    /// The accelerometer's three counts.
    Accel,
    /// The gyro's.
    Gyro,
}

/// The samples of one file.
#[derive(Debug, Clone)]
pub struct Rows {
    /// Timestamps, s, increasing; `None` when the file has no timestamp column. With
    /// [`counter`](Self::counter), a sample counter's values as read.
    pub t: Option<Vec<f64>>,
    /// `t` holds a sample counter (`--columns index=NAME`), not seconds.
    pub counter: bool,
    /// The time column's unit is stated (its name's suffix, or given); otherwise `t` was read
    /// as seconds and its steps may say another unit.
    pub t_stated: bool,
    /// The kept triads: accelerometer then gyro, or the one kept (or the file's one).
    pub triads: Vec<Vec<[f64; 3]>>,
    /// The file line of each sample.
    pub line: Vec<u32>,
    /// The 1-based field of each kept count.
    pub fields: Vec<usize>,
    /// The unit the header names for each kept count (`None`: not stated).
    pub units: Vec<Option<Unit>>,
    /// The header's line, when it named the columns.
    pub header: Option<usize>,
    /// The sensor a file of one sensor's header names.
    pub sensor: Option<Sensor>,
    /// The temperature column's values and its name, when the file has one.
    pub temp: Option<(String, Vec<f64>)>,
    /// The preamble.
    pub preamble: Preamble,
}

impl Rows {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.line.len()
    }

    /// True when there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.line.is_empty()
    }
}

/// The meaning of each field, as the error messages name it.
const NAMES: [&str; 6] = [
    "x count",
    "y count",
    "z count",
    "gyro x count",
    "gyro y count",
    "gyro z count",
];

/// A preamble line: two fields, a name and a number.
fn setting(fields: &[&str]) -> Option<(String, f64)> {
    let [key, value] = fields else { return None };
    if key.parse::<f64>().is_ok() || !key.chars().any(char::is_alphabetic) {
        return None;
    }
    Some(((*key).to_string(), value.parse().ok()?))
}

fn split(s: &str) -> Vec<&str> {
    match crate::obs::fields::separator_of(s.as_bytes()) {
        Some(sep) => s.split(char::from(sep)).map(str::trim).collect(),
        None => s.split_ascii_whitespace().collect(),
    }
}

/// The error of a field that is not a number (or not text).
#[cold]
fn not_a_number(
    path: &Path,
    line: usize,
    k: usize,
    what: &'static str,
    field: &[u8],
) -> RecordingError {
    match std::str::from_utf8(field) {
        Ok(text) => RecordingError::Number {
            path: path.to_path_buf(),
            line,
            field: k + 1,
            what,
            text: crate::obs::shorten(text),
        },
        Err(_) => RecordingError::NotText {
            path: path.to_path_buf(),
            line,
        },
    }
}

/// The samples of one block of lines (and the first error in it, after them).
struct Part {
    times: Vec<f64>,
    triads: Vec<Vec<[f64; 3]>>,
    temps: Vec<f64>,
    lines: Vec<u32>,
    error: Option<RecordingError>,
}

/// Reads sample lines once the columns and the separator are known.
struct Sampler<'a> {
    path: &'a Path,
    cols: &'a Columns,
    /// Which of the file's counts are kept.
    kept: &'a [usize],
    holds: Holds,
    /// The separator (`None`: whitespace).
    separator: Option<u8>,
}

impl Sampler<'_> {
    /// Field `k` (at `span` of the line `bytes`) as a number.
    #[inline(always)]
    fn value(
        &self,
        line: usize,
        bytes: &[u8],
        span: (usize, usize),
        k: usize,
        what: &'static str,
    ) -> Result<f64, RecordingError> {
        let field = &bytes[span.0..span.1];
        match number(field) {
            Some(x) => Ok(x),
            None => match (self.separator, crate::obs::fields::decimal_comma(field)) {
                (Some(b';'), Some(x)) => Ok(x),
                _ => Err(not_a_number(self.path, line, k, what, field)),
            },
        }
    }

    fn part(&self, lines: usize) -> Part {
        Part {
            times: Vec::with_capacity(if self.cols.t.is_some() { lines } else { 0 }),
            triads: vec![Vec::with_capacity(lines); self.kept.len() / 3],
            temps: Vec::new(),
            lines: Vec::with_capacity(lines),
            error: None,
        }
    }

    /// The samples of a block of whole lines (`before` lines precede it), up to its first
    /// error.
    fn block(&self, block: &[u8], before: u64) -> Part {
        let mut part = self.part(block.len() / 24);
        let mut spans: Spans = [(0, 0); MAX_FIELDS];
        for (line, bytes) in crate::obs::fields::lines(block, before) {
            let bytes = bytes.trim_ascii();
            if bytes.is_empty() || bytes[0] == b'#' {
                continue;
            }
            let line = usize::try_from(line).unwrap_or(usize::MAX);
            if let Err(e) = self.take(line, bytes, &mut spans, &mut part) {
                part.error = Some(e);
                break;
            }
        }
        part
    }

    /// One sample line (trimmed, not blank, not a comment) into `part`.
    fn take(
        &self,
        line: usize,
        bytes: &[u8],
        spans: &mut Spans,
        part: &mut Part,
    ) -> Result<(), RecordingError> {
        let count = split_bytes(bytes, self.separator, spans);
        let cols = self.cols;
        if count != cols.width {
            let why = match cols.header {
                Some(hl) => format!("{}, as the header on line {hl} names", cols.width),
                None => format!("{}, as on the first sample line", cols.width),
            };
            return Err(RecordingError::Fields {
                path: self.path.to_path_buf(),
                line,
                found: count,
                expected: why,
            });
        }
        let value = |k: usize, what: &'static str| self.value(line, bytes, spans[k], k, what);
        // Everything is read before anything is kept, so that the part's columns stay aligned.
        let t = match cols.t {
            Some((k, scale)) => {
                let x = value(k, "timestamp")? * scale;
                // A sample counter may wrap: it is unwrapped once read whole.
                if let Some(&prev) = part.times.last()
                    && x <= prev
                    && !self.cols.counter
                {
                    return Err(RecordingError::NotIncreasing {
                        path: self.path.to_path_buf(),
                        line,
                        t: x,
                        prev,
                    });
                }
                Some(x)
            }
            None => None,
        };
        let mut counts = [[0.0; 3]; 2];
        for (n, v) in counts.iter_mut().take(part.triads.len()).enumerate() {
            for (a, x) in v.iter_mut().enumerate() {
                let j = self.kept[3 * n + a];
                let what = if self.holds == Holds::Both {
                    NAMES[j]
                } else {
                    NAMES[j % 3]
                };
                *x = value(cols.counts[j], what)?;
            }
        }
        let temp = cols.temp.map(|k| value(k, "temperature")).transpose()?;
        part.times.extend(t);
        for (triad, v) in part.triads.iter_mut().zip(counts) {
            triad.push(v);
        }
        part.temps.extend(temp);
        part.lines.push(u32::try_from(line).unwrap_or(u32::MAX));
        Ok(())
    }
}

fn expected(holds: Holds) -> String {
    match holds {
        Holds::Both => "7 (timestamp, accelerometer x, y, z, gyro x, y, z counts) or 6 without \
                        the timestamp (then give --sample-rate), or give the gyro file too"
            .into(),
        Holds::One => "4 (timestamp, x, y, z counts), or 3 without the timestamp (then give \
                       --sample-rate)"
            .into(),
    }
}

/// Reads one recording file holding `holds`, keeping the triads `keep` names. The file is
/// streamed: memory holds the kept values and little more.
///
/// # Errors
/// A [`RecordingError`] naming the file, line and field.
pub fn read(path: &Path, holds: Holds, keep: Keep) -> Result<Rows, RecordingError> {
    read_chosen(path, holds, keep, &Chosen::default())
}

/// [`read`], with the columns `chosen` names.
///
/// # Errors
/// As [`read`]; a chosen name that is not in the header lists the ones that are.
pub fn read_chosen(
    path: &Path,
    holds: Holds,
    keep: Keep,
    chosen: &Chosen,
) -> Result<Rows, RecordingError> {
    let io = |source| RecordingError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    // Which of the file's counts are kept.
    let kept: Vec<usize> = match (holds, keep) {
        (Holds::Both, Keep::Accel) => (0..3).collect(),
        (Holds::Both, Keep::Gyro) => (3..6).collect(),
        _ => (0..holds.counts()).collect(),
    };
    let mut rows = Rows {
        t: None,
        counter: false,
        t_stated: false,
        triads: vec![Vec::new(); kept.len() / 3],
        line: Vec::new(),
        fields: Vec::new(),
        units: Vec::new(),
        header: None,
        sensor: None,
        temp: None,
        preamble: Preamble::default(),
    };
    let mut times = Vec::new();
    let mut temps = Vec::new();
    let mut spans: Spans = [(0, 0); MAX_FIELDS];
    let Head {
        columns,
        header,
        first,
    } = read_head(
        &mut reader,
        path,
        holds,
        chosen,
        &mut rows.preamble,
        &mut spans,
    )?;
    if let (Some((first, separator, bytes)), Some(cols)) = (first, &columns) {
        let sampler = Sampler {
            path,
            cols,
            kept: &kept,
            holds,
            separator,
        };
        let mut merge = |part: Part| {
            if let (Some(&t), Some(&prev)) = (part.times.first(), times.last())
                && t <= prev
                && !cols.counter
            {
                return Err(RecordingError::NotIncreasing {
                    path: path.to_path_buf(),
                    line: part.lines.first().map_or(0, |l| *l as usize),
                    t,
                    prev,
                });
            }
            if rows.line.len() + part.lines.len() > crate::obs::MAX_ROWS {
                return Err(RecordingError::TooManyRows {
                    path: path.to_path_buf(),
                    max: crate::obs::MAX_ROWS,
                });
            }
            times.extend(part.times);
            for (triad, values) in rows.triads.iter_mut().zip(part.triads) {
                triad.extend(values);
            }
            temps.extend(part.temps);
            rows.line.extend(part.lines);
            part.error.map_or(Ok(()), Err)
        };
        // The first sample line, then the rest a block of lines at a time on every core.
        let mut head = sampler.part(0);
        if let Err(e) = sampler.take(first, &bytes, &mut spans, &mut head) {
            head.error = Some(e);
        }
        merge(head)?;
        crate::obs::fields::parse_blocks(
            &mut reader,
            first as u64,
            |block, before| Ok(sampler.block(block, before)),
            &mut merge,
            io,
        )?;
    }
    if rows.line.is_empty() {
        return Err(RecordingError::Empty {
            path: path.to_path_buf(),
        });
    }
    if let (Some((hl, h)), Some(c)) = (&header, &columns)
        && c.header.is_some()
        && c.t.is_none()
        && timestamp_like(h)
    {
        // A header naming a time column whose unit cannot be read.
        return Err(RecordingError::Fields {
            path: path.to_path_buf(),
            line: *hl,
            found: split(h).len(),
            expected: "a time column named t, time or timestamp, with _s, _ms, _us or _ns".into(),
        });
    }
    if let Some(c) = &columns {
        rows.fields = kept.iter().map(|&j| c.counts[j] + 1).collect();
        rows.units = kept.iter().map(|&j| c.units[j]).collect();
        rows.header = c.header;
        rows.sensor = c.sensor;
        rows.counter = c.counter;
        rows.t_stated = c.t_stated;
        if let Some(k) = c.temp {
            let name = header
                .as_ref()
                .and_then(|(_, h)| split(h).get(k).map(|s| (*s).to_string()))
                .unwrap_or_default();
            rows.temp = Some((name, temps));
        }
        if c.t.is_some() {
            rows.t = Some(times);
        }
    }
    Ok(rows)
}

/// What the lines before the first sample say: the columns (by the header's names, or by
/// position from the first sample line), the header line, and the first sample line with its
/// separator (`None` when the file has no sample).
struct Head {
    columns: Option<Columns>,
    header: Option<(usize, String)>,
    first: Option<(usize, Option<u8>, Vec<u8>)>,
}

/// Reads the preamble (its settings into `preamble`) and the header, up to and including the
/// first sample line.
fn read_head(
    reader: &mut impl std::io::BufRead,
    path: &Path,
    holds: Holds,
    chosen: &Chosen,
    preamble: &mut Preamble,
    spans: &mut Spans,
) -> Result<Head, RecordingError> {
    let io = |source| RecordingError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bad = |line: usize, found: usize, expected: String| RecordingError::Fields {
        path: path.to_path_buf(),
        line,
        found,
        expected,
    };
    let not_text = |line| RecordingError::NotText {
        path: path.to_path_buf(),
        line,
    };
    let mut columns: Option<Columns> = None;
    let mut header: Option<(usize, String)> = None;
    let mut buf = Vec::with_capacity(256);
    let mut line = 0usize;
    // The separator, fixed by the first sample line (`None` until then).
    let mut separator: Option<Option<u8>> = None;
    // The head: preamble and header lines, up to the first sample line.
    let first = loop {
        buf.clear();
        if crate::obs::fields::read_head_line(reader, &mut buf).map_err(io)? == 0 {
            break None;
        }
        line += 1;
        if crate::obs::fields::too_long(&buf) {
            return Err(RecordingError::LineTooLong {
                path: path.to_path_buf(),
                line,
                max: crate::obs::fields::LONGEST_HEAD_LINE,
            });
        }
        let mut bytes = &buf[..];
        if line == 1
            && let Some(rest) = bytes.strip_prefix(b"\xEF\xBB\xBF")
        {
            crate::obs::note_bom(path);
            bytes = rest;
        }
        let bytes = bytes.trim_ascii();
        if bytes.is_empty() || bytes[0] == b'#' {
            continue;
        }
        // Before the first sample: a preamble line, or the header (read as text).
        if columns.is_none() && header.is_none() {
            let s = std::str::from_utf8(bytes).map_err(|_| not_text(line))?;
            let fields = split(s);
            if fields.first().is_some_and(|f| f.parse::<f64>().is_err())
                && fields.iter().any(|f| f.chars().any(char::is_alphabetic))
            {
                if let Some((key, value)) = setting(&fields) {
                    preamble.note(key, Setting { value, line });
                    continue;
                }
                // The header: the columns by name when it names them.
                columns = named(&fields, line, holds, chosen).map_err(|what| {
                    RecordingError::Columns {
                        path: path.to_path_buf(),
                        line,
                        what,
                    }
                })?;
                header = Some((line, s.to_string()));
                continue;
            }
        }
        // The first sample line fixes the separator and, without a header, the columns.
        let sep = *separator.get_or_insert_with(|| crate::obs::fields::separator_of(bytes));
        let count = split_bytes(bytes, sep, spans);
        if columns.is_none() && !chosen.is_empty() {
            return Err(RecordingError::Columns {
                path: path.to_path_buf(),
                line,
                what: match &header {
                    Some((hl, _)) => ColumnsError::CountsNotNamed { header_line: *hl },
                    None => ColumnsError::NoHeader,
                },
            });
        }
        if columns.is_none() {
            columns =
                Some(positional(count, holds).ok_or_else(|| bad(line, count, expected(holds)))?);
        }
        break Some((line, sep, bytes.to_vec()));
    };
    Ok(Head {
        columns,
        header,
        first,
    })
}

/// True when a header names something time-like that [`timestamp`] does not read.
fn timestamp_like(header: &str) -> bool {
    split(header)
        .iter()
        .any(|h| squash(h).starts_with("time") && timestamp(h).is_none())
}

#[cfg(test)]
mod tests;
