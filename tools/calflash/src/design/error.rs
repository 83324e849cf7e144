//! Why a plan, a candidate set, a model or a search cannot be had: each names the option or
//! the plan it comes from and says what was expected.

use crate::design::exchange::ExchangeError;
use crate::formula::FormulaError;
use crate::obs::ObsError;
use crate::sim::plan::PlanError;
use crate::stats::FitError;

/// A design that cannot be read, checked or searched.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// `--limit` not of the form `NAME=LO:HI` with LO at most HI.
    #[error("--limit `{0}`: expected NAME=LO:HI, for example rate=-800:800")]
    Limit(String),
    /// A limit on a variable the points do not have.
    #[error("--limit {name}: {what} has no variable {name} (it has {has})")]
    LimitOnNoVariable {
        /// The limit's variable.
        name: String,
        /// The points checked ("the candidates").
        what: String,
        /// Their variables, listed.
        has: String,
    },
    /// A point beyond the equipment's limits.
    #[error(
        "{what}, point {point}: {name} = {value} is outside the equipment's limits {lo} to {hi}"
    )]
    BeyondLimit {
        /// The points checked.
        what: String,
        /// 1-based point.
        point: usize,
        /// The variable.
        name: String,
        /// Its value there.
        value: f64,
        /// The limit's low end.
        lo: f64,
        /// Its high end.
        hi: f64,
    },
    /// A model variable the mission profile does not give.
    #[error("--mission: {0}")]
    MissionVariable(#[from] crate::mission::weight::Missing),
    /// A mission the equipment cannot reach at all.
    #[error(
        "--mission: no moment of the flight {profile} is within what {what} reach: {beyond}. A plan over this equipment can promise nothing for this flight but extrapolation (use equipment that reaches it, or --limit to say what it reaches)"
    )]
    MissionBeyondReach {
        /// The profile.
        profile: String,
        /// What sets the reach ("the candidates").
        what: String,
        /// The share of time beyond on each variable.
        beyond: String,
    },
    /// `--plan` is neither a file nor plan items.
    #[error("--plan `{spec}`: not a file, and {source}")]
    Plan {
        /// The option's text.
        spec: String,
        /// Why the items cannot be read.
        source: Box<Error>,
    },
    /// A plan item that cannot be read.
    #[error(transparent)]
    PlanItem(#[from] PlanError),
    /// A grid not of the form `NAME=LO:HI:N`.
    #[error("grid `{text}`: {why}; expected NAME=LO:HI:N, for example rate=-10:10:21")]
    Grid {
        /// The grid as given.
        text: String,
        /// What is wrong with it.
        why: String,
    },
    /// Grids whose product holds too many points.
    #[error("the grids {specs} make {points} points; a region or grid holds at most {max}")]
    TooManyGridPoints {
        /// The grids, as given.
        specs: String,
        /// Points they make.
        points: usize,
        /// The most allowed.
        max: usize,
    },
    /// More candidates than a Fedorov exchange lists.
    #[error(
        "the candidates number {count:.3e}, too many to list (at most {max:.0e}); `design optimize --method coordinate` searches the levels of --grid factors without listing them"
    )]
    TooManyCandidates {
        /// Candidates the items and grids make.
        count: f64,
        /// The most listed.
        max: f64,
    },
    /// Neither plan items nor grids.
    #[error("no candidates: give --candidates plan items or --grid NAME=LO:HI:N")]
    NoCandidates,
    /// A plan or candidate file that cannot be read.
    #[error(transparent)]
    Read(#[from] ObsError),
    /// A variable the model reads that the points do not set.
    #[error(
        "{what}: the model reads `{variable}`, which it does not set (it sets {sets}); name the variable as the plan does, or add a grid {variable}=LO:HI:N"
    )]
    UnsetVariable {
        /// The points checked.
        what: String,
        /// The variable.
        variable: String,
        /// What they set, listed, or "nothing".
        sets: String,
    },
    /// A plan whose model rows are rank deficient.
    #[error("plan {plan} cannot estimate the model{axis}: {why}")]
    NotEstimable {
        /// The plan's name.
        plan: String,
        /// " of axis x" when the model has several blocks, else empty.
        axis: String,
        /// Which term and why, from the formula.
        why: String,
    },
    /// `--at` not of the form `NAME=VALUE[,NAME=VALUE...]`.
    #[error("--at `{0}`: expected NAME=VALUE[,NAME=VALUE...]")]
    OperatingPoint(String),
    /// An `--at` value that is not a finite number.
    #[error("--at `{spec}`: `{value}` is not a finite number")]
    OperatingValue {
        /// The option's text.
        spec: String,
        /// The value as given.
        value: String,
    },
    /// An operating point over a variable the model does not read.
    #[error("--at `{spec}`: the model reads no `{name}`; it reads {reads}")]
    OperatingVariable {
        /// The option's text.
        spec: String,
        /// The variable.
        name: String,
        /// The variables the model reads, listed.
        reads: String,
    },
    /// Operating points that name different variables.
    #[error("--at `{spec}`: every operating point must name the same variables ({first})")]
    OperatingVariables {
        /// The option's text.
        spec: String,
        /// The first point's variables, listed.
        first: String,
    },
    /// No operating point.
    #[error("--at: give at least one operating point, NAME=VALUE[,NAME=VALUE...]")]
    NoOperatingPoint,
    /// A preset's own formula that does not parse (a defect of the presets).
    #[error(transparent)]
    Preset(#[from] FormulaError),
    /// `--model` neither a formula nor a preset.
    #[error("--model: {source} (or a preset: {presets})")]
    Model {
        /// Why it does not parse as a formula.
        source: FormulaError,
        /// The presets, described.
        presets: &'static str,
    },
    /// A preset for another kind of sensor.
    #[error("--model {preset}: the {what} preset is for {sensor}")]
    PresetForOtherSensor {
        /// The preset.
        preset: &'static str,
        /// What it models.
        what: &'static str,
        /// The sensor it is for, with the option that names it.
        sensor: &'static str,
    },
    /// The coordinate exchange asked for what it does not do.
    #[error("--method coordinate: {0}")]
    Coordinate(&'static str),
    /// An exchange that found no plan, with the model's terms.
    #[error("{source}; the model's terms: {terms}")]
    Exchange {
        /// Why.
        source: ExchangeError,
        /// The terms, per block.
        terms: String,
    },
    /// An exchange inside the search for the smallest plan that found none.
    #[error(transparent)]
    Smallest(#[from] ExchangeError),
    /// An optimal plan that cannot estimate the model.
    #[error("the optimal plan of {n} points cannot estimate column {column}")]
    OptimalNotEstimable {
        /// Its points.
        n: usize,
        /// The 0-based dependent column.
        column: usize,
    },
    /// A target not reached with the most observations searched.
    #[error(
        "even {n} observations give an expected error of {error:.3e} > {target:.3e}: lower the noise or the target"
    )]
    TargetNotReached {
        /// The observations tried.
        n: usize,
        /// The expected error they give.
        error: f64,
        /// The target.
        target: f64,
    },
    /// A simulated output column the simulator does not write.
    #[error("the simulator writes no column {0}")]
    NoSimulatedColumn(String),
    /// A simulated calibration that could not be fitted.
    #[error("simulated run {run}: {source:?}")]
    SimulatedFit {
        /// 0-based run.
        run: usize,
        /// Why.
        source: FitError,
    },
}
