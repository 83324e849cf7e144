//! The unit history: every fit and every flash of every unit, in one SQLite file.
//!
//! Default location `$CALFLASH_DB`, else `$XDG_DATA_HOME/calflash/units.sqlite`, else
//! `~/.local/share/calflash/units.sqlite`; `--db` chooses another. Each record is written in
//! one transaction, so a failure (a read-only file, a full disk) leaves no half-written row.

use std::path::{Path, PathBuf};

use rusqlite::{Connection, ErrorCode, OpenFlags, OptionalExtension, params};

use crate::sensor::record::Record;

/// The default database path.
#[must_use]
pub fn default_path() -> PathBuf {
    if let Some(p) = std::env::var_os("CALFLASH_DB") {
        return PathBuf::from(p);
    }
    let data = std::env::var_os("XDG_DATA_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))
        .unwrap_or_else(|| PathBuf::from("."));
    data.join("calflash").join("units.sqlite")
}

/// Where a record that the database cannot take is saved: the directory of the first output
/// file given, else the current directory.
#[must_use]
pub fn beside(outputs: &[Option<&Path>]) -> PathBuf {
    outputs
        .iter()
        .flatten()
        .find_map(|p| p.parent().map(Path::to_path_buf))
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Records with `f` in the database at `path`; when that fails, saves `fallback` as JSON in
/// `beside` so that nothing is lost.
///
/// # Errors
/// When the database could not take the record: the message says why and where the record
/// was saved instead (or that it could not be).
pub fn record_or_save(
    path: &Path,
    f: impl FnOnce(&mut Db) -> Result<i64, String>,
    fallback: &serde_json::Value,
    beside: &Path,
    serial: &str,
) -> Result<String, String> {
    match Db::open(path).and_then(|mut d| f(&mut d)) {
        Ok(id) => Ok(format!("recorded as db:{id} in {}", path.display())),
        Err(e) => {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos());
            let safe: String = serial
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let file = beside.join(format!("calflash-unrecorded-{safe}-{nanos}.json"));
            let body = serde_json::to_vec_pretty(fallback).unwrap_or_default();
            let saved =
                crate::files::write_atomically(&file, |w| std::io::Write::write_all(w, &body));
            Err(match saved {
                Ok(()) => format!(
                    "NOT recorded: {e}; the record is saved in {} instead",
                    file.display()
                ),
                Err(why) => format!(
                    "NOT recorded: {e}; nor could it be saved in {} ({why})",
                    file.display()
                ),
            })
        }
    }
}

/// One row of a unit's history.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Entry {
    /// Record id (for `calflash compare db:ID`).
    pub id: i64,
    /// `fit` or `flash`.
    pub kind: String,
    /// Seconds since 1970.
    pub time: i64,
    /// Hash of the observation data.
    pub data_hash: String,
    /// The models (fits).
    pub model: Option<String>,
    /// Verdict (fits) or verification outcome (flashes).
    pub outcome: String,
    /// The report's path, if any.
    pub report: Option<String>,
    /// Blob bytes (a signed blob's trailer included).
    pub blob_len: usize,
    /// The station key that signed the blob and its counter (`KEYID #COUNTER`), when signed.
    pub signed_by: Option<String>,
}

/// The coefficients of a fit as the history keeps them (and `calflash lot` reads them): per
/// table point its temperature and voltage, and per axis the output, terms, coefficients and
/// standard errors.
#[must_use]
pub fn fit_coefficients(rec: &Record) -> Vec<serde_json::Value> {
    rec.points
        .iter()
        .map(|p| serde_json::json!({"temp": p.temp, "volt": p.volt, "axes": p.axes.iter().map(|a| serde_json::json!({"output": a.output, "terms": a.terms, "coefficients": a.coefficients, "std_errors": a.std_errors})).collect::<Vec<_>>()}))
        .collect()
}

/// A unit's newest fit, for `calflash lot`.
#[derive(Debug, Clone)]
pub struct FitRow {
    /// Serial.
    pub serial: String,
    /// When (Unix seconds).
    pub time: i64,
    /// The station that recorded it (empty before schema 3).
    pub station: String,
    /// The coefficients' JSON.
    pub coefficients: String,
}

/// The history database.
pub struct Db {
    conn: Connection,
    path: PathBuf,
    /// The table has the recording station (schema 3; a version 2 file opened read-only has
    /// not).
    stations: bool,
}

fn explain(path: &Path, e: &rusqlite::Error) -> String {
    let why = match e.sqlite_error_code() {
        Some(ErrorCode::ReadOnly) => "the database file is read-only".to_string(),
        Some(ErrorCode::DiskFull) => "the disk (or the database's size limit) is full".to_string(),
        Some(ErrorCode::SystemIoFailure) => format!(
            "it cannot be written (disk I/O error: the file, or its journal {}-journal beside it, cannot be written)",
            path.file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        ),
        Some(ErrorCode::CannotOpen) => {
            "the database cannot be opened (a directory, or no permission)".to_string()
        }
        Some(ErrorCode::NotADatabase) => "the file is not a calflash database".to_string(),
        _ => e.to_string(),
    };
    format!("the unit history database {}: {why}", path.display())
}

/// The `records` table of the present schema.
macro_rules! records_table {
    () => {
        "CREATE TABLE IF NOT EXISTS records (
    id INTEGER PRIMARY KEY,
    serial TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN ('fit', 'flash', 'health')),
    time INTEGER NOT NULL,
    data_hash TEXT NOT NULL,
    model TEXT,
    coefficients TEXT,
    covariance TEXT,
    report TEXT,
    blob BLOB NOT NULL,
    verification TEXT,
    outcome TEXT NOT NULL,
    record TEXT,
    station TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS records_serial ON records (serial, time);
"
    };
}

const SCHEMA: &str = records_table!();

/// The schema version this calflash reads and writes (`PRAGMA user_version`). Version 0 is a
/// database of the releases before versioning, version 1 one whose records are fits and
/// flashes only, version 2 one without the recording station; all are migrated (in one
/// transaction) when written to: versions 0 and 1 by rebuilding the table so that it also
/// takes the unit's health reports, version 2 by adding the `station` column (empty for the
/// records before it). Read-only, a version 2 database reads with no stations.
pub const SCHEMA_VERSION: i64 = 3;

/// Rebuilds a version 0 or 1 table under the present schema, in one transaction.
const MIGRATE_FROM_1: &str = concat!(
    "BEGIN;
ALTER TABLE records RENAME TO records_v1;
DROP INDEX IF EXISTS records_serial;
",
    records_table!(),
    "INSERT INTO records (id, serial, kind, time, data_hash, model, coefficients, covariance,
    report, blob, verification, outcome, record)
    SELECT id, serial, kind, time, data_hash, model, coefficients, covariance, report, blob,
    verification, outcome, record FROM records_v1;
DROP TABLE records_v1;
PRAGMA user_version = 3;
COMMIT;
"
);

/// Adds the recording station to a version 2 table, in one transaction.
const MIGRATE_FROM_2: &str = "BEGIN;
ALTER TABLE records ADD COLUMN station TEXT NOT NULL DEFAULT '';
PRAGMA user_version = 3;
COMMIT;
";

/// The station recording: `$CALFLASH_STATION`, else the machine's host name, else empty.
#[must_use]
pub fn station() -> String {
    std::env::var("CALFLASH_STATION")
        .ok()
        .filter(|s| !s.trim().is_empty())
        .or_else(|| {
            std::fs::read_to_string("/proc/sys/kernel/hostname")
                .ok()
                .map(|h| h.trim().to_string())
        })
        .unwrap_or_default()
}

/// The columns of `records` the code reads and writes.
const COLUMNS: [&str; 13] = [
    "id",
    "serial",
    "kind",
    "time",
    "data_hash",
    "model",
    "coefficients",
    "covariance",
    "report",
    "blob",
    "verification",
    "outcome",
    "record",
];

/// Checks the schema of an existing database; migrates older versions when `write`. Whether
/// the table (now) has the `station` column.
fn check_schema(conn: &Connection, path: &Path, write: bool) -> Result<bool, String> {
    let version: i64 = conn
        .query_row("PRAGMA user_version", [], |r| r.get(0))
        .map_err(|e| explain(path, &e))?;
    if version > SCHEMA_VERSION {
        return Err(format!(
            "the unit history database {}: written by a newer calflash (schema {version}); this one reads schema {SCHEMA_VERSION} and changes nothing in it",
            path.display()
        ));
    }
    let mut stmt = conn
        .prepare("SELECT name FROM pragma_table_info('records')")
        .map_err(|e| explain(path, &e))?;
    let have: Vec<String> = stmt
        .query_map([], |r| r.get(0))
        .and_then(Iterator::collect)
        .map_err(|e| explain(path, &e))?;
    if let Some(missing) = COLUMNS.iter().find(|c| !have.iter().any(|h| h == *c)) {
        return Err(format!(
            "the unit history database {}: its table `records` has no column `{missing}`: it was altered or is not calflash's; nothing was read or written",
            path.display()
        ));
    }
    if version < SCHEMA_VERSION && write {
        let migrate = if version < 2 {
            MIGRATE_FROM_1
        } else {
            MIGRATE_FROM_2
        };
        conn.execute_batch(migrate).map_err(|e| {
            let _ = conn.execute_batch("ROLLBACK;");
            explain(path, &e)
        })?;
        return Ok(true);
    }
    Ok(have.iter().any(|h| h == "station"))
}

/// One row of `records`.
struct Row<'a> {
    serial: &'a str,
    kind: &'static str,
    time: i64,
    data_hash: String,
    model: Option<String>,
    coefficients: Option<String>,
    covariance: Option<String>,
    report: Option<&'a Path>,
    blob: &'a [u8],
    verification: Option<String>,
    outcome: String,
    record: Option<String>,
}

/// The observation-data hash a blob carries, hex; `None` when it does not decode.
fn blob_hash(blob: &[u8]) -> Option<String> {
    let cal = crate::signing::calibration(blob).ok()?;
    Some(
        cal.data()
            .identity
            .data_hash
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
    )
}

fn now() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64)
}

impl Db {
    /// Opens (creating when needed) the database at `path`.
    ///
    /// # Errors
    /// A message naming the file and why.
    pub fn open(path: &Path) -> Result<Self, String> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("the unit history database {}: {e}", path.display()))?;
        }
        let conn = Connection::open(path).map_err(|e| explain(path, &e))?;
        conn.busy_timeout(std::time::Duration::from_secs(5))
            .map_err(|e| explain(path, &e))?;
        // Creating the schema writes: a read-only file fails here only if it is new.
        let exists: bool = conn
            .query_row(
                "SELECT count(*) FROM sqlite_master WHERE name = 'records'",
                [],
                |r| r.get::<_, i64>(0),
            )
            .map_err(|e| explain(path, &e))?
            > 0;
        if exists {
            check_schema(&conn, path, true)?;
        } else {
            // No calflash table: a new file, or a database that is not ours to write into.
            let version: i64 = conn
                .query_row("PRAGMA user_version", [], |r| r.get(0))
                .map_err(|e| explain(path, &e))?;
            let others: i64 = conn
                .query_row("SELECT count(*) FROM sqlite_master", [], |r| r.get(0))
                .map_err(|e| explain(path, &e))?;
            if version != 0 || others > 0 {
                return Err(format!(
                    "the unit history database {}: it has no table `records` but {} (schema \
                     {version}, {others} other object(s)): it is not a calflash history this \
                     version can write; nothing was written",
                    path.display(),
                    if version > SCHEMA_VERSION {
                        "was written by a newer program"
                    } else {
                        "is not empty"
                    }
                ));
            }
            conn.execute_batch(&format!(
                "BEGIN; {SCHEMA} PRAGMA user_version = {SCHEMA_VERSION}; COMMIT;"
            ))
            .map_err(|e| explain(path, &e))?;
        }
        Ok(Self {
            conn,
            path: path.to_path_buf(),
            stations: true,
        })
    }

    /// Opens an existing database to read it (`history`, `compare db:ID`): never creates one,
    /// never writes.
    ///
    /// # Errors
    /// A missing file, or one that is not a calflash database of a schema this calflash reads.
    pub fn open_existing(path: &Path) -> Result<Self, String> {
        if !path.is_file() {
            return Err(format!(
                "the unit history database {}: there is none (give the one the station records in with --db, or $CALFLASH_DB)",
                path.display()
            ));
        }
        let conn = Connection::open_with_flags(path, OpenFlags::SQLITE_OPEN_READ_ONLY)
            .map_err(|e| explain(path, &e))?;
        conn.busy_timeout(std::time::Duration::from_secs(5))
            .map_err(|e| explain(path, &e))?;
        let stations = check_schema(&conn, path, false)?;
        Ok(Self {
            conn,
            path: path.to_path_buf(),
            stations,
        })
    }

    /// Records a fit.
    ///
    /// # Errors
    /// A message naming the file and why; nothing is written then.
    pub fn record_fit(
        &mut self,
        rec: &Record,
        report: Option<&Path>,
        blob: &[u8],
    ) -> Result<i64, String> {
        let models: Vec<&str> = rec
            .points
            .first()
            .map(|p| p.axes.iter().map(|a| a.model.as_str()).collect())
            .unwrap_or_default();
        let coefficients = fit_coefficients(rec);
        let covariance: Vec<Vec<&Vec<Vec<f64>>>> = rec
            .points
            .iter()
            .map(|p| p.axes.iter().map(|a| &a.covariance).collect())
            .collect();
        self.insert(&Row {
            serial: &rec.serial,
            kind: "fit",
            time: rec.created_unix_s as i64,
            data_hash: rec.data_hash.clone(),
            model: Some(models.join("; ")),
            coefficients: Some(serde_json::to_string(&coefficients).unwrap_or_default()),
            covariance: Some(serde_json::to_string(&covariance).unwrap_or_default()),
            report,
            blob,
            verification: None,
            outcome: format!("{:?}", rec.verdict).to_lowercase(),
            record: Some(serde_json::to_string(rec).unwrap_or_default()),
        })
    }

    /// Records a calibration without equipment (`calflash selfcal`): its JSON record
    /// (`calflash.selfcal/1`, which `calflash compare` reads), its coefficients and covariance,
    /// the report and the blob.
    ///
    /// # Errors
    /// A message naming the file and why; nothing is written then.
    pub fn record_selfcal(
        &mut self,
        serial: &str,
        record: &serde_json::Value,
        report: Option<&Path>,
        blob: &[u8],
    ) -> Result<i64, String> {
        let coefficients = serde_json::json!({"accel": record["accel"], "gyro": record["gyro"]["matrix_rad_s_per_count"], "gyro_bias_counts": record["gyro"]["bias_counts"]});
        let covariance = serde_json::json!({"accel": record["accel"]["covariance"], "gyro": record["gyro"]["covariance"]});
        self.insert(&Row {
            serial,
            kind: "fit",
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: Some("selfcal: accelerometer from |a| = g, gyro from rotations".into()),
            coefficients: Some(coefficients.to_string()),
            covariance: Some(covariance.to_string()),
            report,
            blob,
            verification: None,
            outcome: record["verdict"].as_str().unwrap_or("").to_lowercase(),
            record: Some(record.to_string()),
        })
    }

    /// Records a health report read from the unit (`calflash health`): the verdict as the
    /// outcome, the refined terms as the coefficients and covariance, the whole report as the
    /// record, and the blob of the calibration it judged.
    ///
    /// # Errors
    /// A message naming the file and why; nothing is written then.
    pub fn record_health(
        &mut self,
        serial: &str,
        blob: &[u8],
        record: &serde_json::Value,
    ) -> Result<i64, String> {
        let health = &record["health"];
        let coefficients = serde_json::json!({"bias": health["bias"]});
        let covariance = serde_json::json!({"bias_sigma": health["bias_sigma"], "accel_covariance": health["accel_covariance"]});
        self.insert(&Row {
            serial,
            kind: "health",
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: Some("health at rest: refined biases (spincal::health)".into()),
            coefficients: Some(coefficients.to_string()),
            covariance: Some(covariance.to_string()),
            report: None,
            blob,
            verification: None,
            outcome: health["verdict"].as_str().unwrap_or("").to_lowercase(),
            record: Some(record.to_string()),
        })
    }

    /// Records a flash (done or failed): the unit, the blob, the verification.
    ///
    /// # Errors
    /// A message naming the file and why; nothing is written then.
    pub fn record_flash(
        &mut self,
        unit: &str,
        blob: &[u8],
        verification: &serde_json::Value,
        outcome: &str,
    ) -> Result<i64, String> {
        let sensor = crate::signing::calibration(blob)
            .ok()
            .map(|cal| format!("{:?}", cal.data().sensor));
        self.insert(&Row {
            serial: unit,
            kind: "flash",
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: None,
            coefficients: sensor,
            covariance: None,
            report: None,
            blob,
            verification: Some(verification.to_string()),
            outcome: outcome.into(),
            record: None,
        })
    }

    /// Inserts one record in one transaction; its id.
    fn insert(&mut self, row: &Row<'_>) -> Result<i64, String> {
        let tx = self
            .conn
            .transaction()
            .map_err(|e| explain(&self.path, &e))?;
        tx.execute(
            "INSERT INTO records (serial, kind, time, data_hash, model, coefficients, covariance, report, blob, verification, outcome, record, station)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)",
            params![
                row.serial,
                row.kind,
                row.time,
                row.data_hash,
                row.model,
                row.coefficients,
                row.covariance,
                row.report.map(|p| p.display().to_string()),
                row.blob,
                row.verification,
                row.outcome,
                row.record,
                station(),
            ],
        )
        .map_err(|e| explain(&self.path, &e))?;
        let id = tx.last_insert_rowid();
        tx.commit().map_err(|e| explain(&self.path, &e))?;
        Ok(id)
    }

    /// A unit's history, oldest first.
    ///
    /// # Errors
    /// A message naming the file and why.
    pub fn history(&self, serial: &str) -> Result<Vec<Entry>, String> {
        let mut st = self
            .conn
            .prepare("SELECT id, kind, time, data_hash, model, outcome, report, blob FROM records WHERE serial = ?1 ORDER BY time, id")
            .map_err(|e| explain(&self.path, &e))?;
        let rows = st
            .query_map([serial], |r| {
                Ok(Entry {
                    id: r.get(0)?,
                    kind: r.get(1)?,
                    time: r.get(2)?,
                    data_hash: r.get(3)?,
                    model: r.get(4)?,
                    outcome: r.get(5)?,
                    report: r.get(6)?,
                    blob_len: r.get_ref(7)?.as_blob().map_or(0, <[u8]>::len),
                    signed_by: r
                        .get_ref(7)?
                        .as_blob()
                        .ok()
                        .and_then(crate::signing::signer)
                        .map(|(key, counter)| format!("{key} #{counter}")),
                })
            })
            .map_err(|e| explain(&self.path, &e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| explain(&self.path, &e))
    }

    /// The newest fit of every unit whose serial starts with `prefix` (all units for an empty
    /// one) recorded from `since` to `until` (Unix seconds, inclusive), at `station` when
    /// given, oldest first.
    ///
    /// # Errors
    /// A message naming the file and why; a station asked of a history without stations.
    pub fn latest_fits(
        &self,
        prefix: &str,
        since: i64,
        until: i64,
        station: Option<&str>,
    ) -> Result<Vec<FitRow>, String> {
        if station.is_some() && !self.stations {
            return Err(format!(
                "the unit history database {}: it records no stations (schema 2, opened read-only: it gains them when a calflash of schema {SCHEMA_VERSION} writes to it)",
                self.path.display()
            ));
        }
        let station_col = if self.stations { "r.station" } else { "''" };
        let station_filter = if self.stations {
            "AND (?4 IS NULL OR station = ?4)"
        } else {
            "AND ?4 IS NULL"
        };
        // The newest fit per serial: the greatest (time, id) of its fits in the range.
        let sql = format!(
            "SELECT r.serial, r.time, {station_col}, r.coefficients FROM records r
             JOIN (SELECT serial, max(time * 1000000000 + id) AS k FROM records
                   WHERE kind = 'fit' AND substr(serial, 1, length(?1)) = ?1
                     AND time BETWEEN ?2 AND ?3 {station_filter}
                   GROUP BY serial) n
               ON r.serial = n.serial AND r.time * 1000000000 + r.id = n.k
             WHERE r.coefficients IS NOT NULL
             ORDER BY r.time, r.id"
        );
        let mut st = self
            .conn
            .prepare(&sql)
            .map_err(|e| explain(&self.path, &e))?;
        let rows = st
            .query_map(rusqlite::params![prefix, since, until, station], |r| {
                Ok(FitRow {
                    serial: r.get(0)?,
                    time: r.get(1)?,
                    station: r.get(2)?,
                    coefficients: r.get(3)?,
                })
            })
            .map_err(|e| explain(&self.path, &e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| explain(&self.path, &e))
    }

    /// The highest counter of the signed blobs recorded for unit `serial` (0 for none).
    ///
    /// # Errors
    /// A message naming the file and why.
    pub fn highest_counter(&self, serial: &str) -> Result<u32, String> {
        let mut st = self
            .conn
            .prepare("SELECT blob FROM records WHERE serial = ?1")
            .map_err(|e| explain(&self.path, &e))?;
        let blobs = st
            .query_map([serial], |r| r.get::<_, Vec<u8>>(0))
            .map_err(|e| explain(&self.path, &e))?;
        let mut highest = 0;
        for b in blobs {
            let b = b.map_err(|e| explain(&self.path, &e))?;
            if let Some((_, c)) = crate::signing::signer(&b) {
                highest = highest.max(c);
            }
        }
        Ok(highest)
    }

    /// The JSON record of calibration `id` (of `calflash calibrate` or `calflash selfcal`).
    ///
    /// # Errors
    /// No such record, or a flash.
    pub fn record(&self, id: i64) -> Result<String, String> {
        let text: Option<Option<String>> = self
            .conn
            .query_row("SELECT record FROM records WHERE id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()
            .map_err(|e| explain(&self.path, &e))?;
        match text {
            None => Err(format!("{}: no record {id}", self.path.display())),
            Some(None) => Err(format!(
                "{}: record {id} is a flash, not a calibration; compare calibrations (`calflash history` lists them)",
                self.path.display()
            )),
            Some(Some(t)) => Ok(t),
        }
    }

    /// Where the database is.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flash(db: &mut Db) -> Result<i64, String> {
        db.record_flash(
            "UNIT-1",
            &[0u8; 4000],
            &serde_json::json!({"ok": true}),
            "verified",
        )
    }

    /// A history of schema 1 (fits and flashes only) takes health reports once migrated, and
    /// keeps every record it had.
    #[test]
    fn a_schema_1_history_is_migrated_and_keeps_its_records() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        {
            let c = Connection::open(&path).unwrap();
            let old = SCHEMA.replace("'fit', 'flash', 'health'", "'fit', 'flash'");
            c.execute_batch(&format!("{old} PRAGMA user_version = 1;"))
                .unwrap();
            c.execute(
                "INSERT INTO records (serial, kind, time, data_hash, blob, outcome) \
                 VALUES ('UNIT-1', 'flash', 5, 'ab', x'00', 'verified')",
                [],
            )
            .unwrap();
            // Schema 1 refuses a health report.
            assert!(
                c.execute(
                    "INSERT INTO records (serial, kind, time, data_hash, blob, outcome) \
                     VALUES ('UNIT-1', 'health', 6, 'ab', x'00', 'ok')",
                    [],
                )
                .is_err()
            );
        }
        let mut db = Db::open(&path).unwrap();
        let version: i64 = db
            .conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(version, SCHEMA_VERSION);
        let record = serde_json::json!({"health": {"verdict": "DRIFTED", "bias": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]}});
        db.record_health("UNIT-1", &[0u8; 4], &record).unwrap();
        let kinds: Vec<(String, String)> = db
            .history("UNIT-1")
            .unwrap()
            .into_iter()
            .map(|e| (e.kind, e.outcome))
            .collect();
        assert_eq!(
            kinds,
            [
                ("flash".to_string(), "verified".to_string()),
                ("health".to_string(), "drifted".to_string())
            ]
        );
    }

    #[test]
    fn a_schema_2_history_reads_without_stations_and_gains_them_when_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        let c = Connection::open(&path).unwrap();
        c.execute_batch(&format!(
            "{SCHEMA} ALTER TABLE records DROP COLUMN station; PRAGMA user_version = 2;
             INSERT INTO records (serial, kind, time, data_hash, coefficients, blob, outcome)
             VALUES ('U-1', 'fit', 10, 'h', '[]', x'', 'accept');"
        ))
        .unwrap();
        drop(c);
        // Read-only: no stations, and a station asked for is refused with the reason.
        let d = Db::open_existing(&path).unwrap();
        let rows = d.latest_fits("U-", 0, 100, None).unwrap();
        assert_eq!((rows.len(), rows[0].station.as_str()), (1, ""));
        let e = d.latest_fits("U-", 0, 100, Some("A")).unwrap_err();
        assert!(e.contains("records no stations (schema 2"), "{e}");
        drop(d);
        // Written: migrated in one step, the old record kept with no station.
        let d = Db::open(&path).unwrap();
        let v: i64 = d
            .conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(v, SCHEMA_VERSION);
        let rows = d.latest_fits("U-", 0, 100, Some("")).unwrap();
        assert_eq!(rows.len(), 1);
        assert!(d.latest_fits("U-", 0, 100, Some("A")).unwrap().is_empty());
    }

    #[test]
    fn a_full_database_says_so_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        let mut db = Db::open(&path).unwrap();
        flash(&mut db).unwrap();
        let pages: i64 = db
            .conn
            .query_row("PRAGMA page_count", [], |r| r.get(0))
            .unwrap();
        // The size limit stands in for a full disk: SQLite reports both as SQLITE_FULL.
        let _: i64 = db
            .conn
            .query_row(&format!("PRAGMA max_page_count = {pages}"), [], |r| {
                r.get(0)
            })
            .unwrap();
        let e = flash(&mut db).unwrap_err();
        assert_eq!(
            e,
            format!(
                "the unit history database {}: the disk (or the database's size limit) is full",
                path.display()
            )
        );
        assert_eq!(
            db.history("UNIT-1").unwrap().len(),
            1,
            "the failed record left nothing behind"
        );
    }

    #[test]
    fn a_read_only_database_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        flash(&mut Db::open(&path).unwrap()).unwrap();
        let mut perms = std::fs::metadata(&path).unwrap().permissions();
        perms.set_readonly(true);
        std::fs::set_permissions(&path, perms).unwrap();
        if std::fs::OpenOptions::new().append(true).open(&path).is_ok() {
            // Root writes read-only files; the journal test in host-tests/tests/flash_faults.rs
            // covers an unwritable database there.
            println!(
                "a_read_only_database_says_so: skipped, running as a user who can write read-only files (root)"
            );
            return;
        }
        let mut db = Db::open(&path).unwrap();
        let e = flash(&mut db).unwrap_err();
        assert_eq!(
            e,
            format!(
                "the unit history database {}: the database file is read-only",
                path.display()
            )
        );
        assert_eq!(db.history("UNIT-1").unwrap().len(), 1);
    }

    #[test]
    fn a_file_that_is_not_a_database_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        std::fs::write(&path, b"serial,time\nUNIT-1,0\n".repeat(100)).unwrap();
        let e = Db::open(&path).err().unwrap();
        assert_eq!(
            e,
            format!(
                "the unit history database {}: the file is not a calflash database",
                path.display()
            )
        );
    }

    #[test]
    fn the_schema_version_is_checked_and_reading_creates_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        // Reading a database that is not there creates nothing.
        let e = Db::open_existing(&path).err().unwrap();
        assert!(e.contains("there is none"), "{e}");
        assert!(!path.exists());
        let deep = dir.path().join("a/b/units.sqlite");
        assert!(Db::open_existing(&deep).is_err());
        assert!(!dir.path().join("a").exists());
        // A new database carries the version.
        flash(&mut Db::open(&path).unwrap()).unwrap();
        let conn = Connection::open(&path).unwrap();
        let v: i64 = conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(v, SCHEMA_VERSION);
        // A database of the releases before versioning (version 0) is migrated on write.
        conn.execute_batch("PRAGMA user_version = 0").unwrap();
        assert_eq!(
            Db::open_existing(&path)
                .unwrap()
                .history("UNIT-1")
                .unwrap()
                .len(),
            1
        );
        flash(&mut Db::open(&path).unwrap()).unwrap();
        let v: i64 = conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(v, SCHEMA_VERSION);
        // A newer schema is refused, written into by nobody.
        conn.execute_batch("PRAGMA user_version = 7").unwrap();
        for e in [
            Db::open(&path).err().unwrap(),
            Db::open_existing(&path).err().unwrap(),
        ] {
            assert!(e.contains("newer calflash (schema 7)"), "{e}");
        }
        // An altered table is named, not answered with raw SQL.
        conn.execute_batch("PRAGMA user_version = 1; ALTER TABLE records RENAME COLUMN time TO t")
            .unwrap();
        let e = Db::open_existing(&path).err().unwrap();
        assert!(e.contains("no column `time`"), "{e}");
        // Another program's database, and a newer one without our table, are left alone.
        for (name, sql) in [
            ("other.sqlite", "CREATE TABLE parts (id INTEGER)"),
            ("newer.sqlite", "PRAGMA user_version = 9"),
        ] {
            let p = dir.path().join(name);
            Connection::open(&p).unwrap().execute_batch(sql).unwrap();
            let e = Db::open(&p).err().unwrap();
            assert!(e.contains("it has no table `records`"), "{e}");
            let c = Connection::open(&p).unwrap();
            let tables: i64 = c
                .query_row(
                    "SELECT count(*) FROM sqlite_master WHERE name = 'records'",
                    [],
                    |r| r.get(0),
                )
                .unwrap();
            assert_eq!(tables, 0, "{name}: nothing written");
        }
    }
}
