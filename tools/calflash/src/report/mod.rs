//! Reports: they only read results.

pub mod design;
pub mod html;
pub mod json;
pub mod plot;
pub mod selfcal;
pub mod terminal;

use std::io::Write;
use std::path::Path;

/// Writes `contents` to `path` all at once: into a temporary file beside it, then renamed, so
/// a failure never leaves a half-written or stale-looking output behind.
///
/// # Errors
/// The I/O error, naming the path.
pub fn write_atomically(
    path: &Path,
    contents: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), String> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        // An ordinary file for its reader, not the private 0600 of a temporary file.
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        contents(&mut w).map_err(|e| format!("{}: {e}", path.display()))?;
        w.flush().map_err(|e| format!("{}: {e}", path.display()))?;
    }
    tmp.persist(path)
        .map_err(|e| format!("{}: {}", path.display(), e.error))?;
    Ok(())
}
