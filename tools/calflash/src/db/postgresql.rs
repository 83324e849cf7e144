//! The unit history in a PostgreSQL database that several stations share
//! (`--db postgres://USER:PASSWORD@HOST:PORT/DATABASE`).
//!
//! The same `records` table as the SQLite history, and its version in a one-row table
//! `calflash_schema` (PostgreSQL has no `user_version`). A record is one `INSERT`, whole or
//! absent; stations writing at once each get their own id from the table's sequence. The
//! first station to open an empty database creates the tables, under an advisory lock so that
//! two stations starting together do not both try; a database that holds tables of another
//! program is never taken over. Connections are made without TLS (the
//! plant's network or a local socket), with a 10 s timeout unless the URL sets one; a URL
//! without a password takes `$PGPASSWORD`'s (`~/.pgpass` is not read).

use std::time::Duration;

use postgres::error::SqlState;
use postgres::types::{ToSql, Type};
use postgres::{Client, NoTls};

use super::schema::{Later, Listed, Row};
use super::{Backend, Cause, FitRow, SCHEMA_VERSION, Selection};

/// A PostgreSQL history.
pub struct Postgres {
    /// The connection: `Some` until it is dropped (and kept for the next history opened).
    client: Option<Client>,
    url: String,
    /// The schema version and the columns of later schemas the table has (a version 3
    /// history opened to read lacks the lot).
    version: i64,
    later: Later,
}

/// A connection this process is done with, and the schema it found.
struct Idle {
    url: String,
    client: Client,
    version: i64,
    later: Later,
}

/// Connections this process opened and is done with: a batch's units take them again instead
/// of connecting (a server process each) and checking the schema once per unit.
static IDLE: std::sync::Mutex<Vec<Idle>> = std::sync::Mutex::new(Vec::new());

/// At most this many idle connections are kept.
const MAX_IDLE: usize = 8;

/// An idle connection to `url` whose schema is still `version`; `None` when there is none
/// (or the schema changed: the connection is then dropped).
fn reuse(url: &str) -> Option<Idle> {
    let mut idle = {
        let mut pool = IDLE.lock().ok()?;
        let at = pool.iter().position(|i| i.url == url)?;
        pool.swap_remove(at)
    };
    let version: Option<i32> = idle
        .client
        .query_one("SELECT max(version) FROM calflash_schema", &[])
        .ok()?
        .get(0);
    (i64::from(version.unwrap_or(0)) == idle.version).then_some(idle)
}

impl Drop for Postgres {
    fn drop(&mut self) {
        if let Some(client) = self.client.take()
            && !client.is_closed()
            && let Ok(mut pool) = IDLE.lock()
            && pool.len() < MAX_IDLE
        {
            pool.push(Idle {
                url: std::mem::take(&mut self.url),
                client,
                version: self.version,
                later: self.later,
            });
        }
    }
}

/// The tables of the present schema.
const SCHEMA: &str = "CREATE TABLE calflash_schema (version INTEGER NOT NULL);
CREATE TABLE records (
    id BIGSERIAL PRIMARY KEY,
    serial TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN ('fit', 'flash', 'health', 'flight')),
    time BIGINT NOT NULL,
    data_hash TEXT NOT NULL,
    model TEXT,
    coefficients TEXT,
    covariance TEXT,
    report TEXT,
    blob BYTEA NOT NULL,
    verification TEXT,
    outcome TEXT NOT NULL,
    record TEXT,
    station TEXT NOT NULL DEFAULT '',
    lot TEXT NOT NULL DEFAULT ''
);
CREATE INDEX records_serial ON records (serial, time);
CREATE INDEX records_lot ON records (lot);
";

/// Adds the lot to a version 3 history (the first on PostgreSQL).
const MIGRATE_FROM_3: &str = "ALTER TABLE records ADD COLUMN lot TEXT NOT NULL DEFAULT '';
CREATE INDEX records_lot ON records (lot);
UPDATE calflash_schema SET version = 4;
";

/// Lets a version 4 history take in-flight checks (kind `flight`).
const MIGRATE_FROM_4: &str = "ALTER TABLE records DROP CONSTRAINT IF EXISTS records_kind_check;
ALTER TABLE records ADD CONSTRAINT records_kind_check
    CHECK (kind IN ('fit', 'flash', 'health', 'flight'));
UPDATE calflash_schema SET version = 5;
";

/// The advisory lock under which a station creates the tables ("calf").
const CREATE_LOCK: i64 = 0x6361_6c66;

use super::schema::WRITTEN as COLUMNS;

/// Why the server or the connection failed, in the station's words.
fn why(e: postgres::Error) -> Cause {
    Cause::Postgres {
        why: explain(&e),
        source: e,
    }
}

/// What a client error means for the station.
fn explain(e: &postgres::Error) -> String {
    if let Some(db) = e.as_db_error() {
        let msg = db.message();
        let code = db.code();
        return if *code == SqlState::INVALID_PASSWORD
            || *code == SqlState::INVALID_AUTHORIZATION_SPECIFICATION
        {
            format!("the server refused the login: {msg}")
        } else if *code == SqlState::INVALID_CATALOG_NAME {
            format!("{msg} (the database must be created first: createdb, or CREATE DATABASE)")
        } else if *code == SqlState::INSUFFICIENT_PRIVILEGE {
            format!("the server refused: {msg} (the login may not read or write the history)")
        } else if *code == SqlState::DISK_FULL {
            format!("the server's disk is full: {msg}")
        } else if *code == SqlState::READ_ONLY_SQL_TRANSACTION {
            format!("the server only reads (a standby?): {msg}")
        } else if code.code().starts_with("57") || code.code().starts_with("08") {
            format!("the server is unavailable: {msg}")
        } else {
            format!("the server said: {msg}")
        };
    }
    // The cause (a refused connection, a timeout) is in the error's sources.
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        text = format!("{text}: {s}");
        source = s.source();
    }
    if text.contains("password missing") {
        return "the server asks for a password and the URL gives none".into();
    }
    if e.is_closed() {
        return format!("the connection to the server was lost ({text})");
    }
    format!("the server cannot be reached ({text}): is it running, and listening there?")
}

/// Connects to `url`; a URL without a password takes `$PGPASSWORD`'s, as `psql` does.
fn connect(url: &str) -> Result<Client, Cause> {
    let mut config: postgres::Config = url.parse().map_err(Cause::Url)?;
    if config.get_ssl_mode() == postgres::config::SslMode::Require {
        return Err(Cause::TlsRequired);
    }
    if config.get_password().is_none()
        && let Some(p) = std::env::var_os("PGPASSWORD")
    {
        config.password(p.as_encoded_bytes());
    }
    if config.get_connect_timeout().is_none() {
        config.connect_timeout(Duration::from_secs(10));
    }
    config.application_name("calflash");
    config.connect(NoTls).map_err(why)
}

/// Which of the tables are there: `(calflash_schema, records)`.
fn tables(c: &mut impl postgres::GenericClient) -> Result<(bool, bool), Cause> {
    let row = c
        .query_one(
            "SELECT to_regclass('calflash_schema') IS NOT NULL, to_regclass('records') IS NOT NULL",
            &[],
        )
        .map_err(why)?;
    Ok((row.get(0), row.get(1)))
}

/// How many tables, views, sequences and other relations of its own the database holds,
/// outside the system's schemas.
fn own_objects(c: &mut impl postgres::GenericClient) -> Result<i64, Cause> {
    let row = c
        .query_one(
            "SELECT count(*) FROM pg_class r JOIN pg_namespace n ON n.oid = r.relnamespace
             WHERE r.relkind IN ('r', 'p', 'v', 'm', 'f', 'S')
               AND n.nspname NOT IN ('pg_catalog', 'information_schema')
               AND n.nspname NOT LIKE 'pg\\_toast%'
               AND n.nspname NOT LIKE 'pg\\_temp\\_%'",
            &[],
        )
        .map_err(why)?;
    Ok(row.get(0))
}

/// Checks the version and columns of an existing history; migrates versions 3 and 4 when
/// `write`.
/// The version and the later columns the table (now) has.
fn check_schema(c: &mut impl postgres::GenericClient, write: bool) -> Result<(i64, Later), Cause> {
    let version: Option<i32> = c
        .query_one("SELECT max(version) FROM calflash_schema", &[])
        .map_err(why)?
        .get(0);
    let version = i64::from(version.unwrap_or(0));
    schema_version(version)?;
    let have: Vec<String> = c
        .query(
            "SELECT attname::text FROM pg_attribute
             WHERE attrelid = 'records'::regclass AND attnum > 0 AND NOT attisdropped",
            &[],
        )
        .map_err(why)?
        .iter()
        .map(|r| r.get(0))
        .collect();
    let later = super::schema::check_columns(&have)?;
    if version < SCHEMA_VERSION && write {
        if version < 4 {
            c.batch_execute(MIGRATE_FROM_3).map_err(why)?;
        }
        c.batch_execute(MIGRATE_FROM_4).map_err(why)?;
        return Ok((SCHEMA_VERSION, Later::ALL));
    }
    Ok((version, later))
}

/// Refuses a schema version this calflash does not read.
fn schema_version(version: i64) -> Result<(), Cause> {
    if version > SCHEMA_VERSION {
        return Err(Cause::NewerSchema(version));
    }
    if version < 3 {
        return Err(Cause::UnknownSchema(version));
    }
    Ok(())
}

fn params(row: &Row) -> [&(dyn ToSql + Sync); 14] {
    super::schema::row_values!(row)
}

impl Postgres {
    /// Connects to the history at `url`, creating its tables in an empty database.
    pub(super) fn open(url: &str) -> Result<Self, Cause> {
        if let Some(idle) = reuse(url).filter(|i| i.version == SCHEMA_VERSION) {
            return Ok(Self::from(idle));
        }
        let mut client = connect(url)?;
        let mut tx = client.transaction().map_err(why)?;
        tx.execute("SELECT pg_advisory_xact_lock($1)", &[&CREATE_LOCK])
            .map_err(why)?;
        match tables(&mut tx)? {
            (false, false) => {
                let theirs = own_objects(&mut tx)?;
                if theirs > 0 {
                    return Err(Cause::ForeignDatabase(theirs));
                }
                tx.batch_execute(SCHEMA).map_err(why)?;
                tx.execute(
                    "INSERT INTO calflash_schema (version) VALUES ($1)",
                    &[&(SCHEMA_VERSION as i32)],
                )
                .map_err(why)?;
            }
            (true, _) => {
                check_schema(&mut tx, true)?;
            }
            (false, true) => return Err(Cause::ForeignTable),
        }
        tx.commit().map_err(why)?;
        Ok(Self {
            client: Some(client),
            url: url.to_string(),
            version: SCHEMA_VERSION,
            later: Later::ALL,
        })
    }

    /// Connects to the history at `url` to read it: never creates the tables.
    pub(super) fn open_existing(url: &str) -> Result<Self, Cause> {
        if let Some(idle) = reuse(url) {
            return Ok(Self::from(idle));
        }
        let mut client = connect(url)?;
        match tables(&mut client)? {
            (false, false) => Err(Cause::NoTables),
            (false, true) => Err(Cause::ForeignTable),
            (true, _) => {
                let (version, later) = check_schema(&mut client, false)?;
                Ok(Self {
                    client: Some(client),
                    url: url.to_string(),
                    version,
                    later,
                })
            }
        }
    }

    /// The connection.
    fn client(&mut self) -> &mut Client {
        self.client
            .as_mut()
            .expect("a history's connection is there until it is dropped")
    }
}

impl From<Idle> for Postgres {
    fn from(i: Idle) -> Self {
        Self {
            client: Some(i.client),
            url: i.url,
            version: i.version,
            later: i.later,
        }
    }
}

impl Backend for Postgres {
    fn insert(&mut self, row: &Row) -> Result<i64, Cause> {
        let sql = format!(
            "INSERT INTO records ({COLUMNS}) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14) RETURNING id"
        );
        // One statement: PostgreSQL commits it whole or not at all.
        self.client()
            .query_one(&sql, &params(row))
            .map(|r| r.get(0))
            .map_err(why)
    }

    fn copy(&mut self, rows: &[Row]) -> Result<usize, Cause> {
        let mut tx = self.client().transaction().map_err(why)?;
        tx.batch_execute(
            "CREATE TEMPORARY TABLE incoming (ord BIGINT, serial TEXT, kind TEXT, time BIGINT,
             data_hash TEXT, model TEXT, coefficients TEXT, covariance TEXT, report TEXT,
             blob BYTEA, verification TEXT, outcome TEXT, record TEXT, station TEXT, lot TEXT)
             ON COMMIT DROP",
        )
        .map_err(why)?;
        let sink = tx
            .copy_in(&format!(
                "COPY incoming (ord, {COLUMNS}) FROM STDIN (FORMAT binary)"
            ))
            .map_err(why)?;
        let types = [
            Type::INT8,
            Type::TEXT,
            Type::TEXT,
            Type::INT8,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
            Type::BYTEA,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
            Type::TEXT,
        ];
        let mut w = postgres::binary_copy::BinaryCopyInWriter::new(sink, &types);
        for (ord, row) in rows.iter().enumerate() {
            let ord = ord as i64;
            let mut values: Vec<&(dyn ToSql + Sync)> = vec![&ord];
            values.extend(params(row));
            w.write(&values).map_err(why)?;
        }
        w.finish().map_err(why)?;
        // Only what the history did not hold before the copy: a second copy adds nothing.
        let copied = tx
            .execute(
                &format!(
                    "INSERT INTO records ({COLUMNS}) SELECT {COLUMNS} FROM incoming i
                     WHERE NOT EXISTS (SELECT 1 FROM records r WHERE r.serial = i.serial
                       AND r.kind = i.kind AND r.time = i.time AND r.data_hash = i.data_hash
                       AND r.outcome = i.outcome AND r.station = i.station AND r.blob = i.blob)
                     ORDER BY ord"
                ),
                &[],
            )
            .map_err(why)?;
        tx.commit().map_err(why)?;
        Ok(copied as usize)
    }

    fn history(&mut self, serial: &str) -> Result<Vec<Listed>, Cause> {
        let sql = format!(
            "SELECT id, kind, time, data_hash, model, outcome, report, blob, {}, verification
             FROM records WHERE serial = $1 ORDER BY time, id",
            Later::column(self.later.lot, "lot")
        );
        let rows = self.client().query(&sql, &[&serial]).map_err(why)?;
        Ok(rows
            .iter()
            .map(|r| Listed {
                id: r.get(0),
                kind: r.get(1),
                time: r.get(2),
                data_hash: r.get(3),
                model: r.get(4),
                outcome: r.get(5),
                report: r.get(6),
                blob: r.get(7),
                lot: r.get(8),
                verification: r.get(9),
            })
            .collect())
    }

    fn latest_fits(&mut self, sel: &Selection<'_>) -> Result<Vec<FitRow>, Cause> {
        self.later.check(sel)?;
        // The newest fit per serial: the greatest (time, id) of its fits in the range.
        let sql = format!(
            "SELECT serial, time, station, coefficients, record FROM (
               SELECT DISTINCT ON (serial) serial, time, id, station, coefficients, record
               FROM records
               WHERE kind = 'fit' AND left(serial, length($1)) = $1
                 AND time BETWEEN $2 AND $3 AND ($4::text IS NULL OR station = $4)
                 AND ($5::text IS NULL OR {} = $5)
               ORDER BY serial, time DESC, id DESC) n
             WHERE coefficients IS NOT NULL
             ORDER BY time, id",
            Later::column(self.later.lot, "lot")
        );
        let rows = self
            .client()
            .query(
                &sql,
                &[&sel.prefix, &sel.since, &sel.until, &sel.station, &sel.lot],
            )
            .map_err(why)?;
        Ok(rows
            .iter()
            .map(|r| FitRow {
                serial: r.get(0),
                time: r.get(1),
                station: r.get(2),
                coefficients: r.get(3),
                record: r.get(4),
            })
            .collect())
    }

    fn blobs(&mut self, serial: &str) -> Result<Vec<Vec<u8>>, Cause> {
        let rows = self
            .client()
            .query("SELECT blob FROM records WHERE serial = $1", &[&serial])
            .map_err(why)?;
        Ok(rows.iter().map(|r| r.get(0)).collect())
    }

    fn record(&mut self, id: i64) -> Result<Option<Option<String>>, Cause> {
        let row = self
            .client()
            .query_opt("SELECT record FROM records WHERE id = $1", &[&id])
            .map_err(why)?;
        Ok(row.map(|r| r.get(0)))
    }

    fn rows(&mut self) -> Result<Vec<Row>, Cause> {
        let columns = COLUMNS.replace(
            ", lot",
            &format!(", {}", Later::column(self.later.lot, "lot")),
        );
        let rows = self
            .client()
            .query(&format!("SELECT {columns} FROM records ORDER BY id"), &[])
            .map_err(why)?;
        Ok(rows
            .iter()
            .map(|r| Row {
                serial: r.get(0),
                kind: r.get(1),
                time: r.get(2),
                data_hash: r.get(3),
                model: r.get(4),
                coefficients: r.get(5),
                covariance: r.get(6),
                report: r.get(7),
                blob: r.get(8),
                verification: r.get(9),
                outcome: r.get(10),
                record: r.get(11),
                station: r.get(12),
                lot: r.get(13),
            })
            .collect())
    }
}
