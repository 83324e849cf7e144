//! Which column of a mission profile holds what: found by the header's names (`t`, `ts`,
//! `time_ms`; `f_x`, `ax`, `acc_x`; `w_x`, `gx`, `gyro_x`; `dw_x`; `temp`; `volt`) with the unit
//! a name states (`ax_g`, `gyro_x_dps`), or chosen (`--mission-columns t=ts,fx=Ay:m/s^2,...`).
//! A quantity whose unit is neither stated nor chosen is read as SI, and the profile says so.

use crate::obs::recording::header;
use crate::obs::squash;
use crate::obs::units::{Sensor, Unit};

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Time.
    T,
    /// Specific force along an axis.
    F(usize),
    /// Angular rate about an axis.
    W(usize),
    /// Angular acceleration about an axis.
    Dw(usize),
    /// Temperature, C.
    Temp,
    /// Supply voltage, V.
    Volt,
}

impl Role {
    /// The role's name in `--mission-columns`.
    #[must_use]
    pub fn name(self) -> String {
        let xyz = ["x", "y", "z"];
        match self {
            Self::T => "t".into(),
            Self::F(k) => format!("f{}", xyz[k]),
            Self::W(k) => format!("w{}", xyz[k]),
            Self::Dw(k) => format!("dw{}", xyz[k]),
            Self::Temp => "temp".into(),
            Self::Volt => "volt".into(),
        }
    }

    fn parse(text: &str) -> Option<Self> {
        let s = squash(text);
        let axis = |rest: &str| ["x", "y", "z"].iter().position(|a| *a == rest);
        match s.as_str() {
            "t" => Some(Self::T),
            "temp" => Some(Self::Temp),
            "volt" => Some(Self::Volt),
            _ => {
                if let Some(r) = s.strip_prefix("dw") {
                    axis(r).map(Self::Dw)
                } else if let Some(r) = s.strip_prefix('f').or_else(|| s.strip_prefix('a')) {
                    axis(r).map(Self::F)
                } else if let Some(r) = s.strip_prefix('w').or_else(|| s.strip_prefix('g')) {
                    axis(r).map(Self::W)
                } else {
                    None
                }
            }
        }
    }

    /// The SI unit of the role's values.
    #[must_use]
    pub fn si(self) -> &'static str {
        match self {
            Self::T => "s",
            Self::F(_) => "m/s^2",
            Self::W(_) => "rad/s",
            Self::Dw(_) => "rad/s^2",
            Self::Temp => "C",
            Self::Volt => "V",
        }
    }
}

/// The roles, in the order a profile lists them.
pub const ROLES: [Role; 12] = [
    Role::T,
    Role::F(0),
    Role::F(1),
    Role::F(2),
    Role::W(0),
    Role::W(1),
    Role::W(2),
    Role::Dw(0),
    Role::Dw(1),
    Role::Dw(2),
    Role::Temp,
    Role::Volt,
];

/// One column's choice: its header name and its scale to SI, `None` when the unit was not
/// stated (SI assumed).
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// What it holds.
    pub role: Role,
    /// The header's name.
    pub name: String,
    /// Its scale to SI and the unit's name, when stated.
    pub unit: Option<(f64, &'static str)>,
}

/// `--mission-columns` that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ColumnsError {
    /// An item not of the form `ROLE=NAME[:UNIT]`.
    #[error(
        "--mission-columns `{0}`: expected ROLE=NAME or ROLE=NAME:UNIT, ROLE one of t, fx, fy, fz, wx, wy, wz, dwx, dwy, dwz, temp, volt"
    )]
    NotRoleName(String),
    /// A unit that is not known for the role.
    #[error("--mission-columns `{item}`: `{unit}` is not a unit of {role} (expected {expected})")]
    Unit {
        /// The item.
        item: String,
        /// The unit given.
        unit: String,
        /// The role.
        role: String,
        /// What the role takes.
        expected: &'static str,
    },
    /// A role given twice.
    #[error("--mission-columns `{0}`: that role is given twice")]
    Twice(String),
    /// One column given to two roles.
    #[error(
        "--mission-columns `{item}`: column `{name}` is already {other}; each role reads its own column"
    )]
    SameColumn {
        /// The item.
        item: String,
        /// The column.
        name: String,
        /// The role it already has.
        other: String,
    },
}

/// The scale to SI of `unit` for `role`, and its name.
fn unit_of(role: Role, unit: &str) -> Option<(f64, &'static str)> {
    let physical = |u: Unit| match u {
        Unit::Physical { name, to_si } => Some((to_si, name)),
        Unit::Counts => None,
    };
    match role {
        Role::T => header::timestamp(&format!("t{unit}")).map(|s| (s, time_unit(s))),
        Role::F(_) => Unit::parse(unit, Sensor::Accel).and_then(physical),
        Role::W(_) => Unit::parse(unit, Sensor::Gyro).and_then(physical),
        Role::Dw(_) => match squash(unit).as_str() {
            "rads2" | "radss" | "si" => Some((1.0, "rad/s^2")),
            "degs2" | "degss" => Some((std::f64::consts::PI / 180.0, "deg/s^2")),
            _ => None,
        },
        Role::Temp => {
            matches!(squash(unit).as_str(), "c" | "degc" | "celsius").then_some((1.0, "C"))
        }
        Role::Volt => matches!(squash(unit).as_str(), "v" | "volt" | "volts").then_some((1.0, "V")),
    }
}

/// The name of a time unit from its scale to seconds.
fn time_unit(scale: f64) -> &'static str {
    if scale >= 1.0 {
        "s"
    } else if scale >= 1e-3 {
        "ms"
    } else if scale >= 1e-6 {
        "us"
    } else {
        "ns"
    }
}

fn expected(role: Role) -> &'static str {
    match role {
        Role::T => "s, ms, us or ns",
        Role::F(_) => "m/s^2, g or mg",
        Role::W(_) => "rad/s, deg/s or mdeg/s",
        Role::Dw(_) => "rad/s^2 or deg/s^2",
        Role::Temp => "C",
        Role::Volt => "V",
    }
}

/// Reads `--mission-columns`: `ROLE=NAME[:UNIT]` items separated by commas.
///
/// # Errors
/// An item that is not one, an unknown role or unit, a role given twice.
pub fn parse(text: &str) -> Result<Vec<Column>, ColumnsError> {
    let mut out: Vec<Column> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let bad = || ColumnsError::NotRoleName(item.to_string());
        let (role, rest) = item.split_once('=').ok_or_else(bad)?;
        let role = Role::parse(role).ok_or_else(bad)?;
        let (name, unit) = match rest.rsplit_once(':') {
            Some((n, u)) => {
                let unit = unit_of(role, u.trim()).ok_or_else(|| ColumnsError::Unit {
                    item: item.to_string(),
                    unit: u.trim().to_string(),
                    role: role.name(),
                    expected: expected(role),
                })?;
                (n.trim(), Some(unit))
            }
            None => (rest.trim(), None),
        };
        if name.is_empty() {
            return Err(bad());
        }
        if out.iter().any(|c| c.role == role) {
            return Err(ColumnsError::Twice(item.to_string()));
        }
        if let Some(c) = out.iter().find(|c| c.name == name) {
            return Err(ColumnsError::SameColumn {
                item: item.to_string(),
                name: name.to_string(),
                other: c.role.name(),
            });
        }
        out.push(Column {
            role,
            name: name.to_string(),
            unit,
        });
    }
    Ok(out)
}

/// The role a header name states, with the unit it states.
#[must_use]
pub fn recognise(name: &str) -> Option<Column> {
    let column = |role, unit| {
        Some(Column {
            role,
            name: name.to_string(),
            unit,
        })
    };
    if let Some(scale) = header::timestamp(name) {
        return column(Role::T, Some((scale, time_unit(scale))));
    }
    // The observation files' own names are SI by definition (`crate::columns`).
    if let Some(q) = crate::mission::Quantity::all()
        .into_iter()
        .find(|q| q.name() == name)
    {
        let role = match q {
            crate::mission::Quantity::F(k) => Role::F(k),
            crate::mission::Quantity::W(k) => Role::W(k),
            crate::mission::Quantity::Dw(k) => Role::Dw(k),
            crate::mission::Quantity::Temp => Role::Temp,
            crate::mission::Quantity::Volt => Role::Volt,
        };
        return column(role, Some((1.0, role.si())));
    }
    let s = squash(name);
    for (prefix, role) in [("temp", Role::Temp), ("volt", Role::Volt)] {
        if let Some(rest) = s.strip_prefix(prefix) {
            let unit = if rest.is_empty() {
                None
            } else {
                Some(unit_of(role, rest)?)
            };
            return column(role, unit);
        }
    }
    if let Some(rest) = s.strip_prefix("dw") {
        let k = ["x", "y", "z"].iter().position(|a| rest.starts_with(a))?;
        let unit = if rest.len() == 1 {
            None
        } else {
            Some(unit_of(Role::Dw(k), &rest[1..])?)
        };
        return column(Role::Dw(k), unit);
    }
    let physical = |u: Option<Unit>| match u {
        Some(Unit::Physical { name, to_si }) => Some(Some((to_si, name))),
        Some(Unit::Counts) => None,
        None => Some(None),
    };
    if let Some((k, u)) = header::axis(name, &["f", "specificforce"], Sensor::Accel)
        .or_else(|| header::axis(name, &header::ACCEL, Sensor::Accel))
    {
        return column(Role::F(k), physical(u)?);
    }
    if let Some((k, u)) = header::axis(name, &header::GYRO, Sensor::Gyro) {
        return column(Role::W(k), physical(u)?);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_names_state_their_roles_and_units() {
        let r = |n: &str| recognise(n).map(|c| (c.role, c.unit.map(|u| u.0)));
        assert_eq!(r("ts"), Some((Role::T, Some(1.0))));
        assert_eq!(r("time_ms"), Some((Role::T, Some(1e-3))));
        assert_eq!(r("f_x"), Some((Role::F(0), Some(1.0))));
        assert_eq!(r("Ay"), Some((Role::F(1), None)));
        assert_eq!(r("acc_z_g"), Some((Role::F(2), Some(9.806_65))));
        assert_eq!(r("Gx"), Some((Role::W(0), None)));
        let (role, unit) = r("gyro_y_dps").unwrap();
        assert_eq!(role, Role::W(1));
        assert!((unit.unwrap() - 1f64.to_radians()).abs() < 1e-15);
        assert_eq!(r("dw_z"), Some((Role::Dw(2), Some(1.0))));
        assert_eq!(r("temp"), Some((Role::Temp, Some(1.0))));
        assert_eq!(r("volt"), Some((Role::Volt, Some(1.0))));
        assert_eq!(r("ax"), Some((Role::F(0), None)));
        assert_eq!(r("dwx_degs2"), Some((Role::Dw(0), Some(1f64.to_radians()))));
        assert_eq!(r("id"), None);
        assert_eq!(r("ax_counts"), None, "codes are not a mission");
    }

    #[test]
    fn chosen_columns_take_a_unit_and_refuse_what_they_cannot_read() {
        let c = parse("t=ts, fx=Ay:m/s^2, wx=Gy:deg/s").unwrap();
        assert_eq!(c.len(), 3);
        assert_eq!(c[1].role, Role::F(0));
        assert_eq!(c[1].name, "Ay");
        assert!((c[2].unit.unwrap().0 - 1f64.to_radians()).abs() < 1e-15);
        assert!(matches!(parse("q=x"), Err(ColumnsError::NotRoleName(_))));
        assert!(matches!(parse("fx"), Err(ColumnsError::NotRoleName(_))));
        let e = parse("wx=Gx:furlong").unwrap_err();
        assert_eq!(
            e.to_string(),
            "--mission-columns `wx=Gx:furlong`: `furlong` is not a unit of wx (expected rad/s, deg/s or mdeg/s)"
        );
        assert!(matches!(parse("fx=a,fx=b"), Err(ColumnsError::Twice(_))));
        let e = parse("wx=Gx,wy=Gx,wz=Gx").unwrap_err();
        assert!(matches!(e, ColumnsError::SameColumn { .. }), "{e}");
        assert!(e.to_string().contains("column `Gx` is already"), "{e}");
    }
}
