//! Levenberg-Marquardt for small nonlinear least-squares problems, with Marquardt's scaling.
//!
//! Each step solves `min |J d + r|^2 + lambda |D d|^2` by a QR decomposition of the stacked
//! matrix `[J; sqrt(lambda) D]` (never the normal equations). The covariance at the solution is
//! `s^2 (J'J)^-1` formed from the SVD of `J`, with `s^2 = RSS / (n - p)`.

use nalgebra::{DMatrix, DVector};

/// A least-squares problem: `p` parameters, `n` residuals.
pub trait Problem {
    /// Number of residuals.
    fn residual_count(&self) -> usize;

    /// The residuals at `p`.
    fn residuals(&self, p: &[f64], out: &mut [f64]);

    /// The Jacobian at `p` (`n x p`); forward differences unless overridden.
    fn jacobian(&self, p: &[f64], r: &[f64], out: &mut DMatrix<f64>) {
        let mut q = p.to_vec();
        let mut rq = vec![0.0; r.len()];
        for j in 0..p.len() {
            let h = 1e-7 * p[j].abs().max(1e-3);
            q[j] = p[j] + h;
            self.residuals(&q, &mut rq);
            for i in 0..r.len() {
                out[(i, j)] = (rq[i] - r[i]) / h;
            }
            q[j] = p[j];
        }
    }
}

/// The solution.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Parameters.
    pub p: Vec<f64>,
    /// Residuals at `p`.
    pub residuals: Vec<f64>,
    /// Sum of squared residuals.
    pub rss: f64,
    /// Jacobian at `p`.
    pub jacobian: DMatrix<f64>,
    /// Iterations taken.
    pub iterations: usize,
}

/// Why the solver stopped without a solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LmError {
    /// Fewer residuals than parameters.
    #[error(
        "{n} residuals for {p} parameters; at least as many residuals as parameters are needed"
    )]
    TooFew {
        /// Residuals.
        n: usize,
        /// Parameters.
        p: usize,
    },
    /// A residual was not finite at the start.
    #[error("the residuals are not finite at the starting point")]
    NotFinite,
    /// No convergence.
    #[error("no convergence in {0} iterations")]
    NoConvergence(usize),
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Minimises the sum of squared residuals of `problem` from `p0`.
///
/// # Errors
/// [`LmError`].
pub fn solve(
    problem: &impl Problem,
    p0: &[f64],
    max_iterations: usize,
) -> Result<Solution, LmError> {
    let (n, np) = (problem.residual_count(), p0.len());
    if n < np {
        return Err(LmError::TooFew { n, p: np });
    }
    let mut p = p0.to_vec();
    let mut r = vec![0.0; n];
    problem.residuals(&p, &mut r);
    let mut rss = sum_sq(&r);
    if !rss.is_finite() {
        return Err(LmError::NotFinite);
    }
    let mut j = DMatrix::zeros(n, np);
    problem.jacobian(&p, &r, &mut j);
    let mut d = vec![0.0f64; np];
    let mut lambda: f64 = 1e-3;
    let mut trial = vec![0.0; n];
    for it in 1..=max_iterations {
        for (k, dk) in d.iter_mut().enumerate() {
            *dk = dk.max(j.column(k).norm()).max(1e-300);
        }
        let mut improved = false;
        for _ in 0..40 {
            // [J; sqrt(lambda) D] delta = [-r; 0]
            let mut a = DMatrix::zeros(n + np, np);
            a.view_mut((0, 0), (n, np)).copy_from(&j);
            for k in 0..np {
                a[(n + k, k)] = lambda.sqrt() * d[k];
            }
            let mut b = DVector::zeros(n + np);
            for i in 0..n {
                b[i] = -r[i];
            }
            let qr = a.qr();
            let qtb = qr.q().transpose() * &b;
            let Some(delta) = qr.r().solve_upper_triangular(&qtb) else {
                lambda *= 10.0;
                continue;
            };
            let q: Vec<f64> = p.iter().zip(delta.iter()).map(|(x, dx)| x + dx).collect();
            problem.residuals(&q, &mut trial);
            let t = sum_sq(&trial);
            let step = delta
                .iter()
                .zip(&d)
                .map(|(x, s)| (x * s).powi(2))
                .sum::<f64>()
                .sqrt();
            let scale = p
                .iter()
                .zip(&d)
                .map(|(x, s)| (x * s).powi(2))
                .sum::<f64>()
                .sqrt();
            let small_step = step <= 1e-12 * (scale + 1e-12);
            if t.is_finite() && t <= rss {
                let relative = (rss - t) / rss.max(f64::MIN_POSITIVE);
                p = q;
                std::mem::swap(&mut r, &mut trial);
                rss = t;
                lambda = (lambda / 3.0).max(1e-15);
                improved = true;
                if relative < 1e-14 || small_step {
                    problem.jacobian(&p, &r, &mut j);
                    return Ok(Solution {
                        p,
                        residuals: r,
                        rss,
                        jacobian: j,
                        iterations: it,
                    });
                }
                break;
            }
            if small_step {
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            // No step lowers the sum: a minimum to the precision of the residuals.
            return Ok(Solution {
                p,
                residuals: r,
                rss,
                jacobian: j,
                iterations: it,
            });
        }
        problem.jacobian(&p, &r, &mut j);
    }
    Err(LmError::NoConvergence(max_iterations))
}

/// `s^2 (J'J)^-1` from the SVD of `J`, with `s^2 = rss / (n - p)`; `None` when `J` is rank
/// deficient (a relative singular value below 1e-12) or there are no degrees of freedom.
#[must_use]
pub fn covariance(sol: &Solution) -> Option<DMatrix<f64>> {
    let (n, np) = sol.jacobian.shape();
    covariance_with(sol, n.checked_sub(np)?)
}

/// [`covariance`] with the residual variance on `dof` degrees of freedom, for residuals that
/// do not each carry one (`None` when `dof` is zero).
#[must_use]
pub fn covariance_with(sol: &Solution, dof: usize) -> Option<DMatrix<f64>> {
    let np = sol.jacobian.ncols();
    if dof == 0 {
        return None;
    }
    let s2 = sol.rss / dof as f64;
    let svd = crate::stats::decompose::svd(sol.jacobian.clone(), false, true).ok()?;
    let v_t = svd.v_t?;
    let smax = svd.singular_values.max();
    if svd.singular_values.iter().any(|s| *s <= 1e-12 * smax) {
        return None;
    }
    let mut c = DMatrix::zeros(np, np);
    for k in 0..np {
        let row = v_t.row(k);
        let w = s2 / svd.singular_values[k].powi(2);
        c += w * row.transpose() * row;
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a exp(b x) on exact data: recovered from a poor start.
    struct Exp {
        x: Vec<f64>,
        y: Vec<f64>,
    }

    impl Problem for Exp {
        fn residual_count(&self) -> usize {
            self.x.len()
        }
        fn residuals(&self, p: &[f64], out: &mut [f64]) {
            for ((o, x), y) in out.iter_mut().zip(&self.x).zip(&self.y) {
                *o = p[0] * (p[1] * x).exp() - y;
            }
        }
    }

    #[test]
    fn recovers_an_exponential_and_rosenbrock() {
        let x: Vec<f64> = (0..20).map(|k| f64::from(k) * 0.1).collect();
        let y = x.iter().map(|x| 2.5 * (-1.3 * x).exp()).collect();
        let s = solve(&Exp { x, y }, &[1.0, 0.0], 200).unwrap();
        assert!(
            (s.p[0] - 2.5).abs() < 1e-9 && (s.p[1] + 1.3).abs() < 1e-9,
            "{:?}",
            s.p
        );

        struct Rosen;
        impl Problem for Rosen {
            fn residual_count(&self) -> usize {
                2
            }
            fn residuals(&self, p: &[f64], out: &mut [f64]) {
                out[0] = 10.0 * (p[1] - p[0] * p[0]);
                out[1] = 1.0 - p[0];
            }
        }
        let s = solve(&Rosen, &[-1.2, 1.0], 500).unwrap();
        assert!(
            (s.p[0] - 1.0).abs() < 1e-7 && (s.p[1] - 1.0).abs() < 1e-7,
            "{:?}",
            s.p
        );
    }

    #[test]
    fn covariance_of_a_linear_problem_is_the_ols_covariance() {
        // y = p0 + p1 x with noise: LM's covariance equals s^2 (X'X)^-1.
        struct Line {
            x: Vec<f64>,
            y: Vec<f64>,
        }
        impl Problem for Line {
            fn residual_count(&self) -> usize {
                self.x.len()
            }
            fn residuals(&self, p: &[f64], out: &mut [f64]) {
                for ((o, x), y) in out.iter_mut().zip(&self.x).zip(&self.y) {
                    *o = p[0] + p[1] * x - y;
                }
            }
        }
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let noise = [0.1, -0.2, 0.05, 0.0, 0.3, -0.1, -0.25, 0.15, 0.02, -0.07];
        let y: Vec<f64> = x
            .iter()
            .zip(noise)
            .map(|(x, e)| 1.0 + 2.0 * x + e)
            .collect();
        let s = solve(&Line { x: x.clone(), y }, &[0.0, 0.0], 50).unwrap();
        let c = covariance(&s).unwrap();
        let sxx: f64 = x.iter().map(|x| (x - 4.5).powi(2)).sum();
        let s2 = s.rss / 8.0;
        assert!((c[(1, 1)] - s2 / sxx).abs() < 1e-6 * s2 / sxx, "{c}");
        assert!((c[(0, 0)] - s2 * (0.1 + 4.5 * 4.5 / sxx)).abs() < 1e-6 * c[(0, 0)]);
    }
}
