//! `calflash allan`: the overlapping Allan deviation of a still recording and its IEEE Std 952
//! noise terms, per axis, in stated units, with a log-log figure.

use crate::cmd::Failure;
use std::path::PathBuf;

use super::values;
use clap::Args;
use spincal::model::Rails;

use crate::noise::allan::{self, NoiseTerms, Point};
use crate::obs::recording;
use crate::obs::units::{self, Sensor};
use crate::report;

/// Which sensor of the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    /// The gyro (rad/s with --scale).
    Gyro,
    /// The accelerometer (m/s^2 with --scale).
    Accel,
}

/// Allan deviation of a still recording.
#[derive(Debug, Args)]
pub struct AllanArgs {
    /// The recording (as `calflash selfcal` reads it), or a file of the one sensor `--sensor`
    /// names (a timestamp, or none with `--sample-rate`, and three counts a line).
    pub acc: PathBuf,
    /// The gyro file, when separate.
    pub gyro: Option<PathBuf>,
    /// The sample rate, Hz, of a recording without timestamps (checked against them otherwise).
    #[arg(long = "sample-rate", alias = "rate", value_parser = |s: &str| values::in_range(s, 1.0e-3, 1.0e6))]
    pub rate: Option<f64>,
    /// The units of the values (counts unless stated).
    #[command(flatten)]
    pub units: super::units::UnitArgs,
    /// Columns chosen by name.
    #[command(flatten)]
    pub columns: super::units::ColumnArgs,
    /// Which sensor.
    #[arg(long, value_enum, ignore_case = true, default_value = "gyro")]
    pub sensor: Which,
    /// Counts per SI unit (per rad/s or per m/s^2), one for all axes or three; without it the
    /// deviation is in counts.
    #[arg(long, value_delimiter = ',', value_parser = values::positive)]
    pub scale: Vec<f64>,
    /// Use only samples from this time on, s from the start.
    #[arg(long, value_parser = values::positive)]
    pub from: Option<f64>,
    /// Up to this time, s from the start.
    #[arg(long, value_parser = values::positive)]
    pub to: Option<f64>,
    /// Cluster sizes per doubling of tau.
    #[arg(long, default_value_t = 2, value_parser = |s: &str| values::count_in(s, 1, 64))]
    pub per_octave: usize,
    /// Write the log-log figure (SVG) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write the curve and the terms as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `calflash allan`.
///
/// # Errors
/// Bad input or too short a recording.
pub fn run(args: &AllanArgs) -> Result<(), Failure> {
    crate::files::Paths::new()
        .input("the recording", Some(&args.acc))
        .input("--gyro", args.gyro.as_deref())
        .output("--plot", args.plot.as_deref())
        .output("--json", args.json.as_deref())
        .check()?;
    let rec = read(args)?;
    let idx = window(args, &rec)?;
    let (scale, unit, si) = scale(args, &rec)?;
    let axes = ["x", "y", "z"];
    let mut curves: Vec<Vec<Point>> = Vec::new();
    let mut terms: Vec<NoiseTerms> = Vec::new();
    println!(
        "calflash allan  {}  {} samples at {:.2} Hz ({:.1} s), {} in {unit}",
        rec.source,
        idx.len(),
        rec.rate(),
        idx.len() as f64 / rec.rate(),
        if args.sensor == Which::Gyro {
            "gyro"
        } else {
            "accelerometer"
        }
    );
    for j in 0..3 {
        let kept = if args.sensor == Which::Gyro {
            &rec.gyro
        } else {
            &rec.acc
        };
        let y: Vec<f64> = kept[idx.clone()].iter().map(|v| v[j] / scale[j]).collect();
        let c = allan::overlapping(&y, rec.period, args.per_octave);
        if c.iter().any(|p| !p.adev.is_finite()) {
            // Squares of the cluster differences overflow: name the sample that makes them.
            let k = (0..y.len())
                .max_by(|&p, &q| y[p].abs().total_cmp(&y[q].abs()))
                .unwrap_or(0);
            return Err(format!(
                "{}:{}: {} axis {} = {:e}: too large for the Allan deviation (its squares \
                 overflow); a value that large is a misread: fix the line or take a part \
                 without it (--from/--to)",
                rec.source,
                rec.line[idx.start + k],
                if args.sensor == Which::Gyro {
                    "gyro"
                } else {
                    "accelerometer"
                },
                axes[j],
                y[k]
            )
            .into());
        }
        let t = allan::noise_terms(&c);
        println!("  {}: {}", axes[j], describe(&t, args.sensor, unit, si));
        curves.push(c);
        terms.push(t);
    }
    if let Some(p) = &args.plot {
        let svg = report::allan::figure(&curves, &terms, unit)?;
        crate::files::write_atomically(p, |w| w.write_all(svg.as_bytes()))?;
    }
    if let Some(p) = &args.json {
        let record = allan::Record {
            schema: allan::SCHEMA,
            source: &rec.source,
            unit,
            axes: (0..3)
                .map(|j| allan::AxisRecord {
                    axis: axes[j],
                    curve: &curves[j],
                    terms: &terms[j],
                })
                .collect(),
        };
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &record).map_err(std::io::Error::other)
        })?;
    }
    Ok(())
}

/// The recording: only the sensor `--sensor` names is read and kept.
fn read(args: &AllanArgs) -> Result<recording::Recording, Failure> {
    let opts = recording::Options {
        rails: Rails::new(i32::MIN, i32::MAX),
        rate: args.rate,
        // Only the sensor asked for is read and kept.
        keep: match args.sensor {
            Which::Gyro => crate::obs::layout::Keep::Gyro,
            Which::Accel => crate::obs::layout::Keep::Accel,
        },
        units: args.units.units(),
        columns: args.columns.chosen(),
    };
    let rec = match &args.gyro {
        Some(g) => recording::read_with(&args.acc, Some(g), &opts),
        // Both sensors in one file, or the one sensor --sensor names (read as both halves).
        None => recording::read_with(&args.acc, None, &opts).or_else(|both| match both {
            recording::RecordingError::Fields { .. } => {
                // Its own error when it reads as one sensor but is wrong otherwise.
                recording::read_with(&args.acc, Some(&args.acc), &opts).map_err(|one| match one {
                    recording::RecordingError::Fields { .. } => both,
                    e => e,
                })
            }
            e => Err(e),
        }),
    }?;
    Ok(rec)
}

/// The samples between `--from` and `--to`: at least 100, with no gap.
fn window(args: &AllanArgs, rec: &recording::Recording) -> Result<std::ops::Range<usize>, Failure> {
    let t0 = rec.t[0];
    let (a, b) = (args.from.unwrap_or(0.0), args.to.unwrap_or(f64::INFINITY));
    // Timestamps increase: the samples in [a, b] are one run.
    let idx = rec.t.partition_point(|t| t - t0 < a)..rec.t.partition_point(|t| t - t0 <= b);
    if idx.len() < 100 {
        let span = match (args.from, args.to) {
            (None, None) => String::new(),
            (from, to) => format!(
                " between {} s and {}",
                from.unwrap_or(0.0),
                to.map_or_else(|| "its end".to_string(), |t| format!("{t} s"))
            ),
        };
        return Err(format!(
            "{}: {} samples{span}; the Allan deviation needs a still recording of at least 100 (many thousands for the slow terms)",
            rec.source,
            idx.len()
        ).into());
    }
    if let Some(g) = rec.gaps.iter().find(|g| (a..=b).contains(&(g.from - t0))) {
        return Err(format!(
            "{}:{}: {} samples dropped at {:.3} s; the Allan deviation needs an unbroken record (use --from/--to to take a part without gaps)",
            rec.source,
            g.line,
            g.missing,
            g.from - t0
        ).into());
    }
    Ok(idx)
}

/// Counts per unit per axis (`--scale`), the unit of the values, and whether it is SI.
fn scale(
    args: &AllanArgs,
    rec: &recording::Recording,
) -> Result<([f64; 3], &'static str, bool), Failure> {
    let scale: [f64; 3] = match args.scale.as_slice() {
        [] => [1.0; 3],
        [s] => [*s; 3],
        [x, y, z] => [*x, *y, *z],
        other => {
            return Err(format!("--scale: one value or three, {} given", other.len()).into());
        }
    };
    if scale.iter().any(|s| !(s.is_finite() && *s != 0.0)) {
        return Err("--scale: counts per unit must be finite and non-zero".into());
    }
    let (sensor, read) = match args.sensor {
        Which::Gyro => (Sensor::Gyro, rec.units[1]),
        Which::Accel => (Sensor::Accel, rec.units[0]),
    };
    if read.is_si() && !args.scale.is_empty() {
        return Err(format!(
            "--scale: the values are already in {} (read from {}); --scale is for counts",
            units::si(sensor),
            read.file.name()
        )
        .into());
    }
    let (unit, si) = match (read.is_si(), args.scale.is_empty()) {
        (true, _) => (units::si(sensor), true),
        (false, true) => ("counts", false),
        (false, false) => (units::si(sensor), true),
    };
    Ok((scale, unit, si))
}

fn describe(t: &NoiseTerms, which: Which, unit: &str, si: bool) -> String {
    use crate::report::terminal::num;
    let deg = 180.0 / std::f64::consts::PI;
    // A term the fit set to zero was not resolved by this record (too short, or hidden under
    // the others): said so, not printed as 0.
    let show = |v: f64, units: &[(f64, &str)]| -> String {
        if v > 0.0 {
            units
                .iter()
                .map(|(k, u)| format!("{} {u}", num(v * k)))
                .collect::<Vec<_>>()
                .join(" = ")
        } else {
            "not resolved in this record".to_string()
        }
    };
    let (rw, bi, rrw, q, ramp) = match (which, si) {
        (Which::Gyro, true) => (
            format!(
                "ARW {}",
                show(
                    t.random_walk,
                    &[(1.0, "rad/s/sqrt(Hz)"), (deg * 60.0, "deg/sqrt(h)")]
                )
            ),
            show(
                t.bias_instability,
                &[(1.0, "rad/s"), (deg * 3600.0, "deg/h")],
            ),
            format!(
                "RRW {}",
                show(
                    t.rate_random_walk,
                    &[
                        (1.0, "rad/s/sqrt(s)"),
                        (deg * 3600.0 * 60.0, "deg/h/sqrt(h)")
                    ]
                )
            ),
            show(t.quantization, &[(1.0, "rad")]),
            format!("rate ramp {}", show(t.rate_ramp, &[(1.0, "rad/s^2")])),
        ),
        (Which::Accel, true) => (
            format!(
                "VRW {}",
                show(
                    t.random_walk,
                    &[(1.0, "m/s^2/sqrt(Hz)"), (60.0, "m/s/sqrt(h)")]
                )
            ),
            show(
                t.bias_instability,
                &[(1.0, "m/s^2"), (1.0 / 9.80665e-3, "mg")],
            ),
            format!(
                "acceleration random walk {}",
                show(t.rate_random_walk, &[(1.0, "m/s^2/sqrt(s)")])
            ),
            show(t.quantization, &[(1.0, "m/s")]),
            format!("ramp {}", show(t.rate_ramp, &[(1.0, "m/s^3")])),
        ),
        _ => {
            let per = |suffix: &str| format!("{unit}{suffix}");
            (
                format!(
                    "random walk {}",
                    show(t.random_walk, &[(1.0, &per("/sqrt(Hz)"))])
                ),
                show(t.bias_instability, &[(1.0, unit)]),
                format!(
                    "rate random walk {}",
                    show(t.rate_random_walk, &[(1.0, &per("/sqrt(s)"))])
                ),
                show(t.quantization, &[(1.0, &per(" s"))]),
                format!("ramp {}", show(t.rate_ramp, &[(1.0, &per("/s"))])),
            )
        }
    };
    format!("{rw}; bias instability {bi}; {rrw}; quantization {q}; {ramp}")
}
