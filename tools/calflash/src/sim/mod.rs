//! `calflash simulate`: a virtual sensor with known true coefficients and noise, driven
//! through a test plan, writing an observation file the workflows read.

pub mod plan;
pub mod recording;
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
        Sensor::Accel(t) | Sensor::Gyro(t) => {
            let gyro = matches!(sensor, Sensor::Gyro(_));
            let out_names = if gyro { col::GYRO } else { col::A };
            names.extend(
                col::F
                    .iter()
                    .chain(&col::W)
                    .chain(&[col::TEMP, col::VOLT])
                    .chain(&out_names)
                    .map(|s| s.to_string()),
            );
            for c in conditions {
                let x = if gyro { c.w } else { c.f };
                let out = t.output(x, c.f, c.w, c.temp, c.volt);
                let mut row: Vec<f64> = c.f.iter().chain(&c.w).chain(&env(c)).copied().collect();
                row.extend((0..3).map(|i| noisy(&mut rng, out[i], t.noise[i], quantize)));
                rows.push(row);
            }
        }
        Sensor::Imu(t) => {
            names.extend(
                col::F
                    .iter()
                    .chain(&col::W)
                    .chain(&[col::TEMP, col::VOLT])
                    .chain(&col::A)
                    .chain(&col::GYRO)
                    .map(|s| s.to_string()),
            );
            for c in conditions {
                let a = t.accel.output(c.f, c.f, c.w, c.temp, c.volt);
                let g = t.gyro.output(c.w, c.f, c.w, c.temp, c.volt);
                let mut row: Vec<f64> = c.f.iter().chain(&c.w).chain(&env(c)).copied().collect();
                row.extend((0..3).map(|i| noisy(&mut rng, a[i], t.accel.noise[i], quantize)));
                row.extend((0..3).map(|i| noisy(&mut rng, g[i], t.gyro.noise[i], quantize)));
                rows.push(row);
            }
        }
    }
    Observations { names, rows }
}
