//! `calflash design evaluate`: what a plan estimates, and how well.

use crate::cmd::Failure;
use std::path::PathBuf;

use crate::files::{Paths, Staged};
use clap::Args;

use crate::design::models::{self, Block};
use crate::design::points::{self, Points, Unit};
use crate::design::predict;
use crate::design::space;
use crate::report::design as show;

use super::{ModelArgs, plan_files, unit};

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
    #[arg(long, value_parser = crate::cmd::values::non_negative)]
    pub fixture_error: Option<f64>,
    /// Output noise, counts (1 sigma), for standard errors in counts.
    #[arg(long, value_parser = crate::cmd::values::positive)]
    pub noise: Option<f64>,
    /// Counts per SI unit of the input (for the fixture error).
    #[arg(long, value_parser = crate::cmd::values::positive)]
    pub scale: Option<f64>,
    /// Write the figures and tables as HTML here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Two stages against one (triads): each sensor alone through these plan items first
    /// (its own polynomial with asymmetry), then the assembled unit through the first --plan
    /// (misalignment, bias and scale held); compared with one stage on each further --plan.
    #[arg(long, value_delimiter = ',')]
    pub stage_one: Vec<String>,
    /// With --stage-one: the other family's stage-one plan items for the calibrated comparison
    /// (default: `head:56` for accelerometers; `rate:-8:8:9` four times and `rate:0:0:20` for
    /// gyros).
    #[arg(long, value_delimiter = ',', requires = "stage_one")]
    pub stage_one_other: Vec<String>,
    /// With --stage-one: the cost of one observation of one sensor on its own fixture (a
    /// fixture holding several sensors at once: the cost of an observation over their number).
    #[arg(long, default_value = "1", requires = "stage_one", value_parser = crate::cmd::values::positive)]
    pub cost_stage_one: f64,
    /// With --stage-one: the cost of one observation of the assembled unit (stage two and
    /// one stage).
    #[arg(long, default_value = "1", requires = "stage_one", value_parser = crate::cmd::values::positive)]
    pub cost_unit: f64,
}

pub(super) fn run(a: &EvaluateArgs) -> Result<(), Failure> {
    if !a.stage_one.is_empty() {
        return super::stages::run(a, &a.stage_one);
    }
    plan_files(&a.plan, "--plan", Paths::new())
        .input("--mission", a.model.mission.as_deref())
        .output("--json", a.json.as_deref())
        .output("--report", a.report.as_deref())
        .check()?;
    let (u, gyro) = unit(a.model.sensor);
    let space = a.model.space()?;
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
        return evaluate_spin_rig(a, &space, &blocks, loaded, &union);
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
    if let Some(c) = &curve
        && let Some(name) = c.names.iter().find(|n| !vars.contains(n))
    {
        return Err(format!(
            "--curve {}: the model reads no `{name}`; it reads {}",
            a.curve.as_deref().unwrap_or_default(),
            vars.join(", ")
        )
        .into());
    }
    print!(
        "{}",
        show::evaluate_text(&a.model.model, &blocks, &plans, a.fixture_error)
    );
    // Over the mission, the equipment reaching what the plans together span.
    let mission = super::over_mission(&space, &blocks, &plans, &union, "the plans together")?;
    if let Some(m) = &mission {
        print!("{}", crate::report::mission::plans_text(m));
    }
    write_evaluation(a, &blocks, &plans, curve.as_ref(), mission.as_ref())
}

/// `design evaluate`'s files, all or none.
fn write_evaluation(
    a: &EvaluateArgs,
    blocks: &[Block],
    plans: &[show::PlanResult],
    curve: Option<&Points>,
    mission: Option<&crate::report::mission::OverMission>,
) -> Result<(), Failure> {
    let mut staged = Staged::new();
    if let Some(path) = &a.json {
        let mut v = show::evaluate_json(blocks, plans);
        if let (Some(m), Some(o)) = (mission, v.as_object_mut()) {
            o.insert("mission".into(), serde_json::to_value(m)?);
        }
        staged.write(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    if let Some(path) = &a.report {
        let html = crate::report::provenance::Provenance::now().stamp(&show::evaluate_html(
            &a.model.model,
            blocks,
            plans,
            curve,
        )?);
        staged.write(path, |w| std::io::Write::write_all(w, html.as_bytes()))?;
        crate::report::written::page(path);
    }
    Ok(staged.commit()?)
}

/// `design evaluate` of the spin-rig model: each plan on the lever-arm components it can
/// estimate (plans that estimate the same ones side by side), saying which it cannot and, with
/// --noise and --scale, how well it estimates the others.
fn evaluate_spin_rig(
    a: &EvaluateArgs,
    space: &space::Space,
    blocks: &[Block],
    loaded: Vec<(String, Points)>,
    union: &Points,
) -> Result<(), Failure> {
    if a.fixture_error.is_some() {
        return Err("--fixture-error: not with the lever-arm model".into());
    }
    if a.model.mission.is_some() {
        return Err(
            "--mission: not with the lever-arm model (its plans differ in what they estimate); evaluate them with --model triad".into(),
        );
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
        let criteria = space.evaluate_plan(&spec, &pts, &reduced, union)?;
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
        write_evaluation(a, &g.blocks, &g.plans, curve.as_ref(), None)?;
    }
    Ok(())
}
