//! The files a command reads and writes, under one rule: an output is never an input of the
//! same command, nor another of its outputs (the same file is found by canonical path and, when
//! it exists, by device and inode, so `./a`, `dir/../a` and a hard link are all caught); the
//! outputs are staged beside their destinations and renamed into place together once every one
//! is written, so a failed command leaves none; and a staging file that a killed run left behind
//! (`.calflash-<pid>-*.tmp`, its process gone) is removed the next time a command writes into
//! that directory.

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
    outputs: Vec<(String, PathBuf)>,
    /// The outputs whose directories the command creates (the unit history).
    creates_dir: Vec<bool>,
}

/// Where a path would be: its canonical form, or its canonical directory and its name when
/// the file does not exist yet.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    match (dir.canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// True when `a` and `b` are the same file (or would be).
#[must_use]
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    resolved(a) == resolved(b)
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
            if let Some((input, _)) = self.inputs.iter().find(|(_, p)| same_file(p, out)) {
                let input = input.clone();
                return Err(Error::ReplacesInput { what, path, input });
            }
            if let Some((other, _)) = self.outputs[..i].iter().find(|(_, p)| same_file(p, out)) {
                let other = other.clone();
                return Err(Error::SameOutput { what, path, other });
            }
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

/// Removes the staging files of runs that were killed: `.calflash-<pid>-*.tmp` whose process
/// no longer exists (Linux: `/proc/<pid>`; elsewhere nothing is removed).
fn clean_stale(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
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
        let dir = dir_of(path);
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
        self.files.push((tmp.into_temp_path(), path.to_path_buf()));
        Ok(())
    }

    /// Renames every staged file into place.
    ///
    /// # Errors
    /// A rename that fails (the ones before it are in place, the rest removed), naming it.
    pub fn commit(self) -> Result<(), Error> {
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
    fn a_failed_stage_leaves_nothing_and_stale_files_go() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let mut s = Staged::new();
        s.write(&out, |w| w.write_all(b"1")).unwrap();
        let e = s.write(&dir.path().join("missing/x.html"), |w| w.write_all(b"2"));
        assert!(e.is_err());
        drop(s);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // A killed run's staging file (a process that cannot exist) is removed.
        let stale = dir.path().join(".calflash-4294967-abc.tmp");
        std::fs::write(&stale, "half").unwrap();
        write_atomically(&out, |w| w.write_all(b"done")).unwrap();
        assert!(!stale.exists());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "done");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
