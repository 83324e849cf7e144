//! `calflash flight`: did the calibration survive the launch? A flight's IMU recording
//! navigated with the unit's own correction and checked against GNSS and a barometer.

use std::path::PathBuf;

use clap::Args;

use crate::cmd::Failure;
use crate::files::{Paths, Staged};
use crate::nav::check::{self, Walks};
use crate::nav::consistency;
use crate::nav::input;
use crate::nav::prior::{self, PriorSource, StatedPrior};
use crate::nav::run::Options;
use crate::sensor::record::{self, Record};

/// Check a calibration in flight against GNSS and a barometer.
#[derive(Debug, Args)]
pub struct FlightArgs {
    /// The IMU recording: raw codes (`t`, `a_x..g_z`, optionally `temp`) with `--blob`, or
    /// physical values (a mission profile's columns, `--imu-columns`) without.
    #[arg(required_unless_present = "port")]
    pub recording: Option<PathBuf>,
    /// The unit's calibration blob: the codes go through its correction, and its covariance
    /// factors are the prior of the sensor errors (unless the calibration's record is given or
    /// found in the unit history: `--record`).
    #[arg(long)]
    pub blob: Option<PathBuf>,
    /// The calibration's record (`calibrate --json`) of that blob: the prior is then its
    /// whole model's covariance, cubic and odd-quadratic terms included, over the flight's
    /// rates. Without it, the unit history's record of the blob's calibration is used when
    /// the history holds one, else the blob's covariance factors.
    #[arg(long, requires = "blob")]
    pub record: Option<PathBuf>,
    /// Columns of a physical recording (without --blob), as `--mission-columns` takes them:
    /// `t=ts,fx=Ax:m/s^2,...,wx=Gx:deg/s,...`.
    #[arg(long, default_value = "", conflicts_with = "blob")]
    pub imu_columns: String,
    /// GNSS fixes: `t` (the IMU's clock), `latitude`, `longitude` (degrees), optionally
    /// `height`, `v_east v_north v_up`, `satellites`.
    #[arg(long, required_unless_present = "port")]
    pub gnss: Option<PathBuf>,
    /// Barometer: `t`, `P` (Pa).
    #[arg(long)]
    pub baro: Option<PathBuf>,
    /// The GNSS antenna from the IMU, body axes, m: `X,Y,Z` (each within 5 m: an arm in mm typed
    /// as m is refused).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = lever_component)]
    pub lever: Vec<f64>,
    /// 1-sigma of a fix, m: `HORIZONTAL,VERTICAL`.
    #[arg(long, value_delimiter = ',', default_values_t = [2.5, 5.0], value_parser = |s: &str| super::values::in_range(s, 0.01, 1000.0))]
    pub gnss_noise: Vec<f64>,
    /// How late each fix is stamped, s.
    #[arg(long, default_value_t = 0.0, value_parser = |s: &str| super::values::in_range(s, 0.0, 5.0))]
    pub gnss_latency: f64,
    /// The receiver's slowly varying position error, 1-sigma, m (per axis): the part of a
    /// fix's error that stays over a flight (atmosphere, orbits, multipath; tens of seconds).
    /// A flight shorter than it changes cannot average it out, so the smoothed track's stated
    /// 1-sigma carries it. 1.5 m is a single-frequency receiver's.
    #[arg(long, default_value_t = 1.5, value_parser = |s: &str| super::values::in_range(s, 0.0, 100.0))]
    pub gnss_correlated: f64,
    /// 1-sigma of a barometric height, m.
    #[arg(long, default_value_t = 1.5, value_parser = |s: &str| super::values::in_range(s, 0.01, 1000.0))]
    pub baro_noise: f64,
    /// The barometer port's pressure coefficient, 1-sigma: its height error grows as
    /// `CP v^2 / 2g` with the speed (0 for a barometer that reads the true static pressure).
    #[arg(long, default_value_t = 0.03, value_parser = |s: &str| super::values::in_range(s, 0.0, 2.0))]
    pub baro_cp: f64,
    /// The most rows read of each file (IMU, GNSS, barometer): a longer file is refused, not
    /// read until the memory runs out.
    #[arg(long, default_value_t = crate::nav::input::MAX_ROWS, value_parser = |s: &str| super::values::count_in(s, 2, 1_000_000_000))]
    pub max_samples: usize,
    /// The barometer's bias random walk, m/sqrt(s) (the air against the standard atmosphere).
    #[arg(long, default_value_t = 0.5, value_parser = |s: &str| super::values::in_range(s, 0.0, 100.0))]
    pub baro_walk: f64,
    /// Without covariance in the calibration: the prior, 1-sigma, `ACCEL_BIAS,GYRO_BIAS,
    /// ACCEL_SCALE,GYRO_SCALE` (m/s^2, rad/s, relative, relative).
    #[arg(long, value_delimiter = ',', value_parser = |s: &str| super::values::in_range(s, 1e-9, 100.0))]
    pub prior: Vec<f64>,
    /// The bias random walks, `ACCEL,GYRO` (m/s^2/sqrt(s), rad/s/sqrt(s)).
    #[arg(long, value_delimiter = ',', value_parser = |s: &str| super::values::in_range(s, 0.0, 10.0))]
    pub walk: Vec<f64>,
    /// The false-alarm rate of SHIFTED over all terms together.
    #[arg(long, default_value_t = 0.01, value_parser = |s: &str| super::values::in_range(s, 1e-12, 0.5))]
    pub alpha: f64,
    /// Write the result as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// The unit history the check is recorded in (kind `flight`, with --blob): a SQLite file,
    /// or postgres://USER:PASSWORD@HOST/DB; default $CALFLASH_DB, else the user's data
    /// directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Do not record the check.
    #[arg(long)]
    pub no_db: bool,
    /// Write an HTML report here: the verdict, the innovations against their bounds, the
    /// trajectory against GNSS and the barometer, each sensor error along the flight.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write every innovation here (CSV: t, measurement, innovation, its predicted 1-sigma,
    /// taken), to plot against its bounds.
    #[arg(long)]
    pub innovations: Option<PathBuf>,
    /// Write the smoothed trajectory here (CSV: t, latitude, longitude, height, and the
    /// 1-sigma of east, north and up in m), at every epoch of the filter.
    #[arg(long)]
    pub track: Option<PathBuf>,
    /// Keep every K-th fix after the launch out of the filter and the smoother, and hold each
    /// against the smoothed track at its instant (over the track's 1-sigma with the fix's):
    /// the share within 3 sigma says whether the track can be believed, on any real flight,
    /// with no truth (under 90 %: FILTER DOES NOT FIT).
    #[arg(long, value_name = "K", value_parser = |s: &str| super::values::count_in(s, 2, 1000))]
    pub hold_out: Option<usize>,
    /// Read the flight filter running in the unit on this serial port (or tcp://HOST:PORT)
    /// instead: its estimate, 1-sigma and counts as its flight loop last published them.
    #[arg(long, conflicts_with_all = ["recording", "blob", "gnss", "baro", "report", "innovations", "track"])]
    pub port: Option<String>,
    /// Seconds to wait for each answer from the unit.
    #[arg(long, default_value_t = 2.0, value_parser = |s: &str| super::values::in_range(s, 0.01, 600.0))]
    pub timeout: f64,
}

/// A component of the antenna's arm, m: finite and within 5 m of the IMU.
fn lever_component(s: &str) -> Result<f64, String> {
    let v = super::values::finite(s)?;
    if v.abs() > 5.0 {
        return Err(format!(
            "{v} m: an antenna more than 5 m from the IMU on a round or a rocket; in m, not mm (50 mm is 0.05)"
        ));
    }
    Ok(v)
}

/// Runs `calflash flight`; the verdict (`HELD`, `SHIFTED`, `CANNOT TELL`, `FILTER DOES NOT
/// FIT`; `READ` for a unit's own filter read over `--port`).
///
/// # Errors
/// Unreadable inputs, a flight that cannot be checked.
pub fn run(args: &FlightArgs) -> Result<&'static str, Failure> {
    if let Some(port) = &args.port {
        return super::flight_unit::run(port, args.timeout, args.json.as_deref()).map(|()| "READ");
    }
    let (Some(recording), Some(gnss)) = (&args.recording, &args.gnss) else {
        return Err("calflash flight: give a recording and --gnss, or --port to read the unit's own flight filter".into());
    };
    let db_path = (!args.no_db && args.blob.is_some())
        .then(|| crate::db::Location::or_default(args.db.as_ref()))
        .transpose()?;
    Paths::new()
        .input("the recording", Some(recording))
        .input("--blob", args.blob.as_deref())
        .input("--record", args.record.as_deref())
        .input("--gnss", Some(gnss))
        .input("--baro", args.baro.as_deref())
        .output("--json", args.json.as_deref())
        .output("--innovations", args.innovations.as_deref())
        .output("--track", args.track.as_deref())
        .output("--report", args.report.as_deref())
        .created(
            "the unit history",
            db_path.as_ref().and_then(crate::db::Location::file),
        )
        .check()?;
    for (name, v, n) in [
        ("--lever", &args.lever, 3),
        ("--prior", &args.prior, 4),
        ("--walk", &args.walk, 2),
    ] {
        if !v.is_empty() && v.len() != n {
            return Err(format!("{name}: {n} comma-separated values, {} given", v.len()).into());
        }
    }
    let stated = match args.prior.as_slice() {
        [ab, gb, asf, gsf] => StatedPrior {
            accel_bias: *ab,
            gyro_bias: *gb,
            accel_scale: *asf,
            gyro_scale: *gsf,
        },
        _ => StatedPrior::default(),
    };
    let opts = Options {
        lever: match args.lever.as_slice() {
            [x, y, z] => [*x, *y, *z],
            _ => [0.0; 3],
        },
        gnss_noise: (
            args.gnss_noise.first().copied().unwrap_or(2.5),
            args.gnss_noise.get(1).copied().unwrap_or(5.0),
        ),
        gnss_latency: args.gnss_latency,
        gnss_correlated: args.gnss_correlated,
        baro_noise: args.baro_noise,
        baro_cp: args.baro_cp,
        ..Options::default()
    };
    let mut blob_bytes = Vec::new();
    let mut data_hash = None;
    let mut history_notes: Vec<String> = Vec::new();
    let (imu, prior, serial) = match &args.blob {
        Some(path) => {
            let bytes = crate::files::read_blob(path)?;
            blob_bytes.clone_from(&bytes);
            let cal = crate::signing::calibration(&bytes)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            let imu = input::corrected(recording, &cal, args.max_samples)?;
            let serial = cal.data().identity.serial.to_string();
            data_hash = Some(record::hex(&cal.data().identity.data_hash));
            // The prior over the flight after launch (at zero input when there is none: the
            // check then says there was no launch).
            let from = crate::nav::launch::launch(&imu, opts.launch_force).map_or(0, |l| l.1);
            let record = match &args.record {
                Some(path) => Some((read_record(path)?, path.display().to_string())),
                None => db_path.as_ref().and_then(|loc| {
                    let (found, notes) = history_record(loc, &cal);
                    history_notes = notes;
                    found
                }),
            };
            let from_record = match record {
                Some((rec, at)) => match prior::record_prior(&rec, &cal, &imu, from) {
                    Ok(p) => Some((p, PriorSource::Record(at))),
                    Err(e) if args.record.is_some() => {
                        return Err(format!("--record {at}: {e}").into());
                    }
                    Err(_) => None,
                },
                None => None,
            };
            let prior = from_record
                .or_else(|| {
                    prior::calibration_prior(&cal, &imu, from).map(|p| (p, PriorSource::Factors))
                })
                .unwrap_or_else(|| (prior::stated_prior(&stated), PriorSource::Stated(stated)));
            (imu, prior, serial)
        }
        None => {
            let profile =
                crate::mission::read_at_most(recording, &args.imu_columns, args.max_samples)?;
            (
                input::physical(&profile),
                (prior::stated_prior(&stated), PriorSource::Stated(stated)),
                "(no calibration)".to_string(),
            )
        }
    };
    let (fixes, counts) = input::gnss(gnss, args.max_samples)?;
    if fixes.is_empty() {
        return Err(format!(
            "{}: no usable fix in its {} rows: {} without a fix (fewer than four satellites, or the no-fix marker), {} repeating the fix before; the check needs a receiver's fixes",
            gnss.display(),
            counts.rows,
            counts.no_fix,
            counts.repeated
        )
        .into());
    }
    let baro = args
        .baro
        .as_deref()
        .map(|p| input::baro(p, args.max_samples))
        .transpose()?
        .unwrap_or_default();
    let walks = Walks {
        accel: args.walk.first().copied().unwrap_or(Walks::default().accel),
        gyro: args.walk.get(1).copied().unwrap_or(Walks::default().gyro),
        baro: args.baro_walk,
        ..Walks::default()
    };
    let launch = crate::nav::launch::launch(&imu, opts.launch_force)
        .map_or(f64::INFINITY, |(_, at)| imu.t[at]);
    let all_fixes = fixes.clone();
    let (fixes, held) = match args.hold_out {
        Some(k) => consistency::hold_out(&fixes, k, launch),
        None => (fixes, Vec::new()),
    };
    // On a terminal, that the filter is at work and for how long (nothing drawn otherwise).
    let working = indicatif::ProgressBar::new_spinner();
    working.set_style(
        indicatif::ProgressStyle::with_template("  {spinner} {msg}, {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    working.set_message(format!(
        "filtering, searching what moved and smoothing {} samples, {} fixes",
        imu.t.len(),
        fixes.len()
    ));
    working.enable_steady_tick(std::time::Duration::from_millis(200));
    let checked = check::check(&imu, (&fixes, &baro), prior, &walks, &opts, args.alpha);
    working.finish_and_clear();
    let mut checked = checked.map_err(|e| format!("{}: {e}", recording.display()))?;
    let held_out = args.hold_out.map(|k| {
        let h = consistency::held_out(
            &checked.track,
            &held,
            k,
            opts.gnss_noise,
            (opts.gnss_latency, opts.gnss_correlated),
        );
        if !h.believed && checked.verdict.word != crate::nav::verdict::DOES_NOT_FIT {
            checked.verdict.word = crate::nav::verdict::DOES_NOT_FIT;
            checked.verdict.why = format!(
                "{} of {} held-out fixes within 3 sigma of the smoothed track ({:.1} %, at least {:.0} % where it can be believed): the track the filter keeps does not hold on fixes it did not see, so its estimates are not reported as findings",
                h.within_3_sigma,
                h.fixes,
                100.0 * h.share(),
                100.0 * consistency::HELD_OUT_AT_LEAST
            );
        }
        h
    });
    // Where a kind's innovations were refused, what the recording shows there.
    let diagnosis = refused_span(&checked.verdict.consistency).map(|span| {
        let d = crate::nav::diagnosis::diagnose(span, &imu, &all_fixes, &counts, opts.gnss_noise.0);
        if checked.verdict.word == crate::nav::verdict::DOES_NOT_FIT {
            checked.verdict.why = format!("{}; {}", checked.verdict.why, d.sentence());
        }
        d
    });
    let mut text = crate::report::flight::text(&serial, &checked, &counts);
    let mut record = crate::report::flight::json(&serial, &checked, &counts);
    if let Some(h) = &held_out {
        text.push_str(&crate::report::flight::held_out_text(h));
        record["held_out"] = serde_json::to_value(h)?;
    }
    if let Some(d) = &diagnosis {
        record["diagnosis"] = serde_json::to_value(d)?;
    }
    if !history_notes.is_empty() {
        for note in &history_notes {
            text.push_str(&format!("  warning: {note}\n"));
        }
        record["history_refused"] = serde_json::json!(history_notes);
    }
    // Which calibration it judged, as the health record says it (for `compare`).
    record["data_hash"] = serde_json::json!(data_hash);
    let mut staged = Staged::new();
    if let Some(path) = &args.json {
        let json = serde_json::to_string_pretty(&record)?;
        staged.write(path, |w| w.write_all(json.as_bytes()))?;
    }
    if let Some(path) = &args.innovations {
        let csv = crate::report::flight::innovations_csv(&checked.pass.said);
        staged.write(path, |w| w.write_all(csv.as_bytes()))?;
    }
    if let Some(path) = &args.track {
        let csv = crate::report::flight::track_csv(&checked.track);
        staged.write(path, |w| w.write_all(csv.as_bytes()))?;
    }
    if let Some(path) = &args.report {
        let mut provenance = crate::report::provenance::Provenance::now()
            .serial(&serial)
            .inputs(&[
                ("IMU log", args.recording.as_deref()),
                ("--record", args.record.as_deref()),
                ("GNSS", args.gnss.as_deref()),
                ("barometer", args.baro.as_deref()),
            ]);
        if let Some(b) = &args.blob {
            provenance = provenance.blob_file(b);
        }
        let page = provenance.stamp(&crate::report::flight::html(
            &serial,
            &checked,
            &counts,
            held_out.as_ref(),
        )?);
        staged.write(path, |w| w.write_all(page.as_bytes()))?;
        crate::report::written::page(path);
    }
    staged.commit()?;
    print!("{text}");
    if let Some(path) = db_path {
        let beside = crate::db::beside(&[args.json.as_deref(), Some(recording.as_path())]);
        let said = crate::db::record_or_save(
            &path,
            |d| d.record_flight(&serial, &blob_bytes, &record),
            &record,
            &beside,
            &serial,
        )?;
        if let (Some(page), Some(id)) = (&args.report, said.strip_prefix("recorded as ")) {
            crate::report::provenance::add_record(page, id)?;
        }
        println!("  {said}");
    }
    Ok(checked.verdict.word)
}

/// A calibration record read from `path`.
fn read_record(path: &std::path::Path) -> Result<Record, Failure> {
    let text = crate::files::read_json_text(path, "--record")?;
    let rec: Record = serde_json::from_str(&text).map_err(|e| {
        format!(
            "--record {}: not a calibration record ({e})",
            path.display()
        )
    })?;
    if rec.schema != record::SCHEMA {
        return Err(format!(
            "--record {}: schema `{}`; `{}` is expected",
            path.display(),
            rec.schema,
            record::SCHEMA
        )
        .into());
    }
    rec.check_seal()
        .map_err(|e| format!("--record {}: {e}", path.display()))?;
    Ok(rec)
}

/// The unit history's newest record of the calibration of unit `serial` whose data hash is
/// `hash`, with the words for where it is; `None` when the history holds none (or cannot be
/// read: the blob's factors serve then, and the report says which prior it took). Beside it,
/// a sentence for each record of this calibration passed over because it fails its seal or
/// cannot be read: a tampered history is said, never silently replaced by the blob's factors.
fn history_record(
    loc: &crate::db::Location,
    cal: &spincal::model::Calibration,
) -> (Option<(Record, String)>, Vec<String>) {
    let id = &cal.data().identity;
    let hash = record::hex(&id.data_hash);
    let mut notes = Vec::new();
    let Ok(mut db) = crate::db::Db::open_existing(loc.clone()) else {
        return (None, notes);
    };
    let Ok(history) = db.history(id.serial.as_str()) else {
        return (None, notes);
    };
    let entries: Vec<_> = history
        .into_iter()
        .rev()
        .filter(|e| e.kind == "fit" && e.data_hash.eq_ignore_ascii_case(&hash))
        .collect();
    // The newest record of this very blob: another fit of the same data is not its record.
    for entry in entries {
        let rec = db
            .record(entry.id)
            .map_err(|e| e.to_string())
            .and_then(|text| serde_json::from_str::<Record>(&text).map_err(|e| e.to_string()));
        let rec = match rec {
            Ok(r) if r.schema == record::SCHEMA => r,
            Ok(_) => continue,
            Err(e) => {
                notes.push(format!(
                    "the unit history's record {} of this calibration cannot be read ({e}): not taken",
                    entry.id
                ));
                continue;
            }
        };
        if let Err(e) = rec.check_seal() {
            notes.push(format!(
                "the unit history's record {} of this calibration fails its seal ({e}: edited after it was written?): not taken",
                entry.id
            ));
            continue;
        }
        if crate::nav::prior::record_is_of(&rec, cal).is_ok() {
            return (
                Some((rec, format!("the unit history's record {}", entry.id))),
                notes,
            );
        }
    }
    (None, notes)
}

/// The longest run of refused innovations of the kinds that do not fit (the most refused), s:
/// where the recording is looked at for what lost the track.
fn refused_span(c: &consistency::Consistency) -> Option<(f64, f64)> {
    c.failing()
        .iter()
        .flat_map(|k| &k.refused_runs)
        .max_by_key(|r| r.count)
        .map(|r| (r.from, r.to))
}
