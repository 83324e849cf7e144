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
            "SELECT r.serial, r.time, {station_r}, r.coefficients FROM records r
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
mod tests {
    use super::super::{Db, Error, Location};
    use super::*;

    /// A history over the connection `s`, whose settings the test changes.
    fn db(s: Sqlite) -> Db {
        let location = Location::File(s.path.clone());
        Db {
            backend: Box::new(s),
            location,
        }
    }

    fn user_version(path: &Path) -> i64 {
        Connection::open(path)
            .unwrap()
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap()
    }

    fn flash(db: &mut Db) -> Result<i64, Error> {
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
            let old = SCHEMA.replace("'fit', 'flash', 'health', 'flight'", "'fit', 'flash'");
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
        assert_eq!(user_version(&path), SCHEMA_VERSION);
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

    /// The units `U-*` with a fit from time 0 to 100, at `station` and in `lot` when given.
    fn select<'a>(station: Option<&'a str>, lot: Option<&'a str>) -> Selection<'a> {
        Selection {
            prefix: "U-",
            lot,
            since: 0,
            until: 100,
            station,
        }
    }

    #[test]
    fn older_histories_read_without_stations_or_lots_and_gain_them_when_written() {
        for (version, dropped) in [(2, "station, lot"), (3, "lot")] {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("units.sqlite");
            let c = Connection::open(&path).unwrap();
            let drops: String = dropped
                .split(", ")
                .map(|col| format!("ALTER TABLE records DROP COLUMN {col};"))
                .collect();
            c.execute_batch(&format!(
                "{SCHEMA} DROP INDEX records_lot; {drops} PRAGMA user_version = {version};
                 INSERT INTO records (serial, kind, time, data_hash, coefficients, blob, outcome)
                 VALUES ('U-1', 'fit', 10, 'h', '[]', x'', 'accept');"
            ))
            .unwrap();
            drop(c);
            // Read-only: what it lacks reads empty, and asked for is refused with the reason.
            let mut d = Db::open_existing(&path).unwrap();
            let rows = d.latest_fits(&select(None, None)).unwrap();
            assert_eq!((rows.len(), rows[0].station.as_str()), (1, ""));
            let e = d.latest_fits(&select(None, Some("L1"))).unwrap_err();
            assert!(
                matches!(
                    &e,
                    Error::History {
                        cause: Cause::Lacks("lots"),
                        ..
                    }
                ),
                "{e:?}"
            );
            assert!(
                e.to_string().contains("records no lots (an older schema"),
                "{e}"
            );
            if version == 2 {
                let e = d.latest_fits(&select(Some("A"), None)).unwrap_err();
                assert!(
                    e.to_string()
                        .contains("records no stations (an older schema"),
                    "{e}"
                );
            }
            assert_eq!(d.history("U-1").unwrap()[0].lot, "");
            drop(d);
            // Written: migrated in one step, the old record kept with no station and no lot.
            let mut d = Db::open(&path).unwrap();
            assert_eq!(user_version(&path), SCHEMA_VERSION);
            assert_eq!(d.latest_fits(&select(Some(""), Some(""))).unwrap().len(), 1);
            assert!(d.latest_fits(&select(Some("A"), None)).unwrap().is_empty());
            assert!(d.latest_fits(&select(None, Some("L1"))).unwrap().is_empty());
        }
    }

    #[test]
    fn a_full_database_says_so_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("units.sqlite");
        flash(&mut Db::open(&path).unwrap()).unwrap();
        let s = Sqlite::open(&path).unwrap();
        let pages: i64 = s
            .conn
            .query_row("PRAGMA page_count", [], |r| r.get(0))
            .unwrap();
        // The size limit stands in for a full disk: SQLite reports both as SQLITE_FULL.
        let _: i64 = s
            .conn
            .query_row(&format!("PRAGMA max_page_count = {pages}"), [], |r| {
                r.get(0)
            })
            .unwrap();
        let mut db = db(s);
        let e = flash(&mut db).unwrap_err();
        assert!(matches!(
            &e,
            Error::History { cause: Cause::Sqlite { source, .. }, .. }
                if source.sqlite_error_code() == Some(ErrorCode::DiskFull)
        ));
        assert_eq!(
            e.to_string(),
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
            e.to_string(),
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
            e.to_string(),
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
        assert!(
            matches!(
                e,
                Error::History {
                    cause: Cause::NoFile,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("there is none"), "{e}");
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
            assert!(
                matches!(
                    e,
                    Error::History {
                        cause: Cause::NewerSchema(7),
                        ..
                    }
                ),
                "{e:?}"
            );
            assert!(e.to_string().contains("newer calflash (schema 7)"), "{e}");
        }
        // An altered table is named, not answered with raw SQL.
        conn.execute_batch("PRAGMA user_version = 1; ALTER TABLE records RENAME COLUMN time TO t")
            .unwrap();
        let e = Db::open_existing(&path).err().unwrap();
        assert!(e.to_string().contains("no column `time`"), "{e}");
        // Another program's database, and a newer one without our table, are left alone.
        for (name, sql) in [
            ("other.sqlite", "CREATE TABLE parts (id INTEGER)"),
            ("newer.sqlite", "PRAGMA user_version = 9"),
        ] {
            let p = dir.path().join(name);
            Connection::open(&p).unwrap().execute_batch(sql).unwrap();
            let e = Db::open(&p).err().unwrap();
            assert!(e.to_string().contains("it has no table `records`"), "{e}");
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

    /// Many stations opening one new file at the same instant: one creates the history, every
    /// other waits for it and writes into it; none takes the half-made file for a stranger's.
    /// (Opened in a barrier, many times over: the race it guards lasted microseconds.)
    #[test]
    fn stations_opening_a_new_file_at_once_all_write_into_it() {
        const STATIONS: usize = 6;
        let dir = tempfile::tempdir().unwrap();
        for round in 0..40 {
            let path = dir.path().join(format!("new-{round}.sqlite"));
            let start = std::sync::Arc::new(std::sync::Barrier::new(STATIONS));
            let stations: Vec<_> = (0..STATIONS)
                .map(|s| {
                    let (path, start) = (path.clone(), start.clone());
                    std::thread::spawn(move || {
                        start.wait();
                        let mut db = Db::open(&path).map_err(|e| format!("station {s}: {e}"))?;
                        flash(&mut db).map_err(|e| format!("station {s}: {e}"))
                    })
                })
                .collect();
            for s in stations {
                s.join()
                    .unwrap()
                    .unwrap_or_else(|e| panic!("round {round}: {e}"));
            }
            let n = Db::open_existing(&path)
                .unwrap()
                .history("UNIT-1")
                .unwrap()
                .len();
            assert_eq!(n, STATIONS, "round {round}");
            assert_eq!(user_version(&path), SCHEMA_VERSION);
        }
    }
}
