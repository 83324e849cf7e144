//! The report pages this run of calflash has written, for `--pdf` (issue 68: a printable,
//! signable document of every report): each place that writes a page names it here, and the
//! command line prints them all once the command is done (after a page is sealed again with
//! its history record).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

static PAGES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Notes that the page at `path` was written (once, however often it is written again).
pub fn page(path: &Path) {
    let mut pages = PAGES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if !pages.iter().any(|p| p == path) {
        pages.push(path.to_path_buf());
    }
}

/// The pages written so far, in the order first written.
#[must_use]
pub fn pages() -> Vec<PathBuf> {
    PAGES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone()
}
