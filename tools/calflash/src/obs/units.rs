//! What a recording's columns hold: converter codes (counts), or a physical quantity as a
//! driver delivers it. Physical values are read into SI (m/s^2, rad/s); a stated LSB (the value
//! of one code, in the file's unit) turns them back into codes for a device blob.

use super::squash;

/// The unit of one sensor's columns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unit {
    /// Converter codes.
    Counts,
    /// A physical quantity: its name as the user writes it and its value in SI (m/s^2 or rad/s).
    Physical {
        /// The name (`m/s^2`, `g`, `mg`, `rad/s`, `deg/s`).
        name: &'static str,
        /// One unit in SI.
        to_si: f64,
    },
}

/// Which sensor a unit belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensor {
    /// Specific force.
    Accel,
    /// Rate.
    Gyro,
}

/// Standard gravity, m/s^2 (the unit `g`, as drivers use it).
const STANDARD_GRAVITY: f64 = 9.806_65;

/// The accelerometer's units: squashed spellings (letters and digits, lower case) and the unit.
const ACCEL: [(&[&str], Unit); 3] = [
    (
        &["ms2", "mps2", "mss", "mpss", "si"],
        Unit::Physical {
            name: "m/s^2",
            to_si: 1.0,
        },
    ),
    (
        &["g"],
        Unit::Physical {
            name: "g",
            to_si: STANDARD_GRAVITY,
        },
    ),
    (
        &["mg"],
        Unit::Physical {
            name: "mg",
            to_si: STANDARD_GRAVITY * 1e-3,
        },
    ),
];

/// The gyro's units.
const GYRO: [(&[&str], Unit); 3] = [
    (
        &["rads", "radps", "radsec", "rad", "si"],
        Unit::Physical {
            name: "rad/s",
            to_si: 1.0,
        },
    ),
    (
        &["degs", "dps", "degps", "degsec", "deg"],
        Unit::Physical {
            name: "deg/s",
            to_si: core::f64::consts::PI / 180.0,
        },
    ),
    (
        &["mdps", "mdegs"],
        Unit::Physical {
            name: "mdeg/s",
            to_si: core::f64::consts::PI / 180.0 * 1e-3,
        },
    ),
];

const COUNTS: [&str; 5] = ["counts", "count", "raw", "lsb", "adc"];

impl Unit {
    /// The unit named `text` for `sensor` (`counts`, `m/s^2`, `g`, `mg`; `rad/s`, `deg/s`,
    /// `mdeg/s`; spellings such as `mps2` and `dps` too), or `None`.
    #[must_use]
    pub fn parse(text: &str, sensor: Sensor) -> Option<Self> {
        Self::from_squashed(&squash(text), sensor)
    }

    fn from_squashed(s: &str, sensor: Sensor) -> Option<Self> {
        if COUNTS.contains(&s) {
            return Some(Self::Counts);
        }
        let table: &[(&[&str], Unit)] = match sensor {
            Sensor::Accel => &ACCEL,
            Sensor::Gyro => &GYRO,
        };
        table
            .iter()
            .find(|(names, _)| names.contains(&s))
            .map(|(_, u)| *u)
    }

    /// The unit a column name ends with after its axis letter (`ax_mps2` -> `mps2`), when
    /// `suffix` (squashed) names one; `Some(None)` for no suffix.
    #[must_use]
    pub fn suffix(suffix: &str, sensor: Sensor) -> Option<Option<Self>> {
        if suffix.is_empty() {
            return Some(None);
        }
        Self::from_squashed(suffix, sensor).map(Some)
    }

    /// The unit's name; `counts` for codes.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Counts => "counts",
            Self::Physical { name, .. } => name,
        }
    }

    /// True for a physical quantity.
    #[must_use]
    pub fn is_physical(self) -> bool {
        matches!(self, Self::Physical { .. })
    }
}

/// The SI unit a sensor's physical values are read into.
#[must_use]
pub fn si(sensor: Sensor) -> &'static str {
    match sensor {
        Sensor::Accel => "m/s^2",
        Sensor::Gyro => "rad/s",
    }
}

/// What the readers do with each sensor's values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Units {
    /// The accelerometer's and the gyro's unit in the file, as given (`None`: as the header
    /// says, else counts).
    pub given: [Option<Unit>; 2],
    /// The value of one code, in the file's unit, per sensor: physical values are divided by it
    /// and read as codes.
    pub lsb: [Option<f64>; 2],
}

impl Units {
    /// Codes, unless a header says otherwise.
    pub const DEFAULT: Self = Self {
        given: [None, None],
        lsb: [None, None],
    };
}

/// A sensor's values as read: counts (codes, perhaps made from a physical value and an LSB) or
/// SI values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Read {
    /// The file's unit.
    pub file: Unit,
    /// The value of one code in the file's unit, when physical values were turned into codes.
    pub lsb: Option<f64>,
}

impl Read {
    /// Codes as in the file.
    pub const COUNTS: Self = Self {
        file: Unit::Counts,
        lsb: None,
    };

    /// True when the values read are SI (physical, no LSB).
    #[must_use]
    pub fn is_si(self) -> bool {
        self.file.is_physical() && self.lsb.is_none()
    }

    /// The factor from a file value to the value read.
    #[must_use]
    pub fn factor(self) -> f64 {
        match (self.file, self.lsb) {
            (Unit::Counts, _) => 1.0,
            (Unit::Physical { .. }, Some(l)) => 1.0 / l,
            (Unit::Physical { to_si, .. }, None) => to_si,
        }
    }

    /// What one unit of the values read is, in words (`counts`, `m/s^2`, `codes of 0.0006 g`).
    #[must_use]
    pub fn describe(self, sensor: Sensor) -> String {
        match (self.file, self.lsb) {
            (Unit::Counts, _) => "counts".into(),
            (Unit::Physical { name, .. }, Some(l)) => format!("codes of {l} {name}"),
            (Unit::Physical { .. }, None) => si(sensor).into(),
        }
    }

    /// The unit of the values read, short (`count`, `m/s^2`, `rad/s`), for "per ..." labels.
    #[must_use]
    pub fn per(self, sensor: Sensor) -> &'static str {
        if self.is_si() { si(sensor) } else { "count" }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_are_read_for_their_sensor_only() {
        for s in ["m/s^2", "m/s2", "mps2", "M/S^2", "m_s2"] {
            assert_eq!(
                Unit::parse(s, Sensor::Accel).map(Unit::name),
                Some("m/s^2"),
                "{s}"
            );
        }
        assert_eq!(Unit::parse("g", Sensor::Accel).map(Unit::name), Some("g"));
        assert_eq!(
            Unit::parse("deg/s", Sensor::Gyro).map(Unit::name),
            Some("deg/s")
        );
        assert_eq!(
            Unit::parse("dps", Sensor::Gyro).map(Unit::name),
            Some("deg/s")
        );
        assert_eq!(Unit::parse("counts", Sensor::Gyro), Some(Unit::Counts));
        assert_eq!(Unit::parse("deg/s", Sensor::Accel), None);
        assert_eq!(Unit::parse("g", Sensor::Gyro), None);
        assert_eq!(Unit::parse("furlongs", Sensor::Accel), None);
    }

    #[test]
    fn values_are_read_into_si_or_into_codes_of_the_stated_lsb() {
        let g = Unit::parse("g", Sensor::Accel).unwrap();
        let si = Read { file: g, lsb: None };
        assert!((si.factor() - 9.806_65).abs() < 1e-12);
        assert_eq!(si.describe(Sensor::Accel), "m/s^2");
        let codes = Read {
            file: g,
            lsb: Some(1.0 / 16384.0),
        };
        assert!((codes.factor() - 16384.0).abs() < 1e-9);
        assert_eq!(codes.per(Sensor::Accel), "count");
        let dps = Unit::parse("deg/s", Sensor::Gyro).unwrap();
        let r = Read {
            file: dps,
            lsb: None,
        };
        assert!((r.factor() * 180.0 - core::f64::consts::PI).abs() < 1e-12);
    }
}
