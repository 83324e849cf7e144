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
