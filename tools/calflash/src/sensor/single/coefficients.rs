//! The single axis' device-side coefficients read from a fit's named coefficients: the
//! own-axis polynomial, and the covariance of the bias and the scale factor, at a supply
//! voltage.

use nalgebra::DMatrix;

use super::KINK;
use crate::columns as col;
use crate::sensor::invert::Own;
use crate::sensor::thermal;

/// The own-axis polynomial from named coefficients (at the middle of the supply voltage's
/// span, when the model has voltage terms).
pub fn own_of(names: &[String], coefficients: &[f64], bp: f64) -> Own {
    own_at(names, coefficients, bp, 0.0)
}

/// The own-axis polynomial from named coefficients at scaled supply voltage `y`
/// ([`thermal::VOLT`]): the bias and the scale factor are linear in it.
pub fn own_at(names: &[String], coefficients: &[f64], bp: f64, y: f64) -> Own {
    let c = |term: &str| {
        names
            .iter()
            .position(|n| n == term)
            .map_or(0.0, |i| coefficients[i])
    };
    Own {
        bias: c("1") + y * c(thermal::VOLT),
        slope: c(col::INPUT) + y * c(&thermal::volt_term(col::INPUT)),
        c2: c("input^2"),
        c3: c("input^3"),
        coq: c("input:abs(input)"),
        ca: c(KINK),
        bp,
    }
}

/// The covariance `[var b, cov(b, s), var s]` of the bias and the scale factor at scaled
/// supply voltage `y`, from the covariance `cov` of the coefficients `names`.
#[must_use]
pub fn bias_slope_cov(names: &[String], cov: &DMatrix<f64>, y: f64) -> [f64; 3] {
    let idx = |n: &str| names.iter().position(|m| m == n);
    // b = c_1 + y c_v, s = c_in + y c_in:v: rows of weights over the coefficients.
    let row = |base: &str, volt: &str| -> Vec<(usize, f64)> {
        idx(base)
            .map(|i| (i, 1.0))
            .into_iter()
            .chain(idx(volt).map(|i| (i, y)))
            .collect()
    };
    let b = row("1", thermal::VOLT);
    let sl = row(col::INPUT, &thermal::volt_term(col::INPUT));
    let q = |u: &[(usize, f64)], v: &[(usize, f64)]| {
        u.iter()
            .flat_map(|(i, a)| v.iter().map(move |(j, c)| a * c * cov[(*i, *j)]))
            .sum::<f64>()
    };
    [q(&b, &b), q(&b, &sl), q(&sl, &sl)]
}
