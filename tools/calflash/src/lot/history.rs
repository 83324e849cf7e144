//! A lot as the unit history holds it: every unit a selection takes, with its newest fit,
//! judged as a lot (`calflash lot`), or without the units being calibrated (a batch's and a
//! unit's comparison with the lot).

use super::{Lot, Unit};
use crate::db::{Db, Location, Selection};

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
) -> Result<Lot, String> {
    let mut units = units(path, sel)?;
    units.retain(|u| !excluded(&u.serial));
    judge(path, sel, units, alpha)
}

fn judge(
    path: &Location,
    sel: &Selection<'_>,
    units: Vec<Unit>,
    alpha: f64,
) -> Result<Lot, String> {
    super::judge(units, alpha).map_err(|e| format!("{sel} in {path}: {e}"))
}

/// Every unit `sel` takes, with its newest fit.
fn units(path: &Location, sel: &Selection<'_>) -> Result<Vec<Unit>, String> {
    let rows = Db::open_existing(path)
        .and_then(|mut d| d.latest_fits(sel))
        .map_err(|e| e.to_string())?;
    rows.into_iter()
        .map(|row| {
            super::coefficients(&row.coefficients)
                .map(|coefficients| Unit {
                    serial: row.serial.clone(),
                    time: row.time,
                    station: row.station,
                    coefficients,
                })
                .map_err(|e| format!("{path}: the fit of {}: {e}", row.serial))
        })
        .collect()
}

/// The units `sel` takes from the history at `path`, judged at `alpha`.
///
/// # Errors
/// An unreadable history, too few units, or no shared coefficients.
pub fn load(path: &Location, sel: &Selection<'_>, alpha: f64) -> Result<Lot, String> {
    let units = units(path, sel)?;
    if units.is_empty()
        && let Some(name) = sel.lot
    {
        return Err(format!(
            "no such lot: no unit in {path} was calibrated in lot `{name}`{} (`calflash calibrate --lot {name}` records one; `calflash history` lists the units)",
            if sel.prefix.is_empty() && sel.station.is_none() {
                String::new()
            } else {
                format!(" within {sel}")
            }
        ));
    }
    judge(path, sel, units, alpha)
}
