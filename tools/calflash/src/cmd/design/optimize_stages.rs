//! `calflash design optimize --stage-one-candidates ITEMS`: the best two-stage plans at one
//! stage's cost, against the best one-stage plan ([`crate::design::stage_plans`]), and which
//! wins.

use std::path::PathBuf;

use clap::Args;

use crate::cmd::Failure;
use crate::design::points::{self, Points};
use crate::design::stage_plans::{self, Ask, Found, MAX_STAGE_ONE};
use crate::design::stages::Costs;
use crate::files::Paths;

use super::OptimizeArgs;
use super::stages::{UNITS, other_stage_one};

/// Two stages designed against one.
#[derive(Debug, Args)]
pub struct StagesArgs {
    /// Design two stages too: the plan items a sensor's own fixture reaches in stage one
    /// (single-axis items: head:N, rate:LO:HI:N, centrifuge:LO:HI:N); --candidates are the
    /// assembled unit's, for stage two and one stage. The budget is one stage's: --n
    /// observations of the unit at each --temps.
    #[arg(long, value_delimiter = ',')]
    pub stage_one_candidates: Vec<String>,
    /// The other family's stage-one plan (items), not designed; by default the gyros on a rate
    /// table or the accelerometers on a dividing head.
    #[arg(long, value_delimiter = ',', requires = "stage_one_candidates")]
    pub stage_one_other: Vec<String>,
    /// What one observation of one sensor on its own fixture costs (stage one).
    #[arg(long, default_value = "1", requires = "stage_one_candidates", value_parser = crate::cmd::values::positive)]
    pub cost_stage_one: f64,
    /// What one observation of the assembled unit costs (stage two, one stage).
    #[arg(long, default_value = "1", requires = "stage_one_candidates", value_parser = crate::cmd::values::positive)]
    pub cost_unit: f64,
    /// Where to write a sensor's stage-one plan (CSV, every temperature; `calflash simulate
    /// --sensor single-accel|single-gyro --plan-file`).
    #[arg(long, requires = "stage_one_candidates")]
    pub stage_one_output: Option<PathBuf>,
    /// Where to write the unit's stage-two plan (CSV, at the first temperature).
    #[arg(long, requires = "stage_one_candidates")]
    pub unit_output: Option<PathBuf>,
}

/// Runs the two-stage design.
///
/// # Errors
/// Options that do not go with it, candidates that cannot be read, a model they cannot
/// estimate, files that cannot be written.
pub(super) fn run(o: &OptimizeArgs) -> Result<(), Failure> {
    let s = &o.stages;
    let (Some(stage_one_out), Some(unit_out)) = (&s.stage_one_output, &s.unit_output) else {
        return Err("--stage-one-candidates: give --stage-one-output and --unit-output, where the two stages' plans go (-o takes one stage's)".into());
    };
    Paths::new()
        .input("--mission", o.model.mission.as_deref())
        .output("-o", Some(&o.output))
        .output("--stage-one-output", Some(stage_one_out))
        .output("--unit-output", Some(unit_out))
        .check()?;
    let gyro = match o.model.sensor {
        crate::cmd::values::SensorKind::Accel | crate::cmd::values::SensorKind::Imu => false,
        crate::cmd::values::SensorKind::Gyro => true,
        _ => {
            return Err("--stage-one-candidates: two stages are designed for a triad (--sensor accel, gyro or imu), whose axes are calibrated alone first".into());
        }
    };
    if o.candidates.is_empty() {
        return Err(
            "--stage-one-candidates: give the assembled unit's --candidates (plan items)".into(),
        );
    }
    if !o.grid.is_empty()
        || !o.compare.is_empty()
        || !o.model.region.is_empty()
        || !o.model.limit.is_empty()
        || o.criterion.is_some()
        || o.method == crate::design::search::Method::Coordinate
    {
        return Err("--stage-one-candidates: --grid, --compare, --region, --limit, --criterion and --method coordinate are for one-stage designs (each plan here is I-optimal over its candidates)".into());
    }
    if o.model.model.trim() != "triad-nonlinear" {
        return Err(format!(
            "--stage-one-candidates with --model {}: one stage is designed for what `calibrate` fits in one stage, every term of both families (--model triad-nonlinear, with the asymmetry and the gyros' g-sensitivity)",
            o.model.model
        )
        .into());
    }
    let space = o.model.space()?;
    let other_items = other_stage_one(gyro, &s.stage_one_other);
    let other = crate::sim::plan::plan(&other_items, &o.model.temps, &[3.3], 1, true)
        .map_err(|e| Failure::from(format!("--stage-one-other: {e}")))?;
    let ask = Ask {
        gyro,
        unit_candidates: o.candidates.clone(),
        stage_one_candidates: s.stage_one_candidates.clone(),
        other_stage_one: other,
        temps: o.model.temps.clone(),
        n: o.n,
        costs: Costs {
            stage_one: s.cost_stage_one,
            unit: s.cost_unit,
        },
        restarts: o.restarts,
        seed: o.seed,
        mission: space.mission.clone(),
        units: UNITS,
    };
    let bar = indicatif::ProgressBar::new(stage_plans::SHARES.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  two stages {bar:30} share {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let found = stage_plans::optimize(&ask, |done| bar.set_position(done as u64))
        .map_err(|e| Failure::from(e.to_string()))?;
    bar.finish_and_clear();
    let f = usize::from(gyro);
    let Some(best) = found.best(f) else {
        let why: Vec<String> = found
            .splits
            .iter()
            .filter_map(|(share, s)| s.as_ref().err().map(|e| format!("share {share}: {e}")))
            .collect();
        let budget = found
            .splits
            .iter()
            .all(|(_, s)| matches!(s, Err(stage_plans::NotMade::TooFew(_))));
        return Err(if budget {
            format!(
                "one stage wins: no two-stage plan fits one stage's budget ({}); no plan is written",
                why.join("; ")
            )
        } else {
            format!(
                "--stage-one-candidates: no two-stage plan could be made and calibrated ({}); no plan is written",
                why.join("; ")
            )
        }
        .into());
    };
    let temps = &o.model.temps;
    let triad_cols = |p: &Points| -> Vec<String> {
        crate::columns::F
            .iter()
            .chain(&crate::columns::W)
            .chain(&crate::columns::DW)
            .chain(&[crate::columns::TEMP, crate::columns::VOLT])
            .filter(|n| p.sets(n))
            .map(|n| (*n).to_string())
            .collect()
    };
    let single_cols: Vec<String> = [
        crate::columns::INPUT,
        crate::columns::INPUT_P,
        crate::columns::INPUT_O,
        crate::columns::TEMP,
        crate::columns::VOLT,
    ]
    .map(String::from)
    .to_vec();
    let one_all = stage_plans::at_temps(&found.one_stage, temps);
    let s1_all = stage_plans::at_temps(&best.stage_one, temps);
    for (path, pts, cols) in [
        (&o.output, &one_all, triad_cols(&one_all)),
        (stage_one_out, &s1_all, single_cols),
        (unit_out, &best.unit, triad_cols(&best.unit)),
    ] {
        crate::files::write_atomically(path, |w| {
            std::io::Write::write_all(w, points::to_csv(pts, &cols).as_bytes())
        })?;
    }
    print!("{}", text(o, &ask, &found, f));
    Ok(())
}

/// A plan's distinct points and their counts, in words.
fn tally(p: &Points, names: &[&str]) -> String {
    points::tally(p)
        .iter()
        .map(|(row, count)| {
            let at: Vec<String> = names
                .iter()
                .filter_map(|n| p.names.iter().position(|m| m == n).map(|k| (n, row[k])))
                .filter(|(_, v)| v.abs() > 1e-9)
                .map(|(n, v)| format!("{n}={v:.4}"))
                .collect();
            let at = if at.is_empty() {
                "zero input".to_string()
            } else {
                at.join(" ")
            };
            format!("{count} x ({at})")
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn text(o: &OptimizeArgs, ask: &Ask, found: &Found, f: usize) -> String {
    use std::fmt::Write;
    let (family, unit) = if f == 1 {
        ("gyros", "rad/s")
    } else {
        ("accelerometers", "m/s^2")
    };
    let nt = ask.temps.len();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "calflash design optimize: two stages against one for the {family}, at one stage's budget of {} unit observations ({} at each of {nt} temperature(s)); an observation costs {} on a sensor's fixture, {} on the unit's equipment",
        o.n * nt,
        o.n,
        ask.costs.stage_one,
        ask.costs.unit
    );
    let _ = writeln!(
        out,
        "  judged: {} simulated units (our simulator's sensors) calibrated through each pair of plans as `calibrate` makes it; each calibration's stated 1-sigma averaged over {}",
        UNITS, found.range.what
    );
    let inputs: Vec<&str> = crate::columns::F
        .iter()
        .chain(&crate::columns::W)
        .copied()
        .collect();
    let _ = writeln!(
        out,
        "  one stage (every term of both families, I-optimal over {}): {} observations at each temperature over {} distinct points",
        o.candidates.join(","),
        found.one_stage.rows.len(),
        points::tally(&found.one_stage).len()
    );
    let _ = writeln!(
        out,
        "  share  stage one a sensor  stage two  cost two stages  cost one  two stages {unit}  one stage {unit}  two/one  at equal cost"
    );
    for (share, split) in &found.splits {
        match split {
            Ok(s) => {
                let _ = writeln!(
                    out,
                    "  {share:>5.2}  {:>18}  {:>9}  {:>15.0}  {:>8.0}  {:>16.3e}  {:>15.3e}  {:>7.3}  {:>13.3}",
                    s.stage_one.rows.len() * nt,
                    s.unit.rows.len(),
                    s.cost.0,
                    s.cost.1,
                    s.prediction.two[f],
                    s.prediction.one[f],
                    s.prediction.ratio()[f],
                    s.equal_cost[f]
                );
            }
            Err(e) => {
                let _ = writeln!(out, "  {share:>5.2}  not made: {e}");
            }
        }
    }
    if let Some(best) = found.best(f) {
        let capped = if best.stage_one.rows.len() == MAX_STAGE_ONE {
            format!(" (capped at {MAX_STAGE_ONE} a temperature)")
        } else {
            String::new()
        };
        let _ = writeln!(
            out,
            "  best two stages: share {:.2}; stage one ({}){capped}: {}",
            best.share,
            ask.stage_one_candidates.join(","),
            tally(&best.stage_one, &["input", "input_p", "input_o"])
        );
        let _ = writeln!(out, "  stage two: {}", tally(&best.unit, &inputs));
        let e = best.equal_cost[f];
        let _ = writeln!(
            out,
            "  at equal cost two stages' error is {e:.3} of one stage's for the {family}: {}",
            if e < 1.0 {
                "two stages win"
            } else {
                "one stage wins"
            }
        );
        let _ = writeln!(
            out,
            "  (the other family at this design: two/one at equal cost {:.3}; its stage one is given, not designed)",
            best.equal_cost[1 - f]
        );
    }
    let _ = writeln!(
        out,
        "  wrote {} (one stage), {} (stage one), {} (stage two)",
        o.output.display(),
        o.stages
            .stage_one_output
            .as_deref()
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
        o.stages
            .unit_output
            .as_deref()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    );
    out
}
