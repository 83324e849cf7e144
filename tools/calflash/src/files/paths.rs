//! Which files a command names, and the check that no output is an input or another output.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::Error;
use super::read::is_special;

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
pub(super) fn dir_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}
