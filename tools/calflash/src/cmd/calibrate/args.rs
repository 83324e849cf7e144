//! What `calflash calibrate` takes on its command line, each option with its help.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use spincal::model::Rails;

use crate::cmd::outputs::Outputs;
use crate::cmd::values::{self, SensorKind};
use crate::obs::Format;

/// Asymmetry handling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Asymmetry {
    /// Keep it when the test finds it.
    Auto,
    /// Always keep it.
    Keep,
    /// Never.
    Drop,
}

/// How the coefficients follow the temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ThermalArg {
    /// A fit per temperature setpoint when the observations fall into well-filled setpoints
    /// (at most 16, each with more than twice the model's terms), the continuous model
    /// otherwise (a ramp).
    Auto,
    /// A fit per temperature setpoint.
    Table,
    /// Every coefficient a polynomial in the temperature, fitted with all the observations;
    /// the device gets a table at breakpoints chosen to follow it.
    Continuous,
}

/// Calibrate a sensor: fit, decide, invert, and write the blob, the report and the record.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// The observations: a CSV with a header of these columns. A single axis: `input` (the
    /// reference input, m/s^2 or rad/s) and `output` (counts), optionally `input_p`, `input_o`
    /// (cross-axis inputs), `dir` (+1 ascending, -1 descending). A triad or an IMU, in the
    /// unit's axes: `f_x f_y f_z` (reference specific force, m/s^2) and `a_x a_y a_z`
    /// (accelerometer counts); `w_x w_y w_z` (reference rate, rad/s) and `g_x g_y g_z` (gyro
    /// counts); optionally `dw_x dw_y dw_z` (angular acceleration, rad/s^2), `h_x h_y h_z` (the
    /// fixture's reference mark, for the Earth's rate). Any: `temp` (C), `volt` (V),
    /// `chamber_temp`, `time` (s). Several files, or a directory of them, make a batch: one
    /// unit per file, whose serial is the file's name without extension, calibrated on every
    /// core, each unit's files in `--out-dir`.
    #[arg(required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// What the observations are of.
    #[arg(long, value_enum, ignore_case = true)]
    pub sensor: SensorKind,
    /// The unit's serial number (1 to 16 printable ASCII characters); a batch takes each
    /// unit's from its file name.
    #[arg(long)]
    pub serial: Option<String>,
    /// Blob, report, record and unit history.
    #[command(flatten)]
    pub out: Outputs,
    /// A batch: write each unit's blob (SERIAL.blob) and record (SERIAL.json) here.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// A batch: also write each unit's HTML report (SERIAL.html) into `--out-dir`, and an
    /// index.html with a row and a link per unit.
    #[arg(long, requires = "out_dir")]
    pub reports: bool,
    /// Say only what a person must read: the verdict and the findings that are not ACCEPT,
    /// the calibration in engineering units, and the files written (the notes, the model
    /// tests and the coefficients stay in the record and the report).
    #[arg(long, short)]
    pub quiet: bool,
    /// The file is a fixture's: several units' columns (`PREFIX_COLUMN`, e.g. `u3_a_x`) beside
    /// the shared ones; each unit is calibrated as in a batch.
    #[arg(long)]
    pub fixture: bool,
    /// A fixture's units' serials by prefix (`u1=IMU-0001,u2=IMU-0002`; default: the prefix).
    /// (`--units`, its name before 2026-11-27, is still taken.)
    #[arg(long, alias = "units", value_delimiter = ',', requires = "fixture")]
    pub serials: Vec<String>,
    /// A single-axis model instead of the IEEE 1293 preset (e.g. "output ~ 1 + input + input^2").
    #[arg(long)]
    pub model: Option<String>,
    /// Keep every preset term instead of dropping the ones that are not significant.
    #[arg(long)]
    pub keep_all_terms: bool,
    /// Triads: add own-axis g-squared, cubic and odd-quadratic terms to the preset. An IMU
    /// considers them by default (the data keep those they show; `--linear` to leave them out).
    #[arg(long, conflicts_with = "linear")]
    pub nonlinear: bool,
    /// An IMU: correct without the nonlinear terms (g-squared, cubic, odd-quadratic) even where
    /// the data show them; their estimate then widens the stated 1-sigma, and a note names those
    /// the data show.
    #[arg(long)]
    pub linear: bool,
    /// Single axis: asymmetric scale factor.
    #[arg(long, value_enum, default_value = "auto")]
    pub asymmetry: Asymmetry,
    /// Single axis: the asymmetry breakpoint (input units).
    #[arg(long, default_value_t = 0.0, value_parser = values::finite)]
    pub breakpoint: f64,
    /// The converter's codes: unsigned16 (also offset binary), signed16 (two's complement), any
    /// width from 8 to 32 bits, or the rails LO:HI. Outputs at or beyond a rail are left out.
    #[arg(long, default_value = "unsigned16", value_parser = values::codes)]
    pub codes: Rails,
    /// How the coefficients follow the temperature (`temp` column).
    #[arg(long, value_enum, default_value = "auto")]
    pub thermal: ThermalArg,
    /// Continuous temperature model: the order of every coefficient's temperature polynomial
    /// (0 to 9) instead of choosing each from the data.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=9))]
    pub thermal_order: Option<u32>,
    /// Triads and IMUs: a recording of the unit at rest in one pose while the temperature
    /// sweeps (a timestamp, the counts and a temperature column, as `selfcal` reads them),
    /// calibrated with DATA, a bench run at one temperature that passes through the ramp, into
    /// one continuous temperature model: the biases follow the temperature, the scale factors
    /// are the bench's.
    #[arg(long, value_name = "FILE")]
    pub still_ramp: Option<PathBuf>,
    /// Calibrated temperature span when the data have no temp column.
    #[arg(long, value_name = "LO:HI", default_value = "20:30")]
    pub temp_span: String,
    /// Calibrated supply-voltage span when the data have no volt column.
    #[arg(long, value_name = "LO:HI", default_value = "0:100")]
    pub volt_span: String,
    /// Reject when the residual noise of an axis exceeds this (input units).
    #[arg(long, value_parser = values::positive)]
    pub max_noise: Option<f64>,
    /// Significance level.
    #[arg(long, default_value_t = 0.05, value_parser = values::level)]
    pub alpha: f64,
    /// Field separator of the data.
    #[arg(long, value_enum, default_value = "auto")]
    pub format: Format,
    /// Triads and IMUs: the station's latitude, degrees: the Earth's rate becomes a known
    /// input of the gyro fits (with --heading and, for still positions, the fixture's mark
    /// `h_x h_y h_z` in the data).
    #[arg(long, requires = "heading", value_parser = values::finite)]
    pub latitude: Option<f64>,
    /// The azimuth of the fixture's reference mark from true north, degrees clockwise.
    #[arg(long, requires = "latitude", value_parser = values::finite)]
    pub heading: Option<f64>,
    /// IMUs: the accelerometer's and the gyro's noise (two `calflash allan --json` files, in
    /// SI units) go into the blob, so that the unit can judge its calibration at rest.
    /// (`--noise`, its name before 2026-11-27, is still taken.)
    #[arg(
        long,
        alias = "noise",
        value_name = "ACCEL.json,GYRO.json",
        value_delimiter = ','
    )]
    pub noise_terms: Vec<PathBuf>,
    /// With --noise-terms: the time over which ageing may move the biases by their random walk
    /// before the unit calls a drift SUSPECT (its shelf life, or the interval between bench
    /// checks), in s, or with the suffix h or d.
    #[arg(long, default_value = "365d", requires = "noise_terms", value_parser = values::duration_at_most_a_century)]
    pub ageing: f64,
    /// With --noise-terms: the magnitude of gravity wherever the unit may rest, m/s^2 (a narrower
    /// span lets one pose test the accelerometer along gravity more sharply).
    #[arg(
        long,
        value_name = "LO:HI",
        default_value = "9.78:9.84",
        requires = "noise_terms"
    )]
    pub gravity: String,
    /// With --noise-terms: the probability that the unit calls a calibration that holds SUSPECT
    /// (or one aged within the allowance) in one period at rest: from 1e-12 to 0.5.
    #[arg(long, default_value_t = 1e-3, requires = "noise_terms", value_parser = false_alarm)]
    pub false_alarm: f64,
    /// A mission profile (`calflash mission` reads it): the calibration is judged over the
    /// flight: each output's predicted 1-sigma error along it, where it leaves the calibrated
    /// range, and the terms the bench dropped priced at their bench bound over it.
    #[arg(long)]
    pub mission: Option<PathBuf>,
    #[command(flatten)]
    pub mission_columns: crate::cmd::mission_columns::MissionColumns,
    /// With --mission: the largest acceptable predicted error over the flight, SI per output
    /// family or output: `a=0.05,g=0.002` (m/s^2, rad/s) or `a_x=0.05,...`; above it, REVIEW.
    #[arg(long, requires = "mission", value_parser = requirement)]
    pub requirement: Option<Requirements>,
    /// IMUs, stage two of two: the six sensors' own single-axis calibrations (`calibrate
    /// --sensor single-accel|single-gyro --json`), in the order a_x,a_y,a_z,g_x,g_y,g_z. The
    /// assembled unit's observations then estimate what assembly adds (sensing directions,
    /// bias and scale changes, lever arms, g-sensitivity) with each sensor's own terms and
    /// temperature behaviour carried in, both stages' covariance in the stated 1-sigma; a
    /// sensor whose bias or scale factor moved in assembly is a REVIEW. `history:SERIAL` takes
    /// that sensor's newest calibration from the unit history (`--db`, or the default).
    #[arg(long, value_name = "AX.json,...,GZ.json", value_delimiter = ',')]
    pub stage_one: Vec<PathBuf>,
    /// With --stage-one: a station public key (`calflash keygen`'s PREFIX.pub) whose signed
    /// stage-one records are taken; repeat or separate with commas. The public half of this
    /// station's own --sign-key (or $CALFLASH_SIGN_KEY) is trusted without it. A record
    /// signed by another key, unsigned, or changed after it was signed is refused, naming the
    /// key.
    #[arg(
        long,
        value_name = "PUB",
        value_delimiter = ',',
        requires = "stage_one"
    )]
    pub trust_key: Vec<PathBuf>,
    /// With --stage-one: take stage-one records that no station signed. Their seal can be
    /// recomputed by anyone who edits them, so the stage-two record notes it; for a
    /// laboratory without station keys.
    #[arg(long, requires = "stage_one")]
    pub unsigned_stage_one: bool,
    /// With --stage-one: the unit's as-built list, the serial of the sensor mounted at each
    /// output (`a_x=S-0,a_y=S-1,...,g_z=S-5`, as the assembly's traveller records it). Each
    /// stage-one record's sensor must be the one mounted at its output: records given in the
    /// wrong order are refused, naming both serials.
    #[arg(
        long,
        value_name = "OUTPUT=SERIAL,...",
        value_delimiter = ',',
        requires = "stage_one"
    )]
    pub as_built: Vec<String>,
}

/// `--requirement`: `(output or family, SI)` pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct Requirements(pub Vec<(String, f64)>);

/// `--requirement`, read as it is parsed.
fn requirement(s: &str) -> Result<Requirements, String> {
    crate::mission::judge::requirements(s)
        .map(Requirements)
        .map_err(|e| e.to_string())
}

/// `--false-alarm`: a probability from 1e-12 to 0.5 (the device holds it in f32 and tests a
/// rest period's checkpoints at fractions of it).
fn false_alarm(s: &str) -> Result<f64, String> {
    values::in_range(s, 1e-12, 0.5).map_err(|_| {
        format!("`{s}`: a false-alarm rate from 1e-12 to 0.5 per rest period is expected")
    })
}
