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
    /// The sample rate, Hz, of a recording without timestamps; over a file's own timestamps it is
    /// taken instead of them (a host that stamps samples in batches), and said.
    #[arg(long = "sample-rate", alias = "rate", value_parser = |s: &str| values::in_range(s, 1.0e-3, 1.0e6))]
    pub rate: Option<f64>,
    /// The units of the values (counts unless stated).
    #[command(flatten)]
    pub units: super::units::UnitArgs,
    /// Columns chosen by name.
    #[command(flatten)]
    pub columns: super::units::ColumnArgs,
    /// Which sensor; without it, both when the recording has both (two files, or one of six
    /// counts a line), and a file of one sensor's three counts is read as the gyro.
    #[arg(long, value_enum, ignore_case = true)]
    pub sensor: Option<Which>,
    /// Counts per SI unit (per rad/s or per m/s^2): one for all axes or three (x, y, z) of the
    /// one sensor analysed; of both, two (accelerometer, gyro) or six (accelerometer x, y, z,
    /// then gyro x, y, z). Without it the deviation is in counts.
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
    /// Write the curve and the terms as JSON here (`calflash.allan/2`, every sensor analysed;
    /// `calibrate --noise-terms` reads it).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the HTML report here: the terms per axis, and each axis' curve with its
    /// confidence bars, slope lines and read-off points.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the noise terms as Kalibr's `imu.yaml` here (both sensors, in SI units).
    #[arg(long)]
    pub kalibr: Option<PathBuf>,
}

impl Which {
    /// The sensor's name in the output.
    fn name(self) -> &'static str {
        match self {
            Self::Gyro => "gyro",
            Self::Accel => "accelerometer",
        }
    }

    /// Its name in the JSON record.
    fn key(self) -> &'static str {
        match self {
            Self::Gyro => "gyro",
            Self::Accel => "accel",
        }
    }
}

/// One sensor analysed: which, in what unit (and whether SI), and per axis its curve and terms.
struct Analysed {
    which: Which,
    unit: &'static str,
    si: bool,
    curves: Vec<Vec<Point>>,
    terms: Vec<NoiseTerms>,
}

/// Runs `calflash allan`.
///
/// # Errors
/// Bad input or too short a recording.
pub fn run(args: &AllanArgs) -> Result<(), Failure> {
    crate::files::Paths::new()
        .distinct_input("the recording", Some(&args.acc))
        .distinct_input("--gyro", args.gyro.as_deref())
        .output("--plot", args.plot.as_deref())
        .output("--json", args.json.as_deref())
        .output("--report", args.report.as_deref())
        .output("--kalibr", args.kalibr.as_deref())
        .check()?;
    let (rec, which, said) = read(args)?;
    let idx = window(args, &rec)?;
    let scales = scale(args, &rec, &which)?;
    if args.kalibr.is_some() && !(which.len() == 2 && scales.iter().all(|s| s.2)) {
        return Err(format!(
            "--kalibr: Kalibr's imu.yaml takes both sensors in SI units; this run analyses {}: give a recording of both (or both files) and their --scale (counts per m/s^2 and per rad/s)",
            which
                .iter()
                .zip(&scales)
                .map(|(w, s)| format!("the {} in {}", w.name(), s.1))
                .collect::<Vec<_>>()
                .join(" and ")
        )
        .into());
    }
    let read_line = format!(
        "{} samples at {:.2} Hz ({:.1} s), {}",
        idx.len(),
        rec.rate(),
        idx.len() as f64 / rec.rate(),
        which
            .iter()
            .zip(&scales)
            .map(|(w, (_, unit, _))| format!("{} in {unit}", w.name()))
            .collect::<Vec<_>>()
            .join(" and ")
    );
    println!("calflash allan  {}  {read_line}", rec.source);
    if let Some(s) = said {
        println!("  {s}");
    }
    let mut done: Vec<Analysed> = Vec::new();
    for (w, (scale, unit, si)) in which.iter().zip(scales) {
        let (curves, terms) = analyse(&rec, (idx.clone(), args.per_octave), *w, &scale)?;
        for (j, t) in terms.iter().enumerate() {
            let axis = ["x", "y", "z"][j];
            let label = if which.len() > 1 {
                format!("{} {axis}", w.name())
            } else {
                axis.to_string()
            };
            println!("  {label}: {}", crate::noise::said::line(t, unit));
        }
        done.push(Analysed {
            which: *w,
            unit,
            si,
            curves,
            terms,
        });
    }
    write_outputs(args, &rec, &done, &read_line)
}

/// The curves (at `per_octave` cluster sizes per doubling) and noise terms of the three axes
/// of sensor `w` over the samples `idx`, each count divided by its axis' `scale`.
fn analyse(
    rec: &recording::Recording,
    (idx, per_octave): (std::ops::Range<usize>, usize),
    w: Which,
    scale: &[f64; 3],
) -> Result<(Vec<Vec<Point>>, Vec<NoiseTerms>), Failure> {
    let kept = if w == Which::Gyro {
        &rec.gyro
    } else {
        &rec.acc
    };
    let mut curves = Vec::new();
    let mut terms = Vec::new();
    for j in 0..3 {
        let y: Vec<f64> = kept[idx.clone()].iter().map(|v| v[j] / scale[j]).collect();
        let c = allan::overlapping(&y, rec.period, per_octave);
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
                w.name(),
                ["x", "y", "z"][j],
                y[k]
            )
            .into());
        }
        terms.push(allan::noise_terms(&c));
        curves.push(c);
    }
    Ok((curves, terms))
}

/// The figure, the JSON record, the report and Kalibr's file, as asked.
fn write_outputs(
    args: &AllanArgs,
    rec: &recording::Recording,
    done: &[Analysed],
    read_line: &str,
) -> Result<(), Failure> {
    if let Some(p) = &args.plot {
        // One sensor's figure: the first analysed (the report has every axis of both).
        let first = &done[0];
        let svg = report::allan::figure(&first.curves, &first.terms, first.unit)?;
        crate::files::write_atomically(p, |w| w.write_all(svg.as_bytes()))?;
    }
    if let Some(p) = &args.json {
        let record = allan::Record {
            schema: allan::SCHEMA,
            source: &rec.source,
            sensors: done
                .iter()
                .map(|a| allan::SensorRecord {
                    sensor: a.which.key(),
                    unit: a.unit,
                    axes: (0..3)
                        .map(|j| allan::AxisRecord {
                            axis: ["x", "y", "z"][j],
                            curve: &a.curves[j],
                            terms: &a.terms[j],
                        })
                        .collect(),
                })
                .collect(),
        };
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &record).map_err(std::io::Error::other)
        })?;
    }
    let kalibr = kalibr_yaml(rec, done);
    if let (Some(p), Some(y)) = (&args.kalibr, &kalibr) {
        crate::files::write_atomically(p, |w| w.write_all(y.as_bytes()))?;
    }
    if let Some(p) = &args.report {
        let sensors: Vec<report::allan::Sensor<'_>> = done
            .iter()
            .map(|a| report::allan::Sensor {
                name: a.which.name(),
                unit: a.unit,
                curves: &a.curves,
                terms: &a.terms,
            })
            .collect();
        let page = crate::report::provenance::Provenance::now()
            .inputs(&[
                ("recording", Some(args.acc.as_path())),
                ("gyro recording", args.gyro.as_deref()),
            ])
            .stamp(&report::allan::html(
                &rec.source,
                read_line,
                &sensors,
                kalibr.as_deref(),
            )?);
        crate::files::write_atomically(p, |w| w.write_all(page.as_bytes()))?;
        crate::report::written::page(p);
    }
    Ok(())
}

/// Kalibr's `imu.yaml` when both sensors were analysed in SI units (`None` otherwise).
fn kalibr_yaml(rec: &recording::Recording, done: &[Analysed]) -> Option<String> {
    fn sensor(x: &Analysed) -> crate::noise::kalibr::Sensor<'_> {
        crate::noise::kalibr::Sensor {
            curves: &x.curves,
            terms: &x.terms,
        }
    }
    let find = |w: Which| done.iter().find(|a| a.which == w && a.si);
    let (a, g) = (find(Which::Accel)?, find(Which::Gyro)?);
    Some(crate::noise::kalibr::imu_yaml(
        &sensor(a),
        &sensor(g),
        rec.rate(),
        &rec.source,
    ))
}

/// The recording and the sensors to analyse (with what was assumed, to be said): `--sensor`'s,
/// or both when the recording has both.
fn read(args: &AllanArgs) -> Result<(recording::Recording, Vec<Which>, Option<String>), Failure> {
    let opts = |keep| recording::Options {
        rails: Rails::new(i32::MIN, i32::MAX),
        rate: args.rate,
        keep,
        units: args.units.units(),
        columns: args.columns.chosen(),
    };
    let keep = match args.sensor {
        Some(Which::Gyro) => crate::obs::layout::Keep::Gyro,
        Some(Which::Accel) => crate::obs::layout::Keep::Accel,
        None => crate::obs::layout::Keep::Both,
    };
    let both = recording::read_with(&args.acc, args.gyro.as_deref(), &opts(keep));
    let rec = match (both, &args.gyro) {
        (Ok(rec), _) => rec,
        (Err(e), Some(_)) => return Err(e.into()),
        // One sensor's file: read as both halves, the one --sensor names (the gyro unless).
        (Err(both @ recording::RecordingError::Fields { .. }), None) => {
            let one = args.sensor.unwrap_or(Which::Gyro);
            let keep = if one == Which::Gyro {
                crate::obs::layout::Keep::Gyro
            } else {
                crate::obs::layout::Keep::Accel
            };
            let rec = recording::read_with(&args.acc, Some(&args.acc), &opts(keep)).map_err(
                |e| match e {
                    // Its own error when it reads as one sensor but is wrong otherwise.
                    recording::RecordingError::Fields { .. } => both,
                    e => e,
                },
            )?;
            let said = args.sensor.is_none().then(|| {
                "one sensor's three counts a line: read as the gyro (--sensor accel if it is the accelerometer)".to_string()
            });
            return Ok((rec, vec![one], said));
        }
        (Err(e), None) => return Err(e.into()),
    };
    let which = match args.sensor {
        Some(w) => vec![w],
        None => vec![Which::Accel, Which::Gyro],
    };
    Ok((rec, which, None))
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

/// Counts per unit per axis, the unit of the values, and whether it is SI.
type Scaled = ([f64; 3], &'static str, bool);

/// Per sensor analysed: counts per unit per axis (`--scale`), the unit of the values, and
/// whether it is SI.
fn scale(
    args: &AllanArgs,
    rec: &recording::Recording,
    which: &[Which],
) -> Result<Vec<Scaled>, Failure> {
    let given = args.scale.as_slice();
    let per_sensor: Vec<[f64; 3]> = match (which.len(), given) {
        (_, []) => vec![[1.0; 3]; which.len()],
        (1, [s]) => vec![[*s; 3]],
        (1, [x, y, z]) => vec![[*x, *y, *z]],
        (2, [a, g]) => vec![[*a; 3], [*g; 3]],
        (2, [ax, ay, az, gx, gy, gz]) => vec![[*ax, *ay, *az], [*gx, *gy, *gz]],
        (1, other) => {
            return Err(format!("--scale: one value or three, {} given", other.len()).into());
        }
        (_, other) => {
            return Err(format!(
                "--scale: both sensors are analysed: two values (accelerometer, gyro) or six (accelerometer x, y, z, then gyro x, y, z), {} given; or name one with --sensor",
                other.len()
            )
            .into());
        }
    };
    if per_sensor
        .iter()
        .flatten()
        .any(|s| !(s.is_finite() && *s != 0.0))
    {
        return Err("--scale: counts per unit must be finite and non-zero".into());
    }
    which
        .iter()
        .zip(per_sensor)
        .map(|(w, scale)| {
            let (sensor, read) = match w {
                Which::Gyro => (Sensor::Gyro, rec.units[1]),
                Which::Accel => (Sensor::Accel, rec.units[0]),
            };
            if read.is_si() && !given.is_empty() {
                return Err(format!(
                    "--scale: the values are already in {} (read from {}); --scale is for counts",
                    units::si(sensor),
                    read.file.name()
                )
                .into());
            }
            let (unit, si) = match (read.is_si(), given.is_empty()) {
                (true, _) => (units::si(sensor), true),
                (false, true) => ("counts", false),
                (false, false) => (units::si(sensor), true),
            };
            Ok((scale, unit, si))
        })
        .collect()
}
