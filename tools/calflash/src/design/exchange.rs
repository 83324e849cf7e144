//! Exact optimal designs by exchange: `n` points (repeats allowed) chosen from candidate model
//! rows to maximise `det(X'X)` (D), or minimise `trace(W (X'X)^-1)` with `W = I` (A) or `W`
//! the region's moment matrix (I, the average prediction variance).
//!
//! Modified Fedorov exchange: for each design point in turn, the candidate that improves the
//! criterion most replaces it; passes repeat until none improves. The gain of every candidate is
//! evaluated in `O(p)` from rank-one update formulas, and after a swap the inverse information
//! and the per-candidate quantities are updated in `O(N p)`, with a full recomputation every 25
//! swaps to keep rounding from accumulating. Each restart starts from a different random set of
//! `p` candidates completed greedily (the point of largest prediction variance next); the best
//! design over the restarts is kept.

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};

/// What to optimise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Criterion {
    /// Maximise `det(X'X)`: the smallest joint confidence region of the parameters.
    D,
    /// Minimise `trace((X'X)^-1)`: the smallest average parameter variance.
    A,
    /// Minimise the average prediction variance over the operating region.
    I,
}

/// Search settings.
#[derive(Debug, Clone)]
pub struct Options {
    /// Observations.
    pub n: usize,
    /// Restarts.
    pub restarts: usize,
    /// Seed of the random starts.
    pub seed: u64,
}

/// A design found.
#[derive(Debug, Clone)]
pub struct Found {
    /// Candidate indices of the points (repeats allowed), sorted.
    pub points: Vec<usize>,
    /// The criterion's value: `det(X'X)^(1/p) / n` (D) or `trace(W (X'X)^-1) * n` (A, I).
    pub value: f64,
    /// How many restarts reached (within 1e-9) the best value.
    pub hits: usize,
}

/// Why no design was found.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ExchangeError {
    /// Fewer observations than parameters.
    #[error("{n} observations cannot estimate {p} parameters; at least {p} are needed")]
    TooFew {
        /// Observations.
        n: usize,
        /// Parameters.
        p: usize,
    },
    /// The candidates cannot estimate the model.
    #[error(
        "no set of the candidates estimates every parameter (the candidate model rows have rank {rank} of {p})"
    )]
    Singular {
        /// Rank of the candidates.
        rank: usize,
        /// Parameters.
        p: usize,
    },
    /// A candidate's model row overflows.
    #[error("a candidate's model row is not finite: its values are too large for the model")]
    NotFinite,
}

/// What replacing design row `x_i` by `x_j` depends on, with `u = M^-1 x`: `d_i = x_i' u_i`,
/// `d_j = x_j' u_j`, `d_ij = x_i' u_j`, and for A and I `a_i = u_i' W u_i`, `a_j = u_j' W u_j`,
/// `w_ij = u_i' W u_j`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    pub di: f64,
    pub dj: f64,
    pub dij: f64,
    pub ai: f64,
    pub aj: f64,
    pub wij: f64,
}

impl Pair {
    /// The determinant ratio (D), or the new `trace(W M^-1)` from the current `phi` (A, I), by
    /// the rank-one update formulas (add `x_j`, then remove `x_i`); `None` when the swap makes
    /// the information singular.
    pub(crate) fn effect(&self, criterion: Criterion, phi: f64) -> Option<f64> {
        let Self {
            di,
            dj,
            dij,
            ai,
            aj,
            wij,
        } = *self;
        match criterion {
            Criterion::D => Some((1.0 + dj) * (1.0 - di) + dij * dij),
            _ => {
                let c = dij / (1.0 + dj);
                let d1 = di - dij * dij / (1.0 + dj);
                if 1.0 - d1 <= 1e-12 {
                    return None;
                }
                Some(phi - aj / (1.0 + dj) + (ai - 2.0 * c * wij + c * c * aj) / (1.0 - d1))
            }
        }
    }
}

/// The working state of one exchange: the design, `M^-1` and per-candidate quantities.
struct State<'a> {
    f: &'a DMatrix<f64>,
    w: Option<&'a DMatrix<f64>>,
    design: Vec<usize>,
    m_inv: DMatrix<f64>,
    /// `u_j = M^-1 x_j`, row j.
    u: DMatrix<f64>,
    /// `W u_j`, row j (A and I).
    wu: DMatrix<f64>,
    /// `d_j = x_j' M^-1 x_j`.
    d: Vec<f64>,
    /// `a_j = u_j' W u_j` (A and I).
    a: Vec<f64>,
    since_refresh: usize,
}

impl<'a> State<'a> {
    fn new(f: &'a DMatrix<f64>, w: Option<&'a DMatrix<f64>>, design: Vec<usize>) -> Option<Self> {
        let (nc, p) = f.shape();
        let mut s = Self {
            f,
            w,
            design,
            m_inv: DMatrix::zeros(p, p),
            u: DMatrix::zeros(nc, p),
            wu: DMatrix::zeros(nc, p),
            d: vec![0.0; nc],
            a: vec![0.0; nc],
            since_refresh: 0,
        };
        s.refresh().then_some(s)
    }

    /// Recomputes everything from the design; false when `X'X` is singular.
    fn refresh(&mut self) -> bool {
        let p = self.f.ncols();
        let x = DMatrix::from_fn(self.design.len(), p, |i, j| self.f[(self.design[i], j)]);
        let Some(m_inv) = inverse_information(x) else {
            return false;
        };
        self.u = self.f * &m_inv;
        for j in 0..self.f.nrows() {
            self.d[j] = self.f.row(j).dot(&self.u.row(j));
        }
        if let Some(w) = self.w {
            self.wu = &self.u * w;
            for j in 0..self.f.nrows() {
                self.a[j] = self.u.row(j).dot(&self.wu.row(j));
            }
        }
        self.m_inv = m_inv;
        self.since_refresh = 0;
        true
    }

    /// Adds (`sign = 1`) or removes (`sign = -1`) candidate `k` from the information.
    fn update(&mut self, k: usize, sign: f64) {
        let uk = self.u.row(k).transpose();
        let denom = 1.0 + sign * self.d[k];
        // s_x = x' M^-1 x_k for every candidate.
        let s_all = self.f * &uk;
        let (wuk, ak) = (self.wu.row(k).transpose(), self.a[k]);
        let t_all = if self.w.is_some() {
            Some(&self.u * &wuk)
        } else {
            None
        };
        for j in 0..self.f.nrows() {
            let c = sign * s_all[j] / denom;
            for col in 0..self.u.ncols() {
                self.u[(j, col)] -= c * uk[col];
            }
            self.d[j] -= sign * s_all[j] * s_all[j] / denom;
            if let Some(t) = &t_all {
                for col in 0..self.u.ncols() {
                    self.wu[(j, col)] -= c * wuk[col];
                }
                self.a[j] += -2.0 * c * t[j] + c * c * ak;
            }
        }
        self.m_inv -= (sign / denom) * &uk * uk.transpose();
    }

    fn value(&self, criterion: Criterion) -> f64 {
        let n = self.design.len() as f64;
        match criterion {
            Criterion::D => {
                let p = self.f.ncols();
                // det(M^-1)^(-1/p) / n from the inverse's eigenvalues (it is symmetric).
                let Ok(ev) = crate::stats::decompose::symmetric_eigenvalues(self.m_inv.clone())
                else {
                    return f64::NAN;
                };
                (-ev.iter().map(|v| v.ln()).sum::<f64>() / p as f64).exp() / n
            }
            _ => (self.w.expect("A and I have a weight") * &self.m_inv).trace() * n,
        }
    }

    /// The effect of replacing design candidate `i` by `j`: the determinant ratio (D) or the
    /// new `trace(W M^-1)` (A, I); `None` when the swap would make the information singular.
    fn effect(&self, i: usize, j: usize, criterion: Criterion, phi: f64) -> Option<f64> {
        let pair = Pair {
            di: self.d[i],
            dj: self.d[j],
            dij: self.u.row(i).dot(&self.f.row(j)),
            ai: self.a[i],
            aj: self.a[j],
            wij: if criterion == Criterion::D {
                0.0
            } else {
                self.wu.row(i).dot(&self.u.row(j))
            },
        };
        pair.effect(criterion, phi)
    }

    fn swap(&mut self, slot: usize, j: usize) {
        let i = self.design[slot];
        self.update(j, 1.0);
        self.update(i, -1.0);
        self.design[slot] = j;
        self.since_refresh += 1;
        if self.since_refresh >= 25 {
            self.refresh();
        }
    }

    /// `trace(W M^-1)` in the state's own units (without the factor n).
    fn phi(&self) -> f64 {
        self.w.map_or(0.0, |w| (w * &self.m_inv).trace())
    }
}

/// A random start: `p` candidates in random order that are jointly estimable, then greedily the
/// candidate of largest prediction variance until `n`.
fn start(f: &DMatrix<f64>, n: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Option<Vec<usize>> {
    let (nc, p) = f.shape();
    let mut order: Vec<usize> = (0..nc).collect();
    for k in (1..nc).rev() {
        order.swap(k, rng.random_range(0..=k));
    }
    // Gram-Schmidt over the random order picks p independent rows.
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut design = Vec::new();
    let scale = (0..nc)
        .map(|j| f.row(j).norm())
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    for &j in &order {
        let mut v = f.row(j).transpose();
        for b in &basis {
            let c = v.dot(b);
            v -= c * b;
        }
        if v.norm() > 1e-8 * scale {
            basis.push(v.normalize());
            design.push(j);
            if design.len() == p {
                break;
            }
        }
    }
    if design.len() < p {
        return None;
    }
    // Greedy completion by the largest prediction variance.
    let mut state = State::new(f, None, design)?;
    while state.design.len() < n {
        let j = (0..nc).max_by(|a, b| state.d[*a].total_cmp(&state.d[*b]))?;
        state.update(j, 1.0);
        state.design.push(j);
    }
    Some(state.design)
}

/// The columns of all blocks side by side, each distinct column once; `None` for one block.
fn distinct_columns(fs: &[DMatrix<f64>]) -> Option<DMatrix<f64>> {
    if fs.len() < 2 {
        return None;
    }
    let mut kept: Vec<DVector<f64>> = Vec::new();
    for f in fs {
        for c in f.column_iter() {
            let c = c.into_owned();
            if !kept.iter().any(|k| (k - &c).amax() <= 1e-12 * c.amax()) {
                kept.push(c);
            }
        }
    }
    Some(DMatrix::from_columns(&kept))
}

/// Finds an exact `criterion`-optimal design of `opts.n` points from the candidate model rows
/// `f` (`N x p`). `w` is the region's moment matrix for I (ignored otherwise). `progress(done,
/// total)` is called after each restart.
///
/// # Errors
/// Too few observations, or candidates that cannot estimate the model.
pub fn optimize(
    f: &DMatrix<f64>,
    criterion: Criterion,
    w: Option<&DMatrix<f64>>,
    opts: &Options,
    progress: impl FnMut(usize, usize),
) -> Result<Found, ExchangeError> {
    optimize_blocks(
        std::slice::from_ref(f),
        criterion,
        &[w.cloned()],
        opts,
        progress,
    )
}

/// Like [`optimize`] for several models observed at the same points (the three axes of a
/// triad, each with its own terms): `fs[b]` holds model `b`'s rows of the same `N` candidates.
/// The compound criterion is the product of the determinants (D) or the sum of the traces
/// (A, I); `ws[b]` is block `b`'s region moments for I.
///
/// # Errors
/// Too few observations, or candidates that cannot estimate a model.
pub fn optimize_blocks(
    fs: &[DMatrix<f64>],
    criterion: Criterion,
    ws: &[Option<DMatrix<f64>>],
    opts: &Options,
    mut progress: impl FnMut(usize, usize),
) -> Result<Found, ExchangeError> {
    let nc = fs[0].nrows();
    // Each column scaled to its largest candidate value: a model in SI over a wide range (a
    // cubic in rates to 2,000 rad/s spans 1 to 8e9) is otherwise too ill-conditioned for the
    // rank-one updates. With `X = X' S`, `(X'X)^-1 = S^-1 C' S^-1` and `tr(C W) = tr(C' W')`
    // with `W' = S^-1 W S^-1`: every criterion's optimum is unchanged, and D's value is scaled
    // back at the end.
    let scales: Vec<Vec<f64>> = fs
        .iter()
        .map(|f| {
            f.column_iter()
                .map(|c| {
                    let m = c.amax();
                    if m > 0.0 && m.is_finite() { m } else { 1.0 }
                })
                .collect()
        })
        .collect();
    let scaled: Vec<DMatrix<f64>> = fs
        .iter()
        .zip(&scales)
        .map(|(f, sc)| {
            let mut f = f.clone();
            for (mut c, s) in f.column_iter_mut().zip(sc) {
                c /= *s;
            }
            f
        })
        .collect();
    let fs = &scaled[..];
    for f in fs {
        let p = f.ncols();
        if opts.n < p {
            return Err(ExchangeError::TooFew { n: opts.n, p });
        }
        let sv = crate::stats::decompose::singular_values(f.clone())
            .map_err(|_| ExchangeError::NotFinite)?;
        let rank = sv.iter().filter(|s| **s > 1e-10 * sv.max()).count();
        if rank < p {
            return Err(ExchangeError::Singular { rank, p });
        }
    }
    let weights: Vec<Option<DMatrix<f64>>> = fs
        .iter()
        .enumerate()
        .map(|(b, f)| match criterion {
            Criterion::D => None,
            Criterion::A => Some(DMatrix::identity(f.ncols(), f.ncols())),
            Criterion::I => Some(
                ws.get(b)
                    .cloned()
                    .flatten()
                    .unwrap_or_else(|| DMatrix::identity(f.ncols(), f.ncols())),
            ),
        })
        .zip(&scales)
        .map(|(w, sc)| {
            w.map(|w| DMatrix::from_fn(w.nrows(), w.ncols(), |i, j| w[(i, j)] / (sc[i] * sc[j])))
        })
        .collect();
    // det(X'X)^(1/p) of the unscaled rows, from the scaled ones'.
    let unscale_d: f64 = scales
        .iter()
        .map(|sc| (sc.iter().map(|s| 2.0 * s.ln()).sum::<f64>() / sc.len() as f64).exp())
        .product();
    // The start is built on the blocks' columns together (each distinct column once), so that
    // it estimates every block (a triad's axes each have their own nonlinear terms); when
    // those are too many for the plan or dependent, on the widest block. The exchange then
    // works on all.
    let widest = (0..fs.len()).max_by_key(|b| fs[*b].ncols()).unwrap_or(0);
    let together = distinct_columns(fs).filter(|u| {
        u.ncols() <= opts.n
            && crate::stats::decompose::singular_values(u.clone())
                .is_ok_and(|sv| sv.iter().filter(|s| **s > 1e-10 * sv.max()).count() == u.ncols())
    });
    let start_rows = together.as_ref().unwrap_or(&fs[widest]);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let mut best: Option<Found> = None;
    let restarts = opts.restarts.max(1);
    let better = |v: f64, b: f64| match criterion {
        Criterion::D => v > b,
        _ => v < b,
    };
    for r in 0..restarts {
        progress(r, restarts);
        let Some(design) = start(start_rows, opts.n, &mut rng) else {
            continue;
        };
        let states: Option<Vec<State<'_>>> = fs
            .iter()
            .zip(&weights)
            .map(|(f, w)| State::new(f, w.as_ref(), design.clone()))
            .collect();
        let Some(mut states) = states else { continue };
        for _pass in 0..100 {
            let mut improved = false;
            for slot in 0..opts.n {
                let i = states[0].design[slot];
                let phis: Vec<f64> = states.iter().map(State::phi).collect();
                let total_phi: f64 = phis.iter().sum();
                let mut choice: Option<(usize, f64)> = None;
                'candidates: for j in 0..nc {
                    if j == i {
                        continue;
                    }
                    // D: the product of the blocks' determinant ratios, as a gain over 1.
                    // A, I: the relative decrease of the summed traces.
                    let mut acc = if criterion == Criterion::D { 1.0 } else { 0.0 };
                    for (st, phi) in states.iter().zip(&phis) {
                        let Some(e) = st.effect(i, j, criterion, *phi) else {
                            continue 'candidates;
                        };
                        if criterion == Criterion::D {
                            acc *= e;
                        } else {
                            acc += e;
                        }
                    }
                    let gain = if criterion == Criterion::D {
                        acc - 1.0
                    } else {
                        (total_phi - acc) / total_phi
                    };
                    if choice.is_none_or(|(_, g)| gain > g) {
                        choice = Some((j, gain));
                    }
                }
                if let Some((j, gain)) = choice
                    && gain > 1e-10
                {
                    for st in &mut states {
                        st.swap(slot, j);
                    }
                    improved = true;
                }
            }
            if !improved {
                break;
            }
        }
        let mut value = if criterion == Criterion::D {
            unscale_d
        } else {
            0.0
        };
        for st in &mut states {
            st.refresh();
            let v = st.value(criterion);
            if criterion == Criterion::D {
                value *= v;
            } else {
                value += v;
            }
        }
        match &mut best {
            Some(b) if (value - b.value).abs() <= 1e-9 * b.value.abs() => b.hits += 1,
            Some(b) if !better(value, b.value) => {}
            _ => {
                let mut points = states[0].design.clone();
                points.sort_unstable();
                best = Some(Found {
                    points,
                    value,
                    hits: 1,
                });
            }
        }
    }
    progress(restarts, restarts);
    let p = fs[0].ncols();
    best.ok_or(ExchangeError::Singular { rank: p, p })
}

/// `(X'X)^-1 = V S^-2 V'` from the SVD of the design `x` (never the normal equations); `None`
/// when `x` has fewer rows than columns or a singular value at or below 1e-10 of the largest.
pub(super) fn inverse_information(x: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let p = x.ncols();
    if x.nrows() < p {
        return None;
    }
    let svd = crate::stats::decompose::svd(x, false, true).ok()?;
    let v_t = svd.v_t?;
    let s = &svd.singular_values;
    if s.min() <= 1e-10 * s.max() {
        return None;
    }
    let mut m_inv = DMatrix::zeros(p, p);
    for (k, sk) in s.iter().enumerate() {
        let row = v_t.row(k);
        m_inv += (1.0 / (sk * sk)) * row.transpose() * row;
    }
    Some(m_inv)
}

#[cfg(test)]
mod tests;
