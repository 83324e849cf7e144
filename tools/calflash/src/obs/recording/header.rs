//! Which column of a recording holds what: chosen by the user (`--columns`), found by the
//! header's names (`t`, `time_us`, `ax`, `acc_x`, `gyro_z`, `wx`, ...; the units their names
//! state), or by position when there is no header it recognises.

use crate::obs::squash;
use crate::obs::units::{Sensor, Unit};

/// What a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Holds {
    /// Accelerometer and gyro: six counts a line.
    Both,
    /// One triad: three counts a line.
    One,
}

impl Holds {
    pub(super) fn counts(self) -> usize {
        match self {
            Holds::Both => 6,
            Holds::One => 3,
        }
    }
}

/// Which fields hold what.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Columns {
    /// The timestamp's field and its scale to seconds (1 for a sample counter).
    pub(super) t: Option<(usize, f64)>,
    /// The time field is a sample counter (`--columns index=NAME`): it may wrap, and the rate
    /// turns it into seconds.
    pub(super) counter: bool,
    /// The time field's unit is stated (by its name's suffix, `t_us`, or by the user's
    /// `t=NAME:us`); a bare `t`, `time` or `timestamp` is read as seconds unless its steps say
    /// otherwise.
    pub(super) t_stated: bool,
    /// The fields of the counts, in order.
    pub(super) counts: Vec<usize>,
    /// The unit each count column's name states.
    pub(super) units: Vec<Option<Unit>>,
    /// The sensor of the first triad named (a file of one sensor names which).
    pub(super) sensor: Option<Sensor>,
    /// A temperature column.
    pub(super) temp: Option<usize>,
    /// The number of fields every line has (from the header, or the first sample line).
    pub(super) width: usize,
    /// The header's line, when the columns are chosen by its names.
    pub(super) header: Option<usize>,
}

/// The scale to seconds of a timestamp column named `name`, if it is one.
pub(crate) fn timestamp(name: &str) -> Option<f64> {
    let s = squash(name);
    let rest = ["timestamp", "time", "t"]
        .iter()
        .find_map(|p| s.strip_prefix(p))?;
    match rest {
        "" | "s" | "sec" => Some(1.0),
        "ms" => Some(1e-3),
        "us" => Some(1e-6),
        "ns" => Some(1e-9),
        _ => None,
    }
}

/// True when the timestamp column `name` states its unit (`t_ms`, `time_us`, `timestamp_s`),
/// not only that it is a time (`t`, `TIME`, `timestamp`).
pub(crate) fn timestamp_unit_named(name: &str) -> bool {
    let s = squash(name);
    ["timestamp", "time", "t"]
        .iter()
        .find_map(|p| s.strip_prefix(p))
        .is_some_and(|rest| !rest.is_empty())
}

/// A time column given as `NAME:UNIT` (s, ms, us, ns) or `NAME` whose name states its unit
/// (`t`, `time`, `t_ms`, `time_us`, `timestamp_ns`): the column's name and its scale to
/// seconds. `item` is what the user wrote and `role` what comes before the name where it is
/// written (`t=` in `--columns`), for the message.
///
/// # Errors
/// An unknown unit, or a name that states none.
pub fn time_column(
    spec: &str,
    item: &str,
    role: &'static str,
) -> Result<(String, f64), ColumnsError> {
    match spec.rsplit_once(':') {
        Some((n, u)) => Ok((
            n.trim().to_string(),
            timestamp(&format!("t{u}")).ok_or_else(|| ColumnsError::TimeUnit {
                item: item.to_string(),
                unit: u.to_string(),
            })?,
        )),
        None => Ok((
            spec.to_string(),
            timestamp(spec).ok_or_else(|| ColumnsError::TimeUnitUnstated {
                item: item.to_string(),
                name: spec.to_string(),
                role,
            })?,
        )),
    }
}

/// The axis (0, 1, 2) of a column of `sensor` named by `prefixes`, if it is one, with the unit
/// its name states: a prefix, the axis letter, and a unit or nothing (`ax`, `acc_x`, `AccelX`,
/// `gyro_z`, `wz`, `ax_mps2`, `gyro_x[dps]`).
pub(crate) fn axis(name: &str, prefixes: &[&str], sensor: Sensor) -> Option<(usize, Option<Unit>)> {
    let s = squash(name);
    prefixes.iter().find_map(|p| {
        let rest = s.strip_prefix(p)?;
        let k = ["x", "y", "z"].iter().position(|a| rest.starts_with(a))?;
        Some((k, Unit::suffix(&rest[1..], sensor)?))
    })
}

pub(crate) const ACCEL: [&str; 5] = ["accelerometer", "accel", "acc", "a", "raw_a"];
pub(crate) const GYRO: [&str; 6] = ["gyroscope", "gyro", "gyr", "g", "w", "omega"];

/// Columns the user chose by name (`--columns t=time_us,ax=acc_x,...,temp=die_c`): each role's
/// header name; roles not given are found by the recognised names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Chosen {
    /// The timestamp's column, with its scale to seconds.
    pub t: Option<(String, f64)>,
    /// The timestamp's unit was given (`t=stamp:ms`, `t=time_us`), not only its column.
    pub t_stated: bool,
    /// The accelerometer's x, y, z columns.
    pub accel: [Option<String>; 3],
    /// The gyro's.
    pub gyro: [Option<String>; 3],
    /// A temperature column, carried into the record.
    pub temp: Option<String>,
    /// A sample counter column taken as the time base (with the sample rate) instead of a
    /// timestamp.
    pub index: Option<String>,
}

impl Chosen {
    /// True when nothing is chosen.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// Reads `t=NAME,ax=NAME,ay=...,gz=NAME,temp=NAME`; the time column's unit comes from its
    /// name (`time_us`) or a suffix (`t=stamp:ms`).
    ///
    /// # Errors
    /// A role or a unit that is not known, or a role given twice.
    pub fn parse(text: &str) -> Result<Self, ColumnsError> {
        let mut c = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((role, name)) = item.split_once('=') else {
                return Err(ColumnsError::NotRoleName(item.to_string()));
            };
            let (role, name) = (role.trim().to_ascii_lowercase(), name.trim().to_string());
            let slot: &mut Option<String> = match role.as_str() {
                "ax" => &mut c.accel[0],
                "ay" => &mut c.accel[1],
                "az" => &mut c.accel[2],
                "gx" => &mut c.gyro[0],
                "gy" => &mut c.gyro[1],
                "gz" => &mut c.gyro[2],
                "temp" => &mut c.temp,
                "index" => &mut c.index,
                "t" => {
                    let (column, scale) = time_column(&name, item, "t=")?;
                    c.t_stated = name.contains(':') || timestamp_unit_named(&name);
                    if c.t.replace((column, scale)).is_some() {
                        return Err(ColumnsError::Twice {
                            item: item.to_string(),
                            role: "t".into(),
                        });
                    }
                    continue;
                }
                other => {
                    return Err(ColumnsError::NotRole {
                        item: item.to_string(),
                        role: other.to_string(),
                    });
                }
            };
            if slot.replace(name).is_some() {
                return Err(ColumnsError::Twice {
                    item: item.to_string(),
                    role,
                });
            }
        }
        if let (Some(_), Some(index)) = (&c.t, &c.index) {
            return Err(ColumnsError::Twice {
                item: format!("index={index}"),
                role: "the time base (t= or index=)".into(),
            });
        }
        Ok(c)
    }
}

/// `--columns` that cannot be read, or that name a column the header lacks.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ColumnsError {
    /// An item not of the form `ROLE=NAME`.
    #[error("`{0}`: expected ROLE=NAME (t, index, ax, ay, az, gx, gy, gz or temp)")]
    NotRoleName(String),
    /// A time unit that is not known.
    #[error("`{item}`: the time unit `{unit}` is not s, ms, us or ns")]
    TimeUnit {
        /// The item.
        item: String,
        /// The unit given.
        unit: String,
    },
    /// A time column whose name does not state its unit.
    #[error(
        "`{item}`: the unit of `{name}` cannot be read from its name; give it: {role}{name}:s (or ms, us, ns)"
    )]
    TimeUnitUnstated {
        /// The item.
        item: String,
        /// The column's name.
        name: String,
        /// What comes before the name where it is given (`t=` in `--columns`).
        role: &'static str,
    },
    /// A role that is not known.
    #[error("`{item}`: `{role}` is not a role; expected t, index, ax, ay, az, gx, gy, gz or temp")]
    NotRole {
        /// The item.
        item: String,
        /// The role given.
        role: String,
    },
    /// A role given twice.
    #[error("`{item}`: {role} is given twice")]
    Twice {
        /// The second item.
        item: String,
        /// The role.
        role: String,
    },
    /// A header that does not name the counts `--columns` chose.
    #[error("--columns: the header on line {header_line} does not name the counts")]
    CountsNotNamed {
        /// The header's line.
        header_line: usize,
    },
    /// `--columns` for a file without a header.
    #[error("--columns names columns, but the file has no header line before its first sample")]
    NoHeader,
    /// A chosen column the header does not have.
    #[error("--columns names `{name}`, which is not in the header; its columns are: {header}")]
    NotInHeader {
        /// The name chosen.
        name: String,
        /// The header's columns, listed.
        header: String,
    },
}

/// A count column found: its field, the unit its name states, its sensor.
type Found = (usize, Option<Unit>, Sensor);

/// The index of the header field named `name` (case aside).
fn position(header: &[&str], name: &str) -> Option<usize> {
    header.iter().position(|h| h.eq_ignore_ascii_case(name))
}

/// The columns a header on line `line` names, when it names all the counts `holds` needs.
pub(super) fn named(
    header: &[&str],
    line: usize,
    holds: Holds,
    chosen: &Chosen,
) -> Result<Option<Columns>, ColumnsError> {
    let missing = |name: &str| ColumnsError::NotInHeader {
        name: name.to_string(),
        header: header.join(", "),
    };
    // A sensor's three columns: the chosen names where given (`None` when a file of one sensor
    // has none of them: it is the other sensor's file), the recognised names otherwise.
    let find = |prefixes: &[&str],
                sensor: Sensor,
                names: &[Option<String>; 3]|
     -> Result<Option<[Found; 3]>, ColumnsError> {
        let given: Vec<&String> = names.iter().flatten().collect();
        if holds == Holds::One
            && !given.is_empty()
            && given.iter().all(|n| position(header, n).is_none())
        {
            return Ok(None);
        }
        let mut out = [None; 3];
        for (i, h) in header.iter().enumerate() {
            if let Some((k, unit)) = axis(h, prefixes, sensor) {
                out[k].get_or_insert((i, unit, sensor));
            }
        }
        for (k, name) in names.iter().enumerate() {
            if let Some(name) = name {
                let i = position(header, name).ok_or_else(|| missing(name))?;
                let unit = axis(name, prefixes, sensor).and_then(|(_, u)| u);
                out[k] = Some((i, unit, sensor));
            }
        }
        Ok(match out {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            _ => None,
        })
    };
    let t = match (&chosen.t, &chosen.index) {
        (Some((name, scale)), _) => {
            Some((position(header, name).ok_or_else(|| missing(name))?, *scale))
        }
        (None, Some(name)) => Some((position(header, name).ok_or_else(|| missing(name))?, 1.0)),
        (None, None) => header
            .iter()
            .enumerate()
            .find_map(|(i, h)| timestamp(h).map(|s| (i, s))),
    };
    let t_stated = match (&chosen.t, &chosen.index) {
        (Some(_), _) => chosen.t_stated,
        (None, Some(_)) => true,
        (None, None) => t.is_some_and(|(i, _)| timestamp_unit_named(header[i])),
    };
    let temp = match &chosen.temp {
        Some(name) => Some(position(header, name).ok_or_else(|| missing(name))?),
        None => header.iter().position(|h| squash(h).starts_with("temp")),
    };
    let a = find(&ACCEL, Sensor::Accel, &chosen.accel)?;
    let g = find(&GYRO, Sensor::Gyro, &chosen.gyro)?;
    let found: Vec<Found> = match (holds, a, g) {
        (Holds::Both, Some(a), Some(g)) => a.into_iter().chain(g).collect(),
        (Holds::One, Some(a), _) => a.to_vec(),
        (Holds::One, None, Some(g)) => g.to_vec(),
        _ => return Ok(None),
    };
    Ok(Some(Columns {
        t,
        counter: chosen.t.is_none() && chosen.index.is_some(),
        t_stated,
        counts: found.iter().map(|f| f.0).collect(),
        units: found.iter().map(|f| f.1).collect(),
        sensor: found.first().map(|f| f.2),
        temp,
        width: header.len(),
        header: Some(line),
    }))
}

/// The columns of a file without a recognised header, from its first sample line's width.
pub(super) fn positional(width: usize, holds: Holds) -> Option<Columns> {
    let n = holds.counts();
    let t = if width == n + 1 {
        Some((0, 1.0))
    } else if width == n {
        None
    } else {
        return None;
    };
    let first = usize::from(t.is_some());
    Some(Columns {
        t,
        counter: false,
        t_stated: false,
        counts: (first..first + n).collect(),
        units: vec![None; n],
        sensor: None,
        temp: None,
        width,
        header: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_read_roles_and_time_units_or_say_what_is_wrong() {
        let c = Chosen::parse("t=stamp:ms, AX=a1, ay=a2, az=a3, temp=die").unwrap();
        assert_eq!(c.t, Some(("stamp".into(), 1e-3)));
        assert_eq!(c.accel[0].as_deref(), Some("a1"));
        assert_eq!(c.temp.as_deref(), Some("die"));
        let err = |text: &str| Chosen::parse(text).unwrap_err();
        assert_eq!(err("ax"), ColumnsError::NotRoleName("ax".into()));
        assert!(matches!(err("t=stamp:min"), ColumnsError::TimeUnit { unit, .. } if unit == "min"));
        assert_eq!(
            err("t=stamp").to_string(),
            "`t=stamp`: the unit of `stamp` cannot be read from its name; give it: t=stamp:s (or ms, us, ns)"
        );
        assert!(matches!(err("ax=a, ax=b"), ColumnsError::Twice { role, .. } if role == "ax"));
        assert!(matches!(err("mx=m"), ColumnsError::NotRole { role, .. } if role == "mx"));
    }
}
