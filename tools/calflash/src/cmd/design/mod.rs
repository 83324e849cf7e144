//! `calflash design`: evaluate plans, find optimal ones, predict and confirm their precision.

mod evaluate;
mod optimize;
mod predict;

pub use evaluate::EvaluateArgs;
pub use optimize::{MAX_PLAN, OptimizeArgs};
pub use predict::{MAX_MONTE_CARLO, MAX_SIMULATED, PredictArgs};

use crate::cmd::Failure;
use std::path::Path;

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
    /// triad, triad-nonlinear, gyro-gsens.
    #[arg(long)]
    pub model: String,
    /// The unit the plan items drive (which input a single axis reads; triad inputs are the
    /// specific force, or the rate for a gyro).
    #[arg(long, value_enum, default_value = "single-accel")]
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
}

impl ModelArgs {
    /// Where the plans live, apart from the model.
    #[must_use]
    pub fn space(&self) -> Space {
        Space {
            unit: unit(self.sensor).0,
            temps: self.temps.clone(),
            volts: self.volts.clone(),
            region: self.region.clone(),
            limits: self.limit.clone(),
        }
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
