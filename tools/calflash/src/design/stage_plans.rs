//! Two stages against one at a budget: the one-stage plan and, for each share of the budget
//! given to stage one, the stage-one and unit plans the exchange finds, every pair judged as
//! [`super::stages::predict`] judges plans (simulated units calibrated through both, each
//! calibration's stated 1-sigma over the range), and the share whose two stages err least.
//!
//! The budget is one stage's: `n` observations of the unit at each temperature, at the unit's
//! cost. Two stages spend it on the designed family's three sensors alone at every
//! temperature (stage one) and the unit once (stage two), after the other family's stage one
//! (given, not designed). Each plan is the exchange's I-optimal one over its candidates (the
//! candidates are the region): stage one for its sensor's polynomial
//! ([`super::stages::STAGE_ONE_MODEL`]), stage two for every axis' misalignment (and the gyros'
//! g-sensitivity), one stage for every term `calibrate` fits in one stage (weighted over the
//! mission's moments with one); both stage two and one stage for both families, which the
//! unit plan calibrates together.

use std::sync::Arc;

use super::Error;
use super::exchange::Criterion;
use super::models::Block;
use super::points::{Points, Unit};
use super::predict::conditions;
use super::search::{Method, Search};
use super::space::Space;
use super::stages::{self, Costs, Plans, Prediction, Range, StagesError};
use crate::columns as col;
use crate::formula;
use crate::mission::Profile;
use crate::sim::plan::Condition;

/// The shares of the budget (after the other family's stage one) stage one is given.
pub const SHARES: [f64; 7] = [0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9];
/// Most observations of a sensor at a temperature in stage one.
pub const MAX_STAGE_ONE: usize = 2_000;
/// Fewest observations of a plan searched: twice stage one's six terms.
pub const MIN_PLAN: usize = 12;

/// What to design.
#[derive(Debug, Clone)]
pub struct Ask {
    /// The family designed: the gyros (else the accelerometers).
    pub gyro: bool,
    /// Plan items the unit's equipment reaches (stage two and one stage).
    pub unit_candidates: Vec<String>,
    /// Plan items a sensor's own fixture reaches (stage one).
    pub stage_one_candidates: Vec<String>,
    /// The other family's stage one, at every temperature.
    pub other_stage_one: Vec<Condition>,
    /// Chamber temperatures: stage one and one stage at each, stage two at the first.
    pub temps: Vec<f64>,
    /// One stage's observations at each temperature: the budget.
    pub n: usize,
    /// What an observation costs on each kind of equipment.
    pub costs: Costs,
    /// Random restarts of each exchange.
    pub restarts: usize,
    /// Seed of the restarts.
    pub seed: u64,
    /// The flight the plans are for: weighs one stage's exchange and is the comparison's range.
    pub mission: Option<Arc<Profile>>,
    /// Simulated units each comparison calibrates.
    pub units: u64,
}

/// One share of the budget: its plans (at one temperature) and their prediction.
#[derive(Debug, Clone)]
pub struct Split {
    /// Stage one's share of the budget left after the other family's stage one.
    pub share: f64,
    /// A sensor's stage-one plan at one temperature.
    pub stage_one: Points,
    /// The unit's stage-two plan.
    pub unit: Points,
    /// What each plan costs (two stages, one stage).
    pub cost: (f64, f64),
    /// The prediction.
    pub prediction: Prediction,
    /// Two stages' error over one stage's at equal cost, per family.
    pub equal_cost: [f64; 2],
}

/// Why a share's plans were not made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NotMade {
    /// The budget buys too few observations for stage one or stage two.
    TooFew(String),
    /// A search or a calibration failed.
    Failed(String),
}

impl std::fmt::Display for NotMade {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooFew(s) | Self::Failed(s) => f.write_str(s),
        }
    }
}

/// The designs found.
#[derive(Debug, Clone)]
pub struct Found {
    /// One stage's plan at one temperature.
    pub one_stage: Points,
    /// Each share of [`SHARES`]: its split, or why it could not be made.
    pub splits: Vec<(f64, Result<Split, NotMade>)>,
    /// Where the errors were averaged.
    pub range: Range,
}

impl Found {
    /// The split whose two stages err least at equal cost on family `f` (0 accelerometers, 1
    /// gyros).
    #[must_use]
    pub fn best(&self, f: usize) -> Option<&Split> {
        self.splits
            .iter()
            .filter_map(|(_, s)| s.as_ref().ok())
            .min_by(|a, b| a.equal_cost[f].total_cmp(&b.equal_cost[f]))
    }
}

/// `p` at every one of `temps` (its temperature column set to each in turn).
#[must_use]
pub fn at_temps(p: &Points, temps: &[f64]) -> Points {
    let mut names = p.names.clone();
    let k = names
        .iter()
        .position(|n| n == col::TEMP)
        .unwrap_or_else(|| {
            names.push(col::TEMP.to_string());
            names.len() - 1
        });
    let width = names.len();
    let rows = temps
        .iter()
        .flat_map(|t| {
            p.rows.iter().map(move |r| {
                let mut r = r.clone();
                r.resize(width, 0.0);
                r[k] = *t;
                r
            })
        })
        .collect();
    Points { names, rows }
}

fn space(unit: Unit, temp: f64, mission: Option<Arc<Profile>>) -> Space {
    Space {
        unit,
        temps: vec![temp],
        volts: vec![3.3],
        region: Vec::new(),
        limits: Vec::new(),
        mission,
    }
}

fn search(ask: &Ask, n: usize, candidates: &[String]) -> Search {
    Search {
        n,
        criterion: Criterion::I,
        candidates: candidates.to_vec(),
        grid: Vec::new(),
        restarts: ask.restarts,
        seed: ask.seed,
    }
}

/// One stage's models as `calibrate` fits them with every term: each axis' bias, the three
/// inputs and its own g-squared, cubic, odd-quadratic and asymmetry terms, the gyros' with
/// their g-sensitivity, for both families (the unit plan calibrates both).
///
/// # Errors
/// None in practice (the formulas are fixed).
pub fn one_stage_blocks() -> Result<Vec<Block>, Error> {
    families(|inputs, i| {
        let own = inputs[i];
        format!(
            "1 + {} + {} + {} + {own}^2 + {own}^3 + {own}:abs({own}) + abs({own})",
            inputs[0], inputs[1], inputs[2]
        )
    })
}

/// Stage two's models: each axis' misalignment (the two cross inputs), the gyros' with their
/// g-sensitivity, for both families.
fn stage_two_blocks() -> Result<Vec<Block>, Error> {
    families(|inputs, i| {
        let cross: Vec<&str> = (0..3).filter(|j| *j != i).map(|j| inputs[j]).collect();
        format!("0 + {} + {}", cross[0], cross[1])
    })
}

/// A block per axis of both families, `terms` of the family's inputs and the axis; the gyros'
/// with the specific force's terms added (g-sensitivity).
fn families(terms: impl Fn([&str; 3], usize) -> String) -> Result<Vec<Block>, Error> {
    let mut out = Vec::new();
    for (inputs, outputs, extra) in [
        (col::F, col::A, String::new()),
        (
            col::W,
            col::GYRO,
            format!(" + {} + {} + {}", col::F[0], col::F[1], col::F[2]),
        ),
    ] {
        for (i, output) in outputs.iter().enumerate() {
            let text = format!("{output} ~ {}{extra}", terms(inputs, i));
            out.push(Block {
                label: (*output).to_string(),
                formula: formula::parse(&text)?,
            });
        }
    }
    Ok(out)
}

/// Searches every share of [`SHARES`], telling `progress` each share done.
///
/// # Errors
/// Candidates that cannot be read, one stage's model that its candidates cannot estimate, the
/// other family's stage one costing the whole budget, a mission beyond the candidates.
pub fn optimize(ask: &Ask, mut progress: impl FnMut(usize)) -> Result<Found, StagesError> {
    let (t0, nt) = (ask.temps[0], ask.temps.len());
    let single = if ask.gyro {
        Unit::SingleGyro
    } else {
        Unit::SingleAccel
    };
    let one_space = space(Unit::Triad, t0, ask.mission.clone());
    let one_stage = search(ask, ask.n, &ask.unit_candidates)
        .run(Method::Fedorov, &one_space, &one_stage_blocks()?, |_| {})?
        .plan;
    let one_conditions = conditions(&at_temps(&one_stage, &ask.temps), Unit::Triad);
    // The range from what the equipment reaches, the same for every share.
    let reach = |items: &[String], unit: Unit| -> Result<Vec<Condition>, StagesError> {
        let pts = space(unit, t0, None).candidates(items, &[])?;
        Ok(conditions(&at_temps(&pts, &ask.temps), unit))
    };
    let unit_reach = reach(&ask.unit_candidates, Unit::Triad)?;
    let (accel_one, gyro_one) = {
        let designed = reach(&ask.stage_one_candidates, single)?;
        if ask.gyro {
            (ask.other_stage_one.clone(), designed)
        } else {
            (designed, ask.other_stage_one.clone())
        }
    };
    let reached = Plans {
        accel_one,
        gyro_one,
        unit: unit_reach.clone(),
        one_stage: unit_reach,
    };
    let range = match &ask.mission {
        Some(m) => stages::mission_range(m, &reached, &ask.temps)?,
        None => stages::operating_range(&reached, &ask.temps)?,
    };
    let budget = ask.n as f64 * nt as f64 * ask.costs.unit;
    let other = 3.0 * ask.other_stage_one.len() as f64 * ask.costs.stage_one;
    let left = budget - other;
    if left <= 0.0 {
        return Err(StagesError::Budget(format!(
            "one stage wins: the other family's stage one alone ({} observations a sensor, cost {}) costs more than one stage's whole budget ({}); give it a smaller plan (--stage-one-other), or one stage more observations",
            ask.other_stage_one.len(),
            crate::report::terminal::num(other),
            crate::report::terminal::num(budget)
        )));
    }
    let blocks_one = vec![Block {
        label: "output".into(),
        formula: formula::parse(stages::STAGE_ONE_MODEL).map_err(Error::from)?,
    }];
    let blocks_two = stage_two_blocks()?;
    let mut splits = Vec::new();
    for (k, share) in SHARES.iter().enumerate() {
        let n1 = (share * left / (3.0 * nt as f64 * ask.costs.stage_one)).floor();
        let n2 = ((1.0 - share) * left / ask.costs.unit).floor();
        let split = (|| -> Result<Split, NotMade> {
            if n1 < MIN_PLAN as f64 || n2 < MIN_PLAN as f64 {
                return Err(NotMade::TooFew(format!(
                    "{n1:.0} stage-one and {n2:.0} unit observations: fewer than {MIN_PLAN}"
                )));
            }
            let n1 = (n1 as usize).min(MAX_STAGE_ONE);
            let n2 = n2 as usize;
            let s1 = search(ask, n1, &ask.stage_one_candidates)
                .run(
                    Method::Fedorov,
                    &space(single, t0, None),
                    &blocks_one,
                    |_| {},
                )
                .map_err(|e| NotMade::Failed(format!("stage one: {e}")))?
                .plan;
            let s2 = search(ask, n2, &ask.unit_candidates)
                .run(
                    Method::Fedorov,
                    &space(Unit::Triad, t0, None),
                    &blocks_two,
                    |_| {},
                )
                .map_err(|e| NotMade::Failed(format!("stage two: {e}")))?
                .plan;
            let designed = conditions(&at_temps(&s1, &ask.temps), single);
            let (accel_one, gyro_one) = if ask.gyro {
                (ask.other_stage_one.clone(), designed)
            } else {
                (designed, ask.other_stage_one.clone())
            };
            let plans = Plans {
                accel_one,
                gyro_one,
                unit: conditions(&s2, Unit::Triad),
                one_stage: one_conditions.clone(),
            };
            let prediction = stages::predict(&plans, &range, ask.units)
                .map_err(|e| NotMade::Failed(e.to_string()))?;
            let cost = ask.costs.of(&plans);
            let ratio = prediction.ratio();
            Ok(Split {
                share: *share,
                stage_one: s1,
                unit: s2,
                cost,
                prediction,
                equal_cost: [0, 1].map(|f| ask.costs.at_equal_cost(&plans, ratio[f])),
            })
        })();
        splits.push((*share, split));
        progress(k + 1);
    }
    Ok(Found {
        one_stage,
        splits,
        range,
    })
}
