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

#[cfg(test)]
mod mission_optima {
    use std::sync::Arc;

    use super::*;
    use crate::design::models;
    use crate::mission::Profile;

    /// A gyro's mission at the rates `w_x` (one sample each, equally spaced in time).
    fn mission(rates: &[f64]) -> Arc<Profile> {
        let n = rates.len();
        Arc::new(Profile {
            source: "mission".into(),
            t: (0..n).map(|i| i as f64).collect(),
            line: (1..=n as u64).collect(),
            f: None,
            w: Some(rates.iter().map(|r| [*r, 0.0, 0.0]).collect()),
            dw: Some(vec![[0.0; 3]; n]),
            temp: None,
            volt: None,
            notes: Vec::new(),
        })
    }

    fn space(profile: Arc<Profile>) -> Space {
        Space {
            unit: Unit::SingleGyro,
            temps: vec![25.0],
            volts: vec![5.0],
            region: Vec::new(),
            limits: Vec::new(),
            mission: Some(profile),
        }
    }

    fn plan_over(model: &str, profile: Arc<Profile>, n: usize) -> (Vec<f64>, f64) {
        let blocks = models::blocks(model, true).unwrap();
        let s = Search {
            n,
            criterion: Criterion::I,
            candidates: Vec::new(),
            grid: vec!["input=-1:1:21".into()],
            restarts: 20,
            seed: 3,
        };
        let space = space(profile);
        let found = s.run(Method::Fedorov, &space, &blocks, |_| {}).unwrap();
        let mut rates: Vec<f64> = (0..n).map(|r| found.plan.value(r, "input")).collect();
        rates.sort_by(f64::total_cmp);
        let c = space
            .evaluate_plan("found", &found.plan, &blocks, &found.plan)
            .unwrap();
        let (w, _, _) = space
            .mission_weight(&blocks[0], found.listed.as_ref().unwrap(), "the candidates")
            .unwrap()
            .unwrap();
        let value = crate::mission::weight::mean_variance(&c[0].unscaled_covariance, n, &w.inside);
        (rates, value)
    }

    #[test]
    fn a_line_for_a_flight_at_one_rate_leans_three_to_one_towards_it() {
        // B = [[1, m], [m, m^2]] with m = 1/2: the I-optimal weights at -1 and +1 are 1/4 and
        // 3/4 (a = w+ - w- solves m a^2 - (1 + m^2) a + m = 0), and n tr(C B) = 1 exactly.
        let (rates, value) = plan_over("~ 1 + input", mission(&[0.5; 10]), 40);
        assert_eq!(
            rates.iter().filter(|r| **r == -1.0).count(),
            10,
            "{rates:?}"
        );
        assert_eq!(rates.iter().filter(|r| **r == 1.0).count(), 30, "{rates:?}");
        assert!((value - 1.0).abs() < 1e-9, "{value}");
    }

    #[test]
    fn a_quadratic_for_a_uniform_flight_is_the_textbook_i_optimum() {
        // Rates spread evenly over [-1, 1]: the I-optimal weights are 1/4, 1/2, 1/4 at -1, 0, 1.
        let rates: Vec<f64> = (0..=2000).map(|k| -1.0 + f64::from(k) / 1000.0).collect();
        let (plan, value) = plan_over("~ 1 + input + input^2", mission(&rates), 40);
        let count = |x: f64| plan.iter().filter(|r| (**r - x).abs() < 1e-12).count();
        assert_eq!(
            (count(-1.0), count(0.0), count(1.0)),
            (10, 20, 10),
            "{plan:?}"
        );
        // The continuous optimum's value: tr(M^-1 B) with M = [[1,0,1/2],[0,1/2,0],[1/2,0,1/2]].
        let m =
            nalgebra::DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.5, 0.0, 0.5, 0.0, 0.5, 0.0, 0.5]);
        let f = nalgebra::DMatrix::from_fn(rates.len(), 3, |i, j| rates[i].powi(j as i32));
        // Trapezoid weights: the end samples stand for half a step.
        let mut b = f.transpose() * &f;
        for i in [0, rates.len() - 1] {
            let r = f.row(i).transpose();
            b -= 0.5 * &r * r.transpose();
        }
        b /= (rates.len() - 1) as f64;
        let want = (m.try_inverse().unwrap() * b).trace();
        assert!((value / want - 1.0).abs() < 1e-9, "{value} against {want}");
    }
}
