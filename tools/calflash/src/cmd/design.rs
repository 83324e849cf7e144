//! `calflash design`: evaluate plans, find optimal ones, predict and confirm their precision.

use std::path::{Path, PathBuf};

use crate::files::{Paths, Staged};
use clap::{Args, Subcommand};
use nalgebra::DMatrix;

use super::values::SensorKind;
use crate::design::coordinate;
use crate::design::criteria::{self, Criteria};
use crate::design::exchange::{self, Criterion};
use crate::design::models::{self, Block};
use crate::design::points::{self, Points, Unit};
use crate::design::predict;
use crate::report::design as show;
use crate::sim::{self, truth};

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
    #[arg(long)]
    pub limit: Vec<String>,
}

/// Refuses points beyond the equipment's limits.
fn check_limits(pts: &Points, limits: &[String], what: &str) -> Result<(), String> {
    for l in limits {
        let bad = || format!("--limit `{l}`: expected NAME=LO:HI, for example rate=-800:800");
        let (name, range) = l.split_once('=').ok_or_else(bad)?;
        let (lo, hi) = range.split_once(':').ok_or_else(bad)?;
        let (lo, hi): (f64, f64) = (
            lo.trim().parse().map_err(|_| bad())?,
            hi.trim().parse().map_err(|_| bad())?,
        );
        let name = name.trim();
        if !pts.names.iter().any(|n| n == name) {
            return Err(format!(
                "--limit {name}: {what} has no variable {name} (it has {})",
                pts.names.join(", ")
            ));
        }
        for r in 0..pts.rows.len() {
            let v = pts.value(r, name);
            if !(lo..=hi).contains(&v) {
                return Err(format!(
                    "{what}, point {}: {name} = {v} is outside the equipment's limits {lo} to {hi}",
                    r + 1
                ));
            }
        }
    }
    Ok(())
}

/// `calflash design evaluate`.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// A plan: a file (CSV with a header naming the variables) or plan items
    /// (`tumble:24`, `rate:-10:10:11,tumble:6`, ...). Repeat to compare.
    #[arg(long, required = true)]
    pub plan: Vec<String>,
    /// The prediction-variance curve over one variable, NAME=LO:HI:N (the figure in --report).
    #[arg(long)]
    pub curve: Option<String>,
    /// Orientation error of the fixture, degrees (1 sigma about each axis): the standard errors
    /// with it, for triads (needs --noise and --scale).
    #[arg(long, value_parser = super::values::non_negative)]
    pub fixture_error: Option<f64>,
    /// Output noise, counts (1 sigma), for standard errors in counts.
    #[arg(long, value_parser = super::values::positive)]
    pub noise: Option<f64>,
    /// Counts per SI unit of the input (for the fixture error).
    #[arg(long, value_parser = super::values::positive)]
    pub scale: Option<f64>,
    /// Write the figures and tables as HTML here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Most observations an optimised plan may have.
pub const MAX_PLAN: usize = 100_000;
/// Most Monte Carlo runs of `predict`.
pub const MAX_MONTE_CARLO: usize = 100_000;
/// The most observations a Monte Carlo check simulates in all (runs x plan size): about ten
/// minutes.
pub const MAX_SIMULATED: usize = 1_000_000_000;

/// `calflash design optimize`.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Observations in the plan.
    #[arg(long, value_parser = |s: &str| super::values::count_in(s, 1, MAX_PLAN))]
    pub n: usize,
    /// The criterion.
    #[arg(long, value_enum, default_value = "d")]
    pub criterion: Criterion,
    /// Candidate points the equipment reaches: plan items (head:N, tumble:6|12|18|24|26,
    /// sphere:N, rate:LO:HI:N, centrifuge:LO:HI:N), repeatable.
    #[arg(long)]
    pub candidates: Vec<String>,
    /// Candidate grids NAME=LO:HI:N (repeatable; combined with each other and with the items).
    #[arg(long, value_parser = grid_spec)]
    pub grid: Vec<String>,
    /// Random restarts of the exchange.
    #[arg(long, default_value_t = 10, value_parser = |s: &str| super::values::count_in(s, 1, 1000))]
    pub restarts: usize,
    /// The search.
    #[arg(long, value_enum, default_value = "auto")]
    pub method: Method,
    /// Seed of the restarts.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Compare with these plans too (files or items, repeatable), besides the usual ones.
    #[arg(long)]
    pub compare: Vec<String>,
    /// The plan file to write (CSV), for `calflash simulate --plan-file` and a test station.
    #[arg(long, short)]
    pub output: PathBuf,
}

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
    #[arg(long, value_parser = super::values::positive)]
    pub noise: Option<f64>,
    /// Operating points NAME=VALUE[,NAME=VALUE...] (repeatable).
    #[arg(long)]
    pub at: Vec<String>,
    /// Confirm with this many simulated calibrations (single-axis sensors and triads).
    #[arg(long, value_parser = |s: &str| super::values::count_in(s, 10, MAX_MONTE_CARLO))]
    pub monte_carlo: Option<usize>,
    /// The largest acceptable expected error at the operating points (counts).
    #[arg(long, value_parser = super::values::positive)]
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

/// Runs `calflash design`.
///
/// # Errors
/// Bad input or a plan that cannot estimate the model.
pub fn run(args: &DesignArgs) -> Result<(), String> {
    match &args.action {
        Action::Evaluate(a) => evaluate(a),
        Action::Optimize(a) => optimize(a),
        Action::Predict(a) => predict(a),
    }
}

/// A grid option (`--region`, `--grid`), checked as it is parsed.
fn grid_spec(s: &str) -> Result<String, String> {
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

/// A plan from a file or from items.
fn load_plan(spec: &str, vars: &[String], m: &ModelArgs) -> Result<Points, String> {
    let path = Path::new(spec);
    if path.is_file() {
        return points::read(path, vars);
    }
    let items: Vec<String> = spec.split(',').map(|s| s.trim().to_string()).collect();
    points::from_items(&items, &m.temps, &m.volts, 1, unit(m.sensor).0)
        .map_err(|e| format!("--plan `{spec}`: not a file, and {e}"))
}

fn grids(specs: &[String]) -> Result<Points, String> {
    let mut p = Points {
        names: Vec::new(),
        rows: Vec::new(),
    };
    for g in specs {
        let g = points::grid(g)?;
        let n = p.rows.len().max(1).saturating_mul(g.rows.len());
        if n > crate::sim::plan::MAX_CONDITIONS {
            return Err(format!(
                "the grids {} make {n} points; a region or grid holds at most {}",
                specs.join(" "),
                crate::sim::plan::MAX_CONDITIONS
            ));
        }
        p = p.product(&g);
    }
    Ok(p)
}

/// The most candidates a Fedorov exchange lists (beyond, the coordinate exchange).
const MAX_LISTED: f64 = 2e6;

fn candidates(items: &[String], grid_specs: &[String], m: &ModelArgs) -> Result<Points, String> {
    let from_items = if items.is_empty() {
        Points {
            names: Vec::new(),
            rows: Vec::new(),
        }
    } else {
        points::from_items(items, &m.temps, &m.volts, 1, unit(m.sensor).0)?
    };
    let per_grid: Vec<Points> = grid_specs
        .iter()
        .map(|g| points::grid(g))
        .collect::<Result<_, _>>()?;
    let count = per_grid
        .iter()
        .map(|g| g.rows.len() as f64)
        .product::<f64>()
        * (from_items.rows.len().max(1) as f64);
    if count > MAX_LISTED {
        return Err(format!(
            "the candidates number {count:.3e}, too many to list (at most {MAX_LISTED:.0e}); `design optimize --method coordinate` searches the levels of --grid factors without listing them"
        ));
    }
    let c = per_grid.iter().fold(from_items, |acc, g| acc.product(g));
    if c.rows.is_empty() {
        return Err("no candidates: give --candidates plan items or --grid NAME=LO:HI:N".into());
    }
    Ok(c)
}

/// The model's blocks and, checked, that every variable a block reads is set by `pts` or by
/// the region (variables the points leave out take their defaults only when `strict` is off).
fn check_variables(blocks: &[Block], pts: &Points, what: &str) -> Result<(), String> {
    for v in models::variables(blocks) {
        if !pts.sets(&v) {
            return Err(format!(
                "{what}: the model reads `{v}`, which it does not set (it sets {}); name the variable as the plan does, or add a grid {v}=LO:HI:N",
                if pts.names.is_empty() {
                    "nothing".to_string()
                } else {
                    pts.names.join(", ")
                }
            ));
        }
    }
    Ok(())
}

fn region_rows(m: &ModelArgs, fallback: &Points, block: &Block) -> Result<DMatrix<f64>, String> {
    if m.region.is_empty() {
        Ok(fallback.model_rows(&block.formula))
    } else {
        Ok(grids(&m.region)?.model_rows(&block.formula))
    }
}

/// Evaluates `pts` for every block; a plan that cannot estimate a block names the term.
fn evaluate_plan(
    name: &str,
    pts: &Points,
    blocks: &[Block],
    m: &ModelArgs,
    region_points: &Points,
) -> Result<Vec<Criteria>, String> {
    blocks
        .iter()
        .map(|b| {
            let x = pts.model_rows(&b.formula);
            let region = region_rows(m, region_points, b)?;
            criteria::evaluate(&x, &region, b.formula.intercept).map_err(|dep| {
                let table = to_table(pts, &b.formula);
                let why = b
                    .formula
                    .explain_rank_deficiency(&table, dep.column, &dep.combination);
                format!(
                    "plan {name} cannot estimate the model{}: {why}",
                    if blocks.len() > 1 {
                        format!(" of axis {}", b.label)
                    } else {
                        String::new()
                    }
                )
            })
        })
        .collect()
}

fn to_table(pts: &Points, f: &crate::formula::Formula) -> crate::obs::Table {
    let names = f.columns();
    crate::obs::Table {
        path: PathBuf::from("plan"),
        columns: names
            .iter()
            .map(|n| (0..pts.rows.len()).map(|r| pts.value(r, n)).collect())
            .collect(),
        names,
        lines: (1..=pts.rows.len() as u64).collect(),
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

fn evaluate(a: &EvaluateArgs) -> Result<(), String> {
    plan_files(&a.plan, "--plan", Paths::new())
        .output("--json", a.json.as_deref())
        .output("--report", a.report.as_deref())
        .check()?;
    let (u, gyro) = unit(a.model.sensor);
    let blocks = models::blocks(&a.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let mut loaded = Vec::new();
    for spec in &a.plan {
        let pts = load_plan(spec, &vars, &a.model)?;
        check_variables(&blocks, &pts, &format!("plan {spec}"))?;
        check_limits(&pts, &a.model.limit, &format!("plan {spec}"))?;
        loaded.push((spec.clone(), pts));
    }
    // Without --region, every plan is judged over all the plans' points together.
    let union = union(loaded.iter().map(|(_, p)| p), &vars);
    if models::has_lever(&blocks) {
        return evaluate_spin_rig(a, &blocks, loaded, &union);
    }
    let mut plans = Vec::new();
    for (spec, pts) in loaded {
        let crit = evaluate_plan(&spec, &pts, &blocks, &a.model, &union)?;
        plans.push(show::PlanResult {
            name: spec,
            points: pts,
            criteria: crit,
            fixture: None,
        });
    }
    if let Some(deg) = a.fixture_error {
        let (Some(noise), Some(scale)) = (a.noise, a.scale) else {
            return Err(
                "--fixture-error needs --noise (counts) and --scale (counts per SI unit)".into(),
            );
        };
        if u != Unit::Triad {
            return Err("--fixture-error applies to triads (--sensor accel or gyro)".into());
        }
        for p in &mut plans {
            let se: Vec<(Vec<f64>, Vec<f64>)> = blocks
                .iter()
                .zip(&p.criteria)
                .enumerate()
                .map(|(axis, (b, c))| {
                    let x = p.points.model_rows(&b.formula);
                    let extra = predict::orientation_variance(
                        &p.points,
                        axis,
                        scale,
                        deg.to_radians(),
                        gyro,
                    );
                    let cov = predict::covariance_with(&x, &c.unscaled_covariance, noise, &extra);
                    let plain = (0..c.p)
                        .map(|k| noise * c.unscaled_covariance[(k, k)].sqrt())
                        .collect();
                    (plain, (0..c.p).map(|k| cov[(k, k)].sqrt()).collect())
                })
                .collect();
            p.fixture = Some(se);
        }
    }
    let curve = a.curve.as_deref().map(points::grid).transpose()?;
    print!(
        "{}",
        show::evaluate_text(&a.model.model, &blocks, &plans, a.fixture_error)
    );
    write_evaluation(a, &blocks, &plans, curve.as_ref())
}

/// `design evaluate`'s files, all or none.
fn write_evaluation(
    a: &EvaluateArgs,
    blocks: &[Block],
    plans: &[show::PlanResult],
    curve: Option<&Points>,
) -> Result<(), String> {
    let mut staged = Staged::new();
    if let Some(path) = &a.json {
        let v = show::evaluate_json(blocks, plans);
        staged.write(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    if let Some(path) = &a.report {
        let html = show::evaluate_html(&a.model.model, blocks, plans, curve)?;
        staged.write(path, |w| std::io::Write::write_all(w, html.as_bytes()))?;
    }
    staged.commit()
}

/// `design evaluate` of the spin-rig model: each plan on the lever-arm components it can
/// estimate (plans that estimate the same ones side by side), saying which it cannot and, with
/// --noise and --scale, how well it estimates the others.
fn evaluate_spin_rig(
    a: &EvaluateArgs,
    blocks: &[Block],
    loaded: Vec<(String, Points)>,
    union: &Points,
) -> Result<(), String> {
    if a.fixture_error.is_some() {
        return Err("--fixture-error: not with the lever-arm model".into());
    }
    /// Plans that estimate the same lever-arm components, on the model of those.
    struct Group {
        estimable: [[bool; 3]; 3],
        blocks: Vec<Block>,
        plans: Vec<show::PlanResult>,
    }
    let mut groups: Vec<Group> = Vec::new();
    for (spec, pts) in loaded {
        let (reduced, estimable) = models::lever_blocks(blocks, &pts);
        let criteria = evaluate_plan(&spec, &pts, &reduced, &a.model, union)?;
        let plan = show::PlanResult {
            name: spec,
            points: pts,
            criteria,
            fixture: None,
        };
        match groups.iter_mut().find(|g| g.estimable == estimable) {
            Some(g) => g.plans.push(plan),
            None => groups.push(Group {
                estimable,
                blocks: reduced,
                plans: vec![plan],
            }),
        }
    }
    let per = match (a.noise, a.scale) {
        (Some(n), Some(s)) => Some(n / s),
        _ => None,
    };
    for g in &groups {
        print!(
            "{}",
            show::evaluate_text(&a.model.model, &g.blocks, &g.plans, None)
        );
        for p in &g.plans {
            print!("{}", show::lever_text(p, &g.blocks, &g.estimable, per));
        }
    }
    if (a.json.is_some() || a.report.is_some()) && groups.len() > 1 {
        return Err(
            "--json, --report: these plans estimate different lever-arm components, so they have no model in common; write one per plan (or per group of plans that estimate the same)".into(),
        );
    }
    if let Some(g) = groups.first() {
        let curve = a.curve.as_deref().map(points::grid).transpose()?;
        write_evaluation(a, &g.blocks, &g.plans, curve.as_ref())?;
    }
    Ok(())
}

/// The points of all `plans`, on the variables `vars`.
fn union<'a>(plans: impl Iterator<Item = &'a Points>, vars: &[String]) -> Points {
    let mut rows = Vec::new();
    for p in plans {
        for r in 0..p.rows.len() {
            rows.push(vars.iter().map(|v| p.value(r, v)).collect());
        }
    }
    Points {
        names: vars.to_vec(),
        rows,
    }
}

/// The usual plans to compare an optimum with: uniform spacing over each grid, and the 6, 12 and
/// 24-position tumbles for triads.
fn usual_plans(o: &OptimizeArgs, cands: &Points) -> Vec<(String, Points)> {
    let mut out = Vec::new();
    let (u, _) = unit(o.model.sensor);
    if u == Unit::Triad {
        for k in [6, 12, 24] {
            if let Ok(p) = points::from_items(
                &[format!("tumble:{k}")],
                &o.model.temps,
                &o.model.volts,
                1,
                u,
            ) {
                // Repeated to the plan's size, as a station would.
                let reps = o.n.div_ceil(p.rows.len()).max(1);
                let idx: Vec<usize> = (0..p.rows.len())
                    .cycle()
                    .take(reps * p.rows.len())
                    .collect();
                out.push((format!("tumble:{k} x{reps}"), p.select(&idx)));
            }
        }
    }
    // Uniform: n points spread evenly over the candidates in their order.
    let m = cands.rows.len();
    if m > 0 {
        let idx: Vec<usize> = (0..o.n)
            .map(|k| {
                if o.n == 1 {
                    0
                } else {
                    (k * (m - 1) + (o.n - 1) / 2) / (o.n - 1)
                }
            })
            .collect();
        out.push((
            format!("uniform ({} points over the candidates)", o.n),
            cands.select(&idx),
        ));
    }
    out
}

/// How `optimize` searches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Coordinate exchange when the candidates are only grids of more than 50,000 combinations,
    /// else Fedorov.
    Auto,
    /// Fedorov exchange over the listed candidates.
    Fedorov,
    /// Coordinate exchange over the grids' levels, without listing their combinations.
    Coordinate,
}

/// A found plan, however it was searched.
struct Searched {
    plan: Points,
    hits: usize,
    over: String,
    region: Points,
    listed: Option<Points>,
}

fn search_fedorov(
    o: &OptimizeArgs,
    blocks: &[Block],
    bar: &indicatif::ProgressBar,
    start: std::time::Instant,
) -> Result<Searched, String> {
    let cands = candidates(&o.candidates, &o.grid, &o.model)?;
    check_variables(blocks, &cands, "the candidates")?;
    check_limits(&cands, &o.model.limit, "the candidates")?;
    let fs: Vec<DMatrix<f64>> = blocks
        .iter()
        .map(|b| cands.model_rows(&b.formula))
        .collect();
    let ws: Vec<Option<DMatrix<f64>>> = blocks
        .iter()
        .map(|b| {
            let r = region_rows(&o.model, &cands, b)?;
            Ok::<_, String>(Some(r.transpose() * &r / r.nrows() as f64))
        })
        .collect::<Result<_, _>>()?;
    let opts = exchange::Options {
        n: o.n,
        restarts: o.restarts,
        seed: o.seed,
    };
    let found = exchange::optimize_blocks(&fs, o.criterion, &ws, &opts, |d, _| {
        if start.elapsed().as_secs_f64() > 0.5 {
            bar.set_position(d as u64);
        }
    })
    .map_err(|e| {
        format!(
            "{e}; the model's terms: {}",
            blocks
                .iter()
                .map(|b| b.formula.term_names().join(", "))
                .collect::<Vec<_>>()
                .join(" | ")
        )
    })?;
    Ok(Searched {
        plan: cands.select(&found.points),
        hits: found.hits,
        over: format!("{} candidates (Fedorov exchange)", cands.rows.len()),
        region: cands.clone(),
        listed: Some(cands),
    })
}

fn search_coordinate(
    o: &OptimizeArgs,
    blocks: &[Block],
    bar: &indicatif::ProgressBar,
    start: std::time::Instant,
) -> Result<Searched, String> {
    if !o.candidates.is_empty() {
        return Err("--method coordinate: works on the levels of --grid factors; plan items are listed candidates (use --method fedorov)".into());
    }
    if blocks.len() != 1 {
        return Err(
            "--method coordinate: one model at a time (a formula or the single preset)".into(),
        );
    }
    let factor_grids: Vec<Points> = o
        .grid
        .iter()
        .map(|g| points::grid(g))
        .collect::<Result<_, _>>()?;
    if factor_grids.is_empty() {
        return Err("--method coordinate: give the factors as --grid NAME=LO:HI:N".into());
    }
    let factors: Vec<coordinate::Factor> = factor_grids
        .iter()
        .map(|g| coordinate::Factor {
            name: g.names[0].clone(),
            levels: g.rows.iter().map(|r| r[0]).collect(),
        })
        .collect();
    let names: Vec<String> = factors.iter().map(|f| f.name.clone()).collect();
    let probe = Points {
        names: names.clone(),
        rows: vec![factors.iter().map(|f| f.levels[0]).collect()],
    };
    check_variables(blocks, &probe, "the factors")?;
    let limits_probe = Points {
        names: names.clone(),
        rows: factors
            .iter()
            .enumerate()
            .flat_map(|(k, f)| f.levels.iter().map(move |l| (k, *l)))
            .map(|(k, l)| {
                let mut r = probe.rows[0].clone();
                r[k] = l;
                r
            })
            .collect(),
    };
    check_limits(&limits_probe, &o.model.limit, "the factors")?;
    let formula = blocks[0].formula.clone();
    let row = |x: &[f64]| {
        let mut out = Vec::new();
        let pts = Points {
            names: names.clone(),
            rows: vec![x.to_vec()],
        };
        formula.row(|v| pts.value(0, v), &mut out);
        nalgebra::DVector::from_vec(out)
    };
    // The region: the --region grids, or 20,000 random combinations of the levels.
    let region = if o.model.region.is_empty() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed ^ 0x5eed);
        Points {
            names: names.clone(),
            rows: (0..20_000)
                .map(|_| {
                    factors
                        .iter()
                        .map(|f| f.levels[rng.random_range(0..f.levels.len())])
                        .collect()
                })
                .collect(),
        }
    } else {
        grids(&o.model.region)?
    };
    let r = region.model_rows(&formula);
    let w = r.transpose() * &r / r.nrows() as f64;
    let opts = exchange::Options {
        n: o.n,
        restarts: o.restarts,
        seed: o.seed,
    };
    let found = coordinate::optimize(&factors, &row, o.criterion, Some(&w), &opts, |d, _| {
        if start.elapsed().as_secs_f64() > 0.5 {
            bar.set_position(d as u64);
        }
    })
    .map_err(|e| {
        format!(
            "{e}; the model's terms: {}",
            formula.term_names().join(", ")
        )
    })?;
    let combinations: f64 = factors.iter().map(|f| f.levels.len() as f64).product();
    Ok(Searched {
        plan: Points {
            names,
            rows: found.points,
        },
        hits: found.hits,
        over: format!(
            "{} factors, {combinations:.3e} combinations (coordinate exchange)",
            factors.len()
        ),
        region,
        listed: None,
    })
}

fn optimize(o: &OptimizeArgs) -> Result<(), String> {
    plan_files(&o.candidates, "--candidates", Paths::new())
        .output("-o", Some(&o.output))
        .check()?;
    let (u, gyro) = unit(o.model.sensor);
    let blocks = models::blocks(&o.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let combinations: f64 = o
        .grid
        .iter()
        .filter_map(|g| points::grid(g).ok())
        .map(|g| g.rows.len() as f64)
        .product();
    let method = match o.method {
        Method::Auto
            if o.candidates.is_empty()
                && !o.grid.is_empty()
                && combinations > 50_000.0
                && blocks.len() == 1 =>
        {
            Method::Coordinate
        }
        Method::Auto => Method::Fedorov,
        m => m,
    };
    let bar = indicatif::ProgressBar::new(o.restarts as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  exchange {bar:30} restart {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let searched = match method {
        Method::Coordinate => search_coordinate(o, &blocks, &bar, start)?,
        _ => search_fedorov(o, &blocks, &bar, start)?,
    };
    bar.finish_and_clear();
    let took = start.elapsed();
    let mut compare = vec![("optimal".to_string(), searched.plan.clone())];
    for spec in &o.compare {
        compare.push((spec.clone(), load_plan(spec, &vars, &o.model)?));
    }
    if let Some(cands) = &searched.listed {
        compare.extend(usual_plans(o, cands));
    }
    let mut rows = Vec::new();
    for (i, (name, pts)) in compare.iter().enumerate() {
        match evaluate_plan(name, pts, &blocks, &o.model, &searched.region) {
            // The plan found is the answer: failing to evaluate it is the command's failure.
            Err(e) if i == 0 => return Err(e),
            Ok(c) => rows.push(show::PlanResult {
                name: name.clone(),
                points: pts.clone(),
                criteria: c,
                fixture: None,
            }),
            Err(e) => println!("  ({e})"),
        }
    }
    // The model's variables, then the columns `calflash simulate --plan-file` reads.
    let sim_cols: Vec<&str> = match u {
        Unit::Triad => crate::columns::F
            .iter()
            .chain(crate::columns::W.iter())
            .copied()
            .chain([crate::columns::TEMP, crate::columns::VOLT])
            .collect(),
        _ => vec![
            crate::columns::INPUT,
            crate::columns::INPUT_P,
            crate::columns::INPUT_O,
            crate::columns::TEMP,
            crate::columns::VOLT,
        ],
    };
    let mut keep: Vec<String> = vars.clone();
    for n in &searched.plan.names {
        if sim_cols.contains(&n.as_str()) && !keep.contains(n) {
            keep.push(n.clone());
        }
    }
    crate::files::write_atomically(&o.output, |w| {
        std::io::Write::write_all(w, points::to_csv(&searched.plan, &keep).as_bytes())
    })?;
    let head = show::Search {
        criterion: o.criterion,
        n: o.n,
        over: &searched.over,
        hits: searched.hits,
        took,
        output: &o.output,
    };
    print!(
        "{}",
        show::optimize_text(&head, &searched.plan, &blocks, &rows)
    );
    Ok(())
}

fn predict(a: &PredictArgs) -> Result<(), String> {
    plan_files(a.plan.iter(), "--plan", Paths::new())
        .output("--json", a.json.as_deref())
        .check()?;
    let (u, gyro) = unit(a.model.sensor);
    let blocks = models::blocks(&a.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let sensor = match a.model.sensor {
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
    };
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
    let mut at = Points {
        names: Vec::new(),
        rows: Vec::new(),
    };
    for spec in &a.at {
        let mut names = Vec::new();
        let mut row = Vec::new();
        for kv in spec.split(',') {
            let (k, v) = kv
                .split_once('=')
                .ok_or_else(|| format!("--at `{spec}`: expected NAME=VALUE[,NAME=VALUE...]"))?;
            let k = k.trim();
            let read = models::variables(&blocks);
            if !read.iter().any(|r| r == k) {
                return Err(format!(
                    "--at `{spec}`: the model reads no `{k}`; it reads {}",
                    read.join(", ")
                ));
            }
            names.push(k.to_string());
            row.push(
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("--at `{spec}`: `{v}` is not a finite number"))?,
            );
        }
        if at.rows.is_empty() {
            at.names = names;
        } else if at.names != names {
            return Err(format!(
                "--at `{spec}`: every operating point must name the same variables ({})",
                at.names.join(", ")
            ));
        }
        at.rows.push(row);
    }
    if at.rows.is_empty() {
        return Err("--at: give at least one operating point, NAME=VALUE[,NAME=VALUE...]".into());
    }
    if let Some(target) = a.target {
        if blocks.len() != 1 {
            return Err("--target: one model at a time (a formula or the single preset)".into());
        }
        let cands = candidates(&a.candidates, &a.grid, &a.model)?;
        check_variables(&blocks, &cands, "the candidates")?;
        let f = cands.model_rows(&blocks[0].formula);
        let region = region_rows(&a.model, &cands, &blocks[0])?;
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
        return Ok(());
    }
    let spec = a
        .plan
        .as_deref()
        .ok_or("give --plan (or --target with --candidates)")?;
    let pts = load_plan(spec, &vars, &a.model)?;
    check_variables(&blocks, &pts, &format!("plan {spec}"))?;
    let crit = evaluate_plan(spec, &pts, &blocks, &a.model, &pts)?;
    let outputs: Vec<&str> = match (u, gyro) {
        (Unit::Triad, false) => crate::columns::A.to_vec(),
        (Unit::Triad, true) => crate::columns::GYRO.to_vec(),
        _ => vec![crate::columns::OUTPUT],
    };
    let mut results = Vec::new();
    for (k, (b, c)) in blocks.iter().zip(&crit).enumerate() {
        let at_rows = at.model_rows(&b.formula);
        let e = predict::expected(&c.unscaled_covariance, noises[k], &at_rows);
        let mc = match a.monte_carlo {
            Some(runs) => {
                let x = pts.model_rows(&b.formula);
                let sim = predict::Simulation {
                    sensor: &sensor,
                    unit: u,
                    output: outputs[k.min(outputs.len() - 1)],
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
                    ));
                }
                let bar = indicatif::ProgressBar::new(runs as u64);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(
                        "  simulating {bar:30} {pos}/{len} calibrations, {eta} left",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                let mc = predict::monte_carlo(&pts, &sim, &x, &at_rows, |r| {
                    bar.set_position(r as u64);
                });
                bar.finish_and_clear();
                Some(mc?)
            }
            None => None,
        };
        results.push((b.clone(), e, mc));
    }
    let text = show::predict_text(spec, noise, &at, &results);
    print!("{text}");
    if let Some(path) = &a.json {
        let v = show::predict_json(spec, noise, &at, &results);
        crate::files::write_atomically(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    Ok(())
}
