//! Predicting a calibration's precision from its plan, and confirming it: the expected standard
//! error of every term and the expected error at chosen operating points for a noise level; the
//! same through the simulator by Monte Carlo; the effect of a fixture's orientation error; and
//! the fewest observations that reach a target error.

use nalgebra::DMatrix;

use super::Error;
use super::criteria;
use super::exchange::{self, Criterion, Found};
use super::points::{Points, Unit};
use crate::columns as col;
use crate::sim::{self, plan::Condition};
use crate::stats;

/// Expected standard errors: of the terms, and of the prediction at each operating point.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Expected {
    /// Per term.
    pub terms: Vec<f64>,
    /// Per operating point.
    pub at: Vec<f64>,
}

/// `sigma` times the square roots of the covariance form's diagonal and of `x'(X'X)^-1 x`.
#[must_use]
pub fn expected(unscaled: &DMatrix<f64>, sigma: f64, at: &DMatrix<f64>) -> Expected {
    let terms = (0..unscaled.nrows())
        .map(|k| sigma * unscaled[(k, k)].sqrt())
        .collect();
    let at = criteria::prediction_variance(unscaled, 1, at)
        .iter()
        .map(|v| sigma * v.sqrt())
        .collect();
    Expected { terms, at }
}

/// The variance each point adds to axis `axis`'s output when the fixture holds the unit with a
/// random orientation error of `delta` radians (1 sigma about each axis): the input moves by
/// `e x f`, and the output by `scale` times its component along the axis, so the added variance
/// is `(scale delta)^2 (|f|^2 - f_axis^2)`. `scale` is counts per SI unit.
#[must_use]
pub fn orientation_variance(
    points: &Points,
    axis: usize,
    scale: f64,
    delta: f64,
    gyro: bool,
) -> Vec<f64> {
    let names = if gyro { col::W } else { col::F };
    (0..points.rows.len())
        .map(|r| {
            let v: Vec<f64> = names.iter().map(|n| points.value(r, n)).collect();
            let norm2: f64 = v.iter().map(|x| x * x).sum();
            (scale * delta).powi(2) * (norm2 - v[axis] * v[axis])
        })
        .collect()
}

/// The parameters' covariance when point `r`'s noise variance is `sigma^2 + extra[r]`:
/// `C X' diag(sigma^2 + extra) X C` with `C = (X'X)^-1`.
#[must_use]
pub fn covariance_with(
    x: &DMatrix<f64>,
    unscaled: &DMatrix<f64>,
    sigma: f64,
    extra: &[f64],
) -> DMatrix<f64> {
    let mut xw = x.clone();
    for (r, mut row) in xw.row_iter_mut().enumerate() {
        row *= (sigma * sigma + extra[r]).sqrt();
    }
    let b = unscaled * xw.transpose();
    &b * b.transpose()
}

/// The simulator's conditions for `points` (single axes read `input`, `input_p`, `input_o` as
/// the specific force, or the rate for a gyro).
#[must_use]
pub fn conditions(points: &Points, unit: Unit) -> Vec<Condition> {
    (0..points.rows.len())
        .map(|r| {
            let v = |n: &str| points.value(r, n);
            let single = [v(col::INPUT), v(col::INPUT_P), v(col::INPUT_O)];
            let (f, w) = match unit {
                Unit::SingleAccel => (single, [0.0; 3]),
                Unit::SingleGyro => ([0.0; 3], single),
                Unit::Triad => (col::F.map(v), col::W.map(v)),
            };
            Condition {
                f,
                w,
                dw: col::DW.map(v),
                h: col::H.map(v),
                temp: v(col::TEMP),
                volt: v(col::VOLT),
                dir: 0.0,
            }
        })
        .collect()
}

/// Monte Carlo through the simulator: standard deviations of the fitted terms and of the
/// predictions at the operating points over `runs` simulated calibrations.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MonteCarlo {
    /// Runs.
    pub runs: usize,
    /// Per term.
    pub terms: Vec<f64>,
    /// Per operating point.
    pub at: Vec<f64>,
}

fn sd(samples: &[Vec<f64>], k: usize) -> f64 {
    let n = samples.len() as f64;
    let mean = samples.iter().map(|s| s[k]).sum::<f64>() / n;
    (samples.iter().map(|s| (s[k] - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// The simulated unit of a Monte Carlo run.
#[derive(Debug, Clone, Copy)]
pub struct Simulation<'a> {
    /// The sensor and its truth.
    pub sensor: &'a sim::Sensor,
    /// How plan points drive it.
    pub unit: Unit,
    /// The simulated column the model fits.
    pub output: &'a str,
    /// Runs.
    pub runs: usize,
    /// Seed of the first run.
    pub seed: u64,
}

/// Simulates `sim.runs` calibrations through `points` and fits `x` (the plan's model rows) to
/// the simulated output column each time.
///
/// # Errors
/// A simulated fit that fails.
pub fn monte_carlo(
    points: &Points,
    sim: &Simulation<'_>,
    x: &DMatrix<f64>,
    at: &DMatrix<f64>,
    mut progress: impl FnMut(usize),
) -> Result<MonteCarlo, Error> {
    let (sensor, output, runs, seed) = (sim.sensor, sim.output, sim.runs, sim.seed);
    let conds = conditions(points, sim.unit);
    let names: Vec<String> = (0..x.ncols()).map(|k| format!("c{k}")).collect();
    let mut coefs = Vec::with_capacity(runs);
    let mut preds = Vec::with_capacity(runs);
    for r in 0..runs {
        let obs = sim::simulate(sensor, &conds, seed.wrapping_add(r as u64), false);
        let y = obs
            .column(output)
            .ok_or_else(|| Error::NoSimulatedColumn(output.to_string()))?;
        let fit = stats::fit(x, &y, names.clone(), false, &stats::Options::default())
            .map_err(|source| Error::SimulatedFit { run: r, source })?;
        let p: Vec<f64> = (0..at.nrows())
            .map(|i| {
                at.row(i)
                    .iter()
                    .zip(&fit.coefficients)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect();
        coefs.push(fit.coefficients);
        preds.push(p);
        progress(r + 1);
    }
    Ok(MonteCarlo {
        runs,
        terms: (0..x.ncols()).map(|k| sd(&coefs, k)).collect(),
        at: (0..at.nrows()).map(|k| sd(&preds, k)).collect(),
    })
}

/// The fewest observations whose optimal plan over the candidates `f` gives an expected error of
/// at most `target` at every operating point `at` for noise `sigma`.
#[derive(Debug, Clone)]
pub struct Smallest {
    /// Observations.
    pub n: usize,
    /// The plan.
    pub found: Found,
    /// Its largest expected error at the operating points.
    pub worst: f64,
}

/// What the smallest plan must reach: an expected error of at most `error` at the operating
/// points' model rows `at`, for output noise `sigma`.
#[derive(Debug, Clone, Copy)]
pub struct Target<'a> {
    /// Operating points' model rows.
    pub at: &'a DMatrix<f64>,
    /// Output noise.
    pub sigma: f64,
    /// The largest acceptable expected error.
    pub error: f64,
}

/// Searches `n` by doubling, then bisection, optimising each plan with `restarts` restarts.
///
/// # Errors
/// Candidates that cannot estimate the model, or a target not reached with 100,000 observations.
pub fn smallest_n(
    f: &DMatrix<f64>,
    criterion: Criterion,
    w: Option<&DMatrix<f64>>,
    goal: &Target<'_>,
    restarts: usize,
    mut progress: impl FnMut(usize),
) -> Result<Smallest, Error> {
    let (at, sigma, target) = (goal.at, goal.sigma, goal.error);
    let p = f.ncols();
    let mut worst_at = |n: usize| -> Result<(f64, Found), Error> {
        progress(n);
        let found = exchange::optimize(
            f,
            criterion,
            w,
            &exchange::Options {
                n,
                restarts,
                seed: 1,
            },
            |_, _| {},
        )?;
        let x = DMatrix::from_fn(n, p, |i, j| f[(found.points[i], j)]);
        let c = criteria::evaluate(&x, at, false).map_err(|d| Error::OptimalNotEstimable {
            n,
            column: d.column,
        })?;
        let e = expected(&c.unscaled_covariance, sigma, at);
        Ok((e.at.iter().fold(0.0f64, |m, v| m.max(*v)), found))
    };
    let mut hi = p.max(2);
    let mut best = worst_at(hi)?;
    while best.0 > target {
        if hi >= 100_000 {
            return Err(Error::TargetNotReached {
                n: hi,
                error: best.0,
                target,
            });
        }
        hi = (hi * 2).min(100_000);
        best = worst_at(hi)?;
    }
    let mut lo = (hi / 2).max(p - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let r = worst_at(mid)?;
        if r.0 <= target {
            hi = mid;
            best = r;
        } else {
            lo = mid;
        }
    }
    Ok(Smallest {
        n: hi,
        worst: best.0,
        found: best.1,
    })
}
