//! The unit history in a SQLite file: the station's own, and the default.
//!
//! The schema version is SQLite's `PRAGMA user_version`. Each record is written in one
//! transaction, so a failure (a read-only file, a full disk) leaves no half-written row; two
//! processes writing at once wait for each other (a busy timeout of 5 s per statement).

use std::path::{Path, PathBuf};

use rusqlite::{Connection, ErrorCode, OpenFlags, OptionalExtension, params};

use super::schema::{Later, Listed, Row};
use super::{Backend, Cause, FitRow, SCHEMA_VERSION, Selection};

/// A SQLite history.
pub struct Sqlite {
    pub(super) conn: Connection,
    path: PathBuf,
    /// The columns of later schemas the table has (an older file opened to read lacks some).
    later: Later,
}

/// Why SQLite failed, in the station's words.
fn why(path: &Path, e: rusqlite::Error) -> Cause {
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
    Cause::Sqlite { why, source: e }
}

/// The `records` table of the present schema.
macro_rules! records_table {
    () => {
        "CREATE TABLE IF NOT EXISTS records (
    id INTEGER PRIMARY KEY,
    serial TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN ('fit', 'flash', 'health', 'flight')),
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
    station TEXT NOT NULL DEFAULT '',
    lot TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS records_serial ON records (serial, time);
CREATE INDEX IF NOT EXISTS records_lot ON records (lot);
"
    };
}

pub(super) const SCHEMA: &str = records_table!();

/// Rebuilds an older table under the present schema (run inside the write lock): SQLite
/// cannot change a column's check, and each version took more kinds of record (health in
/// version 2, flights in 5). The columns the old table has are copied; the station and the lot
/// it lacks are left empty.
fn rebuild(later: Later) -> String {
    let mut columns = String::from(
        "id, serial, kind, time, data_hash, model, coefficients, covariance, report, blob, \
         verification, outcome, record",
    );
    if later.station {
        columns.push_str(", station");
    }
    if later.lot {
        columns.push_str(", lot");
    }
    format!(
        "ALTER TABLE records RENAME TO records_old;
DROP INDEX IF EXISTS records_serial;
DROP INDEX IF EXISTS records_lot;
{}INSERT INTO records ({columns}) SELECT {columns} FROM records_old;
DROP TABLE records_old;
PRAGMA user_version = {SCHEMA_VERSION};
",
        records_table!()
    )
}

/// Checks the schema of an existing database: its version and which later columns the table
/// has.
fn check_schema(conn: &Connection, path: &Path) -> Result<(i64, Later), Cause> {
    let version: i64 = conn
        .query_row("PRAGMA user_version", [], |r| r.get(0))
        .map_err(|e| why(path, e))?;
    if version > SCHEMA_VERSION {
        return Err(Cause::NewerSchema(version));
    }
    let mut stmt = conn
        .prepare("SELECT name FROM pragma_table_info('records')")
        .map_err(|e| why(path, e))?;
    let have: Vec<String> = stmt
        .query_map([], |r| r.get(0))
        .and_then(Iterator::collect)
        .map_err(|e| why(path, e))?;
    Ok((version, super::schema::check_columns(&have)?))
}

/// Whether the database has calflash's table.
fn has_records(conn: &Connection, path: &Path) -> Result<bool, Cause> {
    conn.query_row(
        "SELECT count(*) FROM sqlite_master WHERE name = 'records'",
        [],
        |r| r.get::<_, i64>(0),
    )
    .map(|n| n > 0)
    .map_err(|e| why(path, e))
}

/// Makes the database ready to take records of the present schema: creates the table in an
/// empty file, migrates an older one, refuses anything else. Runs under the write lock, so
/// what it sees cannot change before it acts.
fn make_writable(conn: &Connection, path: &Path) -> Result<(), Cause> {
    if has_records(conn, path)? {
        let (version, later) = check_schema(conn, path)?;
        if version == SCHEMA_VERSION {
            return Ok(());
        }
        return conn
            .execute_batch(&rebuild(later))
            .map_err(|e| why(path, e));
    }
    // No calflash table: a new file, or a database that is not ours to write into.
    let version: i64 = conn
        .query_row("PRAGMA user_version", [], |r| r.get(0))
        .map_err(|e| why(path, e))?;
    let others: i64 = conn
        .query_row("SELECT count(*) FROM sqlite_master", [], |r| r.get(0))
        .map_err(|e| why(path, e))?;
    if version != 0 || others > 0 {
        return Err(Cause::NotAHistory {
            version,
            objects: others,
        });
    }
    conn.execute_batch(&format!("{SCHEMA} PRAGMA user_version = {SCHEMA_VERSION};"))
        .map_err(|e| why(path, e))
}

/// The statement that writes one record.
fn insert_sql() -> String {
    format!(
        "INSERT INTO records ({}) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
        super::schema::WRITTEN
    )
}

fn insert_params(row: &Row) -> [&dyn rusqlite::ToSql; 14] {
    super::schema::row_values!(row)
}

/// How long a station waits for another's write to the same file: a busy batch on every core
/// of two stations at once holds the lock in turn for far less, but a loaded machine can make
/// a turn take seconds.
const BUSY_WAIT: std::time::Duration = std::time::Duration::from_secs(60);

impl Sqlite {
    /// Opens (creating when needed) the database at `path`.
    pub(super) fn open(path: &Path) -> Result<Self, Cause> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(Cause::Directory)?;
        }
        let conn = Connection::open(path).map_err(|e| why(path, e))?;
        conn.busy_timeout(BUSY_WAIT).map_err(|e| why(path, e))?;
        // A history of the present schema is written into as it is. Anything else (a new
        // file, an older schema, a stranger's database) is decided again under the write lock:
        // another station may be creating or migrating the same file at this instant, and a
        // half-made history must not be taken for a stranger's.
        let current = has_records(&conn, path)? && check_schema(&conn, path)?.0 == SCHEMA_VERSION;
        if !current {
            conn.execute_batch("BEGIN IMMEDIATE")
                .map_err(|e| why(path, e))?;
            match make_writable(&conn, path) {
                Ok(()) => conn.execute_batch("COMMIT").map_err(|e| {
                    let _ = conn.execute_batch("ROLLBACK");
                    why(path, e)
                })?,
                Err(e) => {
                    let _ = conn.execute_batch("ROLLBACK");
                    return Err(e);
                }
            }
        }
        Ok(Self {
            conn,
            path: path.to_path_buf(),
            later: Later::ALL,
        })
    }

    /// Opens an existing database to read it: never creates one, never writes.
    pub(super) fn open_existing(path: &Path) -> Result<Self, Cause> {
        if !path.is_file() {
            return Err(Cause::NoFile);
        }
        let conn = Connection::open_with_flags(path, OpenFlags::SQLITE_OPEN_READ_ONLY)
            .map_err(|e| why(path, e))?;
        conn.busy_timeout(BUSY_WAIT).map_err(|e| why(path, e))?;
        let (_, later) = check_schema(&conn, path)?;
        Ok(Self {
            conn,
            path: path.to_path_buf(),
            later,
        })
    }

    fn why(&self, e: rusqlite::Error) -> Cause {
        why(&self.path, e)
    }
}

impl Backend for Sqlite {
    fn insert(&mut self, row: &Row) -> Result<i64, Cause> {
        let tx = self
            .conn
            .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
            .map_err(|e| why(&self.path, e))?;
        tx.execute(&insert_sql(), insert_params(row).as_slice())
            .map_err(|e| why(&self.path, e))?;
        let id = tx.last_insert_rowid();
        tx.commit().map_err(|e| why(&self.path, e))?;
        Ok(id)
    }

    fn copy(&mut self, rows: &[Row]) -> Result<usize, Cause> {
        let path = self.path.clone();
        // Immediate: it reads before it writes, and a deferred transaction that another
        // station's write overtakes fails at once instead of waiting.
        let tx = self
            .conn
            .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
            .map_err(|e| why(&path, e))?;
        let mut copied = 0;
        // Only what the history did not hold before the copy: a second copy adds nothing.
        let before: i64 = tx
            .query_row("SELECT coalesce(max(id), 0) FROM records", [], |r| r.get(0))
            .map_err(|e| why(&path, e))?;
        {
            let mut present = tx
                .prepare(
                    "SELECT count(*) FROM records WHERE serial = ?1 AND kind = ?2 AND time = ?3
                     AND data_hash = ?4 AND outcome = ?5 AND station = ?6 AND blob = ?7
                     AND id <= ?8",
                )
                .map_err(|e| why(&path, e))?;
            let mut insert = tx.prepare(&insert_sql()).map_err(|e| why(&path, e))?;
            for row in rows {
                let n: i64 = present
                    .query_row(
                        params![
                            row.serial,
                            row.kind,
                            row.time,
                            row.data_hash,
                            row.outcome,
                            row.station,
                            row.blob,
                            before
                        ],
                        |r| r.get(0),
                    )
                    .map_err(|e| why(&path, e))?;
                if n == 0 {
                    insert
                        .execute(insert_params(row).as_slice())
                        .map_err(|e| why(&path, e))?;
                    copied += 1;
                }
            }
        }
        tx.commit().map_err(|e| why(&path, e))?;
        Ok(copied)
    }

    fn history(&mut self, serial: &str) -> Result<Vec<Listed>, Cause> {
        let mut st = self
            .conn
            .prepare(&format!(
                "SELECT id, kind, time, data_hash, model, outcome, report, blob, {}, verification
                 FROM records WHERE serial = ?1 ORDER BY time, id",
                Later::column(self.later.lot, "lot")
            ))
            .map_err(|e| why(&self.path, e))?;
        let rows = st
            .query_map([serial], |r| {
                Ok(Listed {
                    id: r.get(0)?,
                    kind: r.get(1)?,
                    time: r.get(2)?,
                    data_hash: r.get(3)?,
                    model: r.get(4)?,
                    outcome: r.get(5)?,
                    report: r.get(6)?,
                    blob: r.get(7)?,
                    lot: r.get(8)?,
                    verification: r.get(9)?,
                })
            })
            .map_err(|e| why(&self.path, e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| why(&self.path, e))
    }

    fn latest_fits(&mut self, sel: &Selection<'_>) -> Result<Vec<FitRow>, Cause> {
        self.later.check(sel)?;
        let station = Later::column(self.later.station, "station");
        let station_r = Later::column(self.later.station, "r.station");
        let lot = Later::column(self.later.lot, "lot");
        // The newest fit per serial: the greatest (time, id) of its fits in the range.
        let sql = format!(
            "SELECT r.serial, r.time, {station_r}, r.coefficients, r.record FROM records r
             JOIN (SELECT serial, max(time * 1000000000 + id) AS k FROM records
                   WHERE kind = 'fit' AND substr(serial, 1, length(?1)) = ?1
                     AND time BETWEEN ?2 AND ?3 AND (?4 IS NULL OR {station} = ?4)
                     AND (?5 IS NULL OR {lot} = ?5)
                   GROUP BY serial) n
               ON r.serial = n.serial AND r.time * 1000000000 + r.id = n.k
             WHERE r.coefficients IS NOT NULL
             ORDER BY r.time, r.id"
        );
        let mut st = self.conn.prepare(&sql).map_err(|e| self.why(e))?;
        let rows = st
            .query_map(
                params![sel.prefix, sel.since, sel.until, sel.station, sel.lot],
                |r| {
                    Ok(FitRow {
                        serial: r.get(0)?,
                        time: r.get(1)?,
                        station: r.get(2)?,
                        coefficients: r.get(3)?,
                        record: r.get(4)?,
                    })
                },
            )
            .map_err(|e| why(&self.path, e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| why(&self.path, e))
    }

    fn blobs(&mut self, serial: &str) -> Result<Vec<Vec<u8>>, Cause> {
        let mut st = self
            .conn
            .prepare("SELECT blob FROM records WHERE serial = ?1")
            .map_err(|e| why(&self.path, e))?;
        let rows = st
            .query_map([serial], |r| r.get(0))
            .map_err(|e| why(&self.path, e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| why(&self.path, e))
    }

    fn record(&mut self, id: i64) -> Result<Option<Option<String>>, Cause> {
        self.conn
            .query_row("SELECT record FROM records WHERE id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()
            .map_err(|e| self.why(e))
    }

    fn rows(&mut self) -> Result<Vec<Row>, Cause> {
        let mut st = self
            .conn
            .prepare(&format!(
                "SELECT serial, kind, time, data_hash, model, coefficients, covariance, report,
                 blob, verification, outcome, record, {}, {} FROM records ORDER BY id",
                Later::column(self.later.station, "station"),
                Later::column(self.later.lot, "lot")
            ))
            .map_err(|e| why(&self.path, e))?;
        let rows = st
            .query_map([], |r| {
                Ok(Row {
                    serial: r.get(0)?,
                    kind: r.get(1)?,
                    time: r.get(2)?,
                    data_hash: r.get(3)?,
                    model: r.get(4)?,
                    coefficients: r.get(5)?,
                    covariance: r.get(6)?,
                    report: r.get(7)?,
                    blob: r.get(8)?,
                    verification: r.get(9)?,
                    outcome: r.get(10)?,
                    record: r.get(11)?,
                    station: r.get(12)?,
                    lot: r.get(13)?,
                })
            })
            .map_err(|e| why(&self.path, e))?;
        rows.collect::<Result<_, _>>()
            .map_err(|e| why(&self.path, e))
    }
}

#[cfg(test)]
mod tests;
