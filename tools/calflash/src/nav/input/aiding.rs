//! The aiding sensors' files: the GNSS fixes and the barometer, each checked and named by file,
//! line and column when it cannot be read, with the units a logger gets wrong refused by name.

use std::path::Path;

use super::{Fix, FixCounts, InputError, Pressure, Table, median_rate};

/// The satellites value some receivers log while they have no fix.
pub const NO_FIX_MARKER: f64 = 193.0;

/// Reads GNSS fixes: `t` (or `ts`), `latitude`, `longitude` (degrees), optionally `height`
/// (m), `v_east v_north v_up` (m/s) and `satellites` (a row with fewer than four, or the
/// "no fix" marker 193, is counted and left out, as is a row that repeats the last fix's
/// position: a receiver holding it).
///
/// # Errors
/// As [`super::corrected`]; a latitude or longitude out of range.
pub fn gnss(path: &Path, max_rows: usize) -> Result<(Vec<Fix>, FixCounts), InputError> {
    let mut table = Table::open(path, max_rows)?;
    let what =
        "t, latitude, longitude in degrees; height, v_east, v_north, v_up, satellites optional";
    let mut cols = vec![
        table.need(&["t", "ts", "time"], what)?,
        table.need(&["latitude", "lat"], what)?,
        table.need(&["longitude", "lon"], what)?,
    ];
    let optional = [
        table.column(&["height", "alt", "altitude"]),
        table.column(&["v_east"]),
        table.column(&["v_north"]),
        table.column(&["v_up"]),
        table.column(&["satellites", "sats"]),
    ];
    cols.extend(optional.iter().map(|c| c.unwrap_or(usize::MAX)));
    let file = table.file.clone();
    let header = table.header.clone();
    let mut fixes: Vec<Fix> = Vec::new();
    let mut counts = FixCounts::default();
    let used: Vec<usize> = cols.iter().copied().filter(|c| *c != usize::MAX).collect();
    table.rows(&used, |line, v| {
        counts.rows += 1;
        let mut it = v.iter();
        let mut get = |present: bool| {
            if present {
                it.next().copied().flatten()
            } else {
                None
            }
        };
        let (t, lat, lon) = (get(true), get(true), get(true));
        let [h, ve, vn, vu, sats] = optional.map(|c| get(c.is_some()));
        let field = |col: usize, text: String, why: &'static str| InputError::Field {
            file: file.clone(),
            line,
            column: header.get(col).cloned().unwrap_or_default(),
            text,
            why,
        };
        let (Some(t), Some(lat), Some(lon)) = (t, lat, lon) else {
            counts.no_fix += 1;
            return Ok(());
        };
        if !(-90.0..=90.0).contains(&lat) {
            return Err(field(
                cols[1],
                lat.to_string(),
                "is not a latitude (degrees, -90 to 90)",
            ));
        }
        if !(-180.0..=360.0).contains(&lon) {
            return Err(field(
                cols[2],
                lon.to_string(),
                "is not a longitude (degrees)",
            ));
        }
        if sats.is_some_and(|s| s < 4.0 || s == NO_FIX_MARKER) {
            counts.no_fix += 1;
            return Ok(());
        }
        if let Some(last) = fixes.last() {
            if t < last.t {
                return Err(InputError::Backwards {
                    file: file.clone(),
                    line,
                    t,
                    before: last.t,
                });
            }
            if last.lat_lon == (lat, lon) && last.height == h {
                counts.repeated += 1;
                if counts.longest_hold.is_none_or(|(a, b)| t - last.t > b - a) {
                    counts.longest_hold = Some((last.t, t));
                }
                return Ok(());
            }
        }
        let velocity = match (ve, vn, vu) {
            (Some(e), Some(n), Some(u)) => Some([e, n, u]),
            _ => None,
        };
        fixes.push(Fix {
            t,
            lat_lon: (lat, lon),
            height: h,
            velocity,
            satellites: sats,
        });
        Ok(())
    })?;
    if let Some(what) = misread_units(&fixes) {
        return Err(InputError::Unit { file, what });
    }
    Ok((fixes, counts))
}

/// The longest median interval between GNSS fixes taken as seconds, s.
const SLOWEST_FIX: f64 = 30.0;

/// A logger's milliseconds taken as seconds, or radians as degrees, said: fixes a median of
/// over [`SLOWEST_FIX`] s apart (a receiver gives one to twenty a second: in milliseconds
/// that is 50 to 1,000), or a track that moves some 57 times slower than the file's own
/// velocities.
fn misread_units(fixes: &[Fix]) -> Option<String> {
    let steps: Vec<f64> = fixes.windows(2).map(|w| w[1].t - w[0].t).collect();
    let gap = median_rate(fixes.iter().map(|f| f.t));
    if steps.len() >= 4 && gap.is_finite() && gap > 0.0 && 1.0 / gap > SLOWEST_FIX {
        return Some(format!(
            "its fixes are a median {:.3} s apart in `t`, where a receiver gives one to twenty a second: if its times are in milliseconds, give them in seconds",
            1.0 / gap
        ));
    }
    let in_radians_range = fixes.iter().all(|f| {
        f.lat_lon.0.abs() <= std::f64::consts::FRAC_PI_2
            && f.lat_lon.1.abs() <= std::f64::consts::PI
    });
    if !in_radians_range {
        return None;
    }
    // The track's horizontal distance read as degrees, against the file's own velocities'.
    let (mut drawn, mut told) = (0.0, 0.0);
    for w in fixes.windows(2) {
        let (Some(a), Some(b)) = (w[0].velocity, w[1].velocity) else {
            continue;
        };
        let dt = w[1].t - w[0].t;
        let speed = |v: [f64; 3]| v[0].hypot(v[1]);
        told += 0.5 * (speed(a) + speed(b)) * dt;
        let metres = 6.371e6 * std::f64::consts::PI / 180.0;
        let north = (w[1].lat_lon.0 - w[0].lat_lon.0) * metres;
        let east = (w[1].lat_lon.1 - w[0].lat_lon.1) * metres * w[0].lat_lon.0.to_radians().cos();
        drawn += north.hypot(east);
    }
    let ratio = told / drawn;
    (told > 200.0 && (15.0..120.0).contains(&ratio)).then(|| {
        format!(
            "its latitudes and longitudes draw a track {ratio:.0} times shorter than its own velocities: they look like radians; give them in degrees"
        )
    })
}

/// Reads a barometer: `t` (or `ts`) and `P` (Pa).
///
/// # Errors
/// As [`super::corrected`]; a pressure outside 1 to 120,000 Pa.
pub fn baro(path: &Path, max_rows: usize) -> Result<Vec<Pressure>, InputError> {
    let mut table = Table::open(path, max_rows)?;
    let what = "t and P (static pressure, Pa)";
    let cols = [
        table.need(&["t", "ts", "time"], what)?,
        table.need(&["P", "pressure", "pressure_pa"], what)?,
    ];
    let file = table.file.clone();
    let header = table.header.clone();
    let mut out: Vec<Pressure> = Vec::new();
    table.rows(&cols, |line, v| {
        let (Some(t), Some(pa)) = (v[0], v[1]) else {
            return Ok(());
        };
        if !(1.0..=120_000.0).contains(&pa) {
            return Err(InputError::Field {
                file: file.clone(),
                line,
                column: header.get(cols[1]).cloned().unwrap_or_default(),
                text: pa.to_string(),
                why: "is not a static pressure in Pa (1 to 120,000)",
            });
        }
        if out.last().is_some_and(|p| t < p.t) {
            return Err(InputError::Backwards {
                file: file.clone(),
                line,
                t,
                before: out.last().map_or(t, |p| p.t),
            });
        }
        out.push(Pressure { t, pa });
        Ok(())
    })?;
    // A logger's hPa or kPa taken as Pa is a pressure of 30 km up or higher at the pad.
    if let Some(first) = out.first() {
        let unit = match first.pa {
            p if (300.0..1_100.0).contains(&p) => Some("hPa (mbar)"),
            p if (30.0..110.0).contains(&p) => Some("kPa"),
            _ => None,
        };
        if let Some(unit) = unit {
            return Err(InputError::Unit {
                file,
                what: format!(
                    "its first pressure, {} `Pa`, is the air 30 km up or higher; it looks like {unit}: give the pressure in Pa",
                    first.pa
                ),
            });
        }
    }
    Ok(out)
}
