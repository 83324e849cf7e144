//! Reading an input with a bound on its size (and its lines'), so that a wrong file is refused
//! before it fills the memory.

use std::path::Path;

use super::Error;

/// The whole of input `path`, which is `what` and holds at most `max` bytes: at most `max + 1`
/// bytes are read, so `/dev/zero` or a wrong file of gigabytes is refused, not read.
///
/// # Errors
/// [`Error::Read`], or [`Error::TooLong`].
pub fn read_bounded(path: &Path, max: u64, what: &'static str) -> Result<Vec<u8>, Error> {
    use std::io::Read as _;
    let read = |source| Error::Read {
        path: path.to_path_buf(),
        source,
    };
    let f = std::fs::File::open(path).map_err(read)?;
    // A regular file says its length: refused before a byte is read.
    let stated = f
        .metadata()
        .ok()
        .filter(std::fs::Metadata::is_file)
        .map_or(0, |m| m.len());
    let mut bytes = Vec::new();
    if stated <= max {
        f.take(max + 1).read_to_end(&mut bytes).map_err(read)?;
    }
    if stated > max || bytes.len() as u64 > max {
        return Err(Error::TooLong {
            path: path.to_path_buf(),
            max,
            what,
        });
    }
    Ok(bytes)
}

/// The most a JSON input of calflash's own (a record, a truth, an Allan file) holds.
pub const MAX_JSON: u64 = 64 << 20;

/// A JSON input as text, at most [`MAX_JSON`] bytes.
///
/// # Errors
/// As [`read_bounded`], or text that is not UTF-8 (as an I/O error of kind `InvalidData`).
pub fn read_json_text(path: &Path, what: &'static str) -> Result<String, Error> {
    let bytes = read_bounded(path, MAX_JSON, what)?;
    String::from_utf8(bytes).map_err(|e| Error::Read {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })
}

/// A reader for text tables: it refuses a line longer than `max` bytes (the read fails naming
/// the line, so a reader that gathers a line before looking at it, the `csv` crate, never holds
/// more), and gives a `\r\n` line ending as `\n` (the `csv` crate counts a CRLF file's lines
/// short when a blank line is among them; a lone `\r` is kept).
#[derive(Debug)]
pub struct LineBound<R> {
    inner: std::io::BufReader<R>,
    max: usize,
    run: usize,
    line: u64,
    /// A `\r` read and not yet given: it is dropped if a `\n` follows.
    cr: bool,
}

impl<R: std::io::Read> LineBound<R> {
    /// `inner`, with lines of at most `max` bytes.
    pub fn new(inner: R, max: usize) -> Self {
        Self {
            inner: std::io::BufReader::new(inner),
            max,
            run: 0,
            line: 1,
            cr: false,
        }
    }
}

impl<R: std::io::Read> std::io::Read for LineBound<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use std::io::BufRead;
        let mut out = 0;
        while out == 0 && !buf.is_empty() {
            let avail = self.inner.fill_buf()?;
            if avail.is_empty() {
                if std::mem::take(&mut self.cr) {
                    buf[0] = b'\r';
                    out = 1;
                }
                break;
            }
            let mut used = 0;
            while used < avail.len() && out < buf.len() {
                let b = avail[used];
                if std::mem::take(&mut self.cr) && b != b'\n' {
                    // A lone '\r': given, and `b` looked at again.
                    buf[out] = b'\r';
                    out += 1;
                    continue;
                }
                used += 1;
                if b == b'\r' {
                    self.cr = true;
                } else {
                    buf[out] = b;
                    out += 1;
                }
            }
            self.inner.consume(used);
        }
        for &b in &buf[..out] {
            if b == b'\n' {
                self.run = 0;
                self.line += 1;
            } else {
                self.run += 1;
                if self.run > self.max {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!(
                            "line {} is longer than {} bytes (a binary file?)",
                            self.line, self.max
                        ),
                    ));
                }
            }
        }
        Ok(out)
    }
}

/// A calibration blob file, signed or not: at most [`spincal::signed::MAX_SIGNED_LEN`] bytes.
///
/// # Errors
/// As [`read_bounded`].
pub fn read_blob(path: &Path) -> Result<Vec<u8>, Error> {
    read_bounded(
        path,
        spincal::signed::MAX_SIGNED_LEN as u64,
        "a calibration blob (signed or not)",
    )
}

/// True when `path` exists and is neither a regular file nor a directory (following links):
/// a device, a FIFO, a socket.
#[must_use]
pub fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}
