//! Two stages against one, predicted as the calibrations themselves state it: simulated units
//! (our simulator's six sensors, with the terms both plans' models carry) go through both
//! plans, both calibrations are made exactly as `calibrate` makes them, and each calibration's
//! stated 1-sigma (the device's, from its blob) is averaged over the operating range. The
//! stated 1-sigma covers the truth (`tests/two_stage_independent.rs`: 95 % intervals cover
//! 94.3-95.2 % on a forward model we did not write), so its RMS is the error each plan will
//! have; unlike a variance over a simplified model, it carries every term each calibration
//! fits (stage two's lever arms and g-sensitivity, the holds of what did not move, one stage's
//! lever arms and nonlinear terms). What it cannot carry is a bias from a term a plan's model
//! lacks.

use std::path::Path;

use rayon::prelude::*;
use spincal::model::Quantity;

use crate::sensor::record::Record;
use crate::sensor::stages::Check;
use crate::sensor::stages::one;
use crate::sensor::triad::{self, Kind};
use crate::sensor::{Calibrated, Options, Thermal, WorkflowError, single};
use crate::sim::plan::{self, Condition};
use crate::sim::stages::AssembledTruth;

/// Stage one's model of a sensor over its own input: bias, scale factor, g-squared, cubic,
/// odd-quadratic and asymmetry.
pub const STAGE_ONE_MODEL: &str =
    "output ~ 1 + input + input^2 + input^3 + input:abs(input) + abs(input)";

/// The plans compared, every condition at its temperature.
#[derive(Debug, Clone)]
pub struct Plans {
    /// Each accelerometer alone (single-axis conditions).
    pub accel_one: Vec<Condition>,
    /// Each gyro alone.
    pub gyro_one: Vec<Condition>,
    /// The assembled unit in stage two.
    pub unit: Vec<Condition>,
    /// The assembled unit in one stage.
    pub one_stage: Vec<Condition>,
}

/// Per family (accelerometers, gyros), the RMS of the stated 1-sigma over the operating range
/// (SI), two stages then one; and how many simulated units gave both calibrations a blob.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    pub two: [f64; 2],
    pub one: [f64; 2],
    pub units: usize,
}

impl Prediction {
    /// Two stages' error over one stage's, per family.
    #[must_use]
    pub fn ratio(&self) -> [f64; 2] {
        [self.two[0] / self.one[0], self.two[1] / self.one[1]]
    }
}

/// Per unit of equipment time: the cost of one observation of one sensor on its own fixture
/// (stage one) and of one observation of the assembled unit (stage two, one stage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Costs {
    pub stage_one: f64,
    pub unit: f64,
}

impl Costs {
    /// What each plan costs a unit: stage one's observations of its six sensors and stage
    /// two's of the unit; one stage's of the unit.
    #[must_use]
    pub fn of(&self, p: &Plans) -> (f64, f64) {
        let two = 3.0 * (p.accel_one.len() + p.gyro_one.len()) as f64 * self.stage_one
            + p.unit.len() as f64 * self.unit;
        (two, p.one_stage.len() as f64 * self.unit)
    }

    /// Two stages' error over one stage's at equal cost (each plan repeated in proportion,
    /// the errors going as one over the square root of the observations).
    #[must_use]
    pub fn at_equal_cost(&self, p: &Plans, ratio: f64) -> f64 {
        let (two, one) = self.of(p);
        ratio * (two / one).sqrt()
    }
}

/// Why the prediction could not be made.
#[derive(Debug, thiserror::Error)]
pub enum StagesError {
    #[error("{0}")]
    Plan(#[from] plan::PlanError),
    #[error(transparent)]
    Workflow(#[from] Box<WorkflowError>),
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("the stage-one records: {0}")]
    StageOne(String),
    #[error("{0}")]
    Mission(String),
    #[error("{0}")]
    Budget(String),
    #[error(transparent)]
    Design(#[from] super::Error),
    #[error(
        "none of the {0} simulated units could be calibrated into a blob by both plans (the device refused them)"
    )]
    NoUnit(usize),
}

fn conditions(items: &[&str], temps: &[f64]) -> Result<Vec<Condition>, StagesError> {
    let items: Vec<String> = items.iter().map(|s| (*s).to_string()).collect();
    Ok(plan::plan(&items, temps, &[3.3], 1, false)?)
}

/// Where each family's stated 1-sigma is averaged: the conditions of the accelerometers' and
/// of the gyros' range, and what they are, in words.
#[derive(Debug, Clone)]
pub struct Range {
    pub accel: Vec<Condition>,
    pub gyro: Vec<Condition>,
    pub what: String,
}

/// The operating range at each of `temps`: gravity along 26 directions at rest
/// (accelerometers); rates up to the unit plan's largest about the axes and diagonals (gyros).
///
/// # Errors
/// None in practice (the items are fixed); a plan error if they could not be read.
pub fn operating_range(p: &Plans, temps: &[f64]) -> Result<Range, StagesError> {
    let top = largest(&p.unit, |c| c.w).max(1.0);
    let rates = format!("rate:{}:{top}:9", -top);
    let diagonals = format!("diagonal:{}:{top}:9", -top);
    Ok(Range {
        accel: conditions(&["tumble:26"], temps)?,
        gyro: conditions(&[&rates, &diagonals], temps)?,
        what: format!(
            "the operating range: gravity along 26 directions; rates to {top} rad/s about the axes and diagonals"
        ),
    })
}

fn largest(conditions: &[Condition], of: impl Fn(&Condition) -> [f64; 3]) -> f64 {
    conditions
        .iter()
        .flat_map(|c| of(c).map(f64::abs))
        .fold(0.0, f64::max)
}

/// Most moments of a mission the comparison takes (evenly in time).
pub const MISSION_MOMENTS: usize = 400;

/// The mission's moments the plans reach: the flight's specific force, rates and temperature
/// (each of `temps` when it has none), taken at [`MISSION_MOMENTS`] instants evenly in time; a
/// moment whose specific force or rate on any axis is beyond the largest the plans apply
/// (either plan's unit, stage one's own axis), or whose temperature is beyond `temps`, is
/// extrapolation, left out and counted. Accelerometers take the moments whose specific force is
/// reached, gyros those whose rate and specific force are (the g-sensitivity).
///
/// # Errors
/// A profile without specific force or rates, or a flight wholly beyond the plans' reach.
pub fn mission_range(
    profile: &crate::mission::Profile,
    p: &Plans,
    temps: &[f64],
) -> Result<Range, StagesError> {
    let unit: Vec<Condition> = p.unit.iter().chain(&p.one_stage).copied().collect();
    let reach_f = largest(&unit, |c| c.f).max(largest(&p.accel_one, |c| c.f));
    let reach_w = largest(&unit, |c| c.w).max(largest(&p.gyro_one, |c| c.w));
    let (t_lo, t_hi) = temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(*t), b.max(*t))
        });
    let source = profile.source.display().to_string();
    let (Some(f), Some(w)) = (&profile.f, &profile.w) else {
        return Err(StagesError::Mission(format!(
            "{source}: the comparison needs the flight's specific force and rates (f_x..f_z, w_x..w_z)"
        )));
    };
    let n = profile.len();
    let take = n.min(MISSION_MOMENTS);
    let (mut accel, mut gyro) = (Vec::new(), Vec::new());
    let (mut beyond_f, mut beyond_w) = (0usize, 0usize);
    for k in 0..take {
        let i = if take < 2 {
            0
        } else {
            k * (n - 1) / (take - 1)
        };
        let at_temps: Vec<f64> = match &profile.temp {
            Some(t) if (t_lo..=t_hi).contains(&t[i]) => vec![t[i]],
            Some(_) => Vec::new(),
            None => temps.to_vec(),
        };
        let f_in = f[i].iter().all(|x| x.abs() <= reach_f);
        let w_in = w[i].iter().all(|x| x.abs() <= reach_w);
        beyond_f += usize::from(!f_in || at_temps.is_empty());
        beyond_w += usize::from(!(f_in && w_in) || at_temps.is_empty());
        for temp in at_temps {
            let c = Condition {
                f: f[i],
                w: w[i],
                dw: [0.0; 3],
                h: [0.0; 3],
                temp,
                volt: 3.3,
                dir: 0.0,
            };
            if f_in {
                accel.push(c);
            }
            if f_in && w_in {
                gyro.push(c);
            }
        }
    }
    if accel.is_empty() || gyro.is_empty() {
        return Err(StagesError::Mission(format!(
            "{source}: no moment of the flight is within the plans' reach ({reach_f:.3} m/s^2, {reach_w:.3} rad/s on every axis, {t_lo} to {t_hi} C); {beyond_f} of {take} moments beyond it for the accelerometers, {beyond_w} for the gyros"
        )));
    }
    let share = |b: usize| 100.0 * b as f64 / take as f64;
    Ok(Range {
        accel,
        gyro,
        what: format!(
            "the mission {source} ({take} moments evenly in time; beyond the plans' reach of {reach_f:.3} m/s^2, {reach_w:.3} rad/s and {t_lo} to {t_hi} C, so extrapolation and left out: {:.1} % of them for the accelerometers, {:.1} % for the gyros)",
            share(beyond_f),
            share(beyond_w)
        ),
    })
}

fn write(obs: &crate::sim::Observations, path: &Path) -> Result<(), StagesError> {
    let mut f = std::fs::File::create(path)?;
    obs.write_csv(&mut f)?;
    Ok(())
}

/// Stage one of output `k` (`one::OUTPUTS`) from the observations in `csv`, as the README
/// makes it: every term kept, the asymmetry, a temperature table.
///
/// # Errors
/// The calibration's.
pub fn stage_one(csv: &Path, k: usize, serial: &str) -> Result<Calibrated, Box<WorkflowError>> {
    let mut opts = Options::new(csv, serial);
    opts.thermal = Thermal::Table;
    opts.created = Some(0);
    opts.keep_all_terms = true;
    opts.asymmetry = Some(true);
    let q = if k < 3 {
        Quantity::Acceleration
    } else {
        Quantity::AngularRate
    };
    single::calibrate(&opts, q).map_err(Box::new)
}

/// `c`'s record, sealed, written to `json` (its data file named `csv`).
///
/// # Errors
/// Writing the file.
pub fn write_record(c: &Calibrated, csv: &Path, json: &Path) -> std::io::Result<()> {
    let record = Record::new(c, &csv.display().to_string()).sealed();
    std::fs::write(
        json,
        serde_json::to_string(&record).map_err(std::io::Error::other)?,
    )
}

/// Stage two of the assembled unit's observations in `csv` on the six stage-one `records`.
///
/// # Errors
/// A record that cannot be read (its text), the calibration's.
pub fn stage_two(
    csv: &Path,
    records: &[std::path::PathBuf],
) -> Result<(Calibrated, Check), StagesError> {
    let sensors = one::read_all(records, &crate::sensor::record::Trust::own())
        .map_err(|e| StagesError::StageOne(e.to_string()))?;
    let mut opts = Options::new(csv, "UNIT");
    opts.created = Some(0);
    opts.keep_all_terms = true;
    triad::stage_two::calibrate(&opts, &sensors).map_err(|e| StagesError::Workflow(Box::new(e)))
}

/// One stage of the assembled unit's observations in `csv`: every term, a temperature table.
///
/// # Errors
/// The calibration's.
pub fn one_stage(csv: &Path) -> Result<Calibrated, Box<WorkflowError>> {
    let mut opts = Options::new(csv, "UNIT");
    opts.created = Some(0);
    opts.thermal = Thermal::Table;
    opts.keep_all_terms = true;
    triad::calibrate(&opts, Kind::Imu, true).map_err(Box::new)
}

/// Stage one of every sensor of our simulator's `truth` through `p`, its records in `dir`.
///
/// # Errors
/// Writing the files, a calibration's.
pub fn stage_one_records(
    p: &Plans,
    truth: &AssembledTruth,
    dir: &Path,
    seed: u64,
) -> Result<Vec<std::path::PathBuf>, StagesError> {
    let mut records = Vec::new();
    for (k, output) in one::OUTPUTS.iter().enumerate() {
        let plan = if k < 3 { &p.accel_one } else { &p.gyro_one };
        let csv = dir.join(format!("s1_{output}.csv"));
        write(&truth.stage_one(k, plan, seed * 10 + k as u64), &csv)?;
        let c = stage_one(&csv, k, &format!("S{seed}-{k}"))?;
        let json = dir.join(format!("s1_{output}.json"));
        write_record(&c, &csv, &json)?;
        records.push(json);
    }
    Ok(records)
}

/// Two stages of our simulator's `truth` through `p` (files in `dir`).
///
/// # Errors
/// Writing the files, a calibration's.
pub fn two_stages(
    p: &Plans,
    truth: &AssembledTruth,
    dir: &Path,
    seed: u64,
) -> Result<(Calibrated, Check), StagesError> {
    let records = stage_one_records(p, truth, dir, seed)?;
    let csv = dir.join("unit.csv");
    write(&truth.stage_two(&p.unit, seed + 7), &csv)?;
    stage_two(&csv, &records)
}

/// One stage of our simulator's `truth` through `p` (files in `dir`).
///
/// # Errors
/// Writing the file, the calibration's.
pub fn one_stage_of(
    p: &Plans,
    truth: &AssembledTruth,
    dir: &Path,
    seed: u64,
) -> Result<Calibrated, StagesError> {
    let csv = dir.join("one.csv");
    write(&truth.stage_two(&p.one_stage, seed + 11), &csv)?;
    Ok(one_stage(&csv)?)
}

/// The sums of the squared stated 1-sigma per family over the range, and their counts; `None`
/// when the device refused the calibration.
fn stated(
    c: &Calibrated,
    accel: &[Condition],
    gyro: &[Condition],
) -> Option<([f64; 2], [usize; 2])> {
    let cal = spincal::blob::decode(&c.blob).ok()?;
    let mut device = spincal::correct::AnyImuCorrector::new(&cal, 1000.0).ok()?;
    let (mut sq, mut n) = ([0.0; 2], [0usize; 2]);
    for (family, points) in [(0, accel), (1, gyro)] {
        for p in points {
            device.set_environment(p.temp as f32, 3.3);
            let values: [f32; 6] =
                std::array::from_fn(|j| (if j < 3 { p.f[j] } else { p.w[j - 3] }) as f32);
            let s = device.sigma(&values)?;
            for k in (0..3).map(|i| i + 3 * family) {
                sq[family] += f64::from(s[k]).powi(2);
                n[family] += 1;
            }
        }
    }
    Some((sq, n))
}

/// The prediction over `units` simulated units (our simulator's draws, their asymmetric terms
/// taken out so that both plans' models fit them), each calibration's stated 1-sigma averaged
/// over `range`.
///
/// # Errors
/// A calibration that fails, no unit calibrated by both.
pub fn predict(p: &Plans, range: &Range, units: u64) -> Result<Prediction, StagesError> {
    let (accel, gyro) = (&range.accel, &range.gyro);
    let runs: Vec<Result<Option<_>, StagesError>> = (0..units)
        .into_par_iter()
        .map(|seed| {
            let dir = tempfile::tempdir()?;
            let mut truth = AssembledTruth::draw(5_000 + seed);
            for s in &mut truth.sensors {
                s.asym = 0.0;
            }
            let (two, _) = two_stages(p, &truth, dir.path(), seed)?;
            let one = one_stage_of(p, &truth, dir.path(), seed)?;
            Ok(stated(&two, accel, gyro).zip(stated(&one, accel, gyro)))
        })
        .collect();
    let (mut two, mut one, mut n) = ([0.0; 2], [0.0; 2], 0usize);
    let (mut count_two, mut count_one) = ([0usize; 2], [0usize; 2]);
    for r in runs {
        if let Some(((s2, n2), (s1, n1))) = r? {
            for f in 0..2 {
                two[f] += s2[f];
                one[f] += s1[f];
                count_two[f] += n2[f];
                count_one[f] += n1[f];
            }
            n += 1;
        }
    }
    if n == 0 {
        return Err(StagesError::NoUnit(units as usize));
    }
    let rms = |s: [f64; 2], c: [usize; 2]| [0, 1].map(|f| (s[f] / c[f] as f64).sqrt());
    Ok(Prediction {
        two: rms(two, count_two),
        one: rms(one, count_one),
        units: n,
    })
}
