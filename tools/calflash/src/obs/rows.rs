//! Where the wanted fields of each row of an observation file are, and one block of rows read
//! into them: each field parsed as `f64`, each error naming the file, the line and the column.

use std::path::Path;

use super::{ObsError, fields, shorten};

/// Where the wanted fields of each row are, and how a row is split.
pub(super) struct Layout<'a> {
    path: &'a Path,
    wanted: &'a [String],
    /// For each wanted column, its field index in the file.
    index: Vec<usize>,
    header_len: usize,
    comma: bool,
}

/// The wanted columns of one block of rows, and each row's line.
pub(super) struct Part {
    pub(super) columns: Vec<Vec<f64>>,
    pub(super) lines: Vec<u64>,
}

impl<'a> Layout<'a> {
    pub(super) fn new(
        path: &'a Path,
        wanted: &'a [String],
        header: &[String],
        line: u64,
        comma: bool,
    ) -> Result<Self, ObsError> {
        for (i, name) in header.iter().enumerate() {
            if header[..i].contains(name) {
                return Err(ObsError::DuplicateColumn {
                    path: path.into(),
                    line,
                    name: name.clone(),
                });
            }
        }
        let index = wanted
            .iter()
            .map(|w| {
                header
                    .iter()
                    .position(|h| h == w)
                    .ok_or_else(|| ObsError::MissingColumn {
                        path: path.into(),
                        name: w.clone(),
                        available: header.to_vec(),
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            path,
            wanted,
            index,
            header_len: header.len(),
            comma,
        })
    }

    /// The rows of a block of whole lines (`before` lines precede it).
    pub(super) fn parse(&self, block: &[u8], before: u64) -> Result<Part, ObsError> {
        let mut part = Part {
            columns: vec![Vec::new(); self.wanted.len()],
            lines: Vec::new(),
        };
        // Rows up to the line where the text ends are read first: an error before it is the
        // first in the file.
        let bad = fields::not_text_at(block);
        let text = &block[..bad.map_or(block.len(), |at| {
            block[..at]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |p| p + 1)
        })];
        let mut spans = vec![(0, 0); self.header_len + 1];
        let quotes = self.comma && memchr::memchr(b'"', text).is_some();
        let rows = text.len() / 16;
        for column in &mut part.columns {
            column.reserve(rows);
        }
        for (line, bytes) in fields::lines(text, before) {
            let row = bytes.trim_ascii();
            if row.is_empty() || row[0] == b'#' {
                continue;
            }
            if quotes && row.contains(&b'"') {
                self.quoted_row(line, row, &mut part)?;
                continue;
            }
            let count = fields::split_bytes(row, self.comma.then_some(b','), &mut spans);
            self.check_width(line, count)?;
            for (k, &i) in self.index.iter().enumerate() {
                let (a, b) = spans[i];
                let field = &row[a..b];
                match fields::number(field) {
                    Some(x) => part.columns[k].push(x),
                    None => return Err(self.bad_cell(line, k, i, field)),
                }
            }
            part.lines.push(line);
        }
        match bad {
            Some(at) => Err(ObsError::NotText {
                path: self.path.into(),
                line: fields::line_of(block, before, at),
            }),
            None => Ok(part),
        }
    }

    fn check_width(&self, line: u64, found: usize) -> Result<(), ObsError> {
        if found == self.header_len {
            Ok(())
        } else {
            Err(ObsError::Ragged {
                path: self.path.into(),
                line,
                found,
                expected: self.header_len,
            })
        }
    }

    /// A CSV row with quotes, read as RFC 4180 says (by the csv crate).
    #[cold]
    fn quoted_row(&self, line: u64, row: &[u8], part: &mut Part) -> Result<(), ObsError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(row);
        let mut record = csv::ByteRecord::new();
        let read = reader.read_byte_record(&mut record).unwrap_or(false);
        let not_text = || ObsError::NotText {
            path: self.path.into(),
            line,
        };
        if !read {
            return Err(not_text());
        }
        self.check_width(line, record.len())?;
        for (k, &i) in self.index.iter().enumerate() {
            let field = record.get(i).unwrap_or_default();
            match fields::number(field) {
                Some(x) => part.columns[k].push(x),
                None => return Err(self.bad_cell(line, k, i, field)),
            }
        }
        part.lines.push(line);
        Ok(())
    }

    /// The error of wanted column `k` (field `i`) that is not a finite number.
    #[cold]
    fn bad_cell(&self, line: u64, k: usize, i: usize, field: &[u8]) -> ObsError {
        let text = shorten(&String::from_utf8_lossy(field));
        let (path, column, name) = (self.path.into(), i + 1, self.wanted[k].clone());
        match fast_float2::parse::<f64, _>(field) {
            Ok(x) if !x.is_finite() => ObsError::NotFinite {
                path,
                line,
                column,
                name,
                text,
            },
            _ => ObsError::NotNumber {
                path,
                line,
                column,
                name,
                text,
            },
        }
    }
}
