//! The accelerometer from gravity alone: at every still pose the calibrated specific force has
//! the magnitude of local gravity. The model is the device's correction form,
//!
//! ```text
//! a = M (v + q * v^2) + o,    v = raw - center   (per axis, counts)
//! ```
//!
//! with `M` upper triangular (the body frame is the accelerometer frame: x along the x axis, y in
//! the x-y plane), `o` the offset (`-M b` for a bias `b` in counts) and `q` optional per-axis
//! quadratic terms, kept when a partial F test says they are significant. Levenberg-Marquardt
//! with the analytic Jacobian; covariance from the Jacobian.

use nalgebra::DMatrix;

use super::lm::{self, LmError, Problem, Solution};

/// Parameters: `M` upper triangle row by row (6), `o` (3), then `q` (3) when quadratic.
pub const LINEAR_TERMS: [&str; 9] = ["M11", "M12", "M13", "M22", "M23", "M33", "o1", "o2", "o3"];
/// The quadratic terms' names.
pub const QUADRATIC_TERMS: [&str; 3] = ["q1", "q2", "q3"];

/// The fitted correction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AccelModel {
    /// Zero-input code per axis (counts).
    pub center: [f64; 3],
    /// Scale-misalignment, upper triangular, m/s^2 per count.
    pub matrix: [[f64; 3]; 3],
    /// Offset, m/s^2.
    pub offset: [f64; 3],
    /// Per-axis quadratic terms, 1/count (zero when not kept).
    pub quadratic: [f64; 3],
}

impl AccelModel {
    /// Calibrated specific force for raw counts.
    #[must_use]
    pub fn apply(&self, raw: [f64; 3]) -> [f64; 3] {
        let u: [f64; 3] = std::array::from_fn(|j| {
            let v = raw[j] - self.center[j];
            v + self.quadratic[j] * v * v
        });
        std::array::from_fn(|i| {
            self.offset[i] + (0..3).map(|j| self.matrix[i][j] * u[j]).sum::<f64>()
        })
    }

    /// The model of parameters `p` (the fit's order) about `center`.
    #[must_use]
    pub fn from_params(center: [f64; 3], p: &[f64]) -> Self {
        let n = p.len();
        let p = |k: usize| p.get(k).copied().unwrap_or(0.0);
        Self {
            center,
            matrix: [[p(0), p(1), p(2)], [0.0, p(3), p(4)], [0.0, 0.0, p(5)]],
            offset: [p(6), p(7), p(8)],
            quadratic: if n == 12 {
                [p(9), p(10), p(11)]
            } else {
                [0.0; 3]
            },
        }
    }
}

/// The same correction referred to the center `to`: parameters in the layout of
/// [`LINEAR_TERMS`] (and [`QUADRATIC_TERMS`] when there are 12) for a model whose center is
/// `from`. With `d = to - from` and `s = 1 + 2 q d` per axis, `v_from = v_to + d` gives
/// `M' = M diag(s)`, `q' = q / s` and `o' = o + M (d + q d^2)`: the same function of the raw
/// codes. (Only when some `1 + 2 q d` is zero, far outside any sensor's range, is it not.)
#[must_use]
pub fn recentered(params: &[f64], from: [f64; 3], to: [f64; 3]) -> Vec<f64> {
    let m = AccelModel::from_params(from, params);
    let d: [f64; 3] = std::array::from_fn(|j| to[j] - from[j]);
    let s: [f64; 3] = std::array::from_fn(|j| 1.0 + 2.0 * m.quadratic[j] * d[j]);
    let shift: [f64; 3] = std::array::from_fn(|j| d[j] + m.quadratic[j] * d[j] * d[j]);
    let mut out = Vec::with_capacity(params.len());
    for (i, j) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)] {
        out.push(m.matrix[i][j] * s[j]);
    }
    for i in 0..3 {
        out.push(m.offset[i] + (0..3).map(|j| m.matrix[i][j] * shift[j]).sum::<f64>());
    }
    if params.len() == 12 {
        out.extend((0..3).map(|j| m.quadratic[j] / s[j]));
    }
    out
}

struct Gravity<'a> {
    /// Pose means minus center, counts.
    v: &'a [[f64; 3]],
    g: f64,
    quadratic: bool,
}

impl Gravity<'_> {
    fn force(&self, p: &[f64], v: &[f64; 3]) -> ([f64; 3], [f64; 3]) {
        let q = if self.quadratic {
            [p[9], p[10], p[11]]
        } else {
            [0.0; 3]
        };
        let u: [f64; 3] = std::array::from_fn(|j| v[j] + q[j] * v[j] * v[j]);
        let a = [
            p[0] * u[0] + p[1] * u[1] + p[2] * u[2] + p[6],
            p[3] * u[1] + p[4] * u[2] + p[7],
            p[5] * u[2] + p[8],
        ];
        (a, u)
    }
}

impl Problem for Gravity<'_> {
    fn residual_count(&self) -> usize {
        self.v.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        for (o, v) in out.iter_mut().zip(self.v) {
            let (a, _) = self.force(p, v);
            *o = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - self.g;
        }
    }

    fn jacobian(&self, p: &[f64], _r: &[f64], out: &mut DMatrix<f64>) {
        for (i, v) in self.v.iter().enumerate() {
            let (a, u) = self.force(p, v);
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
                .sqrt()
                .max(f64::MIN_POSITIVE);
            let e = [a[0] / norm, a[1] / norm, a[2] / norm];
            let row = [
                e[0] * u[0],
                e[0] * u[1],
                e[0] * u[2],
                e[1] * u[1],
                e[1] * u[2],
                e[2] * u[2],
                e[0],
                e[1],
                e[2],
            ];
            for (k, x) in row.iter().enumerate() {
                out[(i, k)] = *x;
            }
            if self.quadratic {
                // du_j/dq_j = v_j^2; da/du_j = column j of M.
                let m = [[p[0], p[1], p[2]], [0.0, p[3], p[4]], [0.0, 0.0, p[5]]];
                for j in 0..3 {
                    let col = e[0] * m[0][j] + e[1] * m[1][j] + e[2] * m[2][j];
                    out[(i, 9 + j)] = col * v[j] * v[j];
                }
            }
        }
    }
}

/// A fit of the accelerometer to gravity.
#[derive(Debug, Clone)]
pub struct AccelFit {
    /// The correction.
    pub model: AccelModel,
    /// Parameter names, in order.
    pub terms: Vec<&'static str>,
    /// Parameters.
    pub params: Vec<f64>,
    /// Their covariance (`None` if the Jacobian is rank deficient).
    pub covariance: Option<DMatrix<f64>>,
    /// `|a| - g` at each pose, m/s^2.
    pub residuals: Vec<f64>,
    /// Iterations.
    pub iterations: usize,
}

impl AccelFit {
    /// RMS of the residuals, m/s^2.
    #[must_use]
    pub fn rms(&self) -> f64 {
        (self.residuals.iter().map(|r| r * r).sum::<f64>() / self.residuals.len() as f64).sqrt()
    }

    /// Largest residual magnitude, m/s^2.
    #[must_use]
    pub fn max(&self) -> f64 {
        self.residuals.iter().fold(0.0, |m, r| m.max(r.abs()))
    }

    /// Residual standard deviation with its degrees of freedom, m/s^2.
    #[must_use]
    pub fn sigma(&self) -> f64 {
        let dof = self
            .residuals
            .len()
            .saturating_sub(self.params.len())
            .max(1);
        (self.residuals.iter().map(|r| r * r).sum::<f64>() / dof as f64).sqrt()
    }
}

/// A start from the extremes of each axis: about `+g` and `-g` among the poses.
#[must_use]
pub fn center_and_start(means: &[[f64; 3]], g: f64) -> ([f64; 3], Vec<f64>) {
    let (lo, hi): (Vec<f64>, Vec<f64>) = (0..3)
        .map(|j| {
            means
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
                    (lo.min(m[j]), hi.max(m[j]))
                })
        })
        .unzip();
    let center: [f64; 3] = std::array::from_fn(|j| ((lo[j] + hi[j]) / 2.0).round());
    let s: [f64; 3] = std::array::from_fn(|j| 2.0 * g / (hi[j] - lo[j]).max(1e-9));
    let b: [f64; 3] = std::array::from_fn(|j| (lo[j] + hi[j]) / 2.0 - center[j]);
    (
        center,
        vec![
            s[0],
            0.0,
            0.0,
            s[1],
            0.0,
            s[2],
            -s[0] * b[0],
            -s[1] * b[1],
            -s[2] * b[2],
        ],
    )
}

/// Fits the correction to pose means (raw counts) for gravity `g`; with `quadratic`, the
/// per-axis quadratic terms too.
///
/// # Errors
/// Too few poses, or no convergence.
pub fn fit(
    means: &[[f64; 3]],
    g: f64,
    center: [f64; 3],
    start: &[f64],
    quadratic: bool,
) -> Result<AccelFit, LmError> {
    let v = about(means, center);
    let problem = Gravity {
        v: &v,
        g,
        quadratic,
    };
    let mut p0 = start[..9].to_vec();
    if quadratic {
        p0.extend_from_slice(start.get(9..12).unwrap_or(&[0.0; 3]));
    }
    let sol: Solution = lm::solve(&problem, &p0, 200)?;
    let mut terms = LINEAR_TERMS.to_vec();
    if quadratic {
        terms.extend(QUADRATIC_TERMS);
    }
    Ok(AccelFit::of(sol, center, terms, means.len()))
}

/// The pose means `means` less `center`.
fn about(means: &[[f64; 3]], center: [f64; 3]) -> Vec<[f64; 3]> {
    means
        .iter()
        .map(|m| std::array::from_fn(|j| m[j] - center[j]))
        .collect()
}

impl AccelFit {
    /// The fit of the solution `sol` about `center`, its parameters named `terms`; the residuals
    /// are its first `poses` (the poses', before any pseudo-observation).
    fn of(mut sol: Solution, center: [f64; 3], terms: Vec<&'static str>, poses: usize) -> Self {
        let covariance = lm::covariance(&sol);
        sol.residuals.truncate(poses);
        Self {
            model: AccelModel::from_params(center, &sol.p),
            terms,
            params: sol.p,
            covariance,
            residuals: sol.residuals,
            iterations: sol.iterations,
        }
    }
}

/// `Gravity` with its cross-axis terms (`M12`, `M13`, `M23`) held near `cross` by three
/// pseudo-observations of weight `w` (m/s^2 per unit of the term).
struct HeldCross<'a> {
    gravity: Gravity<'a>,
    cross: [f64; 3],
    w: f64,
}

/// The cross-axis terms' places among the parameters.
const CROSS: [usize; 3] = [1, 2, 4];

impl Problem for HeldCross<'_> {
    fn residual_count(&self) -> usize {
        self.gravity.residual_count() + 3
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let n = self.gravity.residual_count();
        self.gravity.residuals(p, &mut out[..n]);
        for (k, &j) in CROSS.iter().enumerate() {
            out[n + k] = self.w * (p[j] - self.cross[k]);
        }
    }

    fn jacobian(&self, p: &[f64], r: &[f64], out: &mut DMatrix<f64>) {
        let n = self.gravity.residual_count();
        let mut top = DMatrix::zeros(n, p.len());
        self.gravity.jacobian(p, &r[..n], &mut top);
        out.fill(0.0);
        out.view_mut((0, 0), (n, p.len())).copy_from(&top);
        for (k, &j) in CROSS.iter().enumerate() {
            out[(n + k, j)] = self.w;
        }
    }
}

/// Fits the linear correction to pose means with its cross-axis terms held at `start`'s by a
/// weight `w` (m/s^2 per unit): for poses that face only the axes (a six-face session), where
/// `|a| = g` sees the cross-axis terms only to second order. The residuals are the poses'.
///
/// # Errors
/// Too few poses, or no convergence.
pub fn fit_held_cross(
    means: &[[f64; 3]],
    g: f64,
    center: [f64; 3],
    start: &[f64],
    w: f64,
) -> Result<AccelFit, LmError> {
    let v = about(means, center);
    let problem = HeldCross {
        gravity: Gravity {
            v: &v,
            g,
            quadratic: false,
        },
        cross: CROSS.map(|j| start[j]),
        w,
    };
    let sol: Solution = lm::solve(&problem, &start[..9], 200)?;
    Ok(AccelFit::of(
        sol,
        center,
        LINEAR_TERMS.to_vec(),
        means.len(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Poses spread over the sphere, seen through a known sensor.
    pub(crate) fn poses(n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = k as f64 * 2.399_963;
                [r * phi.cos(), r * phi.sin(), z]
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_accelerometer_with_and_without_quadratic_terms() {
        let g = 9.81;
        // Truth in the correction form.
        let truth = AccelModel {
            center: [32768.0, 32768.0, 32768.0],
            matrix: [
                [1.0 / 410.0, 2e-5, -1e-5],
                [0.0, 1.0 / 415.0, 3e-5],
                [0.0, 0.0, 1.0 / 412.0],
            ],
            offset: [0.05, -0.03, 0.08],
            quadratic: [2e-6, 0.0, -1e-6],
        };
        // Invert the truth for raw counts at each pose by Newton's method.
        let raw: Vec<[f64; 3]> = poses(40)
            .iter()
            .map(|d| {
                let target = [g * d[0], g * d[1], g * d[2]];
                let mut x = [32768.0; 3];
                for _ in 0..50 {
                    let a = truth.apply(x);
                    let e: Vec<f64> = (0..3).map(|i| target[i] - a[i]).collect();
                    // Back-substitute through the upper-triangular matrix (quadratic ignored in
                    // the step, Newton converges anyway).
                    let mut du = [0.0; 3];
                    for i in (0..3).rev() {
                        let s: f64 = (i + 1..3).map(|j| truth.matrix[i][j] * du[j]).sum();
                        du[i] = (e[i] - s) / truth.matrix[i][i];
                    }
                    for j in 0..3 {
                        let v = x[j] - 32768.0;
                        x[j] += du[j] / (1.0 + 2.0 * truth.quadratic[j] * v);
                    }
                }
                x
            })
            .collect();
        let (center, start) = center_and_start(&raw, g);
        let lin = fit(&raw, g, center, &start, false).unwrap();
        assert!(
            lin.rms() > 1e-4,
            "the quadratic truth leaves a linear residual: {}",
            lin.rms()
        );
        let mut s2 = lin.params.clone();
        s2.extend([0.0; 3]);
        let quad = fit(&raw, g, center, &s2, true).unwrap();
        assert!(quad.rms() < 1e-9, "{}", quad.rms());
        // The recovered correction agrees with the truth everywhere in the range.
        for x in [[30000.0, 33000.0, 35000.0], [36000.0, 29000.0, 32000.0]] {
            let (a, b) = (truth.apply(x), quad.model.apply(x));
            for i in 0..3 {
                assert!((a[i] - b[i]).abs() < 1e-6, "{a:?} {b:?}");
            }
        }
    }
}

#[cfg(test)]
mod recenter_tests {
    use super::*;

    #[test]
    fn a_recentered_model_is_the_same_function_of_the_codes() {
        let p = [
            2.4e-3, 3e-5, -2e-5, 2.45e-3, 4e-5, 2.41e-3, 0.57, -0.16, 0.09, 2e-7, -1e-7, 3e-7,
        ];
        let (from, to) = (
            [32_768.0, 32_700.5, 33_010.0],
            [32_771.0, 32_690.0, 33_000.25],
        );
        for params in [&p[..9], &p[..]] {
            let a = AccelModel::from_params(from, params);
            let b = AccelModel::from_params(to, &recentered(params, from, to));
            for raw in [
                [32_768.0, 32_768.0, 32_768.0],
                [28_000.0, 37_500.0, 30_100.0],
            ] {
                let (x, y) = (a.apply(raw), b.apply(raw));
                for i in 0..3 {
                    assert!(
                        (x[i] - y[i]).abs() < 1e-9 * (1.0 + x[i].abs()),
                        "{x:?} {y:?}"
                    );
                }
            }
        }
    }
}
