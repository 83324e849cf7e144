//! The options that say what a recording holds: `--units` and `--lsb` (shared by the commands
//! that read recordings: `selfcal`, `allan`, `apply`) and `--columns` (`selfcal`, `allan`).

use clap::Args;

use crate::obs::units::{Sensor, Unit, Units};

/// The units of a recording's values.
#[derive(Debug, Clone, Default, Args)]
pub struct UnitArgs {
    /// The units of the accelerometer's and the gyro's values, `ACCEL,GYRO`: `counts` (the
    /// default, unless the header's names say: `ax_mps2`, `gyro_x[dps]`), or `m/s^2`, `g`, `mg`
    /// and `rad/s`, `deg/s`, `mdeg/s` for values a driver already scaled. Physical values are
    /// calibrated in SI (m/s^2, rad/s); the device blob needs `--lsb`.
    #[arg(long, value_parser = units)]
    pub units: Option<[Unit; 2]>,
    /// The value of one code of the accelerometer and the gyro, `ACCEL,GYRO`, in the units
    /// `--units` gives (as the part's datasheet states: 1/16384 g, 1/131 deg/s): the physical
    /// values are read back into codes, and the blob corrects the codes.
    #[arg(long, value_parser = lsb)]
    pub lsb: Option<[f64; 2]>,
}

/// Columns chosen by name.
#[derive(Debug, Clone, Default, Args)]
pub struct ColumnArgs {
    /// Choose columns by their header names, `t=time_us,ax=acc_x,ay=acc_y,az=acc_z,gx=...,
    /// temp=die_c`: the roles not given are found by the recognised names (t, time_ms, ax,
    /// acc_x, gyro_z, ...); the time column's unit from its name or `t=stamp:ms`; a sample
    /// counter instead of a time, `index=count` with `--sample-rate` (it may wrap; the samples
    /// it skips are gaps); a temperature column is carried into the record.
    #[arg(long, value_parser = |s: &str| crate::obs::header::Chosen::parse(s))]
    pub columns: Option<crate::obs::header::Chosen>,
}

impl ColumnArgs {
    /// What the readers are told.
    #[must_use]
    pub fn chosen(&self) -> crate::obs::header::Chosen {
        self.columns.clone().unwrap_or_default()
    }
}

impl UnitArgs {
    /// What the readers are told.
    #[must_use]
    pub fn units(&self) -> Units {
        Units {
            given: self.units.map_or([None, None], |[a, g]| [Some(a), Some(g)]),
            lsb: self.lsb.map_or([None, None], |[a, g]| [Some(a), Some(g)]),
        }
    }
}

fn pair(s: &str, what: &str) -> Result<(String, String), String> {
    s.split_once(',')
        .map(|(a, g)| (a.trim().to_string(), g.trim().to_string()))
        .ok_or_else(|| {
            format!("`{s}`: expected {what} for the accelerometer and the gyro, ACCEL,GYRO")
        })
}

fn units(s: &str) -> Result<[Unit; 2], String> {
    let (a, g) = pair(s, "the units")?;
    let one = |t: &str, sensor: Sensor, known: &str| {
        Unit::parse(t, sensor).ok_or_else(|| format!("`{t}` in `{s}`: expected {known}"))
    };
    Ok([
        one(
            &a,
            Sensor::Accel,
            "counts, m/s^2, g or mg for the accelerometer",
        )?,
        one(
            &g,
            Sensor::Gyro,
            "counts, rad/s, deg/s or mdeg/s for the gyro",
        )?,
    ])
}

fn lsb(s: &str) -> Result<[f64; 2], String> {
    let (a, g) = pair(s, "the value of one code")?;
    let one = |t: &str| {
        super::values::number_of(t)
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| {
                format!(
                    "`{t}` in `{s}`: expected a number above 0 (a fraction such as 1/16384 too)"
                )
            })
    };
    Ok([one(&a)?, one(&g)?])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_are_read_and_errors_say_what_is_expected() {
        let [a, g] = units("g, deg/s").unwrap();
        assert_eq!((a.name(), g.name()), ("g", "deg/s"));
        assert!(units("g").unwrap_err().contains("ACCEL,GYRO"));
        assert!(
            units("deg/s,g")
                .unwrap_err()
                .contains("for the accelerometer")
        );
        let [la, lg] = lsb("1/16384, 0.0076").unwrap();
        assert!((la - 1.0 / 16384.0).abs() < 1e-15 && (lg - 0.0076).abs() < 1e-15);
        assert!(lsb("0,1").unwrap_err().contains("above 0"));
    }
}
