//! A still unit recorded while the temperature sweeps (PX4's and ArduPilot's procedure), made
//! into observations for the continuous temperature model beside a bench run at one
//! temperature: every sample of the recording is an observation of one pose at rest. The pose's
//! specific force is what the bench's fit says the accelerometer sensed where the ramp passes
//! the bench's temperature; the rate is zero. The bias of each axis then follows the
//! temperature, and the scale factors, which one pose cannot follow, are the bench's (the
//! continuous model names them).

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::Kind;
use crate::columns as col;
use crate::formula;
use crate::obs::recording::{self, Recording};
use crate::obs::{Table, header, layout, units};
use crate::sensor::{AxisFit, Options, WorkflowError};

/// Readings within this many C of the bench's temperature tie the pose to the bench.
const NEAR: f64 = 2.0;
/// The samples taken as observations, at most (evenly through the recording).
const MOST: usize = 600;
/// Seconds of the windows the stillness is checked over.
const WINDOW_S: f64 = 1.0;
/// The pose's specific force may turn by this much (degrees) along the ramp: the bias drift
/// turns it a little, a moved unit much more.
const MOST_TURN_DEG: f64 = 3.0;

/// Why a still ramp cannot be tied to the bench.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StillRampError {
    /// The bench's accelerometer fit has no inverse.
    #[error("--still-ramp: the bench's accelerometer fit is singular")]
    SingularBench,
    /// Too few samples near the bench's temperature.
    #[error(
        "--still-ramp: the recording's temperatures ({lo:.1} to {hi:.1} C) come within {near} C of the bench's {bench:.1} C at {samples} samples; at least 10 tie the still pose to the bench (record the ramp through the bench's temperature)",
        near = NEAR
    )]
    NotThroughBench {
        /// The recording's lowest temperature, C.
        lo: f64,
        /// Its highest.
        hi: f64,
        /// The bench's temperature.
        bench: f64,
        /// Samples near it.
        samples: usize,
    },
    /// The specific force turned within a window.
    #[error(
        "--still-ramp: line {line}: the unit's specific force turned by {turn:.1} degrees within {window} s; the recording must be of one still pose",
        window = WINDOW_S
    )]
    Turned {
        /// The window's first line.
        line: u32,
        /// Degrees.
        turn: f64,
    },
    /// The specific force is far from the pose held at the bench's temperature.
    #[error(
        "--still-ramp: line {line}: the unit's specific force is {turn:.1} degrees from the pose it held at the bench's temperature; the recording must be of one still pose"
    )]
    Moved {
        /// The window's first line.
        line: u32,
        /// Degrees.
        turn: f64,
    },
    /// Bench observations without a temperature column.
    #[error(
        "--still-ramp: the bench observations need their temperature (a `temp` column) to tie the ramp's biases to them"
    )]
    BenchWithoutTemperature,
    /// Bench observations at several temperatures.
    #[error(
        "--still-ramp: the bench observations span {lo:.1} to {hi:.1} C; with a still ramp they are the run at one temperature"
    )]
    BenchAtSeveral {
        /// Lowest, C.
        lo: f64,
        /// Highest.
        hi: f64,
    },
    /// A recording without a temperature column.
    #[error(
        "--still-ramp: the recording has no temperature column (a column named temp...); the ramp is followed by the sensor's own temperature"
    )]
    RecordingWithoutTemperature,
    /// A gyro alone, whose g-sensitivity needs the specific force.
    #[error(
        "--still-ramp: a lone gyro's still pose has an unknown specific force, which its g-sensitivity needs; record the accelerometer with it and calibrate the IMU"
    )]
    LoneGyro,
}

/// `why`, in the file `path`.
fn still(path: &Path, why: StillRampError) -> WorkflowError {
    WorkflowError::StillRamp {
        path: path.to_path_buf(),
        source: why,
    }
}

/// The bench's sensitivity matrix and bias of `outputs` against `inputs`, each axis a
/// straight fit.
fn bench_fit(
    bench: &Table,
    outputs: [&str; 3],
    inputs: [&str; 3],
    opts: &Options,
) -> Result<(Matrix3<f64>, Vector3<f64>), WorkflowError> {
    let mut s = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for (i, out) in outputs.iter().enumerate() {
        let f = formula::parse(&format!(
            "{out} ~ 1 + {} + {} + {}",
            inputs[0], inputs[1], inputs[2]
        ))?;
        let fit = AxisFit::fit(
            &f,
            bench,
            inputs[i],
            opts.alpha,
            (&opts.file, "the bench"),
            true,
        )?;
        b[i] = fit.coef("1");
        for (j, input) in inputs.iter().enumerate() {
            s[(i, j)] = fit.coef(input);
        }
    }
    Ok((s, b))
}

/// The pose's specific force: the mean of the samples within [`NEAR`] C of `t0` through the
/// bench's accelerometer fit; then every second of the recording checked to show it within
/// [`MOST_TURN_DEG`].
fn pose(
    rec: &Recording,
    temps: &[f64],
    t0: f64,
    (s, b): (&Matrix3<f64>, &Vector3<f64>),
    path: &Path,
) -> Result<(Vector3<f64>, usize), WorkflowError> {
    let inv = s
        .try_inverse()
        .ok_or_else(|| still(path, StillRampError::SingularBench))?;
    let sensed = |k: usize| inv * (Vector3::from(rec.acc[k]) - b);
    let near: Vec<usize> = (0..rec.len())
        .filter(|k| (temps[*k] - t0).abs() <= NEAR && !rec.saturated[*k])
        .collect();
    if near.len() < 10 {
        let (lo, hi) = temps
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), t| {
                (a.min(*t), c.max(*t))
            });
        return Err(still(
            path,
            StillRampError::NotThroughBench {
                lo,
                hi,
                bench: t0,
                samples: near.len(),
            },
        ));
    }
    let f = near.iter().map(|k| sensed(*k)).sum::<Vector3<f64>>() / near.len() as f64;
    // Each second against the one before (where the unit was moved), then against the pose
    // (a slow turn).
    let per = ((WINDOW_S / rec.period).round() as usize).max(1);
    let mut previous: Option<Vector3<f64>> = None;
    let mut windows = Vec::new();
    for start in (0..rec.len()).step_by(per) {
        let end = (start + per).min(rec.len());
        let mean = (start..end).map(sensed).sum::<Vector3<f64>>() / (end - start) as f64;
        if let Some(p) = previous {
            let turn = mean.angle(&p).to_degrees();
            if turn > MOST_TURN_DEG {
                return Err(still(
                    path,
                    StillRampError::Turned {
                        line: rec.line[start],
                        turn,
                    },
                ));
            }
        }
        previous = Some(mean);
        windows.push((start, mean));
    }
    for (start, mean) in windows {
        let turn = mean.angle(&f).to_degrees();
        if turn > MOST_TURN_DEG {
            return Err(still(
                path,
                StillRampError::Moved {
                    line: rec.line[start],
                    turn,
                },
            ));
        }
    }
    Ok((f, near.len()))
}

/// The observations of the still recording at `path` for a triad or IMU of `kind` whose bench
/// observations are `bench` (at one temperature, its `temp` column): a table with the bench's
/// columns, its `lines` the recording's.
///
/// # Errors
/// A located [`WorkflowError`]: no temperature in the recording or the bench, a bench at
/// several temperatures, a ramp that does not pass the bench's temperature, a unit that moved.
pub fn observations(
    path: &Path,
    kind: Kind,
    bench: &Table,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<Table, WorkflowError> {
    let Some(bench_temps) = bench.column(col::TEMP) else {
        return Err(still(&opts.file, StillRampError::BenchWithoutTemperature));
    };
    let (lo, hi) = bench_temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), t| {
            (a.min(*t), c.max(*t))
        });
    if hi - lo > NEAR {
        return Err(still(&opts.file, StillRampError::BenchAtSeveral { lo, hi }));
    }
    let t0 = 0.5 * (lo + hi);
    let rec = recording::read_with(
        path,
        None,
        &recording::Options {
            rails: opts.rails,
            rate: None,
            keep: match kind {
                Kind::Accel => layout::Keep::Accel,
                Kind::Gyro => layout::Keep::Gyro,
                Kind::Imu => layout::Keep::Both,
            },
            units: units::Units::DEFAULT,
            columns: header::Chosen::default(),
        },
    )?;
    let Some((temp_name, temps)) = rec.temperature.clone() else {
        return Err(still(path, StillRampError::RecordingWithoutTemperature));
    };
    let gyro_g = bench
        .column(col::F[0])
        .is_some_and(|c| c.iter().any(|x| *x != c[0]));
    let force = match kind {
        Kind::Gyro if gyro_g => {
            return Err(still(path, StillRampError::LoneGyro));
        }
        Kind::Gyro => Vector3::zeros(),
        Kind::Accel | Kind::Imu => {
            let fit = bench_fit(bench, col::A, col::F, opts)?;
            let (f, near) = pose(&rec, &temps, t0, (&fit.0, &fit.1), path)?;
            notes.push(format!(
                "--still-ramp {}: the still pose's specific force [{:.4}, {:.4}, {:.4}] m/s^2 (|f| = {:.4}) from the bench's fit at the {near} samples within {NEAR} C of its {t0:.1} C",
                path.display(),
                f[0],
                f[1],
                f[2],
                f.norm()
            ));
            f
        }
    };
    let usable: Vec<usize> = (0..rec.len()).filter(|k| !rec.saturated[*k]).collect();
    let step = usable.len().div_ceil(MOST).max(1);
    let rows: Vec<usize> = usable.iter().step_by(step).copied().collect();
    let (tlo, thi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), k| {
            (a.min(temps[*k]), c.max(temps[*k]))
        });
    notes.push(format!(
        "--still-ramp {}: {} of its {} samples ({temp_name} {tlo:.1} to {thi:.1} C) are observations of that pose at rest beside the bench's {}",
        path.display(),
        rows.len(),
        rec.len(),
        bench.len()
    ));
    let volt = bench.column(col::VOLT).map(|v| v[0]);
    let columns = bench
        .names
        .iter()
        .map(|name| {
            let axis = |names: [&str; 3]| names.iter().position(|n| n == name);
            rows.iter()
                .map(|k| {
                    if let Some(i) = axis(col::F) {
                        force[i]
                    } else if let Some(i) = axis(col::A) {
                        rec.acc[*k][i]
                    } else if let Some(i) = axis(col::GYRO) {
                        rec.gyro[*k][i]
                    } else if name == col::TEMP {
                        temps[*k]
                    } else if name == col::VOLT {
                        volt.unwrap_or_default()
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    Ok(Table {
        path: path.to_path_buf(),
        names: bench.names.clone(),
        columns,
        lines: rows.iter().map(|k| u64::from(rec.line[*k])).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_ramp_error_names_the_file_and_keeps_its_cause() {
        let e = still(
            Path::new("ramp.csv"),
            StillRampError::NotThroughBench {
                lo: 30.0,
                hi: 60.0,
                bench: 25.0,
                samples: 3,
            },
        );
        assert_eq!(
            e.to_string(),
            "ramp.csv: --still-ramp: the recording's temperatures (30.0 to 60.0 C) come within 2 C of the bench's 25.0 C at 3 samples; at least 10 tie the still pose to the bench (record the ramp through the bench's temperature)"
        );
        let cause = std::error::Error::source(&e).unwrap().to_string();
        assert!(
            cause.starts_with("--still-ramp: the recording's"),
            "{cause}"
        );
        let turned = StillRampError::Turned {
            line: 12,
            turn: 4.25,
        };
        assert_eq!(
            turned.to_string(),
            "--still-ramp: line 12: the unit's specific force turned by 4.2 degrees within 1 s; the recording must be of one still pose"
        );
    }
}
