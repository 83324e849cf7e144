//! A lot as the unit history holds it: every unit a selection takes, with its newest fit,
//! judged as a lot (`calflash lot`), or without the units being calibrated (a batch's and a
//! unit's comparison with the lot).

use super::{Lot, Unit};
use crate::db::{Db, Location, Selection};

/// Why a lot cannot be had from the history.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The history cannot be opened or read.
    #[error(transparent)]
    Db(#[from] crate::db::Error),
    /// A unit's fit in it holds no coefficients a lot can use.
    #[error("{path}: the fit of {serial}: {source}")]
    Fit {
        /// The history.
        path: String,
        /// The unit.
        serial: String,
        /// What is wrong with its fit.
        source: super::Error,
    },
    /// The units taken cannot be judged as a lot.
    #[error("{selection} in {path}: {source}")]
    Judge {
        /// What was taken.
        selection: String,
        /// The history.
        path: String,
        /// Why.
        source: super::Error,
    },
    /// No unit was calibrated in the lot named.
    #[error(
        "no such lot: no unit in {path} was calibrated in lot `{name}`{within} (`calflash calibrate --lot {name}` records one; `calflash history` lists the units)"
    )]
    NoSuchLot {
        /// The history.
        path: String,
        /// The lot.
        name: String,
        /// The rest of the selection, in words (empty when there is none).
        within: String,
    },
}

/// The units `sel` takes from the history at `path`, without those `excluded` (the units
/// being calibrated are compared with the others), judged at `alpha`.
///
/// # Errors
/// As [`load`].
pub fn load_without(
    path: &Location,
    sel: &Selection<'_>,
    excluded: impl Fn(&str) -> bool,
    alpha: f64,
) -> Result<Lot, HistoryError> {
    let mut units = units(path, sel)?;
    units.retain(|u| !excluded(&u.serial));
    judge(path, sel, units, alpha)
}

fn judge(
    path: &Location,
    sel: &Selection<'_>,
    units: Vec<Unit>,
    alpha: f64,
) -> Result<Lot, HistoryError> {
    super::judge(units, alpha).map_err(|source| HistoryError::Judge {
        selection: sel.to_string(),
        path: path.to_string(),
        source,
    })
}

/// Every unit `sel` takes, with its newest fit.
fn units(path: &Location, sel: &Selection<'_>) -> Result<Vec<Unit>, HistoryError> {
    let rows = Db::open_existing(path).and_then(|mut d| d.latest_fits(sel))?;
    rows.into_iter()
        .map(|row| {
            sealed_coefficients(&row)
                .and_then(|json| super::coefficients(&json))
                .map(|coefficients| Unit {
                    serial: row.serial.clone(),
                    time: row.time,
                    station: row.station,
                    coefficients,
                })
                .map_err(|source| HistoryError::Fit {
                    path: path.to_string(),
                    serial: row.serial.clone(),
                    source,
                })
        })
        .collect()
}

/// A unit's coefficients as its fit's sealed record holds them (red team four: the history's
/// `coefficients` column is covered by no seal, and a row copied into it hid a unit far from
/// its lot). A selfcal record, which has no seal, gives the column's.
fn sealed_coefficients(row: &crate::db::FitRow) -> Result<String, super::Error> {
    use crate::sensor::record::{Record, SCHEMA};
    let Some(text) = &row.record else {
        return Ok(row.coefficients.clone());
    };
    let schema = serde_json::from_str::<serde_json::Value>(text)
        .ok()
        .and_then(|v| v["schema"].as_str().map(str::to_string));
    if schema.as_deref() != Some(SCHEMA) {
        return Ok(row.coefficients.clone());
    }
    let rec: Record = serde_json::from_str(text)
        .map_err(|e| super::Error::Unsealed(format!("its record does not read ({e})")))?;
    rec.check_seal()
        .map_err(|e| super::Error::Unsealed(e.to_string()))?;
    Ok(serde_json::Value::from(crate::db::fit_coefficients(&rec)).to_string())
}

/// The units `sel` takes from the history at `path`, judged at `alpha`.
///
/// # Errors
/// An unreadable history, too few units, or no shared coefficients.
pub fn load(path: &Location, sel: &Selection<'_>, alpha: f64) -> Result<Lot, HistoryError> {
    let units = units(path, sel)?;
    if units.is_empty()
        && let Some(name) = sel.lot
    {
        return Err(HistoryError::NoSuchLot {
            path: path.to_string(),
            name: name.to_string(),
            within: if sel.prefix.is_empty() && sel.station.is_none() {
                String::new()
            } else {
                format!(" within {sel}")
            },
        });
    }
    judge(path, sel, units, alpha)
}
