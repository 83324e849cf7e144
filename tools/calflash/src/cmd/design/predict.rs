//! `calflash design predict`: the precision a plan gives, predicted and confirmed by
//! simulation.

use crate::cmd::Failure;
use std::path::PathBuf;

use crate::files::Paths;
use clap::Args;

use crate::cmd::values::SensorKind;
use crate::design::exchange::Criterion;
use crate::design::models;
use crate::design::points::{self, Points, Unit};
use crate::design::predict;
use crate::design::space;
use crate::report::design as show;
use crate::sim::{self, truth};

use super::{ModelArgs, grid_spec, plan_files, unit};

/// Most Monte Carlo runs of `predict`.
pub const MAX_MONTE_CARLO: usize = 100_000;
/// The most observations a Monte Carlo check simulates in all (runs x plan size): about ten
/// minutes.
pub const MAX_SIMULATED: usize = 1_000_000_000;

/// `calflash design predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The plan (file or items). Without it, give --target: the fewest observations on the
    /// optimal plan over --candidates/--grid are found.
    #[arg(long)]
    pub plan: Option<String>,
    /// Output noise, counts (1 sigma); default: the simulator's unit's.
    #[arg(long, value_parser = crate::cmd::values::positive)]
    pub noise: Option<f64>,
    /// Operating points NAME=VALUE[,NAME=VALUE...] (repeatable).
    #[arg(long, value_name = "NAME=VALUE[,...]")]
    pub at: Vec<points::OperatingPoint>,
    /// Confirm with this many simulated calibrations (single-axis sensors and triads).
    #[arg(long, value_parser = |s: &str| crate::cmd::values::count_in(s, 10, MAX_MONTE_CARLO))]
    pub monte_carlo: Option<usize>,
    /// The largest acceptable expected error at the operating points (counts).
    #[arg(long, value_parser = crate::cmd::values::positive)]
    pub target: Option<f64>,
    /// Candidates for --target (plan items).
    #[arg(long)]
    pub candidates: Vec<String>,
    /// Candidate grids for --target.
    #[arg(long, value_parser = grid_spec)]
    pub grid: Vec<String>,
    /// The criterion of the plans for --target.
    #[arg(long, value_enum, default_value = "i")]
    pub criterion: Criterion,
    /// Write JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

pub(super) fn run(a: &PredictArgs) -> Result<(), Failure> {
    plan_files(a.plan.iter(), "--plan", Paths::new())
        .input("--mission", a.model.mission.as_deref())
        .output("--json", a.json.as_deref())
        .check()?;
    let (u, gyro) = unit(a.model.sensor);
    let space = a.model.space()?;
    let blocks = models::blocks(&a.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let sensor = simulated(a.model.sensor)?;
    // Per block: the given noise, or the simulator's unit's (per axis for a triad).
    let noises: Vec<f64> = (0..blocks.len())
        .map(|k| {
            a.noise.unwrap_or(match &sensor {
                sim::Sensor::Single { truth, .. } => truth.noise,
                sim::Sensor::Accel(t) | sim::Sensor::Gyro(t) => t.noise[k.min(2)],
                sim::Sensor::Imu(t) => t.accel.noise[k.min(2)],
            })
        })
        .collect();
    let noise = noises[0];
    // Over a mission, the flight gives the operating points; --at adds its own.
    let at = if a.at.is_empty() && space.mission.is_some() {
        Points {
            names: vars.clone(),
            rows: Vec::new(),
        }
    } else {
        Points::operating(&a.at, &vars)?
    };
    if let Some(target) = a.target {
        if space.mission.is_some() {
            return Err("--mission with --target: not supported; give --plan (the fewest observations are judged at the --at points)".into());
        }
        return fewest(a, (&space, &blocks, &vars), &at, (noise, target));
    }
    let spec = a
        .plan
        .as_deref()
        .ok_or("give --plan (or --target with --candidates)")?;
    let pts = space.load_plan(spec, &vars)?;
    space::check_variables(&blocks, &pts, &format!("plan {spec}"))?;
    let crit = space.evaluate_plan(spec, &pts, &blocks, &pts)?;
    let outputs: Vec<&str> = match (u, gyro) {
        (Unit::Triad, false) => crate::columns::A.to_vec(),
        (Unit::Triad, true) => crate::columns::GYRO.to_vec(),
        _ => vec![crate::columns::OUTPUT],
    };
    let mut results = Vec::new();
    for (k, (b, c)) in blocks.iter().zip(&crit).enumerate() {
        let at_rows = at.model_rows(&b.formula);
        let e = predict::expected(&c.unscaled_covariance, noises[k], &at_rows);
        let mc = match a.monte_carlo.filter(|_| !at.rows.is_empty()) {
            Some(runs) => Some(confirm(
                &sensor,
                (u, outputs[k.min(outputs.len() - 1)]),
                runs,
                &pts,
                &b.formula,
                &at_rows,
            )?),
            None => None,
        };
        results.push((b.clone(), e, mc));
    }
    if !at.rows.is_empty() {
        print!("{}", show::predict_text(spec, noise, &at, &results));
    }
    if space.mission.is_some() {
        over_mission(
            a,
            (&space, &blocks),
            &pts,
            (&crit, &noises),
            (&sensor, u, &outputs),
        )?;
    }
    if let Some(path) = &a.json {
        let v = show::predict_json(spec, noise, &at, &results);
        crate::files::write_atomically(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    Ok(())
}

/// The simulator's unit of the sensor kind (`predict` takes one triad at a time).
fn simulated(kind: SensorKind) -> Result<sim::Sensor, Failure> {
    Ok(match kind {
        SensorKind::SingleAccel => sim::Sensor::Single {
            gyro: false,
            truth: truth::SingleTruth::default(),
        },
        SensorKind::SingleGyro => sim::Sensor::Single {
            gyro: true,
            truth: truth::SingleTruth::default(),
        },
        SensorKind::Accel => sim::Sensor::Accel(truth::TriadTruth::default()),
        SensorKind::Gyro => sim::Sensor::Gyro(truth::TriadTruth::default()),
        SensorKind::Imu => {
            return Err("--sensor imu: predict one triad at a time (accel or gyro)".into());
        }
    })
}

/// `--target`: the fewest observations on the optimal plan over the candidates whose expected
/// error at the operating points `at` is at most `target` for output noise `noise`.
fn fewest(
    a: &PredictArgs,
    (space, blocks, vars): (&space::Space, &[models::Block], &[String]),
    at: &Points,
    (noise, target): (f64, f64),
) -> Result<(), Failure> {
    if blocks.len() != 1 {
        return Err("--target: one model at a time (a formula or the single preset)".into());
    }
    let cands = space.candidates(&a.candidates, &a.grid)?;
    space::check_variables(blocks, &cands, "the candidates")?;
    let f = cands.model_rows(&blocks[0].formula);
    let region = space.region_rows(&cands, &blocks[0])?;
    let w = region.transpose() * &region / region.nrows() as f64;
    let at_rows = at.model_rows(&blocks[0].formula);
    let goal = predict::Target {
        at: &at_rows,
        sigma: noise,
        error: target,
    };
    let s = predict::smallest_n(&f, a.criterion, Some(&w), &goal, 5, |n| {
        eprint!("\r  trying {n} observations   ")
    })?;
    eprint!("\r{:40}\r", "");
    println!(
        "calflash design predict  model {}: the fewest observations for an expected error of at most {target} counts at the {} operating point(s), noise {noise} counts: {} on the {:?}-optimal plan (largest expected error {:.4})",
        a.model.model,
        at.rows.len(),
        s.n,
        a.criterion,
        s.worst
    );
    for (row, count) in points::tally(&cands.select(&s.found.points)) {
        println!(
            "    {count:>4} x  {}",
            cands
                .names
                .iter()
                .zip(&row)
                .filter(|(n, _)| vars.contains(n))
                .map(|(n, v)| format!("{n} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

/// The expected error confirmed by `runs` simulated calibrations of `sensor` (unit `u`,
/// `output` the column fitted) on the plan `pts`, at the model rows `at_rows`.
fn confirm(
    sensor: &sim::Sensor,
    (u, output): (Unit, &str),
    runs: usize,
    pts: &Points,
    formula: &crate::formula::Formula,
    at_rows: &nalgebra::DMatrix<f64>,
) -> Result<predict::MonteCarlo, Failure> {
    let x = pts.model_rows(formula);
    let sim = predict::Simulation {
        sensor,
        unit: u,
        output,
        runs,
        seed: 7,
    };
    let work = runs.saturating_mul(pts.rows.len());
    if work > MAX_SIMULATED {
        return Err(format!(
            "--monte-carlo {runs}: {runs} runs of {} observations is {work} simulated \
             observations; at most {MAX_SIMULATED:e} (fewer runs: 1,000 give the \
             standard errors to about 2 %)",
            pts.rows.len()
        )
        .into());
    }
    let bar = indicatif::ProgressBar::new(runs as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  simulating {bar:30} {pos}/{len} calibrations, {eta} left",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mc = predict::monte_carlo(pts, &sim, &x, at_rows, |r| {
        bar.set_position(r as u64);
    });
    bar.finish_and_clear();
    Ok(mc?)
}

/// Samples of the flight a Monte Carlo check predicts at.
const MISSION_STATES: usize = 2_000;

/// The plan's expected error over the mission per block (RMS over the flight's moments the
/// plan reaches, and the worst), confirmed with --monte-carlo by the spread of the simulated
/// calibrations' predictions at 2,000 of those moments.
fn over_mission(
    a: &PredictArgs,
    (space, blocks): (&space::Space, &[models::Block]),
    pts: &Points,
    (crit, noises): (&[crate::design::criteria::Criteria], &[f64]),
    (sensor, u, outputs): (&sim::Sensor, Unit, &[&str]),
) -> Result<(), Failure> {
    use crate::mission::weight;
    let Some(profile) = &space.mission else {
        return Ok(());
    };
    println!(
        "\nOver the mission {} (the plan's reach: the range of its points on each variable):",
        profile.source.display()
    );
    for (k, (b, c)) in blocks.iter().zip(crit).enumerate() {
        let Some((w, lookup, reach)) = space.mission_weight(b, pts, "the plan's points")? else {
            continue;
        };
        let cov = &c.unscaled_covariance;
        let rms = noises[k] * weight::mean_variance(cov, 1, &w.inside).sqrt();
        let (worst, worst_beyond) =
            weight::worst_variance(profile, &b.formula, &lookup, &reach, cov, 1);
        let label = if blocks.len() > 1 {
            format!("axis {}: ", b.label)
        } else {
            String::new()
        };
        println!(
            "  {label}{} % of the flight within reach: expected error rms {rms:.4} counts, worst {:.4}",
            space::percent(w.share_inside),
            noises[k] * worst.sqrt()
        );
        if w.share_inside < 1.0 {
            println!(
                "    beyond ({}): rms {} counts, worst {}, extrapolated",
                space::describe_beyond(&w, &reach),
                crate::report::terminal::num(
                    noises[k] * weight::mean_variance(cov, 1, &w.outside).sqrt()
                ),
                crate::report::terminal::num(noises[k] * worst_beyond.sqrt())
            );
        }
        if let Some(runs) = a.monte_carlo {
            let (at_rows, dwell) =
                weight::inside_rows(profile, &b.formula, &lookup, &reach, MISSION_STATES);
            let mc = confirm(
                sensor,
                (u, outputs[k.min(outputs.len() - 1)]),
                runs,
                pts,
                &b.formula,
                &at_rows,
            )?;
            let total: f64 = dwell.iter().sum();
            let mc_rms = (mc
                .at
                .iter()
                .zip(&dwell)
                .map(|(s, d)| s * s * d)
                .sum::<f64>()
                / total)
                .sqrt();
            let predicted = (0..at_rows.nrows())
                .map(|i| {
                    let x = at_rows.row(i).transpose();
                    (x.transpose() * cov * &x)[(0, 0)] * dwell[i]
                })
                .sum::<f64>()
                / total;
            let predicted = noises[k] * predicted.sqrt();
            println!(
                "    Monte Carlo ({runs} calibrations, at {} moments): rms {mc_rms:.4} counts against {predicted:.4} predicted at the same moments ({:+.1} %)",
                at_rows.nrows(),
                100.0 * (mc_rms / predicted - 1.0)
            );
        }
    }
    Ok(())
}
