//! `calflash selfcal`: an IMU calibrated from a recording of still poses, with no equipment.

use crate::cmd::Failure;
use std::path::PathBuf;

use crate::files::Paths;
use clap::Args;
use spincal::model::{Rails, Span};

use super::outputs::Outputs;
use crate::nonlinear::selfcal::{self, GyroBias, Options, Quadratic};
use crate::obs::recording;
use crate::report;
use crate::sensor::selfcal::acceptance;
use crate::sensor::selfcal::record::{self, SelfcalRecord};
use crate::sensor::{blob, selfcal as build};

/// Calibrate an IMU without equipment: still poses by hand, gravity as the only reference.
#[derive(Debug, Args)]
pub struct SelfcalArgs {
    /// The accelerometer recording (timestamp and three counts per line), or one file with the
    /// timestamp and six counts (accelerometer, then gyro).
    pub acc: PathBuf,
    /// The gyro recording, when separate (same timestamps, line for line).
    pub gyro: Option<PathBuf>,
    /// Local gravity, m/s^2 (look it up for the site: it varies by 0.5 % over the Earth).
    #[arg(long, value_parser = gravity)]
    pub g: f64,
    /// The unit's serial number.
    #[arg(long)]
    pub serial: String,
    /// Length of the rest at the start of the recording, s (default: what the logger's
    /// preamble states, else 30).
    #[arg(long, value_parser = super::values::positive)]
    pub init_rest: Option<f64>,
    /// The sample rate, Hz, of a recording without timestamps; over a file's own timestamps it is
    /// taken instead of them (a host that stamps samples in batches), and said.
    #[arg(long = "sample-rate", alias = "rate", value_parser = |s: &str| super::values::in_range(s, 1.0, 1.0e6))]
    pub rate: Option<f64>,
    /// The units of the values (counts unless stated).
    #[command(flatten)]
    pub units: super::units::UnitArgs,
    /// Columns chosen by name.
    #[command(flatten)]
    pub columns: super::units::ColumnArgs,
    /// Window of the still measure, s.
    #[arg(long, default_value_t = 1.0, value_parser = super::values::positive)]
    pub window: f64,
    /// Shortest still pose, s.
    #[arg(long, default_value_t = 1.0, value_parser = super::values::positive)]
    pub min_still: f64,
    /// The accelerometer's quadratic terms.
    #[arg(long, value_enum, default_value = "auto")]
    pub quadratic: Quadratic,
    /// Where the gyro bias during rotations comes from.
    #[arg(long, value_enum, default_value = "constant")]
    pub gyro_bias: GyroBias,
    /// A Ferraris session's section list (imucal's JSON: the sample ranges of the six faces
    /// x_p, x_a, y_p, y_a, z_p, z_a and the three turns x_rot, y_rot, z_rot): the faces give
    /// the accelerometer's cross-axis terms and the turns the gyro's scale about each axis.
    #[arg(long, value_name = "FILE")]
    pub sections: Option<std::path::PathBuf>,
    /// The angle of each turn of `--sections` about its axis, degrees (imucal's default).
    #[arg(long, default_value_t = -360.0, allow_negative_numbers = true, requires = "sections", value_parser = super::values::non_zero)]
    pub turn_angle: f64,
    /// The converter's codes: unsigned16 (also offset binary), signed16 (two's complement), any
    /// width from 8 to 32 bits, or the rails LO:HI. Samples at a rail are excluded.
    #[arg(long, default_value = "unsigned16", value_parser = super::values::codes)]
    pub codes: Rails,
    /// Calibrated temperature span, C (LO:HI), stored for the device's flags.
    #[arg(long, default_value = "20:30")]
    pub temp_span: String,
    /// Calibrated supply-voltage span, V (LO:HI).
    #[arg(long, default_value = "0:100")]
    pub volt_span: String,
    /// Blob, report, record and unit history.
    #[command(flatten)]
    pub out: Outputs,
}

/// The initial rest assumed when neither `--init-rest` nor the recording states one, s.
const DEFAULT_REST: f64 = 30.0;

/// The shortest initial rest taken up to the first motion when the default one moves, s.
const MIN_FOUND_REST: f64 = 2.0;

/// Local gravity, m/s^2: between 9.7 and 9.9 on the Earth's surface.
fn gravity(s: &str) -> Result<f64, String> {
    super::values::in_range(s, 9.7, 9.9).map_err(|_| {
        "local gravity is between 9.78 and 9.84 m/s^2 on the Earth's surface; give it in m/s^2"
            .into()
    })
}

/// Runs `calflash selfcal`; true when the calibration is judged REJECT.
///
/// # Errors
/// Bad input, or a recording that cannot calibrate the unit (the message says what to do).
pub fn run(args: &SelfcalArgs) -> Result<bool, Failure> {
    if args.out.lot.is_some() {
        return Err("--lot: lots are judged on the coefficients of `calflash calibrate` (bias and scale per axis); a calibration without equipment has others, so it joins no lot".into());
    }
    args.out.check(
        Paths::new()
            .input("the accelerometer recording", Some(&args.acc))
            .input("--gyro", args.gyro.as_deref())
            .input("--sections", args.sections.as_deref()),
    )?;
    let serial = blob::serial(&args.serial)?;
    let (t0, t1) = super::values::pair(&args.temp_span, "--temp-span")?;
    let (v0, v1) = super::values::pair(&args.volt_span, "--volt-span")?;
    let rails = args.codes;
    let rec = recording::read_with(
        &args.acc,
        args.gyro.as_deref(),
        &recording::Options {
            rails,
            rate: args.rate,
            keep: crate::obs::layout::Keep::Both,
            units: args.units.units(),
            columns: args.columns.chosen(),
        },
    )?;
    let init_rest = match (args.init_rest, rec.rest) {
        (Some(r), _) => r,
        (None, Some(r)) => r,
        (None, None) => DEFAULT_REST,
    };
    let mut opts = Options {
        g: args.g,
        init_rest,
        window: args.window,
        min_still: args.min_still,
        quadratic: args.quadratic,
        gyro_bias: args.gyro_bias,
        sections: match &args.sections {
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .map_err(|e| format!("{}: cannot read the section list: {e}", p.display()))?;
                Some(selfcal::ferraris::Sections::parse(
                    &text,
                    &p.display().to_string(),
                    rec.t.len(),
                    args.turn_angle,
                )?)
            }
            None => None,
        },
        ..Options::default()
    };
    let c = match selfcal::calibrate(&rec, &opts) {
        // No rest was given or stated and the unit moves inside the default one: the rest is
        // up to its first motion (issue 66: a 3 s rest was refused until the user found
        // --init-rest), said.
        Err(selfcal::SelfCalError::RestNotStill { at, .. })
            if args.init_rest.is_none() && rec.rest.is_none() && at >= MIN_FOUND_REST =>
        {
            println!(
                "calflash selfcal: initial rest: the first {at:.1} s, up to where the unit first moves (no --init-rest given or stated, and the default {DEFAULT_REST} s moves); give --init-rest to set it"
            );
            opts.init_rest = at;
            selfcal::calibrate(&rec, &opts)?
        }
        other => other?,
    };
    let reject = !acceptance::rejected(&c).is_empty();
    let mut files = vec![args.acc.as_path()];
    files.extend(args.gyro.as_deref());
    // A rejected calibration writes no blob unless forced; a forced one says so.
    let identity = crate::sensor::blob::new_identity(
        serial.clone(),
        None,
        crate::sensor::data_hash(&files)?,
        reject,
    );
    // SI values cannot make a blob: the device corrects converter codes.
    let si = rec.units.iter().any(|u| u.is_si());
    let check = if si {
        None
    } else {
        let data = build::calibration_data(
            &c,
            &rec,
            identity,
            rails,
            Span::new(t0 as f32, t1 as f32),
            Span::new(v0 as f32, v1 as f32),
        );
        Some(build::build_and_check(&data, &c, &rec)?)
    };
    let check = check.as_ref();
    if si && args.out.blob.is_some() {
        return Err(format!(
            "--blob: {}",
            record::NO_BLOB.trim_start_matches("no blob: ")
        )
        .into());
    }
    let name = serial.as_str();
    let record = SelfcalRecord::new(&c, &rec, check, name);
    let signed = check
        .map(|c| c.blob.clone())
        .filter(|_| !reject || args.out.force_blob)
        .map(|b| args.out.sign(b, name, acceptance::verdict(&c, check).0))
        .transpose()?;
    let blob = signed.as_ref().map(|s| s.bytes.as_slice());
    let mut provenance = crate::report::provenance::Provenance::now()
        .serial(name)
        .input("recording", &args.acc);
    if let Some(g) = &args.gyro {
        provenance = provenance.input("gyro recording", g);
    }
    args.out.write(blob, &record, provenance, || {
        report::selfcal::html(&c, &rec, check, name)
    })?;
    print!("{}", report::selfcal::summary(&c, &rec, check, name));
    if let Some(note) = signed.as_ref().and_then(|s| s.note.as_deref()) {
        println!("{note}");
    }
    if reject && check.is_some() && blob.is_none() {
        println!(
            "  blob: none written: the calibration is judged REJECT (--force-blob writes it, marked so that `flash` refuses it)"
        );
    }
    let report_path = args.out.report.as_deref();
    let fallback = serde_json::to_value(&record).unwrap_or_default();
    if let Some(said) = args.out.record(name, &fallback, |d| {
        d.record_selfcal(name, &record, report_path, blob.unwrap_or_default())
    })? {
        if let (Some(page), Some(id)) = (report_path, said.strip_prefix("recorded as ")) {
            crate::report::provenance::add_record(page, id)?;
        }
        println!("  {said}");
    }
    Ok(reject)
}
