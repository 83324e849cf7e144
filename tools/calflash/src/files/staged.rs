//! Outputs staged beside their destinations and renamed into place together, and the staging
//! files a killed run left behind removed.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::Error;
use super::paths::dir_of;
use super::read::is_special;

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
    /// Files of an earlier run that this one does not replace, removed at the commit.
    removed: Vec<PathBuf>,
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

    /// Removes the regular file at `path`, if there is one, at the commit, before any staged
    /// file is renamed into place: an output this run does not write (the blob of a REJECT)
    /// must not be left holding another run's.
    pub fn remove(&mut self, path: &Path) {
        self.removed.push(path.to_path_buf());
    }

    /// Removes what [`remove`](Self::remove) named, writes the special files in place, then
    /// renames every staged file into place (a
    /// special file that cannot take its bytes, `/dev/full`, leaves no regular output).
    ///
    /// # Errors
    /// A write or rename that fails (the ones before it are done, the rest removed), naming it.
    pub fn commit(self) -> Result<(), Error> {
        for path in self.removed {
            let target = match std::fs::symlink_metadata(&path) {
                Ok(m) if m.file_type().is_symlink() => path.canonicalize().unwrap_or(path),
                Ok(_) => path,
                Err(_) => continue,
            };
            if std::fs::metadata(&target).is_ok_and(|m| m.is_file()) {
                std::fs::remove_file(&target).map_err(|source| Error::Io {
                    path: target.clone(),
                    source,
                })?;
            }
        }
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
