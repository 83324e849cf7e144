//! The noise terms a calibration's blob carries for the unit's health check at rest
//! (`spincal::health`): the white-noise densities and bias random walks of the accelerometer
//! and the gyro from two `calflash allan --json` files (in SI units), and the allowances the
//! unit is held to.

use std::path::{Path, PathBuf};

use spincal::model::{NoiseTerms, Span};

/// Why the noise terms cannot be read from the Allan files, or are refused by the device.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file that cannot be read, or is too long to be an Allan file.
    #[error(transparent)]
    Read(Box<crate::files::Error>),
    /// A file that is not JSON.
    #[error("{}: not JSON: {source}", .path.display())]
    NotJson {
        /// The file.
        path: PathBuf,
        /// Where and why.
        #[source]
        source: serde_json::Error,
    },
    /// JSON that `calflash allan --json` did not write.
    #[error(
        "{}: field \"schema\": expected \"calflash.allan/2\" or \"calflash.allan/1\" (the file `calflash allan --json` writes)",
        .0.display()
    )]
    NotAllan(PathBuf),
    /// An Allan file without the sensor asked for.
    #[error(
        "{}: field \"sensors\": no {sensor} (it has {}): give the file `calflash allan` wrote for the {sensor} (a recording of both sensors gives one file for both)",
        .path.display(),
        if .found.is_empty() { "none".to_string() } else { .found.join(", ") }
    )]
    NoSensor {
        /// The file.
        path: PathBuf,
        /// `accel` or `gyro`.
        sensor: &'static str,
        /// The sensors it has.
        found: Vec<String>,
    },
    /// Terms in another unit than the sensor's SI unit.
    #[error(
        "{}: field \"unit\" is {found}, expected \"{expected}\": run `calflash allan` with --scale (counts per {expected}) so that the terms are in SI units",
        .path.display()
    )]
    Unit {
        /// The file.
        path: PathBuf,
        /// The unit it states, as JSON.
        found: serde_json::Value,
        /// The SI unit.
        expected: &'static str,
    },
    /// Not three axes.
    #[error("{}: field \"axes\": expected the three axes", .0.display())]
    Axes(PathBuf),
    /// A term that is missing, not finite, negative, or beyond what the device stores.
    #[error(
        "{}: axes[{axis}].terms.{key}: expected a non-negative number the device can store \
         (at most 1e30; an Allan file of SI units states noise far below that)",
        .path.display()
    )]
    Term {
        /// The file.
        path: PathBuf,
        /// The axis.
        axis: usize,
        /// The term.
        key: &'static str,
    },
    /// An axis without white noise.
    #[error(
        "{}: axes[{axis}].terms.random_walk is 0: the recording shows no white noise \
         on axis {axis} (too short, or quantisation only); record longer",
        .path.display()
    )]
    NoWhiteNoise {
        /// The file.
        path: PathBuf,
        /// The axis.
        axis: usize,
    },
    /// A gravity span the health check cannot hold a unit to.
    #[error(
        "--gravity {lo}:{hi}: expected LO:HI with LO <= HI, both within 9.7 to 9.9 m/s^2 (the \
         magnitude of gravity anywhere on the Earth's surface)"
    )]
    Gravity {
        /// The span's low end.
        lo: f64,
        /// Its high end.
        hi: f64,
    },
    /// Terms or allowances the device's own check refuses.
    #[error("--noise-terms: {0}")]
    Refused(#[source] spincal::Error),
}

/// What the health check's allowances are, besides the measured noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Allowances {
    /// Seconds over which ageing may move the biases by their random walk.
    pub ageing_s: f64,
    /// Where the unit may rest: the magnitude of gravity, m/s^2.
    pub gravity: (f64, f64),
    /// The false-alarm rate per rest period.
    pub false_alarm: f64,
}

/// One sensor's three axes: white-noise densities and rate random walks, from an Allan JSON.
fn read_axes(path: &Path, unit: &'static str) -> Result<([f64; 3], [f64; 3]), Error> {
    let file = || path.to_path_buf();
    let text = crate::files::read_json_text(path, "an Allan file (calflash allan --json)")
        .map_err(|e| Error::Read(Box::new(e)))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|source| Error::NotJson {
        path: file(),
        source,
    })?;
    let sensor = if unit == "rad/s" { "gyro" } else { "accel" };
    let v = match v["schema"].as_str() {
        Some(crate::noise::allan::SCHEMA_ONE_SENSOR) => v,
        Some(crate::noise::allan::SCHEMA) => {
            let sensors = v["sensors"].as_array().cloned().unwrap_or_default();
            let Some(entry) = sensors.iter().find(|e| e["sensor"] == sensor) else {
                return Err(Error::NoSensor {
                    path: file(),
                    sensor,
                    found: sensors
                        .iter()
                        .filter_map(|e| e["sensor"].as_str().map(str::to_string))
                        .collect(),
                });
            };
            entry.clone()
        }
        _ => return Err(Error::NotAllan(file())),
    };
    if v["unit"] != unit {
        return Err(Error::Unit {
            path: file(),
            found: v["unit"].clone(),
            expected: unit,
        });
    }
    let axes = v["axes"]
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| Error::Axes(file()))?;
    let mut white = [0.0; 3];
    let mut walk = [0.0; 3];
    for (j, a) in axes.iter().enumerate() {
        let term = |key: &'static str| {
            a["terms"][key]
                .as_f64()
                .filter(|x| x.is_finite() && (0.0..=1e30).contains(x))
                .ok_or_else(|| Error::Term {
                    path: file(),
                    axis: j,
                    key,
                })
        };
        white[j] = term("random_walk")?;
        walk[j] = term("rate_random_walk")?;
        if white[j] <= 0.0 {
            return Err(Error::NoWhiteNoise {
                path: file(),
                axis: j,
            });
        }
    }
    Ok((white, walk))
}

/// The noise terms from the accelerometer's and the gyro's Allan JSON files.
///
/// # Errors
/// A message naming the file and the field, or the allowance, that is wrong.
pub fn from_allan(accel: &Path, gyro: &Path, allow: &Allowances) -> Result<NoiseTerms, Error> {
    let (wa, ka) = read_axes(accel, "m/s^2")?;
    let (wg, kg) = read_axes(gyro, "rad/s")?;
    let six = |a: [f64; 3], g: [f64; 3]| [a[0], a[1], a[2], g[0], g[1], g[2]].map(|x| x as f32);
    let (lo, hi) = allow.gravity;
    if !(lo <= hi && lo >= 9.7 && hi <= 9.9) {
        return Err(Error::Gravity { lo, hi });
    }
    let terms = NoiseTerms {
        white: six(wa, wg),
        bias_walk: six(ka, kg),
        ageing_s: allow.ageing_s as f32,
        gravity: Span::new(lo as f32, hi as f32),
        false_alarm: allow.false_alarm as f32,
    };
    // The device's own check, so that a bad allowance is named here and not at the flash.
    let mut probe = spincal::model::CalibrationData::example_imu();
    probe.noise = Some(terms);
    spincal::model::Calibration::new(probe).map_err(Error::Refused)?;
    Ok(terms)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An Allan file as `calflash allan --json` writes it (its `Record`), of one sensor.
    fn allan_file(dir: &Path, name: &str, unit: &str, n: f64, k: f64) -> std::path::PathBuf {
        use crate::noise::allan::{AxisRecord, NoiseTerms as Terms, Record, SCHEMA, SensorRecord};
        let terms = Terms {
            quantization: 0.0,
            random_walk: n,
            bias_instability: 0.0,
            rate_random_walk: k,
            rate_ramp: 0.0,
        };
        let record = Record {
            schema: SCHEMA,
            source: "r.csv",
            sensors: vec![SensorRecord {
                sensor: if unit == "rad/s" { "gyro" } else { "accel" },
                unit,
                axes: ["x", "y", "z"]
                    .map(|axis| AxisRecord {
                        axis,
                        curve: &[],
                        terms: &terms,
                    })
                    .to_vec(),
            }],
        };
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_string(&record).unwrap()).unwrap();
        p
    }

    const ALLOW: Allowances = Allowances {
        ageing_s: 3.0e7,
        gravity: (9.80, 9.82),
        false_alarm: 1e-3,
    };

    #[test]
    fn reads_both_sensors_and_names_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let a = allan_file(dir.path(), "a.json", "m/s^2", 1.5e-3, 1e-5);
        let g = allan_file(dir.path(), "g.json", "rad/s", 2e-4, 5e-7);
        let t = from_allan(&a, &g, &ALLOW).unwrap();
        assert_eq!(t.white, [1.5e-3, 1.5e-3, 1.5e-3, 2e-4, 2e-4, 2e-4]);
        assert_eq!(t.bias_walk[5], 5e-7);
        // Swapped files: the sensor is named.
        let e = from_allan(&g, &a, &ALLOW).unwrap_err().to_string();
        assert!(
            e.contains("g.json: field \"sensors\": no accel (it has gyro)"),
            "{e}"
        );
        // One file of both sensors serves for both.
        let both = dir.path().join("both.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&a).unwrap()).unwrap();
        let gv: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&g).unwrap()).unwrap();
        v["sensors"]
            .as_array_mut()
            .unwrap()
            .push(gv["sensors"][0].clone());
        std::fs::write(&both, v.to_string()).unwrap();
        assert_eq!(from_allan(&both, &both, &ALLOW).unwrap(), t);
        // A one-sensor file of before (calflash.allan/1) is still read, its unit checked.
        let old = dir.path().join("old.json");
        let mut one = gv["sensors"][0].clone();
        one["schema"] = "calflash.allan/1".into();
        std::fs::write(&old, one.to_string()).unwrap();
        assert_eq!(from_allan(&a, &old, &ALLOW).unwrap(), t);
        let e = from_allan(&old, &g, &ALLOW).unwrap_err().to_string();
        assert!(e.contains("old.json") && e.contains("\"unit\""), "{e}");
        // Counts: the unit says so.
        let c = allan_file(dir.path(), "c.json", "counts", 1.0, 0.0);
        let e = from_allan(&c, &g, &ALLOW).unwrap_err().to_string();
        assert!(e.contains("--scale"), "{e}");
        // No white noise on an axis.
        let z = allan_file(dir.path(), "z.json", "rad/s", 0.0, 0.0);
        let e = from_allan(&a, &z, &ALLOW).unwrap_err();
        assert!(matches!(e, Error::NoWhiteNoise { axis: 0, .. }), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("axes[0].terms.random_walk is 0"), "{e}");
        // A gravity span beyond the Earth's.
        let bad = Allowances {
            gravity: (9.5, 9.82),
            ..ALLOW
        };
        let e = from_allan(&a, &g, &bad).unwrap_err();
        assert!(matches!(e, Error::Gravity { .. }), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("--gravity 9.5:9.82"), "{e}");
    }
}
