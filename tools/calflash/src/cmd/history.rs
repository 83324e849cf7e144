//! `calflash history`: every fit and flash of a unit.

use crate::cmd::Failure;
use clap::Args;

use crate::db::Db;

/// List a unit's fits and flashes from the unit history database.
#[derive(Debug, Args)]
pub struct HistoryArgs {
    /// The unit's serial.
    pub serial: String,
    /// The unit history: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `calflash history`.
///
/// # Errors
/// An unreadable database.
pub fn run(args: &HistoryArgs) -> Result<(), Failure> {
    let path = crate::db::Location::or_default(args.db.as_ref())?;
    let rows = Db::open_existing(&path).and_then(|mut d| d.history(&args.serial))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!(
        "calflash history  unit {}  ({} records in {})",
        args.serial,
        rows.len(),
        path
    );
    for r in &rows {
        println!(
            "  db:{:<5} {:<5} {} UTC  {:<9} data {}  blob {} bytes{}{}{}{}",
            r.id,
            r.kind,
            format_time(r.time),
            r.outcome,
            r.data_hash.get(..12).unwrap_or(&r.data_hash),
            r.blob_len,
            if r.lot.is_empty() {
                String::new()
            } else {
                format!("  lot {}", r.lot)
            },
            r.signed_by
                .as_ref()
                .map(|s| if r.signature_checked {
                    format!("  signed by key {s}")
                } else {
                    format!("  claims key {s} (unverified)")
                })
                .unwrap_or_default(),
            r.model
                .as_ref()
                .map(|m| format!("  {m}"))
                .unwrap_or_default(),
            r.report
                .as_ref()
                .map(|p| format!("  report {p}"))
                .unwrap_or_default()
        );
    }
    if rows.is_empty() {
        println!("  no records");
    }
    Ok(())
}

/// `YYYY-MM-DD HH:MM:SS` of a Unix time (UTC), without a date crate.
pub(crate) fn format_time(t: i64) -> String {
    let days = t.div_euclid(86_400);
    let secs = t.rem_euclid(86_400);
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn times() {
        assert_eq!(super::format_time(0), "1970-01-01 00:00:00");
        // Checked against Python: datetime.utcfromtimestamp(1795000000), and a leap day.
        assert_eq!(super::format_time(1_795_000_000), "2026-11-18 11:06:40");
        assert_eq!(super::format_time(951_782_400), "2000-02-29 00:00:00");
    }
}
