//! `calflash calibrate`: a sensor workflow from observations to the device's blob, with the
//! report and the record. Over a directory or a list of files it is a batch ([`batch`]); over
//! a fixture's file of several units, one calibration per unit ([`fixture`]).

mod args;
pub mod batch;
pub mod fixture;

pub use args::{Asymmetry, CalibrateArgs, Requirements, ThermalArg};

use crate::cmd::Failure;
use std::path::PathBuf;

use crate::cmd::values::{self, SensorKind};
use crate::files::Paths;
use spincal::model::{Quantity, Span};

use crate::cmd::outputs::Outputs;
use crate::report::{self, terminal::num, terminal::pval};
use crate::sensor::{self, Options, Verdict, record::Record, single, triad};

/// Runs `calflash calibrate`; returns the verdict (the process exits 3 on reject).
///
/// # Errors
/// A message naming the file, column, term or table point.
pub fn run(args: &CalibrateArgs) -> Result<Verdict, Failure> {
    if args.fixture {
        batch::check_options(args)?;
        return fixture::run(args);
    }
    let single = match args.data.as_slice() {
        [one] if !one.is_dir() => Some(one),
        _ => None,
    };
    let Some(data) = single else {
        return batch::run(args);
    };
    if args.out_dir.is_some() {
        return Err("--out-dir is for a batch (several files or a directory); one unit's files are named by --blob, --report and --json".into());
    }
    let serial = args
        .serial
        .as_deref()
        .ok_or("--serial: the unit's serial number is required (a batch of files takes each from its file name)")?;
    // One writer at a time in each folder the unit's files go to.
    let _locks = crate::files::FolderLock::take_all(
        [
            ("--blob", args.out.blob.as_deref()),
            ("--json", args.out.json.as_deref()),
            ("--report", args.out.report.as_deref()),
        ]
        .into_iter()
        .filter_map(|(what, p)| p.map(|p| (what, p))),
    )?;
    let mut said = String::new();
    let judged = calibrate_one(args, data, serial, &args.out, &mut said);
    print!("{said}");
    judged.map(|j| j.verdict)
}

/// A unit's verdict and the findings that gave it (none for ACCEPT).
#[derive(Debug, Clone)]
pub struct Judged {
    /// The verdict.
    pub verdict: Verdict,
    /// The texts of the findings at that verdict.
    pub reasons: Vec<String>,
    /// Its figures on one line (each output's bias in mg or deg/h, the largest misalignment).
    pub figures: String,
}

/// Calibrates the unit `serial` from `data` with the options of `args`, writing what `out`
/// names; what a person reads goes into `said`; the verdict and its reasons.
///
/// # Errors
/// A message naming the file, column, term or table point.
pub fn calibrate_one(
    args: &CalibrateArgs,
    data: &std::path::Path,
    serial: &str,
    out: &Outputs,
    said: &mut String,
) -> Result<Judged, Failure> {
    use std::fmt::Write as _;
    sensor::blob::serial(serial)?;
    let mut paths = Paths::new()
        .input("the data", Some(data))
        .input("--still-ramp", args.still_ramp.as_deref())
        .input(
            "--noise-terms",
            args.noise_terms.first().map(PathBuf::as_path),
        )
        .input(
            "--noise-terms",
            args.noise_terms.get(1).map(PathBuf::as_path),
        )
        .input("--mission", args.mission.as_deref());
    for p in args.stage_one.iter().filter(|p| from_history(p).is_none()) {
        paths = paths.input("--stage-one", Some(p));
    }
    out.check(paths)?;
    let noise = noise_terms(args)?;
    let mut opts = Options::new(data, serial);
    opts.format = args.format;
    opts.alpha = args.alpha;
    opts.keep_all_terms = args.keep_all_terms;
    opts.linear = args.linear;
    opts.nonlinear_required = args.nonlinear;
    opts.asymmetry = match args.asymmetry {
        Asymmetry::Auto => None,
        Asymmetry::Keep => Some(true),
        Asymmetry::Drop => Some(false),
    };
    opts.breakpoint = args.breakpoint;
    opts.thermal = match args.thermal {
        ThermalArg::Auto => sensor::Thermal::Auto,
        ThermalArg::Table => sensor::Thermal::Table,
        ThermalArg::Continuous => sensor::Thermal::Continuous,
    };
    opts.thermal_order = args.thermal_order;
    opts.still_ramp.clone_from(&args.still_ramp);
    opts.model.clone_from(&args.model);
    opts.max_noise = args.max_noise;
    opts.rails = args.codes;
    if let (Some(lat), Some(heading)) = (args.latitude, args.heading) {
        if matches!(
            args.sensor,
            SensorKind::SingleAccel | SensorKind::SingleGyro | SensorKind::Accel
        ) {
            return Err("--latitude: the Earth's rate is a gyro triad's or an IMU's input".into());
        }
        opts.earth = Some(crate::earth::Station::new(lat, heading)?);
    }
    let (t0, t1) = values::pair(&args.temp_span, "--temp-span")?;
    opts.temp_span = Span::new(t0 as f32, t1 as f32);
    let (v0, v1) = values::pair(&args.volt_span, "--volt-span")?;
    opts.volt_span = Span::new(v0 as f32, v1 as f32);
    let single = matches!(
        args.sensor,
        SensorKind::SingleAccel | SensorKind::SingleGyro
    );
    if single && args.still_ramp.is_some() {
        return Err(
            "--still-ramp is for triads and IMUs; a single axis' still ramp goes in its observation file, with `input` at the still pose's value"
                .into(),
        );
    }
    if args.model.is_some()
        && !matches!(
            args.sensor,
            SensorKind::SingleAccel | SensorKind::SingleGyro
        )
    {
        return Err("--model applies to single-axis sensors; triads use their presets".into());
    }
    let two_stage = !args.stage_one.is_empty();
    if two_stage {
        if args.sensor != SensorKind::Imu {
            return Err("--stage-one: stage two calibrates an assembled IMU (--sensor imu); stage one is each sensor's own calibration".into());
        }
        if args.still_ramp.is_some() || args.nonlinear || args.linear {
            return Err("--stage-one carries each sensor's nonlinear terms and temperature behaviour from stage one: --still-ramp, --nonlinear and --linear do not apply".into());
        }
    }
    let c = match args.sensor {
        SensorKind::Imu if two_stage => {
            let trust = crate::sensor::record::Trust {
                keys: out.trusted(&args.trust_key)?,
                unsigned: args.unsigned_stage_one,
            };
            let sensors = stage_one(&args.stage_one, out, &trust)?;
            as_built(&args.as_built, &sensors)?;
            let elsewhere = built_elsewhere(out, serial, &sensors)?;
            triad::stage_two::calibrate(&opts, &sensors).map(|(mut c, _)| {
                c.notes.push(signers(&sensors));
                c.findings.extend(elsewhere);
                c
            })
        }
        SensorKind::SingleAccel => single::calibrate(&opts, Quantity::Acceleration),
        SensorKind::SingleGyro => single::calibrate(&opts, Quantity::AngularRate),
        SensorKind::Accel => triad::calibrate(&opts, triad::Kind::Accel, args.nonlinear),
        SensorKind::Gyro => triad::calibrate(&opts, triad::Kind::Gyro, args.nonlinear),
        SensorKind::Imu => triad::calibrate(&opts, triad::Kind::Imu, !args.linear),
    }?;
    let mut c = c;
    // A calibration the device refused has no blob to carry the noise terms.
    if let Some(terms) = noise.filter(|_| !c.blob.is_empty()) {
        c.data.noise = Some(terms);
        c.blob = sensor::blob::encode_checked(&c.data)
            .map_err(|e| format!("--noise-terms: {e}"))?
            .0;
    }
    if let Some(path) = &args.mission {
        let profile = crate::mission::read(path, &args.mission_columns.mission_columns)?;
        let judged = crate::mission::judge::judge(
            &c,
            &profile,
            args.sensor == SensorKind::SingleGyro,
            args.requirement.as_ref().map_or(&[][..], |r| &r.0[..]),
            (args.alpha, !args.keep_all_terms),
        )?;
        c.findings.extend(judged.findings.iter().cloned());
        c.mission = Some(judged);
    }
    let data_name = data.display().to_string();
    // Against its lot: judged on the coefficients the history keeps.
    let mut provisional = Record::new(&c, &data_name);
    provisional.lot.clone_from(&out.lot);
    let coefficients = crate::lot::coefficients(
        &serde_json::Value::from(crate::db::fit_coefficients(&provisional)).to_string(),
    )?;
    if let Some(f) = out.lot_finding(c.data.identity.serial.as_str(), &coefficients, 0.001) {
        c.findings.push(f);
    }
    // The worst first, in every print of them (terminal, record, report); each kind in the
    // order it was found.
    c.findings.sort_by_key(|f| std::cmp::Reverse(f.verdict));
    // A rejected calibration has no blob, unless forced; a forced one says so in its identity.
    let blob = match (c.verdict(), out.force_blob) {
        (Verdict::Reject, false) => None,
        (Verdict::Reject, true) => Some(rejected_blob(&c)?),
        _ => Some(c.blob.clone()),
    };
    let serial = c.data.identity.serial.as_str();
    let (blob, signed_note) = match blob {
        Some(b) => {
            let s = out.sign(b, serial, c.verdict())?;
            (Some(s.bytes), s.note)
        }
        None => (None, None),
    };
    let mut record = Record::new(&c, &data_name);
    record.lot.clone_from(&out.lot);
    record.blob = blob.as_deref().map(hex).unwrap_or_default();
    let record = out.seal_record(record)?;
    let mut provenance = crate::report::provenance::Provenance::now()
        .serial(serial)
        .input("data", data);
    for (role, p) in [
        ("--still-ramp", args.still_ramp.as_deref()),
        ("--mission", args.mission.as_deref()),
    ] {
        if let Some(p) = p {
            provenance = provenance.input(role, p);
        }
    }
    for p in &args.noise_terms {
        provenance = provenance.input("--noise-terms", p);
    }
    for p in args.stage_one.iter().filter(|p| from_history(p).is_none()) {
        provenance = provenance.input("--stage-one", p);
    }
    out.write(blob.as_deref(), &record, provenance, || {
        report::html::render(&c, &data_name)
    })?;
    said.push_str(&summary(&c, data, out, blob.is_some(), args.quiet));
    if let Some(note) = signed_note {
        let _ = writeln!(said, "{note}");
    }
    let fallback = serde_json::to_value(&record).unwrap_or_default();
    let report_path = out.report.as_deref();
    if let Some(line) = out.record(serial, &fallback, |d| {
        d.record_fit(&record, report_path, blob.as_deref().unwrap_or_default())
    })? {
        // The page names the history's record of it (written after the page, so added now).
        if let (Some(page), Some(id)) = (report_path, line.strip_prefix("recorded as ")) {
            crate::report::provenance::add_record(page, id)?;
        }
        let _ = writeln!(said, "  {line}");
    }
    let verdict = c.verdict();
    let reasons = c
        .findings
        .iter()
        .filter(|f| verdict != Verdict::Accept && f.verdict == verdict)
        .map(|f| f.text.clone())
        .collect();
    Ok(Judged {
        verdict,
        reasons,
        figures: report::engineering::brief(&c),
    })
}

/// `--as-built`: every output named once with its sensor's serial, and each stage-one record
/// of that sensor.
fn as_built(list: &[String], sensors: &[sensor::stages::Sensor1]) -> Result<(), Failure> {
    use sensor::stages::one::OUTPUTS;
    if list.is_empty() {
        return Ok(());
    }
    let mut serials: [Option<&str>; 6] = [None; 6];
    for item in list {
        let Some((output, serial)) = item.split_once('=') else {
            return Err(format!("--as-built: `{item}` is not OUTPUT=SERIAL (a_x=S-0)").into());
        };
        let Some(k) = OUTPUTS.iter().position(|o| *o == output.trim()) else {
            return Err(format!(
                "--as-built: `{output}` is not an output; the outputs are {}",
                OUTPUTS.join(", ")
            )
            .into());
        };
        if serials[k].replace(serial.trim()).is_some() {
            return Err(format!("--as-built: {output} is given twice").into());
        }
    }
    for (k, s) in sensors.iter().enumerate() {
        let Some(serial) = serials[k] else {
            return Err(format!(
                "--as-built: no serial for {}: the list names the sensor at each of the six outputs",
                OUTPUTS[k]
            )
            .into());
        };
        if s.serial != serial {
            let at = serials
                .iter()
                .position(|x| *x == Some(s.serial.as_str()))
                .map_or_else(
                    || "is not in the as-built list".to_string(),
                    |j| format!("is mounted at {}", OUTPUTS[j]),
                );
            return Err(format!(
                "--stage-one {} (given for {}) is the record of sensor {}, which {at}; the as-built list puts sensor {serial} at {}",
                s.file.display(),
                OUTPUTS[k],
                s.serial,
                OUTPUTS[k]
            )
            .into());
        }
    }
    Ok(())
}

/// A REVIEW for each of `sensors` that the unit history has in another unit: one whose newest
/// calibration is a stage two that took that sensor's record (red team four: the same six
/// records built into IMU-7 and IMU-9 passed twice). None with `--no-db` or a history not yet
/// made.
fn built_elsewhere(
    out: &Outputs,
    unit: &str,
    sensors: &[sensor::stages::Sensor1],
) -> Result<Vec<sensor::Finding>, Failure> {
    if out.no_db {
        return Ok(Vec::new());
    }
    let at = crate::db::Location::or_default(out.db.as_ref())?;
    if at.file().is_some_and(|f| !f.exists()) {
        return Ok(Vec::new());
    }
    let rows = crate::db::Db::open_existing(&at)?.latest_fits(&crate::db::Selection::all())?;
    let mut found = Vec::new();
    for row in rows.iter().filter(|r| r.serial != unit) {
        let Some(v) = row
            .record
            .as_deref()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(t).ok())
        else {
            continue;
        };
        let Some(built) = v["stages"]["sensors"].as_array() else {
            continue;
        };
        for (s, output) in sensors.iter().zip(sensor::stages::one::OUTPUTS) {
            if built.iter().any(|b| b["serial"] == s.serial.as_str()) {
                found.push(sensor::Finding {
                    verdict: Verdict::Review,
                    text: format!(
                        "{output}: sensor {} is already built into unit {} (its newest calibration in {at}): a sensor is in one unit at a time; check the as-built list, or calibrate unit {} again if the sensor was moved",
                        s.serial, row.serial, row.serial
                    ),
                });
            }
        }
    }
    Ok(found)
}

/// Who signed each stage-one record, for the stage-two record's notes.
fn signers(sensors: &[sensor::stages::Sensor1]) -> String {
    let each: Vec<String> = sensors
        .iter()
        .zip(sensor::stages::one::OUTPUTS)
        .map(|(s, o)| format!("{o} ({}) {}", s.serial, s.signed_by))
        .collect();
    format!("stage-one records: {}", each.join("; "))
}

/// `history:SERIAL` in `--stage-one`: the serial.
fn from_history(p: &std::path::Path) -> Option<&str> {
    p.to_str().and_then(|s| s.strip_prefix("history:"))
}

/// The six stage-one records `--stage-one` names: files, or `history:SERIAL` for the sensor's
/// newest calibration in the unit history `out` names (or the default one).
fn stage_one(
    items: &[PathBuf],
    out: &Outputs,
    trust: &crate::sensor::record::Trust,
) -> Result<Vec<sensor::stages::Sensor1>, Failure> {
    use sensor::stages::{StageOneError, one};
    let history = std::cell::RefCell::new(None::<(crate::db::Location, crate::db::Db)>);
    let read = |p: &std::path::Path, k: usize| -> Result<one::Sensor1, StageOneError> {
        let Some(serial) = from_history(p) else {
            return one::read(p, k, trust);
        };
        let fail = |why: String| StageOneError::Unreadable {
            path: p.to_path_buf(),
            why,
        };
        let mut h = history.borrow_mut();
        if h.is_none() {
            let at = crate::db::Location::or_default(out.db.as_ref())
                .map_err(|e| fail(e.to_string()))?;
            let db = crate::db::Db::open_existing(&at).map_err(|e| fail(e.to_string()))?;
            *h = Some((at, db));
        }
        let Some((at, db)) = h.as_mut() else {
            return Err(fail("no unit history".into()));
        };
        let newest = db
            .history(serial)
            .map_err(|e| fail(e.to_string()))?
            .into_iter()
            .rfind(|e| e.kind == "fit")
            .ok_or_else(|| {
                fail(format!(
                    "the unit history {at} has no calibration of sensor {serial}"
                ))
            })?;
        let text = db.record(newest.id).map_err(|e| fail(e.to_string()))?;
        one::from_text(
            &text,
            &std::path::PathBuf::from(format!("{at} record {} ({serial})", newest.id)),
            k,
            trust,
        )
    };
    Ok(one::read_all_with(items, read)?)
}

/// The noise terms `--noise-terms` names, with the allowances; `None` without it.
fn noise_terms(args: &CalibrateArgs) -> Result<Option<spincal::model::NoiseTerms>, Failure> {
    let (accel, gyro) = match args.noise_terms.as_slice() {
        [] => return Ok(None),
        [a, g] => (a, g),
        other => {
            return Err(format!(
                "--noise-terms: two files, the accelerometer's and the gyro's Allan JSON, {} given",
                other.len()
            )
            .into());
        }
    };
    if args.sensor != SensorKind::Imu {
        return Err(
            "--noise-terms: the health check at rest is an IMU's (it needs the gyros and the accelerometers)"
                .into(),
        );
    }
    let gravity = values::pair(&args.gravity, "--gravity")?;
    let allow = crate::noise::stated::Allowances {
        ageing_s: args.ageing,
        gravity,
        false_alarm: args.false_alarm,
    };
    Ok(Some(crate::noise::stated::from_allan(accel, gyro, &allow)?))
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// The blob of a calibration judged REJECT, written because `--force-blob` asked: the same
/// coefficients, its identity marked, so that a flasher refuses it unless told otherwise.
fn rejected_blob(c: &sensor::Calibrated) -> Result<Vec<u8>, String> {
    let mut data = c.data.clone();
    data.identity.fit_rejected = true;
    let cal = spincal::model::Calibration::new(data).map_err(|e| e.to_string())?;
    let mut buf = vec![0u8; spincal::blob::MAX_BLOB_LEN];
    let n = spincal::blob::encode(&cal, &mut buf).map_err(|e| e.to_string())?;
    buf.truncate(n);
    Ok(buf)
}

fn summary(
    c: &sensor::Calibrated,
    data: &std::path::Path,
    out: &Outputs,
    blob_written: bool,
    quiet: bool,
) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let word = Verdict::word;
    let _ = writeln!(
        s,
        "calflash calibrate  {}  unit {}: {}",
        data.display(),
        c.data.identity.serial,
        word(c.verdict())
    );
    for f in c
        .findings
        .iter()
        .filter(|f| !quiet || f.verdict != Verdict::Accept)
    {
        let _ = writeln!(s, "  {:<6} {}", word(f.verdict), f.text);
    }
    if quiet {
        let hidden = c.findings.len() + c.notes.len() + c.decisions.len();
        let _ = writeln!(
            s,
            "  ({hidden} findings, notes and model tests in the record and the report; without --quiet they are printed)"
        );
    }
    for n in c.notes.iter().filter(|_| !quiet) {
        let _ = writeln!(s, "  note   {n}");
    }
    for d in c.decisions.iter().filter(|_| !quiet) {
        let _ = writeln!(
            s,
            "  test   {}: F = {}, p = {}: {}; {}",
            d.name,
            num(d.test.f),
            pval(d.test.p),
            if d.kept { "kept" } else { "not kept" },
            d.detail
        );
    }
    let r = &c.points[c.reference];
    if !quiet {
        let _ = writeln!(
            s,
            "  fit{} (the record and the report hold every point):",
            r.temp.map_or(String::new(), |t| format!(" at {t:.1} C"))
        );
    }
    for (a, axis) in r.axes.iter().enumerate().filter(|_| !quiet) {
        let coefs: Vec<String> = axis
            .fit
            .names
            .iter()
            .zip(&axis.fit.coefficients)
            .zip(&axis.fit.std_errors)
            .map(|((n, b), e)| format!("{n} {} +- {}", num(*b), num(*e)))
            .collect();
        let _ = writeln!(
            s,
            "  {}: {} (noise {} {})",
            axis.output,
            coefs.join(", "),
            num(r.noise[a]),
            c.units[a]
        );
    }
    let _ = writeln!(
        s,
        "  in engineering units (bias: the reading at zero input from the converter's mid-scale; 1-sigma in brackets):"
    );
    for line in crate::report::engineering::lines(c) {
        let _ = writeln!(s, "    {line}");
    }
    if let Some(m) = &c.mission {
        s.push_str(&crate::report::mission::judged_text(m));
    }
    let _ = match c.data.environment.temperature_model {
        spincal::model::TemperatureModel::Chebyshev(n) => writeln!(
            s,
            "  temperature series: {n} terms over {:.1} to {:.1} C; blob {} bytes",
            c.data.environment.temperature_span.lo,
            c.data.environment.temperature_span.hi,
            c.blob.len()
        ),
        spincal::model::TemperatureModel::Table => writeln!(
            s,
            "  table: {} point(s); blob {} bytes",
            c.points.len(),
            c.blob.len()
        ),
    };
    for (p, what) in [
        (&out.blob, "blob"),
        (&out.report, "report"),
        (&out.json, "record"),
    ] {
        match p {
            Some(p) if what == "blob" && !blob_written => {
                let _ = writeln!(
                    s,
                    "  blob: none written to {}: the calibration is judged REJECT (--force-blob writes it, marked so that `flash` refuses it)",
                    p.display()
                );
            }
            Some(p) if what == "blob" && c.verdict() == Verdict::Reject => {
                let _ = writeln!(
                    s,
                    "  blob: {} (of a rejected fit, marked: `flash` refuses it without --force-rejected)",
                    p.display()
                );
            }
            Some(p) => {
                let _ = writeln!(s, "  {what}: {}", p.display());
            }
            None => {}
        }
    }
    s
}
