//! The covariance factor the device stores: the calibration error of a corrected output as a
//! quadratic form in the device's features `[1, u...]`, from the forward fits' covariances.

use nalgebra::{DMatrix, Matrix3};
use spincal::model::{IMU_FEATURES, ImuOutputCovariance};

/// A covariance with no factor: a fit whose covariance is not finite (an observation far
/// outside any physical range reached it), or one that stays indefinite however it is nudged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CovarianceError {
    /// A value is NaN or infinite.
    #[error("its covariance is not finite (an observation far outside the range?)")]
    NotFinite,
    /// Indefinite even with a jitter of 1e-6 of its largest variance.
    #[error("its covariance is not positive semidefinite")]
    Indefinite,
}

/// Packed lower-triangular Cholesky factor (row-major) of a symmetric positive semidefinite
/// matrix; a diagonal jitter (from 1e-14 to at most 1e-6 of the largest variance, ten steps)
/// is added when rounding leaves it indefinite.
///
/// # Errors
/// A [`CovarianceError`].
pub fn packed_cholesky(q: &DMatrix<f64>) -> Result<Vec<f64>, CovarianceError> {
    if !q.iter().all(|v| v.is_finite()) {
        return Err(CovarianceError::NotFinite);
    }
    let n = q.nrows();
    let scale = (0..n)
        .map(|i| q[(i, i)].abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut jitter = 0.0;
    for _ in 0..10 {
        let m = q + DMatrix::identity(n, n) * jitter;
        if let Some(c) = m.cholesky() {
            let l = c.l();
            let mut out = Vec::with_capacity(n * (n + 1) / 2);
            for i in 0..n {
                for j in 0..=i {
                    out.push(l[(i, j)]);
                }
            }
            return Ok(out);
        }
        jitter = if jitter == 0.0 {
            1e-14 * scale
        } else {
            jitter * 10.0
        };
    }
    Err(CovarianceError::Indefinite)
}

/// For outputs `y = M u + off` of a triad whose forward fits (axis k: bias and sensitivity row,
/// covariance `C_k` over `[1, x]`) give `y = S^-1 (out - b)`: the covariance of each `y_i` over
/// the features `[1, u0, u1, u2]`,
/// `Q_i = T' (sum_k (S^-1)_ik^2 C_k) T` with `[1, x] = T [1, u]`.
///
/// # Errors
/// A [`CovarianceError`].
pub fn triad(
    s_inv: &DMatrix<f64>,
    c: &[DMatrix<f64>; 3],
    m: &DMatrix<f64>,
    off: &[f64; 3],
) -> Result<[Vec<f64>; 3], CovarianceError> {
    let mut t = DMatrix::zeros(4, 4);
    t[(0, 0)] = 1.0;
    for j in 0..3 {
        t[(j + 1, 0)] = off[j];
        for k in 0..3 {
            t[(j + 1, k + 1)] = m[(j, k)];
        }
    }
    let one = |i: usize| {
        let mut sum = DMatrix::zeros(4, 4);
        for (k, ck) in c.iter().enumerate() {
            sum += ck * s_inv[(i, k)].powi(2);
        }
        packed_cholesky(&(t.transpose() * sum * &t))
    };
    Ok([one(0)?, one(1)?, one(2)?])
}

/// For a single axis `y = off + scale u`, forward bias and scale with covariance `C` (2x2):
/// `Q = T' C T / slope^2` over `[1, u]`.
///
/// # Errors
/// A [`CovarianceError`].
pub fn single(
    c: &DMatrix<f64>,
    slope: f64,
    off: f64,
    scale: f64,
) -> Result<Vec<f64>, CovarianceError> {
    let t = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, off, scale]);
    packed_cholesky(&(t.transpose() * c * &t / (slope * slope)))
}

/// An IMU output's factor (`spincal::model::IMU_FEATURES`) from the covariance `q` of its
/// forward parameters, `names[k]` naming the parameter of feature `k` (`None`: not in the
/// model) and `scale[k]` the feature's regressor over the device's feature, all over the
/// axis' sensitivity `slope` (the output is `z / S_ii` to first order in the misalignment).
///
/// # Errors
/// A [`CovarianceError`].
pub fn imu_output(
    fit: &crate::stats::Fit,
    names: &[Option<&str>; IMU_FEATURES],
    scale: &[f64; IMU_FEATURES],
    slope: f64,
) -> Result<ImuOutputCovariance, CovarianceError> {
    let idx = names.map(|n| n.and_then(|n| fit.names.iter().position(|m| m == n)));
    let q = DMatrix::from_fn(IMU_FEATURES, IMU_FEATURES, |r, c| match (idx[r], idx[c]) {
        (Some(a), Some(b)) => fit.covariance[(a, b)] * scale[r] * scale[c] / (slope * slope),
        _ => 0.0,
    });
    imu_packed(&q)
}

/// An IMU output's factor from the covariance `q` (4x4) of its offset and matrix row over the
/// device features `[1, u0, u1, u2]` of a triad whose outputs are `y = M u + off`: the same
/// covariance over `[1, y]` (`u = M^-1 (y - off)`), in the first four of the IMU's features
/// (a unit with no lever arm, g-sensitivity or nonlinear term to account for).
///
/// # Errors
/// A [`CovarianceError`].
pub fn imu_output_from_triad(
    q: &DMatrix<f64>,
    m: &Matrix3<f64>,
    off: &[f64; 3],
) -> Result<ImuOutputCovariance, CovarianceError> {
    let inv = m.try_inverse().unwrap_or_else(Matrix3::zeros);
    // [1, u] = T [1, y].
    let mut t = DMatrix::zeros(4, 4);
    t[(0, 0)] = 1.0;
    for j in 0..3 {
        t[(j + 1, 0)] = -(0..3).map(|k| inv[(j, k)] * off[k]).sum::<f64>();
        for k in 0..3 {
            t[(j + 1, k + 1)] = inv[(j, k)];
        }
    }
    let qy = t.transpose() * q * &t;
    let full = DMatrix::from_fn(IMU_FEATURES, IMU_FEATURES, |r, c| {
        if r < 4 && c < 4 { qy[(r, c)] } else { 0.0 }
    });
    imu_packed(&full)
}

fn imu_packed(q: &DMatrix<f64>) -> Result<ImuOutputCovariance, CovarianceError> {
    let l = packed_cholesky(q)?;
    let mut out = [[0.0f32; 11]; 6];
    for (k, v) in l.iter().enumerate().take(66) {
        out[k / 11][k % 11] = *v as f32;
    }
    Ok(out)
}
