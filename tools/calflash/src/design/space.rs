//! Where plans live, apart from the model: the unit the plan items drive, the chamber's
//! temperatures and voltages, the operating region the G and I criteria average over, and the
//! equipment's limits. Plans and candidates are read, checked and evaluated against it.

use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

use nalgebra::DMatrix;

use super::Error;
use super::criteria::{self, Criteria};
use super::models::{self, Block};
use super::points::{self, Points, Unit};
use crate::mission::Profile;
use crate::mission::weight::{self, Lookup, Reach, Weight};

/// An equipment limit `NAME=LO:HI` (`rate=-800:800`): plans and candidates beyond it are
/// refused.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    /// The variable.
    pub name: String,
    /// Lowest value the equipment reaches.
    pub lo: f64,
    /// Highest.
    pub hi: f64,
}

impl FromStr for Limit {
    type Err = Error;

    fn from_str(l: &str) -> Result<Self, Error> {
        let bad = || Error::Limit(l.to_string());
        let (name, range) = l.split_once('=').ok_or_else(bad)?;
        let (lo, hi) = range.split_once(':').ok_or_else(bad)?;
        let (lo, hi): (f64, f64) = (
            lo.trim().parse().map_err(|_| bad())?,
            hi.trim().parse().map_err(|_| bad())?,
        );
        let name = name.trim();
        if name.is_empty() || !lo.is_finite() || !hi.is_finite() || lo > hi {
            return Err(bad());
        }
        Ok(Self {
            name: name.to_string(),
            lo,
            hi,
        })
    }
}

/// What the plans are for, apart from the model.
#[derive(Debug, Clone)]
pub struct Space {
    /// The unit the plan items drive.
    pub unit: Unit,
    /// Chamber temperatures for plan items, C.
    pub temps: Vec<f64>,
    /// Supply voltages for plan items, V.
    pub volts: Vec<f64>,
    /// The operating region (grids `NAME=LO:HI:N`, combined); empty: the candidates or the
    /// plan's own points.
    pub region: Vec<String>,
    /// The equipment's limits.
    pub limits: Vec<Limit>,
    /// The flight the plans are for (`--mission`): its moments weigh the I criterion in place of
    /// the region's.
    pub mission: Option<Arc<Profile>>,
}

impl Space {
    /// Refuses points beyond the equipment's limits.
    ///
    /// # Errors
    /// The first point beyond a limit, or a limit on a variable `pts` lacks.
    pub fn check_limits(&self, pts: &Points, what: &str) -> Result<(), Error> {
        for l in &self.limits {
            let (name, lo, hi) = (l.name.as_str(), l.lo, l.hi);
            if !pts.names.iter().any(|n| n == name) {
                return Err(Error::LimitOnNoVariable {
                    name: name.to_string(),
                    what: what.to_string(),
                    has: pts.names.join(", "),
                });
            }
            for r in 0..pts.rows.len() {
                let v = pts.value(r, name);
                if !(lo..=hi).contains(&v) {
                    return Err(Error::BeyondLimit {
                        what: what.to_string(),
                        point: r + 1,
                        name: name.to_string(),
                        value: v,
                        lo,
                        hi,
                    });
                }
            }
        }
        Ok(())
    }

    /// A plan from a file or from items.
    ///
    /// # Errors
    /// Neither a readable plan file nor plan items.
    pub fn load_plan(&self, spec: &str, vars: &[String]) -> Result<Points, Error> {
        let path = Path::new(spec);
        if path.is_file() {
            return points::read(path, vars);
        }
        let items: Vec<String> = spec.split(',').map(|s| s.trim().to_string()).collect();
        points::from_items(&items, &self.temps, &self.volts, 1, self.unit).map_err(|e| {
            Error::Plan {
                spec: spec.to_string(),
                source: Box::new(e),
            }
        })
    }

    /// The candidates: plan `items` times the grids `grid_specs`.
    ///
    /// # Errors
    /// Malformed items or grids, too many to list, or none.
    pub fn candidates(&self, items: &[String], grid_specs: &[String]) -> Result<Points, Error> {
        let from_items = if items.is_empty() {
            Points {
                names: Vec::new(),
                rows: Vec::new(),
            }
        } else {
            points::from_items(items, &self.temps, &self.volts, 1, self.unit)?
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
            return Err(Error::TooManyCandidates {
                count,
                max: MAX_LISTED,
            });
        }
        let c = per_grid.iter().fold(from_items, |acc, g| acc.product(g));
        if c.rows.is_empty() {
            return Err(Error::NoCandidates);
        }
        Ok(c)
    }

    /// The model rows of the operating region for `block`: the region's grids, else
    /// `fallback`'s points.
    ///
    /// # Errors
    /// A region of too many points.
    pub fn region_rows(&self, fallback: &Points, block: &Block) -> Result<DMatrix<f64>, Error> {
        if self.region.is_empty() {
            Ok(fallback.model_rows(&block.formula))
        } else {
            Ok(grids(&self.region)?.model_rows(&block.formula))
        }
    }

    /// The mission's weight on `block`, the equipment reaching the range of `reach` on each
    /// variable (narrowed by the limits); `None` without a mission.
    ///
    /// # Errors
    /// A variable the profile lacks, or a flight wholly beyond the reach.
    pub fn mission_weight(
        &self,
        block: &Block,
        reach: &Points,
        what: &str,
    ) -> Result<Option<(Weight, Lookup, Reach)>, Error> {
        let Some(p) = &self.mission else {
            return Ok(None);
        };
        let lookup = Lookup::new(p, &block.formula, self.unit)?;
        let vars: Vec<String> = block.formula.columns().into_iter().skip(1).collect();
        let limits: Vec<(&str, f64, f64)> = self
            .limits
            .iter()
            .map(|l| (l.name.as_str(), l.lo, l.hi))
            .collect();
        let reach = Reach::of(reach, &vars, &limits);
        let w = weight::weight(p, &block.formula, &lookup, &reach);
        if w.share_inside == 0.0 {
            return Err(Error::MissionBeyondReach {
                profile: p.source.display().to_string(),
                what: what.to_string(),
                beyond: describe_beyond(&w, &reach),
            });
        }
        Ok(Some((w, lookup, reach)))
    }

    /// Evaluates `pts` for every block; a plan that cannot estimate a block names the term.
    ///
    /// # Errors
    /// A block the plan cannot estimate, or a region of too many points.
    pub fn evaluate_plan(
        &self,
        name: &str,
        pts: &Points,
        blocks: &[Block],
        region_points: &Points,
    ) -> Result<Vec<Criteria>, Error> {
        blocks
            .iter()
            .map(|b| {
                let x = pts.model_rows(&b.formula);
                let region = self.region_rows(region_points, b)?;
                criteria::evaluate(&x, &region, b.formula.intercept).map_err(|dep| {
                    let table = to_table(pts, &b.formula);
                    let why =
                        b.formula
                            .explain_rank_deficiency(&table, dep.column, &dep.combination);
                    Error::NotEstimable {
                        plan: name.to_string(),
                        axis: if blocks.len() > 1 {
                            format!(" of axis {}", b.label)
                        } else {
                            String::new()
                        },
                        why,
                    }
                })
            })
            .collect()
    }
}

/// The share of a flight beyond the reach on each variable, in words.
#[must_use]
pub fn describe_beyond(w: &Weight, reach: &Reach) -> String {
    let parts: Vec<String> = w
        .beyond
        .iter()
        .zip(&reach.bounds)
        .filter(|((_, lo, hi), _)| lo + hi > 0.0)
        .map(|((v, lo, hi), (_, a, b))| {
            use crate::report::terminal::num;
            format!(
                "{v} {} % of the time below {} and {} % above {}",
                percent(*lo),
                num(*a),
                percent(*hi),
                num(*b)
            )
        })
        .collect();
    if parts.is_empty() {
        "nothing beyond".to_string()
    } else {
        parts.join("; ")
    }
}

/// A share as a percentage a reader can tell from 0 and 100: one decimal between 1 and 99 %,
/// three significant digits nearer the ends.
#[must_use]
pub fn percent(share: f64) -> String {
    let p = 100.0 * share;
    if p == 0.0 || p == 100.0 {
        format!("{p:.0}")
    } else if (1.0..=99.0).contains(&p) {
        format!("{p:.1}")
    } else if p < 1.0 {
        format!("{p:.2e}")
    } else {
        format!("{:.3}", 100.0 - (100.0 - p).max(0.001))
            .trim_end_matches('0')
            .to_string()
    }
}

/// The grids `specs` combined.
///
/// # Errors
/// A malformed grid, or too many points.
pub fn grids(specs: &[String]) -> Result<Points, Error> {
    let mut p = Points {
        names: Vec::new(),
        rows: Vec::new(),
    };
    for g in specs {
        let g = points::grid(g)?;
        let n = p.rows.len().max(1).saturating_mul(g.rows.len());
        if n > crate::sim::plan::MAX_CONDITIONS {
            return Err(Error::TooManyGridPoints {
                specs: specs.join(" "),
                points: n,
                max: crate::sim::plan::MAX_CONDITIONS,
            });
        }
        p = p.product(&g);
    }
    Ok(p)
}

/// The most candidates a Fedorov exchange lists (beyond, the coordinate exchange).
pub const MAX_LISTED: f64 = 2e6;

/// The model's blocks and, checked, that every variable a block reads is set by `pts` or by
/// the region (variables the points leave out take their defaults only when `strict` is off).
///
/// # Errors
/// A variable the model reads that `pts` does not set.
pub fn check_variables(blocks: &[Block], pts: &Points, what: &str) -> Result<(), Error> {
    for v in models::variables(blocks) {
        if !pts.sets(&v) {
            return Err(Error::UnsetVariable {
                what: what.to_string(),
                sets: if pts.names.is_empty() {
                    "nothing".to_string()
                } else {
                    pts.names.join(", ")
                },
                variable: v,
            });
        }
    }
    Ok(())
}

/// The points of all `plans`, on the variables `vars`.
#[must_use]
pub fn union<'a>(plans: impl Iterator<Item = &'a Points>, vars: &[String]) -> Points {
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

/// The points as a table of the formula's columns, for explaining a rank deficiency.
pub(crate) fn to_table(pts: &Points, f: &crate::formula::Formula) -> crate::obs::Table {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_limit_reads_name_low_and_high_or_says_what_it_expects() {
        assert_eq!(
            "rate = -800:800".parse::<Limit>().unwrap(),
            Limit {
                name: "rate".into(),
                lo: -800.0,
                hi: 800.0
            }
        );
        for bad in [
            "rate",
            "rate=800",
            "rate=a:b",
            "=1:2",
            "rate=2:1",
            "rate=-inf:1",
        ] {
            let e = bad.parse::<Limit>().unwrap_err();
            assert!(matches!(&e, Error::Limit(text) if text == bad));
            assert_eq!(
                e.to_string(),
                format!("--limit `{bad}`: expected NAME=LO:HI, for example rate=-800:800")
            );
        }
    }

    #[test]
    fn points_beyond_a_limit_are_named() {
        let space = Space {
            unit: Unit::SingleAccel,
            temps: vec![25.0],
            volts: vec![5.0],
            region: Vec::new(),
            limits: vec!["rate=-800:800".parse().unwrap()],
            mission: None,
        };
        let pts = grids(&["rate=-1000:1000:3".into()]).unwrap();
        let beyond = space.check_limits(&pts, "the candidates").unwrap_err();
        assert!(matches!(beyond, Error::BeyondLimit { point: 1, .. }));
        assert_eq!(
            beyond.to_string(),
            "the candidates, point 1: rate = -1000 is outside the equipment's limits -800 to 800"
        );
        let inside = grids(&["rate=-800:800:3".into()]).unwrap();
        assert!(space.check_limits(&inside, "the plan").is_ok());
        let other = grids(&["temp=0:1:2".into()]).unwrap();
        let missing = space.check_limits(&other, "the plan").unwrap_err();
        assert!(matches!(&missing, Error::LimitOnNoVariable { name, .. } if name == "rate"));
        assert!(missing.to_string().contains("has no variable rate"));
    }
}
