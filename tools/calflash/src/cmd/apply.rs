//! `calflash apply`: raw counts through the firmware crate's own correction, to SI values, so
//! a user sees exactly what the device computes.

use crate::cmd::Failure;
use std::path::PathBuf;

use super::values;
use clap::Args;
use spincal::correct::{AnyCorrector, Flags};
use spincal::model::Sensor;

use crate::columns as col;
use crate::files::Paths;
use crate::obs::timing::{Timing, TimingError};
use crate::obs::{self, Format};
use crate::sensor::accuracy::Accuracy;

/// Run a file of raw counts through the device's correction.
#[derive(Debug, Args)]
pub struct ApplyArgs {
    /// The calibration blob.
    #[arg(long)]
    pub blob: PathBuf,
    /// The raw file: observations with a header row, or with `--recording` a raw recording
    /// (timestamp and counts per line, as `calflash selfcal` reads).
    pub input: PathBuf,
    /// The input is a raw recording: timestamp and three counts per line (then give the gyro
    /// file with `--gyro`), or timestamp and six counts.
    #[arg(long)]
    pub recording: bool,
    /// The gyro file of a recording in two files.
    #[arg(long, requires = "recording")]
    pub gyro: Option<PathBuf>,
    /// The raw columns, comma-separated (default: output; a_x,a_y,a_z; g_x,g_y,g_z; or all six
    /// for an IMU). With `--recording`, roles by header name as `selfcal` takes them:
    /// `t=stamp:ms,ax=A1,...,gz=R3,temp=die_c` (a temperature column then sets each sample's
    /// temperature).
    #[arg(long, value_delimiter = ',')]
    pub columns: Vec<String>,
    /// Temperature, C, for every sample (default: the middle of the calibrated span).
    #[arg(long, conflicts_with = "temp_column", value_parser = values::finite_f32)]
    pub temp: Option<f32>,
    /// A column with the temperature of each sample.
    #[arg(long)]
    pub temp_column: Option<String>,
    /// Supply voltage, V (default: the middle of the calibrated span).
    #[arg(long, value_parser = values::finite_f32)]
    pub volt: Option<f32>,
    /// Sample rate, Hz. An IMU calibration with lever arms needs it (its tangential term
    /// takes the rate derivative by backward difference) or the timestamps: `--time-column`,
    /// or a recording's.
    #[arg(long = "sample-rate", alias = "rate", value_parser = values::sample_rate)]
    pub rate: Option<f64>,
    /// The largest angular acceleration the airframe makes, rad/s^2: with a lever arm, a
    /// sample whose rate changed by more over one sample period is flagged `rate-step` (a
    /// glitch or a gap; its tangential lever term is wrong). Default: the device's, 5e5.
    #[arg(long, value_parser = values::positive_f32)]
    pub max_angular_acceleration: Option<f32>,
    /// The units of the values (counts unless stated).
    #[command(flatten)]
    pub units: super::units::UnitArgs,
    /// A column with each sample's time: the rate, when `--sample-rate` is not given, and a sample
    /// after a step that is not the rate is flagged (its rate derivative is unknown). Its unit
    /// from its name (`t`, `time`: seconds; `t_ms`, `time_us`, `timestamp_ns`) or given as
    /// `NAME:ms` (s, ms, us, ns).
    #[arg(long, conflicts_with = "recording", value_parser = time_column)]
    pub time_column: Option<(String, f64)>,
    /// Hold the corrected values against the reference columns of the input (`f_*`, `w_*`, or
    /// `input` for a single axis): mean and RMS error of the unflagged samples against the
    /// stated 1-sigma, per output.
    #[arg(long)]
    pub reference: bool,
    /// Also write the 1-sigma calibration error of each value.
    #[arg(long)]
    pub sigma: bool,
    /// With --reference: write an HTML page of each output's error along the recording
    /// (against its time, or the sample number without one) with the robust figures.
    #[arg(long, requires = "reference")]
    pub report: Option<PathBuf>,
    /// Field separator of the input.
    #[arg(long, value_enum, default_value = "auto")]
    pub format: Format,
    /// The corrected file to write (CSV).
    #[arg(long, short)]
    pub output: PathBuf,
}

/// Raw samples to correct, with a label per sample.
struct Input {
    header: String,
    labels: Vec<String>,
    raw: Vec<Vec<i32>>,
    temps: Option<Vec<f64>>,
    /// Timestamps, s.
    times: Option<Vec<f64>>,
    /// The reference inputs per sample (`--reference`).
    reference: Option<Vec<Vec<f64>>>,
}

fn recording_input(args: &ApplyArgs, channels: usize) -> Result<Input, Failure> {
    let rails = spincal::model::Rails::new(i32::MIN, i32::MAX);
    let (acc, gyro) = match (channels, &args.gyro) {
        (6, Some(g)) => (args.input.as_path(), Some(g.as_path())),
        (6, None) => (args.input.as_path(), None),
        // One triad: its file holds a timestamp and three counts; read it as both halves.
        (3, None) => (args.input.as_path(), Some(args.input.as_path())),
        _ => {
            return Err(format!(
                "--gyro: the calibration corrects {channels} channel(s); a gyro file goes with an IMU calibration"
            ).into());
        }
    };
    let columns = if args.columns.is_empty() {
        crate::obs::header::Chosen::default()
    } else {
        crate::obs::header::Chosen::parse(&args.columns.join(","))
            .map_err(|e| format!("--columns: {e}"))?
    };
    let opts = crate::obs::recording::Options {
        rails,
        rate: args.rate,
        keep: crate::obs::layout::Keep::Both,
        units: args.units.units(),
        columns,
    };
    let rec = crate::obs::recording::read_with(acc, gyro, &opts)?;
    if rec.units.iter().any(|u| u.is_si()) {
        return Err(format!(
            "{}: the values are physical and the blob corrects converter codes; give --lsb \
             ACCEL,GYRO (the value of one code, as the calibration was made with)",
            rec.source
        )
        .into());
    }
    Ok(Input {
        header: "line,t".into(),
        labels: rec
            .line
            .iter()
            .zip(&rec.t)
            .map(|(l, t)| format!("{l},{t}"))
            .collect(),
        raw: rec
            .acc
            .iter()
            .zip(&rec.gyro)
            .map(|(a, g)| {
                let a = a.map(|x| x.round() as i32);
                if channels == 6 {
                    a.into_iter().chain(g.map(|x| x.round() as i32)).collect()
                } else {
                    a.to_vec()
                }
            })
            .collect(),
        // A temperature column sets each sample's temperature, unless --temp fixes one.
        temps: args
            .temp
            .is_none()
            .then(|| rec.temperature.as_ref().map(|(_, v)| v.clone()))
            .flatten(),
        times: Some(rec.t.clone()),
        reference: None,
    })
}

/// Runs `calflash apply`.
///
/// # Errors
/// A bad blob or input file.
pub fn run(args: &ApplyArgs) -> Result<(), Failure> {
    Paths::new()
        .input("--blob", Some(&args.blob))
        .input("the raw file", Some(&args.input))
        .input("--gyro", args.gyro.as_deref())
        .output("-o", Some(&args.output))
        .output("--report", args.report.as_deref())
        .check()?;
    let bytes = crate::files::read_blob(&args.blob)?;
    let cal =
        crate::signing::calibration(&bytes).map_err(|e| format!("{}: {e}", args.blob.display()))?;
    let data = cal.data();
    let channels = Channels::of(&data.sensor);
    let cols: Vec<String> = if args.columns.is_empty() {
        channels.raw.iter().map(|s| s.to_string()).collect()
    } else {
        args.columns.clone()
    };
    if cols.len() != channels.raw.len() && !args.recording {
        return Err(format!(
            "--columns: the calibration corrects {} channel(s), {} columns given",
            channels.raw.len(),
            cols.len()
        )
        .into());
    }
    let input = if args.recording {
        if args.reference {
            return Err("--reference: a raw recording has no reference columns".into());
        }
        recording_input(args, channels.raw.len())?
    } else {
        table_input(args, &cols, &channels.reference)?
    };
    let lever = matches!(
        &data.sensor,
        Sensor::Imu {
            lever_arm: Some(_),
            ..
        }
    );
    let timing = timing(args, &cal, lever, &input)?;
    let env = &data.environment;
    let mid = |s: spincal::model::Span| 0.5 * (s.lo + s.hi);
    let volt = args.volt.unwrap_or_else(|| mid(env.voltage_span));
    let temp0 = args.temp.unwrap_or_else(|| mid(env.temperature_span));
    let imu = matches!(data.sensor, Sensor::Imu { .. });
    let mut corrector = AnyCorrector::new(&cal, timing.as_ref().map_or(1000.0, |t| t.rate as f32))
        .map_err(|e| {
            if imu {
                format!("--sample-rate: {e}")
            } else {
                e.to_string()
            }
        })?;
    if let Some(a) = args.max_angular_acceleration {
        corrector
            .set_max_angular_acceleration(a)
            .map_err(|e| format!("--max-angular-acceleration: {e}"))?;
    }
    corrector.set_environment(temp0, volt);
    let mut header = vec![input.header.clone()];
    header.extend(channels.out.iter().map(|s| s.to_string()));
    header.extend(["flags".to_string(), "flag_names".to_string()]);
    if args.sigma {
        header.extend(channels.out.iter().map(|s| format!("sigma_{s}")));
    }
    let corrected = correct_all(
        args,
        &mut corrector,
        &input,
        timing.as_ref(),
        (temp0, volt),
        &channels.out,
    )?;
    let mut staged = crate::files::Staged::new();
    staged.write(&args.output, |w| {
        writeln!(w, "{}", header.join(","))?;
        w.write_all(corrected.rows.as_bytes())
    })?;
    if let (Some(path), Some(acc)) = (&args.report, &corrected.accuracy) {
        let units: Vec<&'static str> = channels
            .reference
            .iter()
            .map(|r| match (r.chars().next(), &data.sensor) {
                (Some('f'), _) => "m/s^2",
                (Some('w'), _) => "rad/s",
                (
                    _,
                    Sensor::Single {
                        quantity: spincal::model::Quantity::Acceleration,
                        ..
                    },
                ) => "m/s^2",
                _ => "rad/s",
            })
            .collect();
        let (x, label): (Vec<f64>, &str) = match &input.times {
            Some(t) => (t.clone(), "time, s"),
            None => ((0..input.raw.len()).map(|i| i as f64).collect(), "sample"),
        };
        let title = format!(
            "{} corrected with unit {}'s calibration",
            args.input.display(),
            data.identity.serial
        );
        let calibration = calibration_line(&args.blob, &bytes, data);
        let html = crate::report::provenance::Provenance::now()
            .serial(data.identity.serial.as_str())
            .inputs(&[
                ("input", Some(args.input.as_path())),
                ("gyro", args.gyro.as_deref()),
            ])
            .blob_file(&args.blob)
            .stamp(&crate::report::accuracy::html(
                (&title, &calibration),
                acc,
                (&x, label),
                &units,
            )?);
        staged.write(path, |w| w.write_all(html.as_bytes()))?;
        crate::report::written::page(path);
    }
    staged.commit()?;
    report(args, &cal, &input, timing.as_ref(), lever, &corrected);
    Ok(())
}

/// Which calibration a page describes, from the blob's own bytes: its file, length and SHA-256,
/// the unit, when and by which calflash it was made from which data, and who signed it.
fn calibration_line(
    path: &std::path::Path,
    bytes: &[u8],
    data: &spincal::model::CalibrationData,
) -> String {
    use sha2::Digest as _;
    let id = &data.identity;
    let hex = |b: &[u8]| b.iter().map(|x| format!("{x:02x}")).collect::<String>();
    let [a, b, c] = id.tool_version;
    format!(
        "unit {}, blob {} ({} bytes, SHA-256 {}), made {} UTC by calflash {a}.{b}.{c} from data whose SHA-256 begins {}; {}{}",
        id.serial,
        path.display(),
        bytes.len(),
        hex(&sha2::Sha256::digest(bytes)),
        crate::cmd::history::format_time(i64::try_from(id.created_unix_s).unwrap_or(i64::MAX)),
        hex(&id.data_hash),
        match crate::signing::signer(bytes) {
            Some((key, counter)) => format!("signed by station key {key}, counter {counter}"),
            None => "unsigned".to_string(),
        },
        if id.fit_rejected {
            "; its fit was REJECTED and the blob forced"
        } else {
            ""
        }
    )
}

/// The raw columns a calibration's sensor corrects, the names of its outputs, and the
/// reference columns `--reference` compares them with.
struct Channels {
    raw: Vec<&'static str>,
    out: Vec<&'static str>,
    reference: Vec<&'static str>,
}

impl Channels {
    fn of(sensor: &Sensor) -> Self {
        use spincal::model::Quantity::Acceleration;
        let (raw, out, reference) = match sensor {
            Sensor::Single { .. } => (vec![col::OUTPUT], vec!["value"], vec![col::INPUT]),
            Sensor::Triad {
                quantity: Acceleration,
                ..
            } => (col::A.to_vec(), vec!["ax", "ay", "az"], col::F.to_vec()),
            Sensor::Triad { .. } => (col::GYRO.to_vec(), vec!["wx", "wy", "wz"], col::W.to_vec()),
            Sensor::Imu { .. } => (
                col::A.iter().chain(&col::GYRO).copied().collect(),
                vec!["ax", "ay", "az", "wx", "wy", "wz"],
                col::F.iter().chain(&col::W).copied().collect(),
            ),
        };
        Self {
            raw,
            out,
            reference,
        }
    }
}

/// The raw columns `cols` of an observations file, with the temperature, time and reference
/// columns asked for.
fn table_input(
    args: &ApplyArgs,
    cols: &[String],
    reference_cols: &[&str],
) -> Result<Input, Failure> {
    let mut wanted = cols.to_vec();
    wanted.extend(args.temp_column.iter().cloned());
    wanted.extend(args.time_column.iter().map(|(name, _)| name.clone()));
    if args.reference {
        wanted.extend(reference_cols.iter().map(|c| c.to_string()));
    }
    let table = obs::read_columns(&args.input, &wanted, args.format)?;
    let named = |c: &Option<String>| {
        c.as_ref()
            .and_then(|t| table.column(t))
            .map(<[f64]>::to_vec)
    };
    Ok(Input {
        header: "line".into(),
        labels: table.lines.iter().map(ToString::to_string).collect(),
        raw: (0..table.len())
            .map(|i| {
                cols.iter()
                    .map(|c| table.column(c).map_or(0, |v| v[i].round() as i32))
                    .collect()
            })
            .collect(),
        temps: named(&args.temp_column),
        times: args.time_column.as_ref().and_then(|(name, scale)| {
            table
                .column(name)
                .map(|v| v.iter().map(|t| t * scale).collect())
        }),
        reference: args.reference.then(|| {
            (0..table.len())
                .map(|i| {
                    reference_cols
                        .iter()
                        .map(|c| table.column(c).map_or(f64::NAN, |v| v[i]))
                        .collect()
                })
                .collect()
        }),
    })
}

/// `--time-column NAME[:UNIT]`: the column and its scale to seconds.
fn time_column(s: &str) -> Result<(String, f64), String> {
    crate::obs::header::time_column(s, s, "").map_err(|e| e.to_string())
}

/// The sample rate: an IMU with lever arms (`lever`) needs it; a stream with timestamps has
/// its off-rate steps found. `None` when neither the rate nor timestamps are given and no
/// term needs them.
fn timing(
    args: &ApplyArgs,
    cal: &spincal::model::Calibration,
    lever: bool,
    input: &Input,
) -> Result<Option<Timing>, Failure> {
    match Timing::new(args.rate, input.times.as_deref()) {
        Ok(t) if !values::SAMPLE_RATES.contains(&t.rate) => {
            Err(format!(
                "{}: the time column gives {:.3e} Hz, a rate no inertial sensor samples at: is it in another unit? Give it as --time-column NAME:ms (s, ms, us, ns)",
                args.input.display(),
                t.rate
            )
            .into())
        }
        Ok(t) => Ok(Some(t)),
        Err(TimingError::Missing) if !lever => Ok(None),
        Err(TimingError::Missing) => Err(format!(
            "{}: unit {}'s calibration has lever arms, whose tangential term needs the sample rate: give --sample-rate HZ, or the timestamps with --time-column NAME",
            args.blob.display(),
            cal.data().identity.serial
        )
        .into()),
        Err(e) => Err(format!("{}: {e}", args.input.display()).into()),
    }
}

/// Every sample corrected: the output file's rows, how many were flagged, and the accuracy
/// against the reference columns when they were given.
struct Corrected {
    rows: String,
    flagged: usize,
    /// Samples flagged `rate-step`.
    rate_steps: usize,
    accuracy: Option<Accuracy>,
}

/// Runs every sample of `input` through `corrector`, following the temperature column when
/// there is one (`env`: the temperature it starts at, and the voltage), and resetting the rate
/// derivative after each off-rate step.
fn correct_all(
    args: &ApplyArgs,
    corrector: &mut AnyCorrector<'_>,
    input: &Input,
    timing: Option<&Timing>,
    (temp0, volt): (f32, f32),
    out_names: &[&str],
) -> Result<Corrected, Failure> {
    let n = corrector.outputs();
    let temps = input.temps.as_deref();
    let mut last_temp = temp0;
    let mut rows = String::new();
    use std::fmt::Write as _;
    let mut flagged = 0usize;
    let mut rate_steps = 0usize;
    let off_rate: std::collections::HashSet<usize> = timing
        .iter()
        .flat_map(|t| t.off_rate.iter().copied())
        .collect();
    let mut accuracy = input.reference.as_ref().map(|_| Accuracy::new(out_names));
    for (i, raw) in input.raw.iter().enumerate() {
        if off_rate.contains(&i) {
            // The step before this sample is not the rate: its derivative is unknown.
            corrector.reset();
        }
        if let Some(t) = temps {
            let t = t[i] as f32;
            if t != last_temp {
                corrector.set_environment(t, volt);
                last_temp = t;
            }
        }
        let codes = raw.get(..n).unwrap_or_default();
        let Some(o) = corrector.correct(codes) else {
            return Err(format!(
                "{}: sample {} has {} codes; the calibration's sensor takes {n}",
                args.input.display(),
                input.labels[i],
                raw.len()
            )
            .into());
        };
        let values = o.values[..n].to_vec();
        let flags: Flags = o.flags;
        let sigma = corrector.sigma(codes, &o.values).map(|s| s[..n].to_vec());
        flagged += usize::from(!flags.is_clean());
        rate_steps += usize::from(flags.contains(Flags::RATE_STEP));
        if let (Some(acc), Some(reference)) = (&mut accuracy, &input.reference)
            && flags.is_clean()
        {
            acc.add(i, &values, &reference[i], sigma.as_deref());
        }
        let _ = write!(rows, "{}", input.labels[i]);
        for v in &values {
            let _ = write!(rows, ",{v}");
        }
        let _ = write!(rows, ",{},{}", flags.bits(), flags);
        if args.sigma {
            match &sigma {
                Some(s) => s.iter().for_each(|v| {
                    let _ = write!(rows, ",{v}");
                }),
                None => values.iter().for_each(|_| rows.push(',')),
            }
        }
        rows.push('\n');
    }
    Ok(Corrected {
        rows,
        flagged,
        rate_steps,
        accuracy,
    })
}

/// What `apply` says when it is done: the samples, the flagged ones, the rate and its off-rate
/// steps, and the accuracy against the reference.
fn report(
    args: &ApplyArgs,
    cal: &spincal::model::Calibration,
    input: &Input,
    timing: Option<&Timing>,
    lever: bool,
    corrected: &Corrected,
) {
    let data = cal.data();
    println!(
        "calflash apply: {} samples corrected with unit {}'s calibration ({} flagged) into {}",
        input.raw.len(),
        data.identity.serial,
        corrected.flagged,
        args.output.display()
    );
    if let Some(t) = timing {
        println!("  sample rate {}", t.source);
        if !t.off_rate.is_empty() {
            println!(
                "  {} time steps are not the rate (first before line {}): {}",
                t.off_rate.len(),
                input.labels[t.off_rate[0]].split(',').next().unwrap_or(""),
                if lever {
                    "the samples after them are flagged, their rate derivative unknown"
                } else {
                    "no term of this calibration depends on the rate"
                }
            );
        }
    }
    let largest = args
        .max_angular_acceleration
        .unwrap_or(spincal::correct::DEFAULT_MAX_ANGULAR_ACCELERATION);
    if corrected.rate_steps > 0 {
        println!(
            "  {} sample(s) flagged rate-step: the rate changed faster than {largest:e} rad/s^2, more than the airframe turns (--max-angular-acceleration); a glitch or a gap, their lever-arm correction not trusted",
            corrected.rate_steps
        );
    } else if args.max_angular_acceleration.is_some() && !lever {
        println!(
            "  --max-angular-acceleration is not used: this calibration has no lever arm, so no rate difference enters its correction and no rate step is flagged"
        );
    }
    if let Some(acc) = &corrected.accuracy {
        println!(
            "  against the reference columns, {} unflagged samples:",
            acc.count()
        );
        println!(
            "  | output | mean error | RMS error | stated 1-sigma (median) | the statement | median error | robust spread | 99 % of abs. error below | worst (sample) | far out |"
        );
        let n = acc.count();
        for r in acc.rows() {
            use crate::sensor::accuracy::Statement;
            println!(
                "  | {} | {:.4e} | {:.4e} | {} | {} | {:.4e} | {:.4e} | {:.4e} | {:.4e} ({}) | {} |",
                r.name,
                r.mean,
                r.rms,
                r.typical
                    .map_or("(none)".to_string(), |s| format!("{s:.4e}")),
                match r.statement(n) {
                    Statement::Holds => "holds".to_string(),
                    Statement::Overstated => format!(
                        "OVERSTATED: over 3 times the RMS error ({:.1}x)",
                        r.typical.unwrap_or(0.0) / r.rms
                    ),
                    Statement::Understated => format!(
                        "UNDERSTATED: mean z {:+.1}",
                        r.mean_z(n).unwrap_or(f64::NAN)
                    ),
                    Statement::None => "-".to_string(),
                },
                r.median,
                r.spread,
                r.p99,
                r.worst.0,
                input.labels.get(r.worst.1).map_or("", String::as_str),
                r.far_out
            );
        }
        println!(
            "  (the stated 1-sigma is the calibration's error; overstated: over 3 times the RMS error, so no check against it can fail; understated: the mean error beyond 3 of its sigma; the spread adds each sample's noise; far out: beyond five robust spreads from the median)"
        );
    }
}
