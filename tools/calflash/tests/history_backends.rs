//! The unit history on both of its backends (issue 18): a SQLite file, and a database on a
//! real PostgreSQL server that the test starts itself (`host-tests/src/postgres.rs`; skipped with a
//! notice where PostgreSQL is not installed). The same tests run against both: what is
//! recorded reads back alike, two writers at once lose nothing, a record is whole or absent, a
//! history of a newer schema or another program's table is refused and left alone; and on the
//! server, one that is down or refuses the login loses no record and never shows the password.
//! `calflash db migrate` copies a station's file into the shared database, once.

mod common;
#[path = "common/lot_history.rs"]
mod lot_history;
#[path = "../../../host-tests/src/postgres.rs"]
mod pg_server;

use std::path::{Path, PathBuf};

use calflash::db::{self, Db, Location, Selection};
use common::calflash;
use pg_server::Server;

/// The histories a test runs against: a SQLite file in its directory and, when PostgreSQL is
/// installed, a new database on a server of its own.
struct Histories {
    dir: tempfile::TempDir,
    server: Option<Server>,
}

impl Histories {
    fn new(test: &str) -> Self {
        Self {
            dir: tempfile::tempdir().unwrap(),
            server: Server::start(test).unwrap_or_else(|e| panic!("{e}")),
        }
    }

    fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// A new, empty history of each backend, named `name`.
    fn each(&self, name: &str) -> Vec<Location> {
        let mut all = vec![Location::File(self.dir().join(format!("{name}.sqlite")))];
        if let Some(s) = &self.server {
            s.execute("postgres", &format!("CREATE DATABASE {name}"));
            all.push(Location::Server(s.url(name)));
        }
        all
    }
}

/// The bench IMU recording of the examples.
fn bench() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/data/imu_bench.csv")
        .display()
        .to_string()
}

/// `calflash calibrate` of the bench IMU as unit `serial` into `db`, the blob in `blob`.
fn calibrate(
    d: &Path,
    serial: &str,
    db: &str,
    blob: &str,
    extra: &[&str],
) -> (i32, String, String) {
    let bench = bench();
    let mut args = vec![
        "calibrate",
        &bench,
        "--sensor",
        "imu",
        "--serial",
        serial,
        "--blob",
        blob,
        "--db",
        db,
    ];
    args.extend_from_slice(extra);
    calflash(d, &args)
}

/// A URL for `db`, the command line's way.
fn arg(l: &Location) -> String {
    match l {
        Location::File(p) => p.display().to_string(),
        Location::Server(url) => url.clone(),
    }
}

/// Every record of the history as `(serial, kind, outcome, signed_by, blob_len)`.
fn summary(l: &Location, serial: &str) -> Vec<(String, String, Option<String>, usize)> {
    Db::open_existing(l)
        .unwrap()
        .history(serial)
        .unwrap()
        .into_iter()
        .map(|e| (e.kind, e.outcome, e.signed_by, e.blob_len))
        .collect()
}

#[test]
fn what_is_recorded_reads_back_alike_from_both_backends() {
    let h = Histories::new("what_is_recorded_reads_back_alike_from_both_backends");
    let d = h.dir();
    let (code, out, err) = calflash(d, &["keygen", "station"]);
    assert_eq!(code, 0, "{out}{err}");
    let mut seen = Vec::new();
    for l in h.each("alike") {
        let db = arg(&l);
        // Signed twice: the second counter comes from the history.
        for counter in [1, 2] {
            let (code, out, err) = calibrate(
                d,
                "IMU-H-1",
                &db,
                "u.blob",
                // The lot is new, so the unit is a REVIEW: signed on the station's word.
                &["--sign-key", "station.key", "--sign-review", "--lot", "L-H"],
            );
            assert_eq!(code, 0, "{l}: {out}{err}");
            assert!(out.contains(&format!("counter {counter}")), "{l}: {out}");
            assert!(out.contains(&format!("in {l}")), "{l}: {out}");
        }
        let mut d2 = Db::open(&l).unwrap();
        let blob = std::fs::read(d.join("u.blob")).unwrap();
        let flash = d2
            .record_flash(
                "IMU-H-1",
                &blob,
                &serde_json::json!({"ok": true}),
                "verified",
            )
            .unwrap();
        d2.record_health(
            "IMU-H-1",
            &blob,
            &serde_json::json!({"health": {"verdict": "OK", "bias": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]}}),
        )
        .unwrap();
        assert_eq!(d2.highest_counter("IMU-H-1").unwrap(), 2);
        let in_lot = |lot| Selection {
            lot: Some(lot),
            ..Selection::all()
        };
        assert_eq!(d2.latest_fits(&in_lot("L-H")).unwrap().len(), 1, "{l}");
        assert!(d2.latest_fits(&in_lot("L-X")).unwrap().is_empty(), "{l}");
        drop(d2);
        let records = summary(&l, "IMU-H-1");
        assert_eq!(
            records
                .iter()
                .map(|r| (r.0.as_str(), r.1.as_str()))
                .collect::<Vec<_>>(),
            // A unit alone in its lot has none to be compared with: a REVIEW that says so.
            [
                ("fit", "review"),
                ("fit", "review"),
                ("flash", "verified"),
                ("health", "ok")
            ],
            "{l}"
        );
        assert!(records[1].2.as_deref().unwrap().ends_with(" #2"), "{l}");
        // The command line reads it: the history, and a comparison of the two fits.
        let (code, out, err) = calflash(d, &["history", "IMU-H-1", "--db", &db, "--json"]);
        assert_eq!(code, 0, "{l}: {out}{err}");
        let listed: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
        let ids: Vec<String> = listed.iter().map(|e| format!("db:{}", e["id"])).collect();
        let (code, out, err) = calflash(d, &["compare", &ids[0], &ids[1], "--db", &db]);
        assert_eq!(code, 0, "{l}: {out}{err}");
        let (code, _, err) = calflash(
            d,
            &["compare", &ids[0], &format!("db:{flash}"), "--db", &db],
        );
        assert_ne!(code, 0);
        assert!(err.contains("is a flash, not a calibration"), "{l}: {err}");
        seen.push(records);
    }
    // Both backends hold the same records.
    if seen.len() == 2 {
        assert_eq!(seen[0], seen[1]);
    }
}

#[test]
fn two_writers_at_once_lose_nothing_on_either_backend() {
    const EACH: usize = 150;
    let h = Histories::new("two_writers_at_once_lose_nothing_on_either_backend");
    for l in h.each("writers") {
        // Both start on an empty history: one of them creates it, neither fails.
        let writers: Vec<_> = ["A", "B"]
            .into_iter()
            .map(|w| {
                let l = l.clone();
                std::thread::spawn(move || {
                    for i in 0..EACH {
                        // As the command line does: a connection per record.
                        let mut db = Db::open(&l).unwrap_or_else(|e| panic!("{e}"));
                        db.record_flash(
                            &format!("{w}-{i:03}"),
                            &[i as u8; 300],
                            &serde_json::json!({"writer": w}),
                            "verified",
                        )
                        .unwrap_or_else(|e| panic!("{e}"));
                    }
                })
            })
            .collect();
        // Every writer finishes before any failure is reported: the history must outlive them.
        let failed: Vec<_> = writers.into_iter().filter_map(|w| w.join().err()).collect();
        assert!(failed.is_empty(), "{l}: {} writer(s) failed", failed.len());
        let mut db = Db::open_existing(&l).unwrap();
        for w in ["A", "B"] {
            for i in 0..EACH {
                let e = db.history(&format!("{w}-{i:03}")).unwrap();
                assert_eq!(e.len(), 1, "{l}: {w}-{i:03}");
                assert_eq!(e[0].blob_len, 300, "{l}: whole");
            }
        }
    }
}

/// Sets the schema version of the history at `l` to `v`, behind calflash's back.
fn set_version(h: &Histories, l: &Location, name: &str, v: i64) {
    match l {
        Location::File(p) => rusqlite::Connection::open(p)
            .unwrap()
            .execute_batch(&format!("PRAGMA user_version = {v}"))
            .unwrap(),
        Location::Server(_) => h
            .server
            .as_ref()
            .unwrap()
            .execute(name, &format!("UPDATE calflash_schema SET version = {v}")),
    }
}

#[test]
fn a_history_of_a_newer_schema_is_refused_and_the_record_saved_beside() {
    let h = Histories::new("a_history_of_a_newer_schema_is_refused_and_the_record_saved_beside");
    let d = h.dir();
    for l in h.each("newer") {
        let db = arg(&l);
        std::fs::create_dir_all(d.join("out")).unwrap();
        let (code, out, err) = calibrate(d, "IMU-N-1", &db, "out/u.blob", &[]);
        assert_eq!(code, 0, "{l}: {out}{err}");
        set_version(&h, &l, "newer", 7);
        let (code, out, err) = calibrate(d, "IMU-N-1", &db, "out/u.blob", &[]);
        assert_ne!(code, 0, "{l}: {out}");
        assert!(
            err.contains(&format!(
                "the unit history database {l}: written by a newer calflash (schema 7); this one reads schema {} and changes nothing in it",
                calflash::db::SCHEMA_VERSION
            )),
            "{l}: {err}"
        );
        let saved = saved_beside(&d.join("out"), &err);
        assert_eq!(saved["serial"], "IMU-N-1");
        let (code, _, err) = calflash(d, &["history", "IMU-N-1", "--db", &db]);
        assert_ne!(code, 0);
        assert!(err.contains("(schema 7)"), "{l}: {err}");
        // Nothing was written into it.
        set_version(&h, &l, "newer", calflash::db::SCHEMA_VERSION);
        assert_eq!(summary(&l, "IMU-N-1").len(), 1, "{l}");
        std::fs::remove_dir_all(d.join("out")).unwrap();
    }
}

/// The record the message says was saved instead, read; the file removed.
fn saved_beside(dir: &Path, message: &str) -> serde_json::Value {
    let files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("calflash-unrecorded-")
        })
        .collect();
    assert_eq!(files.len(), 1, "{message}");
    assert!(
        message.contains(&format!("the record is saved in {}", files[0].display()))
            || message.contains(&files[0].file_name().unwrap().to_string_lossy().to_string()),
        "{message}"
    );
    let v = serde_json::from_slice(&std::fs::read(&files[0]).unwrap()).unwrap();
    std::fs::remove_file(&files[0]).unwrap();
    v
}

#[test]
fn another_programs_table_is_left_alone_and_reading_creates_nothing() {
    let h = Histories::new("another_programs_table_is_left_alone_and_reading_creates_nothing");
    for l in h.each("empty") {
        // Reading a history that is not there creates nothing.
        let e = Db::open_existing(&l).err().unwrap();
        assert!(
            matches!(
                e,
                db::Error::History {
                    cause: db::Cause::NoFile | db::Cause::NoTables,
                    ..
                }
            ),
            "{l}: {e:?}"
        );
        let e = e.to_string();
        assert!(
            e.contains("there is none") || e.contains("holds no calflash history"),
            "{l}: {e}"
        );
        match &l {
            Location::File(p) => assert!(!p.exists()),
            Location::Server(_) => h.server.as_ref().unwrap().execute(
                "empty",
                "DO $$ BEGIN IF to_regclass('records') IS NOT NULL THEN RAISE 'created'; END IF; END $$",
            ),
        }
    }
    for l in h.each("theirs") {
        let sql = "CREATE TABLE records (part INTEGER)";
        match &l {
            Location::File(p) => rusqlite::Connection::open(p)
                .unwrap()
                .execute_batch(sql)
                .unwrap(),
            Location::Server(_) => h.server.as_ref().unwrap().execute("theirs", sql),
        }
        for e in [
            Db::open(&l).err().unwrap(),
            Db::open_existing(&l).err().unwrap(),
        ] {
            let e = e.to_string();
            assert!(
                e.starts_with(&format!("the unit history database {l}: ")),
                "{e}"
            );
            assert!(e.contains("not calflash's"), "{l}: {e}");
        }
    }
    // Another program's database with tables of its own, none called `records` (issue 30):
    // calflash creates nothing there and records nothing.
    for l in h.each("customers") {
        let sql = "CREATE TABLE customers (id INTEGER); INSERT INTO customers VALUES (1)";
        match &l {
            Location::File(p) => rusqlite::Connection::open(p)
                .unwrap()
                .execute_batch(sql)
                .unwrap(),
            Location::Server(_) => h.server.as_ref().unwrap().execute("customers", sql),
        }
        let e = Db::open(&l).err().unwrap().to_string();
        assert!(
            e.contains("another program's database") || e.contains("is not empty"),
            "{l}: {e}"
        );
        if let Location::Server(_) = &l {
            h.server.as_ref().unwrap().execute(
                "customers",
                "DO $$ BEGIN IF to_regclass('records') IS NOT NULL OR to_regclass('calflash_schema') IS NOT NULL THEN RAISE 'taken over'; END IF; END $$",
            );
        }
    }
}

#[test]
fn a_server_that_is_down_or_refuses_the_login_loses_no_record_and_hides_the_password() {
    let Some(server) = Server::start(
        "a_server_that_is_down_or_refuses_the_login_loses_no_record_and_hides_the_password",
    )
    .unwrap_or_else(|e| panic!("{e}")) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    let good = server.login("station", "s3cret-pw", "shared");
    server.execute("postgres", "CREATE DATABASE shared OWNER station");
    let (code, out, err) = calibrate(d, "IMU-P-1", &good, "out/u.blob", &[]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        !out.contains("s3cret-pw") && !err.contains("s3cret-pw"),
        "{out}{err}"
    );
    let shown = format!("postgres://station@127.0.0.1:{}/shared", server.port);
    assert!(out.contains(&format!("in {shown}")), "{out}");

    let down = {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        format!("postgres://station:s3cret-pw@127.0.0.1:{port}/shared")
    };
    let wrong = good.replace("s3cret-pw", "wr0ng-pw");
    server.execute("postgres", "CREATE ROLE reader LOGIN PASSWORD 'r3ad-pw'");
    server.execute(
        "shared",
        "GRANT SELECT ON records, calflash_schema TO reader",
    );
    let reader = format!("postgres://reader:r3ad-pw@127.0.0.1:{}/shared", server.port);
    for (url, why) in [
        (&down, "the server cannot be reached ("),
        (
            &wrong,
            "the server refused the login: password authentication failed for user \"station\"",
        ),
        (
            &reader,
            "the server refused: permission denied for table records (the login may not read or write the history)",
        ),
    ] {
        let (code, out, err) = calibrate(d, "IMU-P-1", url, "out/u.blob", &[]);
        assert_ne!(code, 0, "{url}: {out}");
        let shown = calflash::db::redact(url);
        assert!(
            err.contains(&format!(
                "the calibration's files are written but it is NOT recorded: the unit history database {shown}: {why}"
            )),
            "{url}: {err}"
        );
        for pw in ["s3cret-pw", "wr0ng-pw", "r3ad-pw"] {
            assert!(
                !err.contains(pw) && !out.contains(pw),
                "{pw} shown: {out}{err}"
            );
        }
        let saved = saved_beside(&d.join("out"), &err);
        assert_eq!(saved["serial"], "IMU-P-1", "{url}");
        assert!(d.join("out/u.blob").is_file());
    }
    // Nothing half-written: the history holds the one record it took.
    assert_eq!(summary(&Location::Server(good.clone()), "IMU-P-1").len(), 1);
    // The URL may come from $CALFLASH_DB, and is shown without its password there too; a
    // URL without one takes $PGPASSWORD's; TLS is refused before connecting.
    let bare = format!("postgres://station@127.0.0.1:{}/shared", server.port);
    let tls = format!("{bare}?sslmode=require");
    for (url, pgpassword, code, said) in [
        (&good, "", 0, "1 records in postgres://station@"),
        (&wrong, "", 1, "the server refused the login"),
        (&bare, "s3cret-pw", 0, "1 records in postgres://station@"),
        (
            &bare,
            "",
            1,
            "the server asks for a password and the URL gives none",
        ),
        (
            &tls,
            "s3cret-pw",
            1,
            "sslmode=require: this calflash connects without TLS",
        ),
    ] {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"));
        cmd.args(["history", "IMU-P-1"]).env("CALFLASH_DB", url);
        if pgpassword.is_empty() {
            cmd.env_remove("PGPASSWORD");
        } else {
            cmd.env("PGPASSWORD", pgpassword);
        }
        let out = cmd.output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(out.status.code(), Some(code), "{text}");
        assert!(text.contains(said), "{text}");
        assert!(!text.contains("pw"), "{text}");
    }
}

#[test]
fn a_stations_history_is_migrated_into_the_shared_database_once() {
    const T0: i64 = 1_795_478_400;
    let Some(server) =
        Server::start("a_stations_history_is_migrated_into_the_shared_database_once")
            .unwrap_or_else(|e| panic!("{e}"))
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let file = d.join("station.sqlite");
    lot_history::write(&file, "LOT-M-", 300, T0, 21, |i, b, _| {
        if i % 50 == 7 {
            b[2] += 600.0;
        }
    });
    // A calibration recorded the ordinary way, with its station.
    let (code, out, err) = calibrate(d, "IMU-M-1", "station.sqlite", "u.blob", &[]);
    assert_eq!(code, 0, "{out}{err}");
    server.execute("postgres", "CREATE DATABASE shared");
    let url = server.url("shared");
    let migrate = || {
        calflash(
            d,
            &[
                "db",
                "migrate",
                "station.sqlite",
                "--to",
                &url,
                "--station",
                "BENCH-7",
            ],
        )
    };
    let (code, out, err) = migrate();
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("301 of 301 records copied"), "{out}");
    // Again: nothing twice.
    let (code, out, err) = migrate();
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("0 of 301 records copied (301 were there already)"),
        "{out}"
    );
    // The lot reads the same from both, and the copied records kept or gained their station.
    let lot = |db: &str, json: &str| {
        let (code, out, err) = calflash(
            d,
            &[
                "lot", "LOT-M-", "--db", db, "--json", json, "--chart", "az:1",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(d.join(json)).unwrap()).unwrap()
    };
    let (a, b) = (lot("station.sqlite", "a.json"), lot(&url, "b.json"));
    assert_eq!(a["units"], 300);
    assert_eq!(a["outliers"].as_array().map(Vec::len), Some(6), "{a}");
    assert_eq!(a, b);
    let mut shared = Db::open_existing(Location::Server(url.clone())).unwrap();
    let rows = shared
        .latest_fits(&Selection {
            prefix: "LOT-M-",
            station: Some("BENCH-7"),
            ..Selection::all()
        })
        .unwrap();
    assert_eq!(rows.len(), 300, "records without a station get --station");
    let own = calflash::db::station();
    assert_eq!(
        shared
            .latest_fits(&Selection {
                prefix: "IMU-M-",
                station: Some(&own),
                ..Selection::all()
            })
            .unwrap()
            .len(),
        1,
        "a record's own station is kept"
    );
    // Into the same history it came from: refused.
    let (code, _, err) = calflash(
        d,
        &["db", "migrate", "station.sqlite", "--to", "station.sqlite"],
    );
    assert_ne!(code, 0);
    assert!(err.contains("is both the history to copy"), "{err}");
}

#[test]
fn a_history_of_schema_3_reads_without_lots_and_gains_them_when_written() {
    let h = Histories::new("a_history_of_schema_3_reads_without_lots_and_gains_them_when_written");
    for l in h.each("older") {
        Db::open(&l)
            .unwrap()
            .record_flash("U-1", &[1; 8], &serde_json::json!({}), "verified")
            .unwrap();
        let sql = "DROP INDEX records_lot; ALTER TABLE records DROP COLUMN lot";
        match &l {
            Location::File(p) => rusqlite::Connection::open(p)
                .unwrap()
                .execute_batch(&format!("{sql}; PRAGMA user_version = 3"))
                .unwrap(),
            Location::Server(_) => h.server.as_ref().unwrap().execute(
                "older",
                &format!("{sql}; UPDATE calflash_schema SET version = 3"),
            ),
        }
        let lot = Selection {
            lot: Some("L-1"),
            ..Selection::all()
        };
        let mut old = Db::open_existing(&l).unwrap();
        assert_eq!(old.history("U-1").unwrap()[0].lot, "", "{l}");
        let e = old.latest_fits(&lot).unwrap_err().to_string();
        assert!(e.contains("records no lots"), "{l}: {e}");
        drop(old);
        let mut new = Db::open(&l).unwrap();
        assert!(new.latest_fits(&lot).unwrap().is_empty(), "{l}");
        assert_eq!(new.history("U-1").unwrap().len(), 1, "{l}: kept");
    }
}

#[test]
fn a_history_of_schema_4_takes_in_flight_checks_once_written() {
    let h = Histories::new("a_history_of_schema_4_takes_in_flight_checks_once_written");
    for l in h.each("flights") {
        Db::open(&l)
            .unwrap()
            .record_flash("U-1", &[1; 8], &serde_json::json!({}), "verified")
            .unwrap();
        // Schema 4 as it was: its check knows no flights.
        let four = "'fit', 'flash', 'health'";
        match &l {
            Location::File(p) => {
                let c = rusqlite::Connection::open(p).unwrap();
                let sql: String = c
                    .query_row(
                        "SELECT sql FROM sqlite_master WHERE name = 'records'",
                        [],
                        |r| r.get(0),
                    )
                    .unwrap();
                c.execute_batch(&format!(
                    "ALTER TABLE records RENAME TO r4; DROP INDEX records_serial; DROP INDEX records_lot;
                     {}; INSERT INTO records SELECT * FROM r4; DROP TABLE r4; PRAGMA user_version = 4",
                    sql.replace("'fit', 'flash', 'health', 'flight'", four)
                ))
                .unwrap();
            }
            Location::Server(_) => h.server.as_ref().unwrap().execute(
                "flights",
                &format!(
                    "ALTER TABLE records DROP CONSTRAINT records_kind_check;
                     ALTER TABLE records ADD CONSTRAINT records_kind_check CHECK (kind IN ({four}));
                     UPDATE calflash_schema SET version = 4"
                ),
            ),
        }
        let mut db = Db::open(&l).unwrap();
        let record = serde_json::json!({"verdict": "HELD", "terms": [{"name": "accel bias x", "estimate": 0.01, "sigma": 0.02}]});
        db.record_flight("U-1", &[1; 8], &record).unwrap();
        let kinds: Vec<(String, String)> = db
            .history("U-1")
            .unwrap()
            .into_iter()
            .map(|e| (e.kind, e.outcome))
            .collect();
        assert_eq!(
            kinds,
            [
                ("flash".to_string(), "verified".to_string()),
                ("flight".to_string(), "held".to_string())
            ],
            "{l}"
        );
    }
}

/// The server `cargo xtask history` starts keeps its cluster: a database made in one run is
/// there in the next, and a port already taken is refused, naming it.
#[test]
fn a_kept_history_server_keeps_its_databases_between_runs() {
    if Server::start("a_kept_history_server_keeps_its_databases_between_runs")
        .unwrap()
        .is_none()
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cluster = dir.path().join("cluster");
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let first = Server::start_kept(&cluster, port).unwrap();
    first.execute("postgres", "CREATE DATABASE kept");
    first.execute("kept", "CREATE TABLE t (x int); INSERT INTO t VALUES (42)");
    let Err(taken) = Server::start_kept(&dir.path().join("other"), port) else {
        panic!("a second server started on the taken port {port}");
    };
    assert!(taken.contains(&port.to_string()), "{taken}");
    drop(first);
    let again = Server::start_kept(&cluster, port).unwrap();
    again.execute(
        "kept",
        "DO $$ BEGIN IF (SELECT x FROM t) <> 42 THEN RAISE 'lost'; END IF; END $$",
    );
    assert!(again.try_execute("nothere", "SELECT 1").is_err());
}
