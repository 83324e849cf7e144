//! How near a design is to collinear: its condition number, each column's variance inflation
//! factor, and the error that names the column a rank-deficient design cannot separate.

use nalgebra::DMatrix;

use super::{Factored, FitError, largest_row};

/// The condition number of `X`, from the singular values of `R D` (those of `X`).
pub(super) fn condition_number(f: &Factored, x: &DMatrix<f64>, y: &[f64]) -> Result<f64, FitError> {
    let mut rd = f.r.clone();
    for (j, mut c) in rd.column_iter_mut().enumerate() {
        c *= f.norms[j];
    }
    let sv = crate::stats::decompose::singular_values(rd).map_err(|_| FitError::Overflow {
        row: largest_row(x, y),
    })?;
    Ok(sv.max() / sv.min())
}

/// The variance inflation factor of each column (`None` for the intercept's constant column).
pub(super) fn variance_inflation(
    x: &DMatrix<f64>,
    unscaled: &DMatrix<f64>,
    intercept: bool,
) -> Vec<Option<f64>> {
    (0..x.ncols())
        .map(|j| {
            let col = x.column(j);
            let is_constant = col.iter().all(|v| *v == col[0]);
            if intercept && is_constant {
                None
            } else {
                let ss = if intercept {
                    let mean = col.mean();
                    col.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>()
                } else {
                    col.iter().map(|v| v * v).sum()
                };
                Some(unscaled[(j, j)] * ss)
            }
        })
        .collect()
}

/// Column `j` is (nearly) explained by the columns before it: find the combination.
pub(super) fn rank_deficient(r: &DMatrix<f64>, norms: &[f64], j: usize) -> FitError {
    let combination = if j == 0 {
        Vec::new()
    } else {
        let r11 = r.view((0, 0), (j, j)).clone_owned();
        let rhs = r.view((0, j), (j, 1)).clone_owned();
        r11.solve_upper_triangular(&rhs).map_or_else(Vec::new, |c| {
            // Scaled columns: x_j / d_j = sum c_k x_k / d_k.
            (0..j).map(|k| (k, c[k] * norms[j] / norms[k])).collect()
        })
    };
    FitError::RankDeficient {
        column: j,
        combination,
    }
}
