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
/// matrix `Q`.
///
/// A feature whose variance is zero (a term not in the model) keeps a zero row and column: it
/// adds nothing to any output's stated error. The others are factored as their correlation
/// matrix, `Q = D R D` with `D` the standard deviations, so that the diagonal jitter added when
/// rounding leaves `R` indefinite (from 1e-14 to at most 1e-6, ten steps) is relative to each
/// feature's own variance. A jitter relative to the largest variance instead gave a term left
/// out of the model a standard error of 1e-7 of the bias's, which its feature at a spinning
/// round's rates (a cube of 10^4 m/s^2 is 10^12) turned into a stated 1-sigma of 20,000 m/s^2.
///
/// # Errors
/// A [`CovarianceError`].
pub fn packed_cholesky(q: &DMatrix<f64>) -> Result<Vec<f64>, CovarianceError> {
    if !q.iter().all(|v| v.is_finite()) {
        return Err(CovarianceError::NotFinite);
    }
    let n = q.nrows();
    if (0..n).any(|i| q[(i, i)] < 0.0) {
        return Err(CovarianceError::Indefinite);
    }
    let active: Vec<usize> = (0..n).filter(|&i| q[(i, i)] > 0.0).collect();
    let sd: Vec<f64> = active.iter().map(|&i| q[(i, i)].sqrt()).collect();
    let m = active.len();
    let r = DMatrix::from_fn(m, m, |a, b| {
        if a == b {
            1.0
        } else {
            q[(active[a], active[b])] / (sd[a] * sd[b])
        }
    });
    let mut jitter = 0.0;
    for _ in 0..10 {
        if let Some(c) = (&r + DMatrix::identity(m, m) * jitter).cholesky() {
            let l = c.l();
            let mut full = DMatrix::zeros(n, n);
            for a in 0..m {
                for b in 0..=a {
                    full[(active[a], active[b])] = l[(a, b)] * sd[a];
                }
            }
            let mut out = Vec::with_capacity(n * (n + 1) / 2);
            for i in 0..n {
                for j in 0..=i {
                    out.push(full[(i, j)]);
                }
            }
            return Ok(out);
        }
        jitter = if jitter == 0.0 { 1e-14 } else { jitter * 10.0 };
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

#[cfg(test)]
mod tests {
    use super::packed_cholesky;
    use nalgebra::DMatrix;

    fn unpack(p: &[f64], n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(
            n,
            n,
            |i, j| if j <= i { p[i * (i + 1) / 2 + j] } else { 0.0 },
        )
    }

    /// A term not in the model (zero variance) states no error at any input, however large
    /// its feature: the spinning round's cube of 10^4 m/s^2 is 10^12.
    #[test]
    fn a_term_left_out_adds_nothing() {
        let mut q = DMatrix::zeros(3, 3);
        q[(0, 0)] = 1e-2;
        q[(1, 1)] = 1e-8;
        q[(0, 1)] = -0.9e-5;
        q[(1, 0)] = -0.9e-5;
        let l = unpack(&packed_cholesky(&q).unwrap(), 3);
        assert_eq!(l.row(2).iter().copied().fold(0.0, f64::max), 0.0);
        let f = nalgebra::DVector::from_vec(vec![1.0, 300.0, 1e12]);
        let stated = (l.transpose() * &f).norm();
        let exact = (f.transpose() * &q * &f)[(0, 0)].sqrt();
        assert!(
            (stated / exact - 1.0).abs() < 1e-9,
            "{stated} against {exact}"
        );
    }

    /// Features of very different scales with a near-singular correlation: the factor
    /// rebuilds `Q` within rounding of each element's own scale.
    #[test]
    fn the_factor_rebuilds_a_badly_scaled_covariance() {
        let sd = [0.1, 3e-5, 1e-9, 2e-13];
        let rho: f64 = 0.999_999;
        let q = DMatrix::from_fn(4, 4, |i, j| {
            sd[i]
                * sd[j]
                * if i == j {
                    1.0
                } else {
                    rho.powi((i as i32 - j as i32).abs())
                }
        });
        let l = unpack(&packed_cholesky(&q).unwrap(), 4);
        let back = &l * l.transpose();
        for i in 0..4 {
            for j in 0..4 {
                let scale = sd[i] * sd[j];
                assert!(
                    ((back[(i, j)] - q[(i, j)]) / scale).abs() < 1e-10,
                    "({i}, {j}): {} against {}",
                    back[(i, j)],
                    q[(i, j)]
                );
            }
        }
    }

    #[test]
    fn negative_variances_and_nan_are_refused() {
        let mut q = DMatrix::identity(2, 2);
        q[(1, 1)] = -1.0;
        assert!(packed_cholesky(&q).is_err());
        q[(1, 1)] = f64::NAN;
        assert!(packed_cholesky(&q).is_err());
    }
}
