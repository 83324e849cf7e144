//! The history's schema, shared by both backends: its version, the columns of `records` and
//! those older versions lack, and a record as the backends write and list it.

use super::{Cause, Selection};

/// The schema version this calflash reads and writes. On SQLite (`PRAGMA user_version`)
/// version 0 is a database of the releases before versioning, version 1 one whose records are
/// fits and flashes only, version 2 one without the recording station, version 3 one without
/// the production lot, version 4 one without in-flight checks; all are migrated (in one
/// transaction) when written to, by rebuilding the table so that it takes every kind of
/// record and has every column (empty for the records before them). On PostgreSQL (table
/// `calflash_schema`) version 3 lacks the lot and version 4 the flights, both gained when
/// written to. Read-only, an older history reads with no stations or lots.
pub const SCHEMA_VERSION: i64 = 5;

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

/// The columns that older schemas lack.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Later {
    /// `station` (schema 3).
    pub(super) station: bool,
    /// `lot` (schema 4).
    pub(super) lot: bool,
}

impl Later {
    /// All of them: the present schema.
    pub(super) const ALL: Self = Self {
        station: true,
        lot: true,
    };

    /// The SQL of column `name` (present in the table when `have`): the column, else an empty
    /// text.
    pub(super) fn column(have: bool, name: &str) -> &str {
        if have { name } else { "''" }
    }

    /// Refuses a selection by a column the history lacks.
    pub(super) fn check(self, sel: &Selection<'_>) -> Result<(), Cause> {
        for (asked, have, what) in [
            (sel.station.is_some(), self.station, "stations"),
            (sel.lot.is_some(), self.lot, "lots"),
        ] {
            if asked && !have {
                return Err(Cause::Lacks(what));
            }
        }
        Ok(())
    }
}

/// Checks that a table with columns `have` is calflash's `records`; which later columns it
/// has.
pub(super) fn check_columns(have: &[String]) -> Result<Later, Cause> {
    match COLUMNS.iter().find(|c| !have.iter().any(|h| h == *c)) {
        Some(missing) => Err(Cause::MissingColumn(missing)),
        None => Ok(Later {
            station: have.iter().any(|h| h == "station"),
            lot: have.iter().any(|h| h == "lot"),
        }),
    }
}

/// The columns a record is written in, in the order of [`row_values!`].
pub(super) const WRITTEN: &str = "serial, kind, time, data_hash, model, coefficients, covariance, report, blob, verification, outcome, record, station, lot";

/// A [`Row`]'s values in the order of [`WRITTEN`], as an array of references to the backend's
/// parameter type (the function's return type says which).
macro_rules! row_values {
    ($row:expr) => {
        [
            &$row.serial,
            &$row.kind,
            &$row.time,
            &$row.data_hash,
            &$row.model,
            &$row.coefficients,
            &$row.covariance,
            &$row.report,
            &$row.blob,
            &$row.verification,
            &$row.outcome,
            &$row.record,
            &$row.station,
            &$row.lot,
        ]
    };
}
pub(super) use row_values;

/// One record as both backends store it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Row {
    pub(super) serial: String,
    pub(super) kind: String,
    pub(super) time: i64,
    pub(super) data_hash: String,
    pub(super) model: Option<String>,
    pub(super) coefficients: Option<String>,
    pub(super) covariance: Option<String>,
    pub(super) report: Option<String>,
    pub(super) blob: Vec<u8>,
    pub(super) verification: Option<String>,
    pub(super) outcome: String,
    pub(super) record: Option<String>,
    pub(super) station: String,
    pub(super) lot: String,
}

/// One record as a unit's history lists it.
pub(super) struct Listed {
    pub(super) id: i64,
    pub(super) kind: String,
    pub(super) time: i64,
    pub(super) data_hash: String,
    pub(super) model: Option<String>,
    pub(super) outcome: String,
    pub(super) report: Option<String>,
    pub(super) blob: Vec<u8>,
    pub(super) lot: String,
    /// A flash's verification (JSON), with the unit's trust.
    pub(super) verification: Option<String>,
}
