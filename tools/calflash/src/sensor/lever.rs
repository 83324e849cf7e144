//! The fit's side of the model under rotation (`spincal::model::rotation`): what each axis
//! feels, as regressors.
//!
//! Accelerometer axis `i` outputs `b_i + s_i . F_i + S_ii n_i(x_i)` with
//! `F_i = f + A r_i`, `A = C(w) + [dw]x`, `C(w) r = w x (w x r)`, and `x_i = s_i . F_i / S_ii`
//! what it senses. The product `s_i . A r_i` makes the model bilinear in the sensitivity row
//! `s_i` and the lever arm `r_i`; it is fitted by Gauss-Newton, each step a linear regression
//! of the pseudo-response `y + s^ . A r^` on `1`, `F^_i` (for `s_i`), `A' s^` (for `r_i`) and the
//! nonlinear terms of `x^_i`, which at convergence is the least-squares fit with the covariance
//! of its Jacobian. A gyro axis outputs `b_i + s_i . w + g_i . f + S_ii n_i(x_i)`, linear but for
//! `x_i = (s_i . w + g_i . f) / S_ii`, refreshed each step the same way.

use spincal::model::rotation::{dot, force_at, lever_gradient};

use crate::columns as col;
use crate::obs::Table;

/// A lever-arm regressor that never reaches this fraction of its axis' strongest one is zero
/// in the plan but for rounding: the plan does not move that component at all. Any other
/// component is a candidate, whatever its share: the fit keeps it when dropping it costs more
/// than the noise (the partial F test of the terms' backward elimination), so a tilted
/// fixture's 2.5 % regressor on a 1.5 mm arm (37 m/s^2 at 1,000 rad/s) is fitted, not left in
/// the residuals.
pub const ROUNDING_FRACTION: f64 = 1e-9;

/// Axis letters.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// The name of the lever-arm regressor of accelerometer axis `i`, component `k`.
#[must_use]
pub fn column(i: usize, k: usize) -> String {
    format!("lever_{}{}", AXES[i], AXES[k])
}

/// The column of what an axis senses, SI units: the argument of its nonlinear terms.
pub const SENSED: &str = "sensed";

/// The asymmetry term of what an axis senses, `|sensed|` (a two-stage calibration carries a
/// sensor's asymmetric scale factor about zero into the unit: `sensor::stages`).
pub const SENSED_KINK: &str = "sensed_kink";

/// `A' s` for `A = C(w) + [dw]x`: the gradient of `s . (w x (w x r) + dw x r)` in `r`
/// ([`spincal::model::rotation::lever_gradient`]).
#[must_use]
pub fn gradient(s: &[f64; 3], w: &[f64; 3], dw: &[f64; 3]) -> [f64; 3] {
    lever_gradient(s, w, dw)
}

/// Which lever-arm components (row: accelerometer axis, column: component) the plan's rates
/// and angular accelerations can estimate: those whose regressor, for an axis sensing along
/// itself, is not zero in the plan (it reaches [`ROUNDING_FRACTION`] of that axis' strongest
/// one somewhere). Whether the data support each is the fit's test, not the plan's.
#[must_use]
pub fn estimable(motion: impl Iterator<Item = ([f64; 3], [f64; 3])>) -> [[bool; 3]; 3] {
    let mut peak = [[0.0f64; 3]; 3];
    for (w, dw) in motion {
        for (i, row) in peak.iter_mut().enumerate() {
            let mut e = [0.0; 3];
            e[i] = 1.0;
            for (p, g) in row.iter_mut().zip(gradient(&e, &w, &dw)) {
                *p = p.max(g.abs());
            }
        }
    }
    peak.map(|row| {
        let top = row.iter().copied().fold(0.0, f64::max);
        row.map(|p| top > 0.0 && p >= ROUNDING_FRACTION * top)
    })
}

/// The rates and angular accelerations of a table's rows (zero where a column is missing).
#[must_use]
pub fn motion(table: &Table) -> Vec<([f64; 3], [f64; 3])> {
    let get = |names: [&str; 3], r: usize| {
        std::array::from_fn(|k| table.column(names[k]).map_or(0.0, |c| c[r]))
    };
    (0..table.len())
        .map(|r| (get(col::W, r), get(col::DW, r)))
        .collect()
}

/// One axis' current estimates, from which the next step's regressors are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Sensitivity row (counts per SI unit).
    pub s: [f64; 3],
    /// Lever arm (accelerometer), metres.
    pub r: [f64; 3],
    /// g-sensitivity row (gyro), counts per m/s^2.
    pub g: [f64; 3],
}

impl Estimate {
    /// The start for axis `i`: unit sensitivity along itself, no lever arm, no g-sensitivity.
    /// The first step's lever coefficients are then `S_ii r_ik`, and its sensed input is the
    /// axis' own reference input.
    #[must_use]
    pub fn start(i: usize) -> Self {
        let mut s = [0.0; 3];
        s[i] = 1.0;
        Self {
            s,
            r: [0.0; 3],
            g: [0.0; 3],
        }
    }
}

/// What one axis' regression reads: the table with the inputs replaced by what axis `i`
/// feels under `est`.
///
/// - Accelerometer with `lever` components: `f_*` becomes the force at the axis, `F^_i`; the
///   regressors `lever_i*` (the estimable components) are `A' s^`; the output becomes the
///   Gauss-Newton pseudo-response `y + s^ . A r^`.
/// - `nonlinear`: the column [`SENSED`] is what the axis senses, `x^_i`.
#[must_use]
pub fn axis_table(
    table: &Table,
    gyro: bool,
    i: usize,
    output: &str,
    est: &Estimate,
    lever: Option<&[bool; 3]>,
    nonlinear: bool,
) -> Table {
    let mut out = table.clone();
    let n = table.len();
    let get = |names: [&str; 3], r: usize| -> [f64; 3] {
        std::array::from_fn(|k| table.column(names[k]).map_or(0.0, |c| c[r]))
    };
    let mut forces = vec![[0.0; 3]; n];
    let mut grads = vec![[0.0; 3]; n];
    let mut pseudo = table
        .column(output)
        .map(<[f64]>::to_vec)
        .unwrap_or_default();
    let mut sensed = vec![0.0; n];
    for r in 0..n {
        let (f, w, dw) = (get(col::F, r), get(col::W, r), get(col::DW, r));
        let z = if gyro {
            dot(&est.s, &w) + dot(&est.g, &f)
        } else {
            let at = force_at(&f, &w, &dw, &est.r);
            forces[r] = at;
            grads[r] = gradient(&est.s, &w, &dw);
            if lever.is_some() {
                let fr: [f64; 3] = std::array::from_fn(|k| at[k] - f[k]);
                pseudo[r] += dot(&est.s, &fr);
            }
            dot(&est.s, &at)
        };
        sensed[r] = z / est.s[i];
    }
    if let Some(which) = lever {
        for (k, name) in col::F.iter().enumerate() {
            out.set_column(name, forces.iter().map(|x| x[k]).collect());
        }
        for (k, use_it) in which.iter().enumerate() {
            if *use_it {
                out.set_column(&column(i, k), grads.iter().map(|x| x[k]).collect());
            }
        }
        out.set_column(output, pseudo);
    }
    if nonlinear {
        out.set_column(SENSED, sensed);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gradient_is_the_derivative_of_what_the_axis_senses() {
        let s = [412.0, 1.2, -0.7];
        let (w, dw) = ([30.0, -1800.0, 55.0], [400.0, 20.0, -900.0]);
        let r = [0.001, -0.002, 0.0025];
        let g = gradient(&s, &w, &dw);
        let sensed = |r: &[f64; 3]| dot(&s, &force_at(&[0.0; 3], &w, &dw, r));
        for k in 0..3 {
            let mut rp = r;
            rp[k] += 1e-6;
            let num = (sensed(&rp) - sensed(&r)) / 1e-6;
            assert!(
                (num - g[k]).abs() < 1e-6 * g[k].abs().max(1.0),
                "{k}: {num} {}",
                g[k]
            );
        }
        // Linear in r: the sensed term is exactly gradient . r.
        assert!((sensed(&r) - dot(&g, &r)).abs() < 1e-9 * sensed(&r).abs());
    }

    #[test]
    fn axis_spins_estimate_only_the_own_components_and_diagonals_the_rest() {
        let axes: Vec<([f64; 3], [f64; 3])> = (0..3)
            .map(|k| {
                let mut w = [0.0; 3];
                w[k] = 1000.0;
                (w, [0.0; 3])
            })
            .collect();
        let e = estimable(axes.iter().copied());
        for (i, row) in e.iter().enumerate() {
            for (k, ok) in row.iter().enumerate() {
                assert_eq!(*ok, i == k, "{i}{k}");
            }
        }
        let h = 1000.0 / 2f64.sqrt();
        let diag = [
            ([h, h, 0.0], [0.0; 3]),
            ([0.0, h, h], [0.0; 3]),
            ([h, 0.0, h], [0.0; 3]),
        ];
        let e = estimable(axes.iter().copied().chain(diag));
        assert!(e.iter().flatten().all(|x| *x));
        // A fixture tilted 1.4 degrees off the x axis: its 2.5 % regressor moves r_yx (by
        // 37 m/s^2 on a 1.5 mm arm at 1,000 rad/s): a candidate, for the fit to test.
        let tilted = [([1000.0, 25.0, 0.0], [0.0; 3])];
        let e = estimable(axes.iter().copied().chain(tilted));
        assert!(e[1][0] && e[0][1], "{e:?}");
        assert!(!e[2][0] && !e[0][2], "{e:?}");
    }
}
