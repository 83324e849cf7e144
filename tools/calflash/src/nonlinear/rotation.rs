//! The gyro from the rotations between still poses: integrating the calibrated rate from the end
//! of one pose to the start of the next must turn the gravity direction seen at the first pose
//! into the one seen at the next. The model is the device's correction form,
//!
//! ```text
//! w = M (raw - bias)    (rad/s; M full 3x3: scale, misalignment to the accelerometer frame)
//! ```
//!
//! The bias (counts) is known during each rotation from the still poses around it (the mean
//! gyro output at each pose, interpolated in time), so the fit has the nine entries of `M`.
//! Integration: the rotation vector of each step from the mid-step rate with the coning
//! correction, composed exactly (Rodrigues).

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::lm::{self, LmError, Problem};

/// The parameter names: `M` row by row.
pub const TERMS: [&str; 9] = [
    "G11", "G12", "G13", "G21", "G22", "G23", "G31", "G32", "G33",
];

/// One rotation between two still poses.
#[derive(Debug, Clone)]
pub struct Segment {
    /// Time steps, s (`x.len() - 1` of them).
    pub dt: Vec<f64>,
    /// Gyro counts minus the bias, at each sample.
    pub x: Vec<[f64; 3]>,
    /// Gravity direction (unit) at the pose before, body frame.
    pub from: [f64; 3],
    /// At the pose after.
    pub to: [f64; 3],
}

/// The unit quaternion `[w, x, y, z]` of the rotation vector `phi`: exact to double precision
/// for the small per-sample angles here (a Taylor series below 0.05 rad, sin and cos above).
fn quat_of(phi: [f64; 3]) -> [f64; 4] {
    let t2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    let (c, s) = if t2 < 2.5e-3 {
        // cos(t/2) and sin(t/2)/t to t^6: error below 1e-14 at 0.05 rad.
        (
            1.0 - t2 / 8.0 + t2 * t2 / 384.0 - t2 * t2 * t2 / 46_080.0,
            0.5 - t2 / 48.0 + t2 * t2 / 3840.0 - t2 * t2 * t2 / 645_120.0,
        )
    } else {
        let t = t2.sqrt();
        ((0.5 * t).cos(), (0.5 * t).sin() / t)
    };
    [c, s * phi[0], s * phi[1], s * phi[2]]
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The rotation over `seg` with the gyro matrix `m`: `R` maps body vectors at the end to body
/// vectors at the start (`g_to = R^T g_from`).
#[must_use]
pub fn integrate(m: &Matrix3<f64>, seg: &Segment) -> Matrix3<f64> {
    let w = |x: &[f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| m[(i, 0)] * x[0] + m[(i, 1)] * x[1] + m[(i, 2)] * x[2])
    };
    let mut q = [1.0, 0.0, 0.0, 0.0];
    let mut w0 = w(&seg.x[0]);
    for (k, dt) in seg.dt.iter().enumerate() {
        let w1 = w(&seg.x[k + 1]);
        let c = [
            w0[1] * w1[2] - w0[2] * w1[1],
            w0[2] * w1[0] - w0[0] * w1[2],
            w0[0] * w1[1] - w0[1] * w1[0],
        ];
        let phi: [f64; 3] =
            std::array::from_fn(|i| 0.5 * (w0[i] + w1[i]) * dt + c[i] * (dt * dt / 12.0));
        q = quat_mul(q, quat_of(phi));
        w0 = w1;
    }
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = q.map(|v| v / n);
    Matrix3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    )
}

/// Angle between the predicted and the measured gravity direction after `seg`, radians.
#[must_use]
pub fn angle(m: &Matrix3<f64>, seg: &Segment) -> f64 {
    let r = integrate(m, seg);
    let p = r.transpose() * Vector3::from(seg.from);
    let t = Vector3::from(seg.to);
    p.cross(&t).norm().atan2(p.dot(&t))
}

/// Forward differences of `problem`'s residuals `r` at the matrix `p`, with one step relative to
/// the matrix's size (its entries share one scale; the off-diagonal ones are near zero).
fn matrix_jacobian(problem: &impl Problem, p: &[f64], r: &[f64], out: &mut DMatrix<f64>) {
    let mut q = p.to_vec();
    let mut hi = vec![0.0; r.len()];
    let h = 1e-7 * p.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-12);
    for j in 0..p.len() {
        q[j] = p[j] + h;
        problem.residuals(&q, &mut hi);
        q[j] = p[j];
        for i in 0..r.len() {
            out[(i, j)] = (hi[i] - r[i]) / h;
        }
    }
}

struct Rotations<'a> {
    segments: &'a [Segment],
}

fn matrix(p: &[f64]) -> Matrix3<f64> {
    Matrix3::new(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8])
}

impl Problem for Rotations<'_> {
    fn residual_count(&self) -> usize {
        3 * self.segments.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let m = matrix(p);
        for (k, seg) in self.segments.iter().enumerate() {
            let r = integrate(&m, seg);
            let pred = r.transpose() * Vector3::from(seg.from);
            for i in 0..3 {
                out[3 * k + i] = seg.to[i] - pred[i];
            }
        }
    }

    fn jacobian(&self, p: &[f64], r: &[f64], out: &mut DMatrix<f64>) {
        matrix_jacobian(self, p, r, out);
    }
}

/// A turn of known rotation vector (a Ferraris session's turn about one axis): the gyro's
/// counts less the bias over it must integrate to `angle`.
#[derive(Debug, Clone)]
pub struct KnownTurn {
    /// Time steps, s.
    pub dt: Vec<f64>,
    /// Gyro counts minus the bias, at each sample.
    pub x: Vec<[f64; 3]>,
    /// The rotation vector it turns through, rad (body frame).
    pub angle: [f64; 3],
}

impl KnownTurn {
    /// The counts integrated over the turn (trapezoid), count-seconds.
    fn integral(&self) -> [f64; 3] {
        let mut s = [0.0; 3];
        for (w, dt) in self.x.windows(2).zip(&self.dt) {
            for j in 0..3 {
                s[j] += 0.5 * (w[0][j] + w[1][j]) * dt;
            }
        }
        s
    }
}

struct WithTurns<'a> {
    rotations: Rotations<'a>,
    /// Each known turn's integral and its rotation vector.
    turns: Vec<([f64; 3], [f64; 3])>,
}

impl Problem for WithTurns<'_> {
    fn residual_count(&self) -> usize {
        self.rotations.residual_count() + 3 * self.turns.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let n = self.rotations.residual_count();
        self.rotations.residuals(p, &mut out[..n]);
        let m = matrix(p);
        for (k, (s, angle)) in self.turns.iter().enumerate() {
            let w = m * Vector3::from(*s);
            for i in 0..3 {
                out[n + 3 * k + i] = angle[i] - w[i];
            }
        }
    }

    fn jacobian(&self, p: &[f64], r: &[f64], out: &mut DMatrix<f64>) {
        matrix_jacobian(self, p, r, out);
    }
}

/// A fit of the gyro to the rotations.
#[derive(Debug, Clone)]
pub struct GyroFit {
    /// `M`, rad/s per count.
    pub matrix: [[f64; 3]; 3],
    /// Its nine entries' covariance (`None` if not all are observable).
    pub covariance: Option<DMatrix<f64>>,
    /// Angle error after each rotation, radians.
    pub angles: Vec<f64>,
    /// Iterations.
    pub iterations: usize,
}

impl GyroFit {
    /// RMS of the angle errors, degrees.
    #[must_use]
    pub fn rms_deg(&self) -> f64 {
        (self.angles.iter().map(|a| a * a).sum::<f64>() / self.angles.len() as f64)
            .sqrt()
            .to_degrees()
    }

    /// Largest angle error, degrees.
    #[must_use]
    pub fn max_deg(&self) -> f64 {
        self.angles
            .iter()
            .fold(0.0f64, |m, a| m.max(*a))
            .to_degrees()
    }
}

/// Fits `M` from `start` (row-major) to the rotations.
///
/// # Errors
/// Too few rotations (three per four parameters), or no convergence.
pub fn fit(segments: &[Segment], start: [[f64; 3]; 3]) -> Result<GyroFit, LmError> {
    fit_with_turns(segments, &[], start)
}

/// Fits `M` from `start` (row-major) to the rotations and the turns of known rotation vector
/// (three residuals each, in radians as the rotations' are).
///
/// # Errors
/// Too few rotations and turns for the nine entries, or no convergence.
pub fn fit_with_turns(
    segments: &[Segment],
    known: &[KnownTurn],
    start: [[f64; 3]; 3],
) -> Result<GyroFit, LmError> {
    let problem = WithTurns {
        rotations: Rotations { segments },
        turns: known.iter().map(|t| (t.integral(), t.angle)).collect(),
    };
    let p0: Vec<f64> = start.iter().flatten().copied().collect();
    let sol = lm::solve(&problem, &p0, 100)?;
    // Each segment's residual is the difference of two unit vectors: its component along the
    // measured direction is second order, so a segment carries two degrees of freedom, not
    // three; a known turn carries three.
    let covariance = (2 * segments.len() + 3 * known.len())
        .checked_sub(9)
        .and_then(|dof| lm::covariance_with(&sol, dof));
    let m = matrix(&sol.p);
    Ok(GyroFit {
        matrix: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
        covariance,
        angles: segments.iter().map(|s| angle(&m, s)).collect(),
        iterations: sol.iterations,
    })
}

/// The gyro fit's covariance with the error of the gravity directions carried in. The
/// directions at the ends of every segment come from the accelerometer's calibration, so an
/// error in its parameters `p` (covariance `cov_p`) moves them all together; `ends(q)` gives
/// every segment's (from, to) for parameters `q`. The matrix moves by `X dp`, `X` the
/// least-squares solution of `J X = -dr/dp` (SVD), `J` the fit's Jacobian and `dr/dp` by central
/// differences; the result is `cov + X cov_p X^T`.
#[must_use]
pub fn with_direction_error(
    segments: &[Segment],
    fit: &GyroFit,
    p: &[f64],
    cov_p: &DMatrix<f64>,
    ends: impl Fn(&[f64]) -> Vec<([f64; 3], [f64; 3])>,
) -> Option<DMatrix<f64>> {
    let cov = fit.covariance.as_ref()?;
    let g: Vec<f64> = fit.matrix.iter().flatten().copied().collect();
    let problem = Rotations { segments };
    let n = problem.residual_count();
    let mut r0 = vec![0.0; n];
    problem.residuals(&g, &mut r0);
    let mut jac = DMatrix::zeros(n, g.len());
    problem.jacobian(&g, &r0, &mut jac);
    // Only the ends move: each segment's rotation is integrated once, with the fitted matrix.
    let m = matrix(&g);
    let rotations: Vec<Matrix3<f64>> = segments.iter().map(|s| integrate(&m, s)).collect();
    let residuals_at = |q: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; n];
        for (k, (r, (from, to))) in rotations.iter().zip(ends(q)).enumerate() {
            let pred = r.transpose() * Vector3::from(from);
            for i in 0..3 {
                out[3 * k + i] = to[i] - pred[i];
            }
        }
        out
    };
    let mut dr = DMatrix::zeros(n, p.len());
    let mut q = p.to_vec();
    for k in 0..p.len() {
        let h = 1e-3 * cov_p[(k, k)].sqrt().max(1e-12 * p[k].abs().max(1e-300));
        q[k] = p[k] + h;
        let up = residuals_at(&q);
        q[k] = p[k] - h;
        let down = residuals_at(&q);
        q[k] = p[k];
        for i in 0..n {
            dr[(i, k)] = -(up[i] - down[i]) / (2.0 * h);
        }
    }
    let svd = crate::stats::decompose::svd(jac, true, true).ok()?;
    let x = svd.solve(&dr, 1e-12 * svd.singular_values.max()).ok()?;
    Some(cov + &x * cov_p * x.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_gyro_from_simulated_rotations() {
        let truth = Matrix3::new(
            2.1e-4, 3e-6, -2e-6, -4e-6, 2.08e-4, 5e-6, 1e-6, -3e-6, 2.12e-4,
        );
        let inv = truth.try_inverse().unwrap();
        // Rotations about varied axes, 2 s at 100 Hz with a smooth rate profile.
        let mut g = Vector3::new(0.0, 0.0, 1.0);
        let mut segments = Vec::new();
        for k in 0..12 {
            let axis = Vector3::new(
                (k as f64).sin(),
                (k as f64 * 1.7).cos(),
                0.5 + (k % 3) as f64,
            )
            .normalize();
            let n = 200;
            let dt = 0.01;
            let peak = 1.5;
            let rates: Vec<Vector3<f64>> = (0..=n)
                .map(|s| axis * peak * (std::f64::consts::PI * s as f64 / n as f64).sin())
                .collect();
            let x: Vec<[f64; 3]> = rates
                .iter()
                .map(|w| {
                    let c = inv * w;
                    [c[0], c[1], c[2]]
                })
                .collect();
            let seg0 = Segment {
                dt: vec![dt; n],
                x,
                from: g.into(),
                to: [0.0; 3],
            };
            // The truth's own integration gives the gravity direction after.
            let r = integrate(&truth, &seg0);
            let to = r.transpose() * g;
            segments.push(Segment {
                to: to.into(),
                ..seg0
            });
            g = to;
        }
        let start = [[2e-4, 0.0, 0.0], [0.0, 2e-4, 0.0], [0.0, 0.0, 2e-4]];
        let f = fit(&segments, start).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (f.matrix[i][j] - truth[(i, j)]).abs() < 1e-9,
                    "{:?}",
                    f.matrix
                );
            }
        }
        assert!(f.rms_deg() < 1e-6);
    }
}
