//! What a calibration command writes: the blob, the HTML report, the JSON record, and the
//! entry in the unit history. Shared by `calflash calibrate` and `calflash selfcal`.

use std::path::PathBuf;

use clap::Args;

use crate::db::{self, Db};
use crate::report;

/// Where a calibration goes.
#[derive(Debug, Args)]
pub struct Outputs {
    /// Write the blob here.
    #[arg(long)]
    pub blob: Option<PathBuf>,
    /// Write the HTML report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the calibration record (JSON, for `calflash compare`) here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// The unit history database (default: $CALFLASH_DB, else the user's data directory).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Do not record the calibration.
    #[arg(long)]
    pub no_db: bool,
}

impl Outputs {
    /// Writes the files asked for, each atomically; the report is rendered (only when asked
    /// for) before anything is written, so a report that cannot be drawn leaves no file.
    ///
    /// # Errors
    /// A file that cannot be written, or the report's error.
    pub fn write(
        &self,
        blob: &[u8],
        record: &impl serde::Serialize,
        html: impl FnOnce() -> Result<String, String>,
    ) -> Result<(), String> {
        let html = self.report.as_ref().map(|_| html()).transpose()?;
        if let Some(p) = &self.blob {
            report::write_atomically(p, |w| w.write_all(blob))?;
        }
        if let (Some(p), Some(html)) = (&self.report, &html) {
            report::write_atomically(p, |w| w.write_all(html.as_bytes()))?;
        }
        if let Some(p) = &self.json {
            report::write_atomically(p, |w| {
                serde_json::to_writer_pretty(&mut *w, record).map_err(std::io::Error::other)
            })?;
        }
        Ok(())
    }

    /// Records the calibration in the unit history with `save` (unless `--no-db`) and prints
    /// where; when the database cannot take it, `record` is saved as JSON beside the outputs.
    ///
    /// # Errors
    /// The database's error, saying where the record went instead.
    pub fn record(
        &self,
        serial: &str,
        record: &serde_json::Value,
        save: impl FnOnce(&mut Db) -> Result<i64, String>,
    ) -> Result<(), String> {
        if self.no_db {
            return Ok(());
        }
        let path = self.db.clone().unwrap_or_else(db::default_path);
        let beside = db::beside(&[
            self.blob.as_deref(),
            self.json.as_deref(),
            self.report.as_deref(),
        ]);
        let said = db::record_or_save(&path, save, record, &beside, serial)
            .map_err(|e| format!("the calibration is written but {e}"))?;
        println!("  {said}");
        Ok(())
    }
}
