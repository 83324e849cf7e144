//! The bounds a sample's doubt is judged by: the largest rate change between two samples an
//! angular acceleration allows, and the lever term's range over the gyros' calibrated rates.

use crate::model::Channel;
use crate::model::interval::Bound;
use crate::model::rotation::LeverTerms;

/// The square of the largest rate change between two samples at `rate_hz` for an angular
/// acceleration `rad_per_s2`.
pub(super) fn step_sq(rad_per_s2: f32, rate_hz: f32) -> f32 {
    let step = rad_per_s2 / rate_hz;
    step * step
}

/// A bound on the lever term `e` for rates inside the gyro's calibrated ranges and rate
/// differences no wider than them.
pub(super) fn lever_bound(terms: &LeverTerms<f32>, gyro: &[Channel; 3]) -> [Bound; 3] {
    let big = |c: &Channel| libm::fmaxf(libm::fabsf(c.range.lo), libm::fabsf(c.range.hi));
    let [b0, b1, b2] = gyro.map(|c| big(&c));
    let m = [b0 * b0, b1 * b1, b2 * b2, b0 * b1, b0 * b2, b1 * b2];
    let d = gyro.map(|c| c.range.hi - c.range.lo);
    core::array::from_fn(|j| {
        let (Some(q), Some(t)) = (terms.quad.get(j), terms.tangential.get(j)) else {
            return Bound::point(0.0);
        };
        let e = q
            .iter()
            .zip(&m)
            .map(|(c, x)| libm::fabsf(*c) * x)
            .chain(t.iter().zip(&d).map(|(c, x)| libm::fabsf(*c) * x))
            .fold(0.0, |s, x| s + x);
        // Room for the rounding of both evaluations.
        let e = e * 1.0001;
        Bound::new(-e, e)
    })
}
