//! Searching for an optimal plan: Fedorov exchange over listed candidates, or coordinate
//! exchange over the levels of grid factors too many to list; and the usual plans to compare
//! the optimum with.

use nalgebra::DMatrix;

use super::Error;
use super::coordinate;
use super::exchange::{self, Criterion};
use super::models::Block;
use super::points::{self, Points, Unit};
use super::space::{self, Space};

/// What to search for.
#[derive(Debug, Clone)]
pub struct Search {
    /// Observations in the plan.
    pub n: usize,
    /// The criterion.
    pub criterion: Criterion,
    /// Candidate plan items the equipment reaches.
    pub candidates: Vec<String>,
    /// Candidate grids `NAME=LO:HI:N`.
    pub grid: Vec<String>,
    /// Random restarts of the exchange.
    pub restarts: usize,
    /// Seed of the restarts.
    pub seed: u64,
}

/// How the search goes.
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
pub struct Searched {
    /// The plan.
    pub plan: Points,
    /// How many restarts found it.
    pub hits: usize,
    /// What was searched, in words.
    pub over: String,
    /// The operating region the criterion averaged over.
    pub region: Points,
    /// The candidates, when they were listed (Fedorov).
    pub listed: Option<Points>,
}

impl Search {
    /// The method `Auto` stands for: coordinate exchange when the candidates are only grids of
    /// more than 50,000 combinations of one model, else Fedorov.
    #[must_use]
    pub fn method(&self, asked: Method, blocks: &[Block]) -> Method {
        let combinations: f64 = self
            .grid
            .iter()
            .filter_map(|g| points::grid(g).ok())
            .map(|g| g.rows.len() as f64)
            .product();
        match asked {
            Method::Auto
                if self.candidates.is_empty()
                    && !self.grid.is_empty()
                    && combinations > 50_000.0
                    && blocks.len() == 1 =>
            {
                Method::Coordinate
            }
            Method::Auto => Method::Fedorov,
            m => m,
        }
    }

    /// Searches by `method` (see [`Search::method`]), telling `progress` each restart done.
    ///
    /// # Errors
    /// Candidates or factors that cannot be read or do not set the model's variables, points
    /// beyond the limits, or no plan that estimates the model.
    pub fn run(
        &self,
        method: Method,
        space: &Space,
        blocks: &[Block],
        progress: impl FnMut(usize),
    ) -> Result<Searched, Error> {
        match self.method(method, blocks) {
            Method::Coordinate => self.coordinate(space, blocks, progress),
            _ => self.fedorov(space, blocks, progress),
        }
    }

    fn fedorov(
        &self,
        space: &Space,
        blocks: &[Block],
        mut progress: impl FnMut(usize),
    ) -> Result<Searched, Error> {
        let cands = space.candidates(&self.candidates, &self.grid)?;
        space::check_variables(blocks, &cands, "the candidates")?;
        space.check_limits(&cands, "the candidates")?;
        let fs: Vec<DMatrix<f64>> = blocks
            .iter()
            .map(|b| cands.model_rows(&b.formula))
            .collect();
        let ws: Vec<Option<DMatrix<f64>>> = blocks
            .iter()
            .map(|b| {
                if let Some((w, _, _)) = space.mission_weight(b, &cands, "the candidates")? {
                    return Ok(Some(w.inside));
                }
                let r = space.region_rows(&cands, b)?;
                Ok::<_, Error>(Some(r.transpose() * &r / r.nrows() as f64))
            })
            .collect::<Result<_, _>>()?;
        let opts = exchange::Options {
            n: self.n,
            restarts: self.restarts,
            seed: self.seed,
        };
        let found = exchange::optimize_blocks(&fs, self.criterion, &ws, &opts, |d, _| progress(d))
            .map_err(|source| Error::Exchange {
                source,
                terms: blocks
                    .iter()
                    .map(|b| b.formula.term_names().join(", "))
                    .collect::<Vec<_>>()
                    .join(" | "),
            })?;
        Ok(Searched {
            plan: cands.select(&found.points),
            hits: found.hits,
            over: format!("{} candidates (Fedorov exchange)", cands.rows.len()),
            region: cands.clone(),
            listed: Some(cands),
        })
    }

    fn coordinate(
        &self,
        space: &Space,
        blocks: &[Block],
        mut progress: impl FnMut(usize),
    ) -> Result<Searched, Error> {
        if !self.candidates.is_empty() {
            return Err(Error::Coordinate(
                "works on the levels of --grid factors; plan items are listed candidates (use --method fedorov)",
            ));
        }
        if blocks.len() != 1 {
            return Err(Error::Coordinate(
                "one model at a time (a formula or the single preset)",
            ));
        }
        let factor_grids: Vec<Points> = self
            .grid
            .iter()
            .map(|g| points::grid(g))
            .collect::<Result<_, _>>()?;
        if factor_grids.is_empty() {
            return Err(Error::Coordinate("give the factors as --grid NAME=LO:HI:N"));
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
        space::check_variables(blocks, &probe, "the factors")?;
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
        space.check_limits(&limits_probe, "the factors")?;
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
        let region = if space.region.is_empty() {
            use rand::{RngExt, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(self.seed ^ 0x5eed);
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
            space::grids(&space.region)?
        };
        let w = match space.mission_weight(&blocks[0], &limits_probe, "the factors")? {
            Some((w, _, _)) => w.inside,
            None => {
                let r = region.model_rows(&formula);
                r.transpose() * &r / r.nrows() as f64
            }
        };
        let opts = exchange::Options {
            n: self.n,
            restarts: self.restarts,
            seed: self.seed,
        };
        let found =
            coordinate::optimize(&factors, &row, self.criterion, Some(&w), &opts, |d, _| {
                progress(d)
            })
            .map_err(|source| Error::Exchange {
                source,
                terms: formula.term_names().join(", "),
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

    /// The usual plans to compare an optimum with: uniform spacing over each grid, and the 6, 12 and
    /// 24-position tumbles for triads.
    #[must_use]
    pub fn usual_plans(&self, space: &Space, cands: &Points) -> Vec<(String, Points)> {
        let mut out = Vec::new();
        if space.unit == Unit::Triad {
            for k in [6, 12, 24] {
                if let Ok(p) = points::from_items(
                    &[format!("tumble:{k}")],
                    &space.temps,
                    &space.volts,
                    1,
                    space.unit,
                ) {
                    // Repeated to the plan's size, as a station would.
                    let reps = self.n.div_ceil(p.rows.len()).max(1);
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
            let idx: Vec<usize> = (0..self.n)
                .map(|k| {
                    if self.n == 1 {
                        0
                    } else {
                        (k * (m - 1) + (self.n - 1) / 2) / (self.n - 1)
                    }
                })
                .collect();
            out.push((
                format!("uniform ({} points over the candidates)", self.n),
                cands.select(&idx),
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::models;

    fn search(candidates: &[&str], grid: &[&str]) -> Search {
        Search {
            n: 4,
            criterion: Criterion::D,
            candidates: candidates.iter().map(|s| s.to_string()).collect(),
            grid: grid.iter().map(|s| s.to_string()).collect(),
            restarts: 2,
            seed: 1,
        }
    }

    #[test]
    fn auto_lists_the_candidates_unless_grids_are_too_many_to_list() {
        let one = models::blocks("~ 1 + rate + temp", false).unwrap();
        let small = search(&[], &["rate=-10:10:21", "temp=-40:85:6"]);
        assert_eq!(small.method(Method::Auto, &one), Method::Fedorov);
        let large = search(&[], &["rate=-10:10:1001", "temp=-40:85:126"]);
        assert_eq!(large.method(Method::Auto, &one), Method::Coordinate);
        // Plan items are listed candidates; an explicit method is kept.
        let items = search(&["head:36"], &["rate=-10:10:1001", "temp=-40:85:126"]);
        assert_eq!(items.method(Method::Auto, &one), Method::Fedorov);
        assert_eq!(small.method(Method::Coordinate, &one), Method::Coordinate);
    }

    #[test]
    fn a_fedorov_search_finds_the_ends_of_a_line() {
        let blocks = models::blocks("~ 1 + rate", false).unwrap();
        let space = Space {
            unit: Unit::SingleGyro,
            temps: vec![25.0],
            volts: vec![5.0],
            region: Vec::new(),
            limits: Vec::new(),
            mission: None,
        };
        let found = search(&[], &["rate=-10:10:21"])
            .run(Method::Auto, &space, &blocks, |_| {})
            .unwrap();
        let mut rates: Vec<f64> = (0..4).map(|r| found.plan.value(r, "rate")).collect();
        rates.sort_by(f64::total_cmp);
        assert_eq!(rates, [-10.0, -10.0, 10.0, 10.0], "D-optimal for a line");
        assert!(found.listed.is_some());
    }
}
