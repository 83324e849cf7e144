//! `calflash design`: evaluate plans, find optimal ones, predict and confirm their precision.

mod evaluate;
mod optimize;
mod optimize_stages;
mod predict;
mod stages;

pub use evaluate::EvaluateArgs;
pub use optimize::{MAX_PLAN, OptimizeArgs};
pub use predict::{MAX_MONTE_CARLO, MAX_SIMULATED, PredictArgs};

use crate::cmd::Failure;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::{Args, Subcommand};

use super::values::SensorKind;
use crate::design::points::{self, Unit};
use crate::design::space::{Limit, Space};
use crate::files::Paths;

/// Plans before tests: evaluate, optimise, predict.
#[derive(Debug, Args)]
pub struct DesignArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
}

/// The design subcommands.
#[derive(Debug, Subcommand)]
pub enum Action {
    /// Criteria, covariance form and prediction variance of one or more plans, side by side.
    Evaluate(EvaluateArgs),
    /// An exact optimal plan over the points the equipment can reach.
    Optimize(OptimizeArgs),
    /// Expected errors of a plan, confirmed by Monte Carlo; or the fewest observations for a
    /// target error.
    Predict(PredictArgs),
}

/// What the plans are for.
#[derive(Debug, Args)]
pub struct ModelArgs {
    /// The model: a formula (`~ 1 + rate + rate^2` or `volts ~ ...`) or a preset: single,
    /// triad, triad-nonlinear, gyro-gsens, accel-lever (the spin rig's lever arms).
    #[arg(long)]
    pub model: String,
    /// The unit the plan items drive (which input a single axis reads; triad inputs are the
    /// specific force, or the rate for a gyro).
    #[arg(long, value_enum, ignore_case = true, default_value = "single-accel")]
    pub sensor: SensorKind,
    /// The operating region for the G and I criteria (repeatable grids NAME=LO:HI:N, combined);
    /// default: the candidates or the plan's own points.
    #[arg(long, value_parser = grid_spec)]
    pub region: Vec<String>,
    /// Chamber temperatures for plan items, C.
    #[arg(long, default_value = "25", value_delimiter = ',', value_parser = super::values::finite)]
    pub temps: Vec<f64>,
    /// Supply voltages for plan items, V.
    #[arg(long, default_value = "5", value_delimiter = ',', value_parser = super::values::finite)]
    pub volts: Vec<f64>,
    /// The equipment's limits NAME=LO:HI (repeatable): a plan or candidate beyond them is
    /// refused.
    #[arg(long, value_name = "NAME=LO:HI")]
    pub limit: Vec<Limit>,
    /// A mission profile (`calflash mission` reads it): the plans are judged, and optimised
    /// with the I criterion, by their prediction variance averaged over the flight's moments
    /// the equipment reaches; the rest is reported as extrapolation.
    #[arg(long)]
    pub mission: Option<PathBuf>,
    #[command(flatten)]
    pub mission_columns: crate::cmd::mission_columns::MissionColumns,
}

impl ModelArgs {
    /// Where the plans live, apart from the model, with the mission read.
    ///
    /// # Errors
    /// A mission profile that cannot be read.
    pub fn space(&self) -> Result<Space, crate::mission::MissionError> {
        let mission = match &self.mission {
            Some(path) => Some(Arc::new(crate::mission::read(
                path,
                &self.mission_columns.mission_columns,
            )?)),
            None => None,
        };
        Ok(Space {
            unit: unit(self.sensor).0,
            temps: self.temps.clone(),
            volts: self.volts.clone(),
            region: self.region.clone(),
            limits: self.limit.clone(),
            mission,
        })
    }
}

/// Runs `calflash design`.
///
/// # Errors
/// Bad input or a plan that cannot estimate the model.
pub fn run(args: &DesignArgs) -> Result<(), Failure> {
    match &args.action {
        Action::Evaluate(a) => evaluate::run(a),
        Action::Optimize(a) => optimize::run(a),
        Action::Predict(a) => predict::run(a),
    }
}

/// A grid option (`--region`, `--grid`), checked as it is parsed.
fn grid_spec(s: &str) -> Result<String, crate::design::Error> {
    points::grid(s).map(|_| s.to_string())
}

fn unit(kind: SensorKind) -> (Unit, bool) {
    match kind {
        SensorKind::SingleAccel => (Unit::SingleAccel, false),
        SensorKind::SingleGyro => (Unit::SingleGyro, true),
        SensorKind::Accel | SensorKind::Imu => (Unit::Triad, false),
        SensorKind::Gyro => (Unit::Triad, true),
    }
}

/// The plan files among plan specifications (the rest are plan items).
fn plan_files<'a>(
    specs: impl IntoIterator<Item = &'a String>,
    what: &str,
    mut paths: Paths,
) -> Paths {
    for s in specs {
        let p = Path::new(s);
        if p.is_file() {
            paths = paths.input(what, Some(p));
        }
    }
    paths
}

/// The plans over the space's mission, the equipment reaching what `reach` spans (`what` says
/// what that is); `None` without a mission.
///
/// # Errors
/// A variable the profile lacks, or a flight wholly beyond the reach.
fn over_mission(
    space: &Space,
    blocks: &[crate::design::models::Block],
    plans: &[crate::report::design::PlanResult],
    reach: &crate::design::points::Points,
    what: &str,
) -> Result<Option<crate::report::mission::OverMission>, crate::design::Error> {
    use crate::mission::weight;
    use crate::report::mission::{OverMission, PlanOverMission};
    let Some(profile) = &space.mission else {
        return Ok(None);
    };
    let mut m = OverMission {
        profile: profile.source.display().to_string(),
        reach: what.to_string(),
        blocks: Vec::new(),
        assumed: Vec::new(),
        plans: plans
            .iter()
            .map(|p| PlanOverMission {
                plan: p.name.clone(),
                n: p.points.rows.len(),
                mean_inside: Vec::new(),
                worst_inside: Vec::new(),
                mean_beyond: Vec::new(),
                worst_beyond: Vec::new(),
            })
            .collect(),
    };
    for (b, block) in blocks.iter().enumerate() {
        let Some((w, lookup, r)) = space.mission_weight(block, reach, what)? else {
            return Ok(None);
        };
        for v in lookup.assumed(profile) {
            if !m.assumed.contains(&v) {
                m.assumed.push(v);
            }
        }
        m.blocks.push((
            block.label.clone(),
            w.share_inside,
            crate::design::space::describe_beyond(&w, &r),
        ));
        for (pm, p) in m.plans.iter_mut().zip(plans) {
            let c = &p.criteria[b].unscaled_covariance;
            let (worst_in, worst_out) =
                weight::worst_variance(profile, &block.formula, &lookup, &r, c, 1);
            pm.mean_inside.push(weight::mean_variance(c, 1, &w.inside));
            pm.worst_inside.push(worst_in);
            pm.mean_beyond.push(weight::mean_variance(c, 1, &w.outside));
            pm.worst_beyond.push(worst_out);
        }
    }
    Ok(Some(m))
}
