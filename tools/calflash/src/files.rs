//! The files a command reads and writes, under one rule: an output is never an input of the
//! same command, nor another of its outputs (the same file is found by canonical path and, when
//! it exists, by device and inode, so `./a`, `dir/../a` and a hard link are all caught); the
//! outputs are staged beside their destinations and renamed into place together once every one
//! is written, so a failed command leaves none; and a staging file that a killed run left behind
//! (`.calflash-<pid>-*.tmp`, its process gone) is removed the first time a command writes into
//! that directory (once per directory and process, so a batch of thousands of units reads its
//! folder once, not once per file).
//!
//! An output that exists and is not a regular file (a device such as `/dev/null`, `/dev/stdout`,
//! a FIFO, a socket) is never renamed over: a rename would replace the device with a file (run
//! as root, `--json /dev/null` would break every other program on the machine). Its bytes are
//! held until the commit and written into it in place. An output that is a symbolic link to a
//! file is staged beside the link's target and replaces the target, so the link stays.
//!
//! A file a unit's serial names ([`unit_file`]) is made only of a serial that is a safe file
//! name: no separator, no `..`, nothing hidden, so a serial cannot write outside its folder.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a command's files cannot be used as given, or an output cannot be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An output's directory does not exist (and the command does not create it).
    #[error("{what} {}: the directory {} does not exist; create it first", .path.display(), .dir.display())]
    NoDirectory {
        /// The option that gave it.
        what: String,
        /// The output.
        path: PathBuf,
        /// Its directory.
        dir: PathBuf,
    },
    /// An output that is a directory.
    #[error("{what} {}: that is a directory; give a file name", .path.display())]
    IsDirectory {
        /// The option that gave it.
        what: String,
        /// The output.
        path: PathBuf,
    },
    /// An output that is one of the command's inputs.
    #[error("{what} {}: that is the file {input} reads; the command would replace its own input", .path.display())]
    ReplacesInput {
        /// The option that gave the output.
        what: String,
        /// The output.
        path: PathBuf,
        /// The option that gave the input.
        input: String,
    },
    /// Two inputs that must be two files (the two records compared, the two sensors' recordings)
    /// and are one.
    #[error("{what} {} and {other} name one file: each must be its own", .path.display())]
    SameInput {
        /// The option that gave the input.
        what: String,
        /// The input.
        path: PathBuf,
        /// The option that gave the other.
        other: String,
    },
    /// Two outputs that are one file.
    #[error("{what} {} and {other} name one file: give each output its own path", .path.display())]
    SameOutput {
        /// The option that gave the output.
        what: String,
        /// The output.
        path: PathBuf,
        /// The option that gave the other.
        other: String,
    },
    /// A unit's serial that cannot name a file.
    #[error(
        "unit `{serial}`: a serial that names a file must be a plain file name: letters, digits, \
         `-`, `_`, `+` and `.`, not starting with `.` (it would write {})",
        .path.display()
    )]
    UnsafeSerial {
        /// The serial.
        serial: String,
        /// The file it would have named.
        path: PathBuf,
    },
    /// An input longer than any file of its kind can be.
    #[error("{}: longer than {max} bytes: not {what}", .path.display())]
    TooLong {
        /// The input.
        path: PathBuf,
        /// The most its kind holds.
        max: u64,
        /// What it should be.
        what: &'static str,
    },
    /// Reading an input failed.
    #[error("{}: {source}", .path.display())]
    Read {
        /// The input.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing or renaming an output failed.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The output.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

/// The files of one command, named by the option that gave them.
#[derive(Debug, Clone, Default)]
pub struct Paths {
    inputs: Vec<(String, PathBuf)>,
    /// The indices of the inputs that must each be a file of its own.
    distinct: Vec<usize>,
    outputs: Vec<(String, PathBuf)>,
    /// The outputs whose directories the command creates (the unit history).
    creates_dir: Vec<bool>,
}

thread_local! {
    /// How many paths this thread has resolved against the file system (see [`resolutions`]).
    static RESOLUTIONS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// How many times this thread has resolved a path (a `canonicalize`, a walk of every component
/// of it) for the overlap check: a count, so a test can hold the check's cost per file constant
/// however many files a batch has, which a timing could not.
#[must_use]
pub fn resolutions() -> u64 {
    RESOLUTIONS.with(std::cell::Cell::get)
}

fn canonicalize(path: &Path) -> std::io::Result<PathBuf> {
    RESOLUTIONS.with(|n| n.set(n.get() + 1));
    path.canonicalize()
}

/// Where a path would be: its canonical form, or its canonical directory and its name when
/// the file does not exist yet. `dirs` holds the directories already resolved, so the files of
/// one folder resolve it once.
fn resolved(path: &Path, dirs: &mut HashMap<PathBuf, Option<PathBuf>>) -> PathBuf {
    if let Ok(p) = canonicalize(path) {
        return p;
    }
    let dir = dir_of(path);
    let canonical_dir = dirs
        .entry(dir.to_path_buf())
        .or_insert_with(|| canonicalize(dir).ok());
    match (canonical_dir, path.file_name()) {
        (Some(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// One file as the overlap check knows it: its device and inode when it exists, and where it
/// is (or would be).
struct Identity {
    inode: Option<(u64, u64)>,
    place: PathBuf,
}

impl Identity {
    fn of(path: &Path, dirs: &mut HashMap<PathBuf, Option<PathBuf>>) -> Self {
        #[cfg(unix)]
        let inode = {
            use std::os::unix::fs::MetadataExt as _;
            std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
        };
        #[cfg(not(unix))]
        let inode = None;
        Self {
            inode,
            place: resolved(path, dirs),
        }
    }
}

/// The files seen so far, each under its inode and its place, with the option that gave it:
/// looked up, not scanned, so a batch of n files costs n look-ups.
struct Seen {
    by_inode: HashMap<(u64, u64), usize>,
    by_place: HashMap<PathBuf, usize>,
}

impl Seen {
    fn with_capacity(n: usize) -> Self {
        Self {
            by_inode: HashMap::with_capacity(n),
            by_place: HashMap::with_capacity(n),
        }
    }

    /// The first file recorded that is `id`'s file.
    fn find(&self, id: &Identity) -> Option<usize> {
        id.inode
            .and_then(|i| self.by_inode.get(&i))
            .or_else(|| self.by_place.get(&id.place))
            .copied()
    }

    /// Records `id` as file `k` (a file seen before keeps its first name).
    fn add(&mut self, id: Identity, k: usize) {
        if let Some(i) = id.inode {
            self.by_inode.entry(i).or_insert(k);
        }
        self.by_place.entry(id.place).or_insert(k);
    }
}

/// True when `a` and `b` are the same file (or would be).
#[must_use]
pub fn same_file(a: &Path, b: &Path) -> bool {
    let mut dirs = HashMap::new();
    let (a, b) = (Identity::of(a, &mut dirs), Identity::of(b, &mut dirs));
    match (a.inode, b.inode) {
        (Some(x), Some(y)) => x == y,
        _ => a.place == b.place,
    }
}

impl Paths {
    /// No files yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// A file the command reads, given by `what` (an option or `the data`).
    #[must_use]
    pub fn input(mut self, what: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.inputs.push((what.into(), p.to_path_buf()));
        }
        self
    }

    /// A file the command reads that must not be another such input: it holds something
    /// the others do not (the later of two records, the gyro's recording beside the
    /// accelerometer's), and one file given twice would be read as both.
    #[must_use]
    pub fn distinct_input(mut self, what: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.distinct.push(self.inputs.len());
            self.inputs.push((what.into(), p.to_path_buf()));
        }
        self
    }

    /// A file the command writes, given by `what`.
    #[must_use]
    pub fn output(mut self, what: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.outputs.push((what.into(), p.to_path_buf()));
            self.creates_dir.push(false);
        }
        self
    }

    /// A file the command writes, creating its directory when needed (the unit history).
    #[must_use]
    pub fn created(mut self, what: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.outputs.push((what.into(), p.to_path_buf()));
            self.creates_dir.push(true);
        }
        self
    }

    /// Checks that no output is an input or another output, and that each output's directory
    /// exists (unless the command creates it) and the output is not a directory.
    ///
    /// # Errors
    /// The two options that name one file.
    pub fn check(&self) -> Result<(), Error> {
        let mut dirs = HashMap::new();
        let mut inputs = Seen::with_capacity(self.inputs.len());
        let mut distinct = Seen::with_capacity(self.distinct.len());
        for (k, (what, p)) in self.inputs.iter().enumerate() {
            let id = Identity::of(p, &mut dirs);
            if self.distinct.contains(&k) {
                if let Some(j) = distinct.find(&id) {
                    return Err(Error::SameInput {
                        what: what.clone(),
                        path: p.clone(),
                        other: self.inputs[j].0.clone(),
                    });
                }
                distinct.add(Identity::of(p, &mut dirs), k);
            }
            inputs.add(id, k);
        }
        let mut outputs = Seen::with_capacity(self.outputs.len());
        for (i, (what, out)) in self.outputs.iter().enumerate() {
            let (what, path) = (what.clone(), out.clone());
            let dir = dir_of(out);
            if !self.creates_dir[i] && !dir.is_dir() {
                let dir = dir.to_path_buf();
                return Err(Error::NoDirectory { what, path, dir });
            }
            if out.is_dir() {
                return Err(Error::IsDirectory { what, path });
            }
            if is_special(out) {
                // Written in place, never replaced: /dev/null twice is no conflict.
                continue;
            }
            let id = Identity::of(out, &mut dirs);
            if let Some(k) = inputs.find(&id) {
                let input = self.inputs[k].0.clone();
                return Err(Error::ReplacesInput { what, path, input });
            }
            if let Some(k) = outputs.find(&id) {
                let other = self.outputs[k].0.clone();
                return Err(Error::SameOutput { what, path, other });
            }
            outputs.add(id, i);
        }
        Ok(())
    }
}

/// The directory a file goes into.
fn dir_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

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

/// The file `SERIAL.ext` in `dir` for unit `serial`, refused when the serial is not a plain
/// file name (a separator, `..`, a leading `.`, a character outside letters, digits and
/// `-_+.`): a serial never writes outside its folder nor hides its file.
///
/// # Errors
/// [`Error::UnsafeSerial`].
pub fn unit_file(dir: &Path, serial: &str, ext: &str) -> Result<PathBuf, Error> {
    let path = dir.join(format!("{serial}.{ext}"));
    let plain = !serial.is_empty()
        && !serial.starts_with('.')
        && serial
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '+' | '.'));
    if plain {
        Ok(path)
    } else {
        Err(Error::UnsafeSerial {
            serial: serial.to_string(),
            path,
        })
    }
}

/// Removes the staging files of runs that were killed: `.calflash-<pid>-*.tmp` whose process
/// no longer exists (Linux: `/proc/<pid>`; elsewhere nothing is removed). Each directory is
/// read once per process.
fn clean_stale(dir: &Path) {
    static CLEANED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
    if !Path::new("/proc/self").exists() {
        return;
    }
    let key = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    {
        let mut cleaned = CLEANED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if cleaned.contains(&key) {
            return;
        }
        cleaned.push(key);
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(rest) = name
            .strip_prefix(".calflash-")
            .and_then(|r| r.strip_suffix(".tmp"))
        else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Outputs staged beside their destinations, renamed into place by [`Staged::commit`];
/// dropped uncommitted, they are removed.
#[derive(Debug, Default)]
pub struct Staged {
    files: Vec<(tempfile::TempPath, PathBuf)>,
    /// Outputs that are special files: their bytes, written in place at the commit.
    special: Vec<(Vec<u8>, PathBuf)>,
}

impl Staged {
    /// Nothing staged.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `contents` to a staging file for `path`.
    ///
    /// # Errors
    /// The I/O error, naming `path`.
    pub fn write(
        &mut self,
        path: &Path,
        contents: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), Error> {
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        if is_special(path) {
            let mut bytes = Vec::new();
            contents(&mut bytes).map_err(io)?;
            self.special.push((bytes, path.to_path_buf()));
            return Ok(());
        }
        // A link to a file: replace the file it points to, keep the link.
        let target = match std::fs::symlink_metadata(path) {
            Ok(m) if m.file_type().is_symlink() => path.canonicalize().map_err(io)?,
            _ => path.to_path_buf(),
        };
        let dir = dir_of(&target);
        clean_stale(dir);
        let mut builder = tempfile::Builder::new();
        let prefix = format!(".calflash-{}-", std::process::id());
        builder.prefix(&prefix).suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt as _;
            // An ordinary file for its reader, not the private 0600 of a temporary file.
            builder.permissions(std::fs::Permissions::from_mode(0o644));
        }
        let mut tmp = builder.tempfile_in(dir).map_err(io)?;
        {
            let mut w = std::io::BufWriter::new(tmp.as_file_mut());
            contents(&mut w).map_err(io)?;
            w.flush().map_err(io)?;
        }
        self.files.push((tmp.into_temp_path(), target));
        Ok(())
    }

    /// Writes the special files in place, then renames every staged file into place (a
    /// special file that cannot take its bytes, `/dev/full`, leaves no regular output).
    ///
    /// # Errors
    /// A write or rename that fails (the ones before it are done, the rest removed), naming it.
    pub fn commit(self) -> Result<(), Error> {
        for (bytes, path) in self.special {
            let io = |source| Error::Io {
                path: path.clone(),
                source,
            };
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(&path)
                .map_err(io)?;
            f.write_all(&bytes).map_err(io)?;
            f.flush().map_err(io)?;
        }
        for (tmp, path) in self.files {
            if let Err(e) = tmp.persist(&path) {
                return Err(Error::Io {
                    path,
                    source: e.error,
                });
            }
        }
        Ok(())
    }
}

/// Writes one file in place of `path` atomically (staged, then renamed).
///
/// # Errors
/// The I/O error, naming `path`.
pub fn write_atomically(
    path: &Path,
    contents: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), Error> {
    let mut s = Staged::new();
    s.write(path, contents)?;
    s.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_under_two_names_is_caught() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        std::fs::write(&a, "x").unwrap();
        let link = dir.path().join("link.csv");
        std::fs::hard_link(&a, &link).unwrap();
        let dotted = dir.path().join(".").join("a.csv");
        for out in [&a, &link, &dotted] {
            let e = Paths::new()
                .input("the data", Some(&a))
                .output("--blob", Some(out))
                .check()
                .unwrap_err();
            let e = e.to_string();
            assert!(e.contains("--blob") && e.contains("the data reads"), "{e}");
        }
        // Two outputs, one not yet existing.
        let n = dir.path().join("new.json");
        let e = Paths::new()
            .output("--blob", Some(&n))
            .output("--json", Some(&dir.path().join("sub/../new.json")))
            .check()
            .unwrap_err();
        // `sub` does not exist, so that output cannot be written at all.
        assert!(e.to_string().contains("sub/.. does not exist"), "{e}");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let e = Paths::new()
            .output("--blob", Some(&n))
            .output("--json", Some(&dir.path().join("sub/../new.json")))
            .check()
            .unwrap_err();
        let e = e.to_string();
        assert!(e.contains("--json") && e.contains("--blob"), "{e}");
        assert!(
            Paths::new()
                .input("the data", Some(&a))
                .output("-o", Some(&n))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn two_inputs_that_must_differ_are_refused_when_one_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("acc.txt");
        std::fs::write(&a, "x").unwrap();
        let dotted = dir.path().join(".").join("acc.txt");
        let e = Paths::new()
            .distinct_input("the recording", Some(&a))
            .distinct_input("--gyro", Some(&dotted))
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("--gyro") && e.contains("the recording"), "{e}");
        // Inputs that may be one file (a blob read twice) are not refused.
        assert!(
            Paths::new()
                .input("--blob", Some(&a))
                .input("the data", Some(&a))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn a_failed_stage_leaves_nothing_and_stale_files_go() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let mut s = Staged::new();
        s.write(&out, |w| w.write_all(b"1")).unwrap();
        let e = s.write(&dir.path().join("missing/x.html"), |w| w.write_all(b"2"));
        assert!(e.is_err());
        drop(s);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // A killed run's staging file (a process that cannot exist) is removed by the first
        // write of this process into its directory.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let stale = dir.path().join(".calflash-4294967-abc.tmp");
        std::fs::write(&stale, "half").unwrap();
        write_atomically(&out, |w| w.write_all(b"done")).unwrap();
        assert!(!stale.exists());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "done");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // The directory is read once per process: a later write does not read it again.
        std::fs::write(&stale, "half").unwrap();
        write_atomically(&out, |w| w.write_all(b"again")).unwrap();
        assert!(stale.exists(), "the folder was read a second time");
    }

    #[test]
    fn a_special_file_is_written_in_place_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available here");
            return;
        }
        // A link to the FIFO, as /dev/stdout is a link to the process's pipe.
        let link = dir.path().join("stdout");
        std::os::unix::fs::symlink(&fifo, &link).unwrap();
        for out in [&fifo, &link] {
            let reader = {
                let fifo = fifo.clone();
                std::thread::spawn(move || std::fs::read(fifo).unwrap())
            };
            write_atomically(out, |w| w.write_all(b"through the pipe")).unwrap();
            assert_eq!(reader.join().unwrap(), b"through the pipe");
            let m = std::fs::metadata(&fifo).unwrap();
            assert!(!m.is_file(), "the FIFO was replaced by a file");
            assert!(
                std::fs::symlink_metadata(&link)
                    .unwrap()
                    .file_type()
                    .is_symlink()
            );
        }
        // Two outputs into one special file are no conflict; into one regular file they are.
        assert!(is_special(Path::new("/dev/null")));
        assert!(
            Paths::new()
                .output("-o", Some(Path::new("/dev/null")))
                .output("--json", Some(Path::new("/dev/null")))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn a_link_to_a_file_keeps_the_link_and_replaces_its_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("real.json");
        std::fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomically(&link, |w| w.write_all(b"new")).unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
    }

    #[test]
    fn reads_are_bounded() {
        let e = read_blob(Path::new("/dev/zero")).unwrap_err();
        assert!(
            matches!(e, Error::TooLong { max, .. } if max == spincal::signed::MAX_SIGNED_LEN as u64)
        );
        assert!(e.to_string().contains("not a calibration blob"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b");
        std::fs::write(&p, [7u8; 10]).unwrap();
        assert_eq!(read_bounded(&p, 10, "ten").unwrap().len(), 10);
        assert!(read_bounded(&p, 9, "nine").is_err());
    }

    #[test]
    fn a_line_too_long_is_refused_naming_it() {
        use std::io::Read as _;
        let mut ok = String::new();
        LineBound::new(&b"ab\ncd\n"[..], 2)
            .read_to_string(&mut ok)
            .unwrap();
        assert_eq!(ok, "ab\ncd\n");
        let mut s = String::new();
        let e = LineBound::new(&b"ab\ncde\n"[..], 2)
            .read_to_string(&mut s)
            .unwrap_err();
        assert!(
            e.to_string().contains("line 2 is longer than 2 bytes"),
            "{e}"
        );
    }

    /// Reads `text` through a [`LineBound`] in reads of `chunk` bytes.
    fn through(text: &[u8], chunk: usize) -> Vec<u8> {
        use std::io::Read as _;
        let mut r = LineBound::new(text, 100);
        let (mut out, mut buf) = (Vec::new(), vec![0; chunk]);
        loop {
            let n = r.read(&mut buf).unwrap();
            if n == 0 {
                return out;
            }
            out.extend_from_slice(&buf[..n]);
        }
    }

    #[test]
    fn a_crlf_line_ending_is_read_as_lf_and_a_lone_cr_kept() {
        let text = b"a,b\r\n1,2\r\n\r\n3\r4\r\n\r";
        for chunk in [1, 2, 3, 64] {
            assert_eq!(through(text, chunk), b"a,b\n1,2\n\n3\r4\n\r", "{chunk}");
        }
    }

    #[test]
    fn a_crlf_table_names_the_right_line() {
        // The csv crate alone counts a CRLF file's third line as its second.
        let text = "t,x\r\n1,2\r\n3,no\r\n";
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(LineBound::new(text.as_bytes(), 100));
        let mut lines = Vec::new();
        for r in reader.records() {
            let r = r.unwrap();
            lines.push((r.position().unwrap().line(), r.get(1).unwrap().to_string()));
        }
        assert_eq!(lines, [(2, "2".into()), (3, "no".into())]);
    }

    #[test]
    fn a_serial_names_a_file_only_when_it_is_a_plain_name() {
        let dir = Path::new("out");
        assert_eq!(
            unit_file(dir, "IMU-0007_b+2.1", "blob").unwrap(),
            Path::new("out/IMU-0007_b+2.1.blob")
        );
        for bad in [
            "../x", "/tmp/x", "a/b", "..", ".hidden", "", "a b", "a\\b", "a:b",
        ] {
            let e = unit_file(dir, bad, "blob").unwrap_err();
            assert!(
                matches!(&e, Error::UnsafeSerial { serial, .. } if serial == bad),
                "{bad}"
            );
            assert!(e.to_string().contains("plain file name"), "{e}");
        }
    }
}
