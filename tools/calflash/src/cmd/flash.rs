//! `calflash flash`: write a blob into a unit over its serial link and verify it there.

use std::path::PathBuf;
use std::time::Duration;

use clap::Args;

use crate::db;
use crate::device::{self, Client, FlashOptions, link::Link};

/// Write a calibration into a unit, commit it, read it back, run test vectors, record it.
#[derive(Debug, Args)]
pub struct FlashArgs {
    /// The blob to write.
    #[arg(long)]
    pub blob: PathBuf,
    /// The unit's link: a serial device or pty path, or tcp://HOST:PORT.
    #[arg(long)]
    pub port: String,
    /// Write even when the blob's serial differs from the unit's.
    #[arg(long)]
    pub force: bool,
    /// Seconds to wait for each answer.
    #[arg(long, default_value_t = 3.0)]
    pub timeout: f64,
    /// Test-vector batches (16 samples each).
    #[arg(long, default_value_t = 4)]
    pub vectors: usize,
    /// The unit history database (default: $CALFLASH_DB, else the user's data directory).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Do not record the flash.
    #[arg(long)]
    pub no_db: bool,
}

/// Runs `calflash flash`.
///
/// # Errors
/// A message saying what failed and what the unit holds.
pub fn run(args: &FlashArgs) -> Result<(), String> {
    let bytes = std::fs::read(&args.blob).map_err(|e| format!("{}: {e}", args.blob.display()))?;
    let timeout = Duration::from_secs_f64(args.timeout.max(0.05));
    let link = Link::open(&args.port, timeout)?;
    let mut client = Client::new(link, timeout);
    let bar = indicatif::ProgressBar::new(bytes.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  writing {bar:40} {bytes}/{total_bytes}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let opts = FlashOptions {
        force: args.force,
        vector_batches: args.vectors,
    };
    let result = device::flash(&mut client, &bytes, &opts, |done, _| {
        bar.set_position(done as u64)
    });
    bar.finish_and_clear();
    let db_path = args.db.clone().unwrap_or_else(db::default_path);
    let beside = args.blob.parent().map_or_else(
        || std::path::PathBuf::from("."),
        std::path::Path::to_path_buf,
    );
    let unit = spincal::blob::decode(&bytes).map_or_else(
        |_| "?".into(),
        |c| c.data().identity.serial.as_str().to_string(),
    );
    match result {
        Ok(report) => {
            println!(
                "calflash flash  {} -> unit {} ({}): committed as slot sequence {}",
                args.blob.display(),
                report.unit,
                args.port,
                report.seq
            );
            println!(
                "  previous calibration {}; {} bytes read back identical; {} test vectors through the unit's correction, largest difference {} ulp",
                report.previous.as_deref().unwrap_or("(none)"),
                report.bytes,
                report.vectors,
                report.max_ulp
            );
            if !args.no_db {
                let v = serde_json::to_value(&report).unwrap_or_default();
                let said = db::record_or_save(
                    &db_path,
                    |d| d.record_flash(&report.unit, &bytes, &v, "verified"),
                    &v,
                    &beside,
                    &report.unit,
                )
                .map_err(|e| {
                    format!("the unit holds the new calibration, verified, but the flash is {e}")
                })?;
                println!("  {said}");
            }
            Ok(())
        }
        Err(e) => {
            let msg = e.to_string();
            if !args.no_db
                && !matches!(
                    e,
                    device::flash::FlashError::Device(device::DeviceError::Io { .. })
                )
            {
                let v = serde_json::json!({"error": msg, "port": args.port});
                match db::record_or_save(
                    &db_path,
                    |d| d.record_flash(&unit, &bytes, &v, "failed"),
                    &v,
                    &beside,
                    &unit,
                ) {
                    Ok(said) => eprintln!("  the failed attempt is {said}"),
                    Err(said) => eprintln!("  the failed attempt is {said}"),
                }
            }
            Err(msg)
        }
    }
}
