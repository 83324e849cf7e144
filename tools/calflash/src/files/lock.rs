//! One writer at a time for a folder of unit outputs: a command that writes calibrations
//! holds an advisory lock on `.calflash.lock` in each folder it writes into, for its whole
//! run, and a second one is refused with the holder named (its process, command line and start),
//! so that two runs can never leave a unit's blob from one beside its record from the other.
//! The lock goes with the process (the kernel drops it when the file closes, a killed run too).
//! The file is removed when the lock is let go, so that a folder keeps only the outputs; a
//! killed run's file stays, naming it, and is taken over by the next writer. A writer that
//! locked a file another had just removed finds its path no longer names that file, and
//! takes the lock again on the new one.

use std::io::{Read as _, Seek as _, Write as _};
use std::path::{Path, PathBuf};

use super::Error;

/// The lock file's name in a folder.
pub const LOCK_FILE: &str = ".calflash.lock";

/// A held lock on a folder; released (and its file removed) when dropped.
#[derive(Debug)]
pub struct FolderLock {
    file: std::fs::File,
    /// The folder.
    pub dir: PathBuf,
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // Removed while still held: a writer that opens the path now makes a new file.
        let _ = std::fs::remove_file(self.dir.join(LOCK_FILE));
        let _ = self.file.unlock();
    }
}

/// Whether `path` still names the open `file` (same device and inode).
fn still_names(path: &Path, file: &std::fs::File) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    match (std::fs::metadata(path), file.metadata()) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// The folder `path` is written into (`.` for a bare file name).
#[must_use]
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

impl FolderLock {
    /// Takes the lock on `dir` for `what` (the option that writes there), or says who holds it.
    ///
    /// # Errors
    /// [`Error::Locked`] naming the holder, or the I/O error on the lock file.
    pub fn take(dir: &Path, what: &str) -> Result<Self, Error> {
        let path = dir.join(LOCK_FILE);
        let io = |source| Error::Io {
            path: path.clone(),
            source,
        };
        let mut file = loop {
            let mut file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            match file.try_lock() {
                // Locked, and still the file its path names: held.
                Ok(()) if still_names(&path, &file) => break file,
                // The holder let it go and removed it meanwhile: again, on the new file.
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    return Err(Error::Locked {
                        what: what.to_string(),
                        dir: dir.to_path_buf(),
                        holder: holder.trim().to_string(),
                    });
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
            }
        };
        let args: Vec<String> = std::env::args().collect();
        let since = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let line = format!(
            "process {} (`{}`), since {since} s after the epoch\n",
            std::process::id(),
            args.join(" ")
        );
        file.set_len(0).map_err(io)?;
        file.rewind().map_err(io)?;
        file.write_all(line.as_bytes()).map_err(io)?;
        file.flush().map_err(io)?;
        Ok(Self {
            file,
            dir: dir.to_path_buf(),
        })
    }

    /// The locks on the folders of `outputs` (each folder once), taken in order of their
    /// canonical paths so that two commands taking the same folders cannot each hold one.
    ///
    /// # Errors
    /// As [`take`](Self::take).
    pub fn take_all<'a>(
        outputs: impl IntoIterator<Item = (&'a str, &'a Path)>,
    ) -> Result<Vec<Self>, Error> {
        let mut dirs: Vec<(PathBuf, &str)> = Vec::new();
        for (what, path) in outputs {
            if super::is_special(path) {
                continue;
            }
            // A folder that does not exist is left for the command's own check to name.
            let Ok(dir) = folder_of(path).canonicalize() else {
                continue;
            };
            if !dirs.iter().any(|(d, _)| *d == dir) {
                dirs.push((dir, what));
            }
        }
        dirs.sort();
        dirs.into_iter()
            .map(|(d, what)| Self::take(&d, what))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_naming_the_first_and_may_write_once_it_is_gone() {
        let d = tempfile::tempdir().unwrap();
        let first = FolderLock::take(d.path(), "--out-dir").unwrap();
        let err = FolderLock::take(d.path(), "--out-dir")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("process {}", std::process::id()))
                && err.contains("--out-dir")
                && err.contains("one writer at a time"),
            "{err}"
        );
        drop(first);
        assert!(!d.path().join(LOCK_FILE).exists(), "the lock's file stays");
        let again = FolderLock::take_all([
            ("--blob", d.path().join("a.blob").as_path()),
            ("--json", d.path().join("a.json").as_path()),
        ])
        .unwrap();
        assert_eq!(again.len(), 1);
    }
}
