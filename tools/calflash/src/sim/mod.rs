//! `calflash simulate`: a virtual sensor with known true coefficients and noise, driven
//! through a test plan, writing an observation file the workflows read.

pub mod flight;
pub mod plan;
pub mod px4;
pub mod ramp;
pub mod recording;
pub mod rest;
pub mod spin;
pub mod stages;
pub mod still;
pub mod truth;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::columns as col;
use plan::Condition;
use truth::{ImuTruth, SingleTruth, TriadTruth};

/// What is simulated.
#[derive(Debug, Clone, PartialEq)]
pub enum Sensor {
    /// A single-axis accelerometer (`gyro: false`) or gyro.
    Single {
        /// Reads the rate rather than the specific force.
        gyro: bool,
        /// Its truth.
        truth: SingleTruth,
    },
    /// An accelerometer triad.
    Accel(TriadTruth),
    /// A gyro triad (g-sensitivity reads the specific force).
    Gyro(TriadTruth),
    /// Both.
    Imu(Box<ImuTruth>),
}

/// The code the default units' biases are centred on: mid-scale of an unsigned 16-bit
/// converter.
const DEFAULT_MID: f64 = 32_768.0;

impl Sensor {
    /// The same unit behind a converter with `rails`: the biases move from mid-scale of the
    /// unsigned 16-bit converter the default units are written for to mid-scale of `rails`
    /// (zero for signed codes), everything else as it is.
    #[must_use]
    pub fn with_codes(mut self, rails: spincal::model::Rails) -> Self {
        let mid = (f64::from(rails.lo) + f64::from(rails.hi) + 1.0) / 2.0;
        let shift = mid.floor() - DEFAULT_MID;
        let triad = |t: &mut truth::TriadTruth| t.bias.iter_mut().for_each(|b| *b += shift);
        match &mut self {
            Self::Single { truth, .. } => truth.k0 += shift,
            Self::Accel(t) | Self::Gyro(t) => triad(t),
            Self::Imu(t) => {
                triad(&mut t.accel);
                triad(&mut t.gyro);
            }
        }
        self
    }
}

/// Simulated observations: column names and rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Observations {
    /// Column names.
    pub names: Vec<String>,
    /// Rows of values.
    pub rows: Vec<Vec<f64>>,
}

impl Observations {
    /// Writes the observations as CSV.
    ///
    /// # Errors
    /// The writer's.
    pub fn write_csv(&self, mut w: impl std::io::Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.names.join(","))?;
        let mut line = String::new();
        for r in &self.rows {
            line.clear();
            for (i, v) in r.iter().enumerate() {
                if i > 0 {
                    line.push(',');
                }
                line.push_str(&v.to_string());
            }
            writeln!(w, "{line}")?;
        }
        Ok(())
    }

    /// The observations as a table, as if read from `path` (line numbers from 2: the header
    /// is line 1).
    #[must_use]
    pub fn to_table(&self, path: &str) -> crate::obs::Table {
        crate::obs::Table {
            path: path.into(),
            names: self.names.clone(),
            columns: (0..self.names.len())
                .map(|i| self.rows.iter().map(|r| r[i]).collect())
                .collect(),
            lines: (0..self.rows.len() as u64).map(|i| i + 2).collect(),
        }
    }

    /// Saturates the sensor's outputs (`output`, `a_*`, `g_*`) at the converter's rails, as
    /// its ADC would; returns how many values it changed.
    pub fn saturate(&mut self, rails: spincal::model::Rails) -> usize {
        let outputs: Vec<usize> = self
            .names
            .iter()
            .enumerate()
            .filter(|(_, n)| {
                *n == col::OUTPUT || col::A.contains(&n.as_str()) || col::GYRO.contains(&n.as_str())
            })
            .map(|(i, _)| i)
            .collect();
        let (lo, hi) = (f64::from(rails.lo), f64::from(rails.hi));
        let mut changed = 0;
        for row in &mut self.rows {
            for &i in &outputs {
                let v = row[i].clamp(lo, hi);
                if v != row[i] {
                    row[i] = v;
                    changed += 1;
                }
            }
        }
        changed
    }

    /// A column's values.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(self.rows.iter().map(|r| r[i]).collect())
    }
}

fn noisy(rng: &mut ChaCha8Rng, x: f64, sigma: f64, quantize: bool) -> f64 {
    let v = if sigma > 0.0 {
        x + Normal::new(0.0, sigma).expect("sigma > 0").sample(rng)
    } else {
        x
    };
    if quantize { v.round() } else { v }
}

/// Runs the plan through the sensor. `quantize` rounds outputs to whole counts (a single
/// reading); otherwise they are left as averages.
#[must_use]
pub fn simulate(
    sensor: &Sensor,
    conditions: &[Condition],
    seed: u64,
    quantize: bool,
) -> Observations {
    simulate_at(sensor, conditions, seed, quantize, None)
        .expect("only the Earth's rate can make a condition fail, and there is no station")
}

/// A condition whose Earth rate the station cannot know.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("plan row {row}: {why}")]
pub struct EarthRowError {
    /// The condition's index, from 1.
    pub row: usize,
    /// Why.
    pub why: crate::earth::EarthError,
}

/// [`simulate`] at a station: with `earth`, the gyros sense the Earth's rate on top of the
/// table's (the files' `w_*` stay the table's rates, as a station records them) and the files
/// carry the fixture's reference mark `h_*`.
///
/// # Errors
/// A condition whose Earth rate cannot be known (`crate::earth`).
pub fn simulate_at(
    sensor: &Sensor,
    conditions: &[Condition],
    seed: u64,
    quantize: bool,
    earth: Option<&crate::earth::Station>,
) -> Result<Observations, EarthRowError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut names: Vec<String> = Vec::new();
    let mut rows = Vec::with_capacity(conditions.len());
    let env = |c: &Condition| [c.temp, c.volt];
    match sensor {
        Sensor::Single { gyro, truth } => {
            names.extend(
                [
                    col::INPUT,
                    col::INPUT_P,
                    col::INPUT_O,
                    col::TEMP,
                    col::VOLT,
                    col::DIR,
                    col::OUTPUT,
                ]
                .map(String::from),
            );
            for c in conditions {
                let x = if *gyro { c.w } else { c.f };
                let out = truth.output(x[0], x[1], x[2], c.temp, c.volt, c.dir);
                rows.push(vec![
                    x[0],
                    x[1],
                    x[2],
                    c.temp,
                    c.volt,
                    c.dir,
                    noisy(&mut rng, out, truth.noise, quantize),
                ]);
            }
        }
        Sensor::Accel(_) | Sensor::Gyro(_) | Sensor::Imu(_) => {
            // Angular acceleration columns only when the plan has some.
            let spins_up = conditions.iter().any(|c| c.dw.iter().any(|x| *x != 0.0));
            let (accel, gyro) = match sensor {
                Sensor::Accel(t) => (Some(t), None),
                Sensor::Gyro(t) => (None, Some(t)),
                Sensor::Imu(t) => (Some(&t.accel), Some(&t.gyro)),
                Sensor::Single { .. } => (None, None),
            };
            let mut inputs: Vec<&str> = col::F.iter().chain(&col::W).copied().collect();
            if spins_up {
                inputs.extend(col::DW);
            }
            if earth.is_some() {
                inputs.extend(col::H);
            }
            names.extend(
                inputs
                    .iter()
                    .chain(&[col::TEMP, col::VOLT])
                    .chain(accel.map_or(&[][..], |_| &col::A[..]))
                    .chain(gyro.map_or(&[][..], |_| &col::GYRO[..]))
                    .map(|s| s.to_string()),
            );
            for (n, c) in conditions.iter().enumerate() {
                let mut row: Vec<f64> = c.f.iter().chain(&c.w).copied().collect();
                if spins_up {
                    row.extend(c.dw);
                }
                // The inertial rate: the table's plus the Earth's.
                let mut w = c.w;
                if let Some(station) = earth {
                    row.extend(c.h);
                    let e = station
                        .rate_in_body(c.f, c.w, c.h)
                        .map_err(|why| EarthRowError { row: n + 1, why })?;
                    w = std::array::from_fn(|k| w[k] + e[k]);
                }
                row.extend(env(c));
                if let Some(t) = accel {
                    let a = t.accel_output(c.f, w, c.dw, c.temp, c.volt);
                    row.extend((0..3).map(|i| noisy(&mut rng, a[i], t.noise[i], quantize)));
                }
                if let Some(t) = gyro {
                    let g = t.gyro_output(w, c.f, c.temp, c.volt);
                    row.extend((0..3).map(|i| noisy(&mut rng, g[i], t.noise[i], quantize)));
                }
                rows.push(row);
            }
        }
    }
    Ok(Observations { names, rows })
}

#[cfg(test)]
mod tests {
    use super::*;
    use spincal::model::Rails;

    #[test]
    fn the_default_unit_moves_to_the_middle_of_another_converter() {
        let imu = || Sensor::Imu(Box::default());
        let Sensor::Imu(u) = imu() else {
            unreachable!()
        };
        let Sensor::Imu(s) = imu().with_codes(Rails::signed(16)) else {
            unreachable!()
        };
        let Sensor::Imu(t) = imu().with_codes(Rails::unsigned(12)) else {
            unreachable!()
        };
        for j in 0..3 {
            assert_eq!(s.accel.bias[j], u.accel.bias[j] - 32_768.0);
            assert_eq!(s.gyro.bias[j], u.gyro.bias[j] - 32_768.0);
            assert_eq!(t.accel.bias[j], u.accel.bias[j] - 32_768.0 + 2_048.0);
        }
        assert_eq!(s.accel.s, u.accel.s);
        let Sensor::Imu(same) = imu().with_codes(Rails::unsigned(16)) else {
            unreachable!()
        };
        assert_eq!(*same, *u);
    }
}
