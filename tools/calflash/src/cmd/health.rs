//! `calflash health`: is the unit's calibration still good? The device's own health check at
//! rest (`spincal::health`), read from the unit over its link, or run on the host over a raw
//! recording with the unit's blob; shown, and recorded in the unit history.

use crate::cmd::Failure;
use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Args;
use spincal::correct::AnyImuCorrector;
use spincal::health::{Health, RestMonitor};

use super::values;
use crate::db;
use crate::device::{Client, link::Link};
use crate::files::Paths;

/// Judge a unit's calibration at rest.
#[derive(Debug, Args)]
pub struct HealthArgs {
    /// A raw recording of the unit (a timestamp and the six counts per line, as `selfcal`
    /// reads them): run through the device's correction and health check, on the host with
    /// `--blob`, or in the unit with `--port`.
    pub recording: Option<PathBuf>,
    /// The unit's calibration blob (with a recording, without `--port`).
    #[arg(long, conflicts_with = "port")]
    pub blob: Option<PathBuf>,
    /// The unit's link (a serial device or pty path, or tcp://HOST:PORT): its health is read
    /// from it (after the recording is given to it, when there is one).
    #[arg(long)]
    pub port: Option<String>,
    /// Seconds to wait for each answer (a slow link, or a unit emulated on a busy host:
    /// `$CALFLASH_TIMEOUT`).
    #[arg(long, env = "CALFLASH_TIMEOUT", default_value_t = 3.0, value_parser = |s: &str| values::in_range(s, 0.1, 3600.0))]
    pub timeout: f64,
    /// The sample rate, Hz, of a recording without timestamps.
    #[arg(long = "sample-rate", alias = "rate", value_parser = values::sample_rate)]
    pub rate: Option<f64>,
    /// Temperature, C (default: the mean of the recording's temperature column, else the
    /// middle of the calibrated span, said with how far the calibration moves over the span).
    #[arg(long, value_parser = values::finite_f32)]
    pub temp: Option<f32>,
    /// Supply voltage, V (default: the middle of the calibrated span).
    #[arg(long, value_parser = values::finite_f32)]
    pub volt: Option<f32>,
    /// Write the health as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the HTML report here: the verdict, what the check rested on, and each output's
    /// refined bias against the calibration's stated 1-sigma.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The unit history: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Do not record the health.
    #[arg(long)]
    pub no_db: bool,
}

/// Runs `calflash health`; returns the verdict's word.
///
/// # Errors
/// A message naming the file, line or request that failed.
pub fn run(args: &HealthArgs) -> Result<&'static str, Failure> {
    let db_path = (!args.no_db)
        .then(|| crate::db::Location::or_default(args.db.as_ref()))
        .transpose()?;
    Paths::new()
        .input("the recording", args.recording.as_deref())
        .input("--blob", args.blob.as_deref())
        .output("--json", args.json.as_deref())
        .output("--report", args.report.as_deref())
        .created(
            "the unit history",
            db_path.as_ref().and_then(db::Location::file),
        )
        .check()?;
    let (health, blob, serial, source, said) = match (&args.port, &args.blob, &args.recording) {
        (Some(port), _, rec) => from_unit(args, port, rec.as_deref())?,
        (None, Some(b), Some(rec)) => {
            let bytes = crate::files::read_blob(b)?;
            let (h, said) = on_host(args, &bytes, rec)?;
            let serial = serial_of(&bytes, b)?;
            (h, bytes, serial, rec.display().to_string(), Some(said))
        }
        _ => {
            return Err(
                "calflash health: give --port (read the unit's health), or --blob with a recording (run the unit's check on the host)"
                    .into(),
            );
        }
    };
    let data_hash = crate::signing::calibration(&blob)
        .map(|c| {
            c.data()
                .identity
                .data_hash
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        })
        .unwrap_or_default();
    let record = serde_json::json!({
        "schema": "calflash.health/1",
        "serial": serial,
        "data_hash": data_hash,
        "source": source,
        "health": json(&health),
    });
    print!("{}", summary(&serial, &source, &health));
    if let Some(said) = &said {
        println!("{said}");
    }
    if let Some(p) = &args.report {
        let mut provenance = crate::report::provenance::Provenance::now()
            .serial(&serial)
            .inputs(&[("recording", args.recording.as_deref())]);
        if let Some(b) = &args.blob {
            provenance = provenance.blob_file(b);
        }
        let page = provenance.stamp(&crate::report::health::html(
            &serial,
            &source,
            &health,
            said.as_deref(),
        )?);
        crate::files::write_atomically(p, |w| std::io::Write::write_all(w, page.as_bytes()))?;
        crate::report::written::page(p);
        println!("  report: {}", p.display());
    }
    if let Some(p) = &args.json {
        let body = serde_json::to_vec_pretty(&record)?;
        crate::files::write_atomically(p, |w| std::io::Write::write_all(w, &body))?;
        println!("  record: {}", p.display());
    }
    if let Some(path) = db_path {
        let beside = db::beside(&[args.json.as_deref(), args.recording.as_deref()]);
        match db::record_or_save(
            &path,
            |d| d.record_health(&serial, &blob, &record),
            &record,
            &beside,
            &serial,
        ) {
            Ok(said) => {
                if let (Some(page), Some(id)) = (&args.report, said.strip_prefix("recorded as ")) {
                    crate::report::provenance::add_record(page, id)?;
                }
                println!("  {said}");
            }
            // A unit judged SUSPECT keeps its exit code when the history is down: the
            // verdict is the answer, the history's failure is said beside it.
            Err(e) if health.verdict.word() == "SUSPECT" => {
                eprintln!("calflash: the health is judged SUSPECT but is not in the history: {e}");
            }
            Err(e) => return Err(e.into()),
        }
    }
    Ok(health.verdict.word())
}

fn serial_of(bytes: &[u8], path: &Path) -> Result<String, String> {
    let cal = crate::signing::calibration(bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(cal.data().identity.serial.as_str().to_string())
}

/// A health judged: the health, the unit's blob, its serial, where the samples came from, and
/// how the temperature was found (when a recording was given).
type Judged = (Health, Vec<u8>, String, String, Option<String>);

/// A recording's raw samples, its rate and its temperature column's mean (name, C), if any.
type Samples = (Vec<[i32; 6]>, f64, Option<(String, f32)>);

/// The recording's raw samples, the rate, and its temperature column's mean.
fn samples(args: &HealthArgs, rec: &Path) -> Result<Samples, String> {
    let opts = crate::obs::recording::Options {
        rails: spincal::model::Rails::new(i32::MIN, i32::MAX),
        rate: args.rate,
        keep: crate::obs::layout::Keep::Both,
        units: crate::obs::units::Units::DEFAULT,
        columns: crate::obs::header::Chosen::default(),
    };
    let r = crate::obs::recording::read_with(rec, None, &opts).map_err(|e| e.to_string())?;
    let raw = r
        .acc
        .iter()
        .zip(&r.gyro)
        .map(|(a, g)| {
            let c = |x: f64| x.round() as i32;
            [c(a[0]), c(a[1]), c(a[2]), c(g[0]), c(g[1]), c(g[2])]
        })
        .collect();
    let temp = r.temperature.as_ref().and_then(|(name, t)| {
        let finite: Vec<f64> = t.iter().copied().filter(|x| x.is_finite()).collect();
        (!finite.is_empty()).then(|| {
            (
                name.clone(),
                (finite.iter().sum::<f64>() / finite.len() as f64) as f32,
            )
        })
    });
    Ok((raw, r.rate(), temp))
}

/// The environment the recording is corrected at, and how its temperature was found: `--temp`,
/// else the recording's temperature column (its mean), else the middle of the calibrated span,
/// said with how far the calibration moves between there and the span's ends (a unit at
/// another temperature reads as drifted by that much). The voltage: `--volt`, else the middle
/// of its span.
fn environment(
    args: &HealthArgs,
    cal: &spincal::model::Calibration,
    column: Option<&(String, f32)>,
    raw: Option<&[i32; 6]>,
) -> (f32, f32, String) {
    let env = &cal.data().environment;
    let mid = |s: spincal::model::Span| 0.5 * (s.lo + s.hi);
    let v = args.volt.unwrap_or(mid(env.voltage_span));
    if let Some(t) = args.temp {
        return (t, v, format!("  temperature  {t} C (--temp)"));
    }
    if let Some((name, t)) = column {
        return (
            *t,
            v,
            format!("  temperature  {t:.2} C, the mean of the recording's column {name}"),
        );
    }
    let span = env.temperature_span;
    let t = mid(span);
    let moved = raw
        .filter(|_| span.hi > span.lo)
        .and_then(|r| moved_across(cal, *r, (span, t), v));
    let how = moved.map_or(String::new(), |(sigma, output)| {
        format!(
            "; between it and the span's ends the calibration moves by up to {sigma:.1} of its stated 1-sigma ({output}), which a unit at another temperature reads as drift"
        )
    });
    (
        t,
        v,
        format!(
            "  temperature  assumed {t} C, the middle of the calibrated span {} to {} C: the recording states none (give --temp, or a temperature column){how}",
            span.lo, span.hi
        ),
    )
}

/// The largest change of the corrected sample `raw` between the temperature `mid` and the ends
/// of `span`, in the stated 1-sigma at `mid`, and the output it is on.
fn moved_across(
    cal: &spincal::model::Calibration,
    raw: [i32; 6],
    (span, mid): (spincal::model::Span, f32),
    volt: f32,
) -> Option<(f32, &'static str)> {
    use crate::report::health::OUTPUTS;
    let mut imu = AnyImuCorrector::new(cal, 1000.0).ok()?;
    let mut at = |t: f32| {
        imu.set_environment(t, volt);
        imu.reset();
        imu.correct(raw).values
    };
    let (centre, lo, hi) = (at(mid), at(span.lo), at(span.hi));
    imu.set_environment(mid, volt);
    let sigma = imu.sigma(&centre)?;
    (0..6)
        .map(|i| {
            let d = (lo[i] - centre[i]).abs().max((hi[i] - centre[i]).abs());
            (d / sigma[i].max(f32::MIN_POSITIVE), OUTPUTS[i])
        })
        .filter(|(x, _)| x.is_finite())
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

/// The device's correction and health check over the recording, on the host; and how its
/// temperature was found.
fn on_host(args: &HealthArgs, bytes: &[u8], rec: &Path) -> Result<(Health, String), Failure> {
    let name = args.blob.as_deref().unwrap_or(rec).display().to_string();
    let cal = crate::signing::calibration(bytes).map_err(|e| format!("{name}: {e}"))?;
    let (raw, rate, column) = samples(args, rec)?;
    let mut imu = AnyImuCorrector::new(&cal, rate as f32).map_err(|e| format!("{name}: {e}"))?;
    let mut monitor = RestMonitor::new(&cal, rate as f32).map_err(|e| format!("{name}: {e}"))?;
    let (t, v, said) = environment(args, &cal, column.as_ref(), raw.first());
    imu.set_environment(t, v);
    for r in &raw {
        let out = imu.correct(*r);
        imu.observe_rest(&mut monitor, &out);
    }
    Ok((monitor.health(), said))
}

/// The unit's own health, after giving it the recording (if any).
fn from_unit(args: &HealthArgs, port: &str, rec: Option<&Path>) -> Result<Judged, Failure> {
    let timeout = Duration::from_secs_f64(args.timeout);
    let link = Link::open(port, timeout)?;
    let mut client = Client::new(link, timeout);
    let id = client.identify().map_err(|e| format!("{port}: {e}"))?;
    let blob = client.read_blob(id.blob_len as usize)?;
    let cal = crate::signing::calibration(&blob).map_err(|e| format!("the unit's blob: {e}"))?;
    let mut said = None;
    if let Some(rec) = rec {
        let (raw, rate, column) = samples(args, rec)?;
        let device_rate = f64::from(spincal::protocol::vector_rate_hz());
        if (rate - device_rate).abs() > 1e-6 * device_rate {
            return Err(format!(
                "{}: sampled at {rate} Hz; the unit's stream runs at {device_rate} Hz",
                rec.display()
            )
            .into());
        }
        let (t, v, env_said) = environment(args, &cal, column.as_ref(), raw.first());
        said = Some(env_said);
        let bar = indicatif::ProgressBar::new(raw.len() as u64);
        for chunk in raw.chunks(spincal::protocol::MAX_VECTORS) {
            client
                .observe_rest(t, v, chunk)
                .map_err(|e| e.to_string())?;
            bar.inc(chunk.len() as u64);
        }
        bar.finish_and_clear();
    }
    let health = client.health().map_err(|e| e.to_string())?;
    let source = match rec {
        Some(r) => format!("unit on {port}, given {}", r.display()),
        None => format!("unit on {port}"),
    };
    Ok((health, blob, id.unit.as_str().to_string(), source, said))
}

fn json(h: &Health) -> serde_json::Value {
    serde_json::json!({
        "verdict": h.verdict.word(),
        "bias": h.bias,
        "bias_sigma": h.bias_sigma,
        "stated_sigma": h.stated_sigma,
        "accel_covariance": h.accel_covariance,
        "gravity_error": h.gravity_error,
        "statistic": h.statistic,
        "threshold": h.threshold,
        "rest_s": h.rest_s,
        "rest_windows": h.rest_windows,
        "moving_windows": h.moving_windows,
        "ignored_samples": h.ignored_samples,
    })
}

fn summary(serial: &str, source: &str, h: &Health) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calflash health  unit {serial} ({source}): {}",
        h.verdict.word()
    );
    let _ = writeln!(
        s,
        "  at rest {:.1} s ({} windows; {} moving; {} samples left out)",
        h.rest_s, h.rest_windows, h.moving_windows, h.ignored_samples
    );
    let _ = writeln!(
        s,
        "  largest statistic: {:.2} under the factory prior, {:.2} with ageing (thresholds {:.2}, {:.2})",
        h.statistic[0], h.statistic[1], h.threshold[0], h.threshold[1]
    );
    for (i, name) in crate::report::health::OUTPUTS.iter().enumerate() {
        let unit = if i < 3 { "m/s^2" } else { "rad/s" };
        let _ = writeln!(
            s,
            "  {name}: refined bias {:+.3e} +- {:.3e} {unit} (the calibration states {:.3e})",
            h.bias[i], h.bias_sigma[i], h.stated_sigma[i]
        );
    }
    s
}
