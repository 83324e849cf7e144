//! `calflash flash`: write a blob into a unit over its serial link and verify it there.

use crate::cmd::Failure;
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
    /// Write a blob whose fit was judged REJECT (made with `calibrate --force-blob`).
    #[arg(long)]
    pub force_rejected: bool,
    /// Seconds to wait for each answer (a slow link, or a unit emulated on a busy host:
    /// `$CALFLASH_TIMEOUT`).
    #[arg(long, env = "CALFLASH_TIMEOUT", default_value_t = 3.0, value_parser = timeout)]
    pub timeout: f64,
    /// Test-vector batches (16 samples each).
    #[arg(long, default_value_t = 4, value_parser = |s: &str| super::values::count_in(s, 1, 256))]
    pub vectors: usize,
    /// The unit history: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Do not record the flash.
    #[arg(long)]
    pub no_db: bool,
    /// Sign an unsigned blob here, for the unit that answers, at the counter above the one it
    /// holds, with the station's private key (default: $CALFLASH_SIGN_KEY). A blob signed
    /// already is written as it is.
    #[arg(long)]
    pub sign_key: Option<PathBuf>,
}

/// A link timeout, seconds: from 0.1 to 3600.
fn timeout(s: &str) -> Result<f64, String> {
    super::values::in_range(s, 0.1, 3600.0)
}

/// Runs `calflash flash`.
///
/// # Errors
/// A message saying what failed and what the unit holds.
pub fn run(args: &FlashArgs) -> Result<(), Failure> {
    let bytes = crate::files::read_blob(&args.blob)?;
    // The rule every path into a unit applies, before a key is read. A refused blob (or one
    // that is none) goes on to the unit's flash, which refuses it and records the refusal
    // under the unit that answered.
    let warning = match crate::signing::calibration(&bytes) {
        Ok(cal) => crate::approval::admit(
            &cal.data().identity,
            &args.blob,
            crate::approval::Act::Flash,
            args.force_rejected,
        ),
        Err(_) => Ok(None),
    };
    let key = crate::signing::key_path(args.sign_key.as_deref())
        .map(|p| crate::signing::load_private(&p))
        .transpose()?;
    let timeout = Duration::from_secs_f64(args.timeout);
    let link = Link::open(&args.port, timeout)?;
    let mut client = Client::new(link, timeout);
    // Who answers: a unit that does not says so and nothing is recorded.
    let id = client
        .identify()
        .map_err(|e| format!("{}: {e}", args.port))?;
    if id.trust == spincal::protocol::Trust::Unprovisioned {
        println!(
            "  unit {} is UNPROVISIONED: it holds no station key and takes unsigned calibrations from anyone with the cable",
            id.unit
        );
    }
    // A refused blob is not signed; the unit's flash refuses it below and records the refusal.
    if let Ok(Some(w)) = &warning {
        eprintln!("calflash: {w}");
    }
    let bytes = match key {
        Some(key) if warning.is_ok() && spincal::signed::parts(&bytes).1.is_none() => {
            let counter = id
                .counter
                .checked_add(1)
                .ok_or("the unit holds the highest counter there is")?;
            let signed = crate::signing::sign(&bytes, &key, counter, false)
                .map_err(|e| format!("{}: {e}", args.blob.display()))?;
            println!(
                "  signed for unit {} at counter {counter} (the unit holds {})",
                id.unit, id.counter
            );
            signed
        }
        _ => bytes,
    };
    let bar = indicatif::ProgressBar::new(bytes.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  writing {bar:40} {bytes}/{total_bytes}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let opts = FlashOptions {
        force: args.force,
        rejected_fit: args.force_rejected,
        vector_batches: args.vectors,
    };
    let result = device::flash(&mut client, &id, &bytes, &opts, |done, _| {
        bar.set_position(done as u64)
    });
    bar.finish_and_clear();
    let db_path = crate::db::Location::or_default(args.db.as_ref())?;
    let beside = args.blob.parent().map_or_else(
        || std::path::PathBuf::from("."),
        std::path::Path::to_path_buf,
    );
    // Everything is recorded under the unit that answered, whatever the blob says.
    let unit = id.unit.as_str().to_string();
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
            if let Some(key) = &report.signed_by {
                println!(
                    "  signed by station key {key}, counter {}; the unit ({}) {}",
                    report.counter,
                    report.trust,
                    if report.trust == "provisioned" {
                        "verified the signature before committing"
                    } else {
                        "cannot check signatures"
                    }
                );
            }
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
            if !args.no_db {
                let v = serde_json::json!({
                    "error": msg,
                    "port": args.port,
                    "blob_serial": crate::signing::calibration(&bytes)
                        .ok()
                        .map(|c| c.data().identity.serial.as_str().to_string()),
                });
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
            Err(msg.into())
        }
    }
}
