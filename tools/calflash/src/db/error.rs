//! Why a unit history could not do what was asked, in the station's words.

use super::{Location, SCHEMA_VERSION};

/// A failure of the unit history, naming it (a server's URL without its password).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The history at `location` could not be opened, read or written; nothing was written.
    #[error("the unit history database {location}: {cause}")]
    History {
        /// Where the history is.
        location: Location,
        /// Why it failed.
        #[source]
        cause: Cause,
    },
    /// `compare db:ID` of a record the history does not hold.
    #[error("{location}: no record {id}")]
    NoRecord {
        /// Where the history is.
        location: Location,
        /// The record asked for.
        id: i64,
    },
    /// `compare db:ID` of a flash.
    #[error(
        "{location}: record {id} is a flash, not a calibration; compare calibrations (`calflash history` lists them)"
    )]
    NotACalibration {
        /// Where the history is.
        location: Location,
        /// The record asked for.
        id: i64,
    },
}

/// Why a history failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Cause {
    /// SQLite refused; `why` says it as a station would (a read-only file, a full disk).
    #[error("{why}")]
    Sqlite {
        /// What it means for the station.
        why: String,
        /// SQLite's own error.
        #[source]
        source: rusqlite::Error,
    },
    /// The PostgreSQL server or the connection to it failed.
    #[error("{why}")]
    Postgres {
        /// What it means for the station (a refused login, a server down).
        why: String,
        /// The client's own error.
        #[source]
        source: postgres::Error,
    },
    /// The directory of a new history file cannot be made.
    #[error("{0}")]
    Directory(#[source] std::io::Error),
    /// The `--db` URL does not parse.
    #[error("not a PostgreSQL URL this calflash reads: {0}")]
    Url(#[source] postgres::Error),
    /// The URL asks for TLS, which this client does not speak.
    #[error(
        "sslmode=require: this calflash connects without TLS (a server on the plant's network \
         or this machine); drop sslmode or give sslmode=disable"
    )]
    TlsRequired,
    /// A history written by a newer calflash: read and written by nobody.
    #[error(
        "written by a newer calflash (schema {0}); this one reads schema {SCHEMA_VERSION} and changes nothing in it"
    )]
    NewerSchema(i64),
    /// A `calflash_schema` table naming a version no calflash wrote on PostgreSQL.
    #[error(
        "its calflash_schema says schema {0}, which no calflash wrote on PostgreSQL (they \
         write schema 3 and later); nothing was read or written"
    )]
    UnknownSchema(i64),
    /// The `records` table lacks a column calflash reads.
    #[error(
        "its table `records` has no column `{0}`: it was altered or is not calflash's; nothing was read or written"
    )]
    MissingColumn(&'static str),
    /// A PostgreSQL database with a `records` table that is not calflash's.
    #[error(
        "it has a table `records` but no `calflash_schema`: the table is not calflash's; \
         nothing was read or written"
    )]
    ForeignTable,
    /// A PostgreSQL database without calflash's tables that holds tables of its own: another
    /// program's database, which calflash never takes over.
    #[error(
        "it holds {0} table(s) or other object(s) of its own and no calflash history: it is \
         another program's database; calflash creates its tables only in an empty database \
         (createdb a new one for the history); nothing was written"
    )]
    ForeignDatabase(i64),
    /// A SQLite file without calflash's table that is not empty: another program's.
    #[error(
        "it has no table `records` but {} (schema {version}, {objects} other object(s)): it is \
         not a calflash history this version can write; nothing was written",
        if *.version > SCHEMA_VERSION { "was written by a newer program" } else { "is not empty" }
    )]
    NotAHistory {
        /// Its `PRAGMA user_version`.
        version: i64,
        /// How many tables, indices and views it has.
        objects: i64,
    },
    /// No history file there, to read (reading creates none).
    #[error("there is none (give the one the station records in with --db, or $CALFLASH_DB)")]
    NoFile,
    /// A PostgreSQL database without the history's tables, to read.
    #[error(
        "it holds no calflash history (nothing has been recorded there yet; the first \
         calibration recorded there creates it)"
    )]
    NoTables,
    /// A selection by stations or lots of an older history opened to read.
    #[error(
        "it records no {0} (an older schema, opened to read: it gains them when a calflash of schema {SCHEMA_VERSION} writes to it)"
    )]
    Lacks(&'static str),
}

impl Cause {
    /// This cause at `location`.
    pub(super) fn at(self, location: &Location) -> Error {
        Error::History {
            location: location.clone(),
            cause: self,
        }
    }
}

/// A record the history could not take, and where it went instead.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NotRecorded {
    /// Saved as JSON beside the outputs.
    #[error("NOT recorded: {cause}; the record is saved in {} instead", .saved.display())]
    Saved {
        /// Why the history did not take it.
        #[source]
        cause: Box<Error>,
        /// The JSON file that holds it.
        saved: std::path::PathBuf,
    },
    /// Neither recorded nor saved.
    #[error("NOT recorded: {cause}; nor could it be saved in {} ({why})", .file.display())]
    Lost {
        /// Why the history did not take it.
        #[source]
        cause: Box<Error>,
        /// Where it was to be saved.
        file: std::path::PathBuf,
        /// Why it could not be.
        why: crate::files::Error,
    },
}
