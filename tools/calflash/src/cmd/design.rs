//! `calflash design`: evaluate plans, find optimal ones, predict and confirm their precision.

use std::path::{Path, PathBuf};

use crate::files::{Paths, Staged};
use clap::{Args, Subcommand};

use super::values::SensorKind;
use crate::design::exchange::Criterion;
use crate::design::models::{self, Block};
use crate::design::points::{self, Points, Unit};
use crate::design::predict;
use crate::design::search::{Method, Search};
use crate::design::space::{self, Limit, Space};
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
    #[arg(long, value_name = "NAME=VALUE[,...]")]
    pub at: Vec<points::OperatingPoint>,
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
    let space = a.model.space();
    let blocks = models::blocks(&a.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let mut loaded = Vec::new();
    for spec in &a.plan {
        let pts = space.load_plan(spec, &vars)?;
        space::check_variables(&blocks, &pts, &format!("plan {spec}"))?;
        space.check_limits(&pts, &format!("plan {spec}"))?;
        loaded.push((spec.clone(), pts));
    }
    // Without --region, every plan is judged over all the plans' points together.
    let union = space::union(loaded.iter().map(|(_, p)| p), &vars);
    if models::has_lever(&blocks) {
        return evaluate_spin_rig(a, &blocks, loaded, &union);
    }
    let mut plans = Vec::new();
    for (spec, pts) in loaded {
        let crit = space.evaluate_plan(&spec, &pts, &blocks, &union)?;
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
        let criteria = a
            .model
            .space()
            .evaluate_plan(&spec, &pts, &reduced, union)?;
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

fn optimize(o: &OptimizeArgs) -> Result<(), String> {
    plan_files(&o.candidates, "--candidates", Paths::new())
        .output("-o", Some(&o.output))
        .check()?;
    let (u, gyro) = unit(o.model.sensor);
    let space = o.model.space();
    let blocks = models::blocks(&o.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let search = Search {
        n: o.n,
        criterion: o.criterion,
        candidates: o.candidates.clone(),
        grid: o.grid.clone(),
        restarts: o.restarts,
        seed: o.seed,
    };
    let bar = indicatif::ProgressBar::new(o.restarts as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  exchange {bar:30} restart {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let searched = search.run(o.method, &space, &blocks, |done| {
        if start.elapsed().as_secs_f64() > 0.5 {
            bar.set_position(done as u64);
        }
    })?;
    bar.finish_and_clear();
    let took = start.elapsed();
    let mut compare = vec![("optimal".to_string(), searched.plan.clone())];
    for spec in &o.compare {
        compare.push((spec.clone(), space.load_plan(spec, &vars)?));
    }
    if let Some(cands) = &searched.listed {
        compare.extend(search.usual_plans(&space, cands));
    }
    let mut rows = Vec::new();
    for (i, (name, pts)) in compare.iter().enumerate() {
        match space.evaluate_plan(name, pts, &blocks, &searched.region) {
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
    let space = a.model.space();
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
    for point in &a.at {
        let spec = &point.text;
        if let Some((k, _)) = point.values.iter().find(|(k, _)| !vars.contains(k)) {
            return Err(format!(
                "--at `{spec}`: the model reads no `{k}`; it reads {}",
                vars.join(", ")
            ));
        }
        let names: Vec<String> = point.values.iter().map(|(k, _)| k.clone()).collect();
        if at.rows.is_empty() {
            at.names = names;
        } else if at.names != names {
            return Err(format!(
                "--at `{spec}`: every operating point must name the same variables ({})",
                at.names.join(", ")
            ));
        }
        at.rows.push(point.values.iter().map(|(_, v)| *v).collect());
    }
    if at.rows.is_empty() {
        return Err("--at: give at least one operating point, NAME=VALUE[,NAME=VALUE...]".into());
    }
    if let Some(target) = a.target {
        if blocks.len() != 1 {
            return Err("--target: one model at a time (a formula or the single preset)".into());
        }
        let cands = space.candidates(&a.candidates, &a.grid)?;
        space::check_variables(&blocks, &cands, "the candidates")?;
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
        return Ok(());
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
