//! What `calflash simulate` takes on its command line, each option with its help.

use std::path::PathBuf;

use clap::Args;

use crate::cmd::values::SensorKind;

/// Simulate a sensor with known true coefficients and noise through a test plan.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// What to simulate.
    #[arg(long, value_enum, ignore_case = true)]
    pub sensor: SensorKind,
    /// Plan items (repeatable): head:N, tumble:6|12|18|24|26, sphere:N, rate:LO:HI:N (rad/s),
    /// diagonal:LO:HI:N (rad/s, about the 45-degree diagonals), centrifuge:LO:HI:N (g),
    /// sweep:LO:HI:N, fine:LO:HI:N.
    #[arg(long, required_unless_present_any = ["plan_file", "spin", "rest", "flight", "still", "tumble"])]
    pub plan: Vec<String>,
    /// An IMU at rest and being handled, as the raw counts of this blob's device correction
    /// (for `calflash health` and `allan`): rests of `--hold` seconds in `--poses` poses, one
    /// second turning between them, at `--sample-rate`, its biases off the calibration by
    /// `--shift`. The file has a row per sample: `t` and the six counts.
    #[arg(long, value_name = "BLOB", conflicts_with_all = ["plan", "plan_file", "spin"])]
    pub rest: Option<PathBuf>,
    /// With --rest: how far each bias `ax,ay,az,wx,wy,wz` is off the calibration, in the
    /// calibration's stated 1-sigma at rest (an aged or shocked unit).
    #[arg(long, requires = "rest", value_delimiter = ',', allow_negative_numbers = true, value_parser = crate::cmd::values::finite)]
    pub shift: Vec<f64>,
    /// With --rest: the unit has aged this long since its calibration (s, or with h or d):
    /// each bias has also wandered by a draw of its stored random walk over that time.
    #[arg(long, default_value = "0", requires = "rest", value_parser = crate::cmd::values::duration_at_most_a_century)]
    pub aged: f64,
    /// With --rest: the number of rest poses.
    #[arg(long, default_value_t = 3, requires = "rest", value_parser = |s: &str| crate::cmd::values::count_in(s, 1, 24))]
    pub poses: usize,
    /// With --rest: seconds at rest in each pose.
    #[arg(long, default_value_t = 5.0, requires = "rest", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.1, 3600.0))]
    pub hold: f64,
    /// A spin-rig flight of an IMU instead of a plan: the unit rolls about its x axis, held
    /// horizontal (gravity transverse), through comma-separated segments `HZ:SECONDS` (steady)
    /// and `FROM-TO:SECONDS` (spin-up or spin-down), each starting where the one before ends,
    /// e.g. `50:1,50-150:0.2,150:1,150-300:0.5,300:1`. The
    /// file has a row per sample: `t`, the true `f_*`, `w_*`, `dw_*` and the raw `a_*`, `g_*`
    /// counts (noisy, rounded), for `calflash apply --time-column t --reference`.
    #[arg(long, conflicts_with_all = ["plan", "plan_file"])]
    pub spin: Option<String>,
    /// A flight of an IMU (a mission profile with the unit's raw codes): `shell` or `rocket`,
    /// then `:KEY=VALUE,...` for what differs from the default flight. A shell: setback (g,
    /// 15000), velocity (m/s, 800), spin (rev/s, 300), elevation (degrees, 45), tip-off (rad/s,
    /// 5), seconds (60), conditioned (C, 21), altitude (m, 0). A rocket: thrust (N, 1800), burn
    /// (s, 6), elevation (84), rail (m, 12), cant (0.077), seconds (300), conditioned (25),
    /// altitude. The file has a row per sample: `t`, the true `f_*`, `w_*`, `dw_*`, `temp`,
    /// `volt` (the profile `calflash mission` and `--mission` read) and the raw `a_*`, `g_*`.
    #[arg(long, conflicts_with_all = ["plan", "plan_file", "spin", "rest"])]
    pub flight: Option<String>,
    /// An IMU lying still (z up) this many seconds, for `calflash allan`: a row per sample,
    /// `t`, the six codes and `temp`, with the truth's white noise and `--bias-walk`.
    #[arg(long, conflicts_with_all = ["plan", "plan_file", "spin", "rest", "flight"], value_parser = |s: &str| crate::cmd::values::in_range(s, 1.0, 1.0e6))]
    pub still: Option<f64>,
    /// An IMU turned by hand through this many still poses after a 30 s rest, for `calflash
    /// selfcal` (`--init-rest 30`, `--g 9.81`): a line per sample at 100 Hz (or
    /// `--sample-rate`), the time and the six codes, space-separated.
    #[arg(long, conflicts_with_all = ["plan", "plan_file", "spin", "rest", "flight", "still"], value_parser = |s: &str| crate::cmd::values::count_in(s, 1, 1000))]
    pub tumble: Option<usize>,
    /// This many units on one fixture through the plan, in one file as `calibrate --fixture`
    /// reads it: the plan's columns once, then each unit's outputs prefixed `u1_`, `u2_`, ...
    /// (the same truth, each unit with its own noise: seeds `--seed`, `--seed`+1, ...).
    #[arg(long, conflicts_with_all = ["spin", "rest", "flight", "still", "tumble", "stages"], value_parser = |s: &str| crate::cmd::values::count_in(s, 2, 64))]
    pub fixture: Option<usize>,
    /// With --still: each bias's random walk, counts per root second, `ACCEL,GYRO`.
    #[arg(long, requires = "still", value_delimiter = ',', value_parser = crate::cmd::values::non_negative)]
    pub bias_walk: Vec<f64>,
    /// With --flight: write what a GNSS receiver riding along reports here (CSV: t, latitude,
    /// longitude, height, v_east, v_north, v_up, satellites), for `calflash flight --gnss`. The
    /// flight is then launched on the turning Earth (lat=, lon=, azimuth= in --flight; 45 N,
    /// 0 E, fired north unless given).
    #[arg(long, requires = "flight")]
    pub gnss: Option<PathBuf>,
    /// The GNSS fixes' 1-sigma noise, m: `HORIZONTAL,VERTICAL`.
    #[arg(long, default_values_t = [2.0, 4.0], value_delimiter = ',', requires = "gnss", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.01, 1000.0))]
    pub gnss_noise: Vec<f64>,
    /// Fixes per second.
    #[arg(long, default_value_t = 10.0, requires = "gnss", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.1, 100.0))]
    pub gnss_rate: f64,
    /// How late each fix is stamped, s.
    #[arg(long, default_value_t = 0.0, requires = "gnss", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.0, 5.0))]
    pub gnss_latency: f64,
    /// No fix for this long after launch, s.
    #[arg(long, default_value_t = 1.0, requires = "gnss", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.0, 1.0e4))]
    pub gnss_outage: f64,
    /// When the receiver has fixes: `flight` (a shell's GNSS fuze acquires in flight, no fix on
    /// the pad: a shell's default) or `pad` (from the pad on: a rocket's default).
    #[arg(long, requires = "gnss", value_parser = ["flight", "pad"])]
    pub gnss_acquire: Option<String>,
    /// The receiver's slowly varying position error, `SIGMA,TAU` (m, s): a first-order
    /// Gauss-Markov error on each axis beside the white noise, 0 for none.
    #[arg(long, default_values_t = [1.5, 60.0], value_delimiter = ',', requires = "gnss", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.0, 1.0e4))]
    pub gnss_correlated: Vec<f64>,
    /// The GNSS antenna from the IMU, body axes, m: `X,Y,Z` (`calflash flight --lever`).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, requires = "gnss", num_args = 1, value_parser = crate::cmd::values::finite)]
    pub gnss_antenna: Vec<f64>,
    /// With --flight: write a barometer's readings here (CSV: t, T in C, P in Pa, 100 Hz).
    #[arg(long, requires = "flight")]
    pub baro: Option<PathBuf>,
    /// The barometer's 1-sigma noise, Pa.
    #[arg(long, default_value_t = 2.0, requires = "baro", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.0, 1000.0))]
    pub baro_noise: f64,
    /// With --flight: the unit's errors shift at launch by these, `KEY=VALUE,...`: ax ay az
    /// (accelerometer biases, m/s^2), wx wy wz (gyro biases, rad/s), sax say saz swx swy swz
    /// (scale factors, relative).
    #[arg(long, requires = "flight")]
    pub launch_shift: Option<String>,
    /// With --flight: write the flight's truth here (CSV: t, position x y z in m downrange,
    /// left and up from the launch point, velocity vx vy vz, attitude qw qx qy qz body to
    /// Earth).
    #[arg(long, requires = "flight")]
    pub flight_truth: Option<PathBuf>,
    /// Samples per second of a spin-rig flight (2000 unless stated) or of a unit at rest (1000).
    #[arg(long, value_parser = |s: &str| crate::cmd::values::in_range(s, 1.0, 1.0e6))]
    pub sample_rate: Option<f64>,
    /// The unit's axis a spin-rig flight turns it about, `X,Y,Z` in its own axes.
    #[arg(
        long,
        default_value = "1,0,0",
        requires = "spin",
        allow_negative_numbers = true
    )]
    pub spin_axis: String,
    /// Coning of a spin-rig flight: `DEGREES:HZ`, the roll axis' half-angle and its rate.
    #[arg(long, requires = "spin")]
    pub coning: Option<String>,
    /// The station's latitude, degrees: triads and IMUs sense the Earth's rate too, and the
    /// file carries the fixture's mark `h_*` of each still position.
    #[arg(long, requires = "heading", conflicts_with = "spin", value_parser = crate::cmd::values::finite)]
    pub latitude: Option<f64>,
    /// The azimuth of the fixture's reference mark from true north, degrees clockwise.
    #[arg(long, requires = "latitude", value_parser = crate::cmd::values::finite)]
    pub heading: Option<f64>,
    /// A plan file instead (CSV with a header; columns f_x f_y f_z w_x w_y w_z for triads or
    /// input input_p input_o for a single axis, temp, volt; missing ones are 0, 25 C, 5 V), as
    /// `calflash design optimize` writes it. Each row is one observation.
    #[arg(long, conflicts_with = "plan")]
    pub plan_file: Option<PathBuf>,
    /// Chamber temperatures, C (comma-separated). A hand-turned recording, a unit at rest and a
    /// flight have no chamber: refused with them (a flight's temperature is its
    /// `conditioned=` key).
    #[arg(long, default_value = "25", value_delimiter = ',', value_parser = crate::cmd::values::finite, conflicts_with_all = ["tumble", "rest", "flight"])]
    pub temps: Vec<f64>,
    /// A chamber ramp instead of fixed temperatures, `FROM:TO` in C: the plan (repeated
    /// `--repeat` times) is run while the chamber sweeps, each observation at its own
    /// temperature; the file gets `time` (s) and `chamber_temp` columns, and `temp` is the
    /// sensor's own reading.
    #[arg(long, conflicts_with_all = ["temps", "spin"], allow_hyphen_values = true)]
    pub ramp: Option<String>,
    /// The ramp's duration, minutes.
    #[arg(long, default_value_t = 120.0, requires = "ramp", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.1, 1.0e5))]
    pub ramp_minutes: f64,
    /// An uneven ramp: fast at first, slow at the end (the observations crowd at the end).
    #[arg(long, requires = "ramp")]
    pub uneven: bool,
    /// The sensor's thermal time constant behind the chamber, seconds.
    #[arg(long, default_value_t = 0.0, requires = "ramp", value_parser = |s: &str| crate::cmd::values::in_range(s, 0.0, 1.0e5))]
    pub lag: f64,
    /// Self-heating after power-on, `RISE:SECONDS`: the sensor rises RISE C above its
    /// surroundings with that time constant.
    #[arg(long, requires = "ramp")]
    pub self_heating: Option<String>,
    /// The sensor reports its temperature in steps of this many C (1: whole degrees).
    #[arg(long, requires = "ramp", value_parser = crate::cmd::values::positive)]
    pub temp_step: Option<f64>,
    /// Supply voltages, V (comma-separated).
    #[arg(long, default_value = "5", value_delimiter = ',', value_parser = crate::cmd::values::finite)]
    pub volts: Vec<f64>,
    /// Repetitions of the whole plan at each temperature and voltage.
    #[arg(long, default_value_t = 1, value_parser = crate::cmd::values::at_least_one)]
    pub repeat: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Round outputs to whole counts (single readings rather than averages).
    #[arg(long)]
    pub quantize: bool,
    /// The converter's codes (unsigned16, signed16, any width from 8 to 32 bits, or LO:HI):
    /// outputs saturate at its rails, as the converter's do.
    #[arg(long, default_value = "unsigned16", value_parser = crate::cmd::values::codes)]
    pub codes: spincal::model::Rails,
    /// True coefficients (JSON, the fields of the sensor's truth); default: a typical unit.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Write the truth used here (JSON).
    #[arg(long)]
    pub write_truth: Option<PathBuf>,
    /// Two stages from one truth (`--sensor imu`): each of the six sensors through
    /// `--stage-one-plan` at `--temps` on its own fixture, written as DIR/a_x.csv ...
    /// DIR/g_z.csv (single-axis observations for `calibrate --sensor single-accel|single-gyro`),
    /// and the unit they are assembled into through `--plan` at `--assembly-temp` (`-o`, for
    /// `calibrate --sensor imu --stage-one`). `--truth` reads an assembled unit's truth (the
    /// six sensors, their directions, lever arms, g-sensitivity, and what assembly changed);
    /// by default one is drawn from `--seed`.
    #[arg(long, value_name = "DIR", requires = "plan", conflicts_with_all = ["plan_file", "ramp", "spin", "rest", "flight", "still"])]
    pub stages: Option<PathBuf>,
    /// With --stages: the stage-one plan items, every sensor through all of them (default:
    /// the accelerometers on a dividing head, head:56; the gyros on a rate table,
    /// rate:-8:8:41 and rate:0:0:15).
    #[arg(long, requires = "stages")]
    pub stage_one_plan: Vec<String>,
    /// With --stages: the chamber's temperature for the assembled unit's plan, C.
    #[arg(long, default_value_t = 25.0, requires = "stages", value_parser = crate::cmd::values::finite)]
    pub assembly_temp: f64,
    /// With --stages: what assembly changes in a sensor's scale factor, `OUTPUT=RELATIVE`
    /// (comma-separated, e.g. `a_y=7.5e-4`).
    #[arg(long, value_delimiter = ',', requires = "stages")]
    pub assembly_shift: Vec<String>,
    /// The observation file to write (CSV).
    #[arg(long, short)]
    pub output: PathBuf,
}
