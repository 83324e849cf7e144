//! Coordinate exchange (Meyer and Nachtsheim, 1995): exact optimal designs over factors with
//! levels (a rate table's steps, a chamber's temperatures) without listing every combination,
//! so spaces of billions of candidates are searched. Each pass changes one coordinate of one
//! design point at a time to the level that improves the criterion most, with the same
//! rank-one update formulas as the Fedorov exchange; passes repeat until none improves.

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};

use super::exchange::{Criterion, ExchangeError, Options, Pair, inverse_information};

/// One factor and the levels it can take.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// Its name.
    pub name: String,
    /// Its levels.
    pub levels: Vec<f64>,
}

/// A design found.
#[derive(Debug, Clone)]
pub struct Found {
    /// The points: one value per factor.
    pub points: Vec<Vec<f64>>,
    /// The criterion as [`super::exchange::Found::value`].
    pub value: f64,
    /// Restarts that reached it.
    pub hits: usize,
}

struct Info<'a, R: Fn(&[f64]) -> DVector<f64>> {
    row: &'a R,
    w: Option<&'a DMatrix<f64>>,
    points: Vec<Vec<f64>>,
    rows: Vec<DVector<f64>>,
    m_inv: DMatrix<f64>,
    swaps: usize,
}

impl<'a, R: Fn(&[f64]) -> DVector<f64>> Info<'a, R> {
    fn new(row: &'a R, w: Option<&'a DMatrix<f64>>, points: Vec<Vec<f64>>) -> Option<Self> {
        let rows: Vec<DVector<f64>> = points.iter().map(|p| row(p)).collect();
        let mut s = Self {
            row,
            w,
            points,
            rows,
            m_inv: DMatrix::zeros(0, 0),
            swaps: 0,
        };
        s.refresh().then_some(s)
    }

    fn refresh(&mut self) -> bool {
        let p = self.rows[0].len();
        let x = DMatrix::from_fn(self.rows.len(), p, |i, j| self.rows[i][j]);
        let Some(m_inv) = inverse_information(x) else {
            return false;
        };
        self.m_inv = m_inv;
        self.swaps = 0;
        true
    }

    fn phi(&self) -> f64 {
        self.w.map_or(0.0, |w| (w * &self.m_inv).trace())
    }

    fn pair(&self, xi: &DVector<f64>, xj: &DVector<f64>, criterion: Criterion) -> Pair {
        let (ui, uj) = (&self.m_inv * xi, &self.m_inv * xj);
        let (ai, aj, wij) = match (criterion, self.w) {
            (Criterion::D, _) | (_, None) => (0.0, 0.0, 0.0),
            (_, Some(w)) => {
                let wui = w * &ui;
                (ui.dot(&wui), uj.dot(&(w * &uj)), wui.dot(&uj))
            }
        };
        Pair {
            di: xi.dot(&ui),
            dj: xj.dot(&uj),
            dij: xi.dot(&uj),
            ai,
            aj,
            wij,
        }
    }

    /// Replaces point `slot` by `point` (its model row `x`).
    fn replace(&mut self, slot: usize, point: Vec<f64>, x: DVector<f64>) {
        for (v, sign) in [(x.clone(), 1.0), (self.rows[slot].clone(), -1.0)] {
            let u = &self.m_inv * &v;
            let denom = 1.0 + sign * v.dot(&u);
            self.m_inv -= (sign / denom) * &u * u.transpose();
        }
        self.points[slot] = point;
        self.rows[slot] = x;
        self.swaps += 1;
        if self.swaps >= 25 {
            self.refresh();
        }
    }

    fn value(&self, criterion: Criterion) -> f64 {
        let n = self.points.len() as f64;
        match criterion {
            Criterion::D => {
                let p = self.m_inv.nrows();
                let Ok(ev) = crate::stats::decompose::symmetric_eigenvalues(self.m_inv.clone())
                else {
                    return f64::NAN;
                };
                (-ev.iter().map(|v| v.ln()).sum::<f64>() / p as f64).exp() / n
            }
            _ => self.phi() * n,
        }
    }
}

/// Finds an exact `criterion`-optimal design of `opts.n` points over the factors, with `row`
/// the model row of a point (one value per factor) and `w` the region's moments for I.
///
/// # Errors
/// Too few observations, or no random start that estimates the model in 200 tries.
pub fn optimize<R: Fn(&[f64]) -> DVector<f64>>(
    factors: &[Factor],
    row: &R,
    criterion: Criterion,
    w: Option<&DMatrix<f64>>,
    opts: &Options,
    mut progress: impl FnMut(usize, usize),
) -> Result<Found, ExchangeError> {
    let random = |rng: &mut rand_chacha::ChaCha8Rng| -> Vec<f64> {
        factors
            .iter()
            .map(|f| f.levels[rng.random_range(0..f.levels.len())])
            .collect()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let p = row(&random(&mut rng)).len();
    if opts.n < p {
        return Err(ExchangeError::TooFew { n: opts.n, p });
    }
    let identity = DMatrix::identity(p, p);
    let weight = match criterion {
        Criterion::D => None,
        Criterion::A => Some(&identity),
        Criterion::I => Some(w.unwrap_or(&identity)),
    };
    let restarts = opts.restarts.max(1);
    let mut best: Option<Found> = None;
    for r in 0..restarts {
        progress(r, restarts);
        let Some(mut info) = (0..200)
            .find_map(|_| Info::new(row, weight, (0..opts.n).map(|_| random(&mut rng)).collect()))
        else {
            return Err(ExchangeError::Singular { rank: 0, p });
        };
        for _pass in 0..100 {
            let mut improved = false;
            for slot in 0..opts.n {
                for (k, factor) in factors.iter().enumerate() {
                    let phi = info.phi();
                    let xi = info.rows[slot].clone();
                    let mut choice: Option<(f64, Vec<f64>, DVector<f64>)> = None;
                    for &level in &factor.levels {
                        if level == info.points[slot][k] {
                            continue;
                        }
                        let mut point = info.points[slot].clone();
                        point[k] = level;
                        let xj = (info.row)(&point);
                        let Some(e) = info.pair(&xi, &xj, criterion).effect(criterion, phi) else {
                            continue;
                        };
                        let gain = if criterion == Criterion::D {
                            e - 1.0
                        } else {
                            (phi - e) / phi
                        };
                        if choice.as_ref().is_none_or(|(g, _, _)| gain > *g) {
                            choice = Some((gain, point, xj));
                        }
                    }
                    if let Some((gain, point, xj)) = choice
                        && gain > 1e-10
                    {
                        info.replace(slot, point, xj);
                        improved = true;
                    }
                }
            }
            if !improved {
                break;
            }
        }
        info.refresh();
        let value = info.value(criterion);
        let better = match criterion {
            Criterion::D => best.as_ref().is_none_or(|b| value > b.value * (1.0 + 1e-9)),
            _ => best.as_ref().is_none_or(|b| value < b.value * (1.0 - 1e-9)),
        };
        match &mut best {
            Some(b) if !better && (value - b.value).abs() <= 1e-9 * b.value.abs() => b.hits += 1,
            Some(_) if !better => {}
            _ => {
                let mut points = info.points.clone();
                points.sort_by(|a, b| {
                    a.iter()
                        .zip(b)
                        .map(|(x, y)| x.total_cmp(y))
                        .find(|o| o.is_ne())
                        .unwrap_or(std::cmp::Ordering::Equal)
                });
                best = Some(Found {
                    points,
                    value,
                    hits: 1,
                });
            }
        }
    }
    progress(restarts, restarts);
    best.ok_or(ExchangeError::Singular { rank: 0, p })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::exchange;

    fn quad2(x: &[f64]) -> DVector<f64> {
        DVector::from_vec(vec![1.0, x[0], x[1], x[0] * x[0], x[1] * x[1], x[0] * x[1]])
    }

    #[test]
    fn agrees_with_the_fedorov_exchange_over_the_listed_candidates() {
        let levels: Vec<f64> = (0..21).map(|k| -1.0 + 0.1 * f64::from(k)).collect();
        let factors = [
            Factor {
                name: "a".into(),
                levels: levels.clone(),
            },
            Factor {
                name: "b".into(),
                levels: levels.clone(),
            },
        ];
        let opts = Options {
            n: 12,
            restarts: 10,
            seed: 5,
        };
        let coord = optimize(&factors, &quad2, Criterion::D, None, &opts, |_, _| {}).unwrap();
        let cands: Vec<[f64; 2]> = levels
            .iter()
            .flat_map(|a| levels.iter().map(move |b| [*a, *b]))
            .collect();
        let f = DMatrix::from_fn(cands.len(), 6, |i, j| quad2(&cands[i])[j]);
        let fed = exchange::optimize(&f, Criterion::D, None, &opts, |_, _| {}).unwrap();
        assert!(
            (coord.value / fed.value - 1.0).abs() < 1e-6,
            "coordinate {} Fedorov {}",
            coord.value,
            fed.value
        );
        // And on a line, the known optimum.
        let line = |x: &[f64]| DVector::from_vec(vec![1.0, x[0]]);
        let found = optimize(
            &factors[..1],
            &line,
            Criterion::D,
            None,
            &Options {
                n: 8,
                restarts: 3,
                seed: 1,
            },
            |_, _| {},
        )
        .unwrap();
        let ends: Vec<f64> = found.points.iter().map(|p| p[0]).collect();
        assert_eq!(ends, [-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0]);
    }
}
