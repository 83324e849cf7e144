//! The decompositions every numerical loop of the tool goes through, bounded: nalgebra's
//! `svd()` and `symmetric_eigenvalues()` iterate without limit, and on a matrix holding NaN or
//! infinity they never stop. These check the input first and cap the sweeps, so a failure is an
//! error the caller can locate, not a hang.

use nalgebra::{DMatrix, DVector, SVD, SymmetricEigen};

/// Why a decomposition failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecomposeError {
    /// The matrix holds NaN or an infinity.
    #[error("the matrix holds a value that is not finite")]
    NotFinite,
    /// The iteration did not converge within its bound.
    #[error("the decomposition did not converge in {0} sweeps")]
    NoConvergence(usize),
}

/// The sweeps allowed for a matrix of `n` columns: far above what a finite matrix needs
/// (about 2 per singular value).
fn sweeps(n: usize) -> usize {
    1_000 + 100 * n
}

fn finite(m: &DMatrix<f64>) -> Result<(), DecomposeError> {
    if m.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(DecomposeError::NotFinite)
    }
}

/// The thin SVD of `m` (with `U` and/or `V'` as asked).
///
/// # Errors
/// A [`DecomposeError`].
pub fn svd(
    m: DMatrix<f64>,
    u: bool,
    v_t: bool,
) -> Result<SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, DecomposeError> {
    finite(&m)?;
    let n = sweeps(m.ncols().max(m.nrows()));
    SVD::try_new(m, u, v_t, f64::EPSILON, n).ok_or(DecomposeError::NoConvergence(n))
}

/// The singular values of `m`.
///
/// # Errors
/// A [`DecomposeError`].
pub fn singular_values(m: DMatrix<f64>) -> Result<DVector<f64>, DecomposeError> {
    svd(m, false, false).map(|s| s.singular_values)
}

/// The eigenvalues of the symmetric matrix `m`.
///
/// # Errors
/// A [`DecomposeError`].
pub fn symmetric_eigenvalues(m: DMatrix<f64>) -> Result<DVector<f64>, DecomposeError> {
    finite(&m)?;
    let n = sweeps(m.ncols());
    SymmetricEigen::try_new(m, f64::EPSILON, n)
        .map(|e| e.eigenvalues)
        .ok_or(DecomposeError::NoConvergence(n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn not_finite_is_an_error_not_a_hang() {
        let mut m = DMatrix::from_element(3, 2, 1.0);
        m[(1, 1)] = f64::NAN;
        assert_eq!(
            svd(m.clone(), true, true).err(),
            Some(DecomposeError::NotFinite)
        );
        m[(1, 1)] = f64::INFINITY;
        assert_eq!(svd(m, false, true).err(), Some(DecomposeError::NotFinite));
        let s = DMatrix::from_row_slice(2, 2, &[2.0, f64::NAN, f64::NAN, 1.0]);
        assert_eq!(
            symmetric_eigenvalues(s).err(),
            Some(DecomposeError::NotFinite)
        );
        let good = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let mut ev: Vec<f64> = symmetric_eigenvalues(good)
            .unwrap()
            .iter()
            .copied()
            .collect();
        ev.sort_by(f64::total_cmp);
        assert!((ev[0] - 1.0).abs() < 1e-12 && (ev[1] - 3.0).abs() < 1e-12);
    }
}
