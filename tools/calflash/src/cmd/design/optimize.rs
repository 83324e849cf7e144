//! `calflash design optimize`: the plan of a given size that estimates the model best.

use crate::cmd::Failure;
use std::path::PathBuf;

use crate::files::Paths;
use clap::Args;

use crate::design::exchange::Criterion;
use crate::design::models;
use crate::design::points::{self, Unit};
use crate::design::search::{Method, Search};
use crate::report::design as show;

use super::{ModelArgs, grid_spec, plan_files, unit};

/// Most observations an optimised plan may have.
pub const MAX_PLAN: usize = 100_000;
/// `calflash design optimize`.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Observations in the plan.
    #[arg(long, value_parser = |s: &str| crate::cmd::values::count_in(s, 1, MAX_PLAN))]
    pub n: usize,
    /// The criterion: D by default, I (averaged over the flight) with --mission.
    #[arg(long, value_enum)]
    pub criterion: Option<Criterion>,
    /// Candidate points the equipment reaches: plan items (head:N, tumble:6|12|18|24|26,
    /// sphere:N, rate:LO:HI:N, diagonal:LO:HI:N, centrifuge:LO:HI:N), repeatable.
    #[arg(long)]
    pub candidates: Vec<String>,
    /// Candidate grids NAME=LO:HI:N (repeatable; combined with each other and with the items).
    #[arg(long, value_parser = grid_spec)]
    pub grid: Vec<String>,
    /// Random restarts of the exchange.
    #[arg(long, default_value_t = 10, value_parser = |s: &str| crate::cmd::values::count_in(s, 1, 1000))]
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
    /// The plan file to write (CSV), for `calflash simulate --plan-file` and a test station;
    /// with --stage-one-candidates, one stage's plan at every temperature.
    #[arg(long, short)]
    pub output: PathBuf,
    #[command(flatten)]
    pub stages: super::optimize_stages::StagesArgs,
}

pub(super) fn run(o: &OptimizeArgs) -> Result<(), Failure> {
    if !o.stages.stage_one_candidates.is_empty() {
        return super::optimize_stages::run(o);
    }
    plan_files(&o.candidates, "--candidates", Paths::new())
        .input("--mission", o.model.mission.as_deref())
        .output("-o", Some(&o.output))
        .check()?;
    let (u, gyro) = unit(o.model.sensor);
    let space = o.model.space()?;
    let blocks = models::blocks(&o.model.model, gyro)?;
    let vars = models::variables(&blocks);
    let criterion = o.criterion.unwrap_or(if space.mission.is_some() {
        Criterion::I
    } else {
        Criterion::D
    });
    let search = Search {
        n: o.n,
        criterion,
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
            Err(e) if i == 0 => return Err(e.into()),
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
        criterion,
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
    // Over the mission, the equipment reaching what the candidates span.
    let reach = searched.listed.as_ref().unwrap_or(&searched.plan);
    if let Some(m) = super::over_mission(&space, &blocks, &rows, reach, "the candidates")? {
        print!("{}", crate::report::mission::plans_text(&m));
    }
    Ok(())
}
