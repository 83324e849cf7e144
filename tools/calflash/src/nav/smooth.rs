//! The Rauch-Tung-Striebel smoother over a closed-loop error-state pass: each epoch's
//! smoothed error is its gain times the smoothed estimate's departure from the next epoch's
//! prediction, `dx_k = G_k (x_{k+1|N} - x_{k+1|k})`, `G_k = P_k|k Phi' P_{k+1|k}^-1` (by
//! Cholesky), and `P_k|N = P_k|k + G_k (P_{k+1|N} - P_{k+1|k}) G_k'`.

use spincal::nav::filter::Estimate;
use spincal::nav::{STATES, StateMatrix};

use super::run::Epoch;

/// The smoothed estimate and covariance of each epoch (the last is the filter's own).
#[must_use]
pub fn smooth(epochs: &[Epoch]) -> Vec<(Estimate<f64>, StateMatrix<f64>)> {
    let mut out: Vec<(Estimate<f64>, StateMatrix<f64>)> =
        epochs.iter().map(|e| e.filtered).collect();
    for k in (0..epochs.len().saturating_sub(1)).rev() {
        let next = &epochs[k + 1];
        let (xf, pf) = &epochs[k].filtered;
        let (xp, pp) = &next.predicted;
        // A state the pass leaves out (the receiver's error when the fixes are taken as
        // white) has no variance and no covariance: a unit on its diagonal leaves the others'
        // solution as it is and its own gain row zero (its `P_k|k` row is).
        let mut pp_solved = *pp;
        for i in 0..STATES {
            if pp[(i, i)] == 0.0 {
                pp_solved[(i, i)] = 1.0;
            }
        }
        let Some(chol) = pp_solved.cholesky() else {
            continue;
        };
        // G' = P_{k+1|k}^-1 Phi P_k|k.
        let g = chol.solve(&(next.phi * pf)).transpose();
        let (xs_next, ps_next) = out[k + 1];
        let dx = g * xs_next.minus(xp);
        let p = pf + g * (ps_next - pp) * g.transpose();
        out[k] = (xf.plus(&dx), (p + p.transpose()) * 0.5);
    }
    out
}
