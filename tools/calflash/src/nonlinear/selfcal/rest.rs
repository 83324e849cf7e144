//! The initial rest of a hand-turned recording, checked: long enough and still, its level of
//! motion (what a still pose is held to) and the one-sample glitches inside it.

use super::super::statics;
use super::{Options, SelfCalError};
use crate::obs::recording::Recording;

/// The initial rest, checked: long enough and still.
pub(super) struct Rest {
    /// The first sample after it.
    pub(super) end: usize,
    /// The accelerometer's quantisation variance, which floors every variance.
    pub(super) floor: [f64; 3],
    /// Its level of motion (the accelerometer's measure at rest).
    pub(super) level: f64,
    /// Two still runs whose means agree within this (8 sigma of the rest's noise, per axis),
    /// a window apart at most, are one hold.
    pub(super) tol: [f64; 3],
    /// One-sample glitches inside it, left out of its level (sample indices).
    pub(super) glitches: Vec<usize>,
}

impl Rest {
    /// The rest of `opts.init_rest` seconds at the start of `rec`.
    ///
    /// # Errors
    /// A recording shorter than the rest, or a rest with a second far noisier than its
    /// quietest (the unit was moved).
    pub(super) fn checked(rec: &Recording, opts: &Options) -> Result<Self, SelfCalError> {
        let source = rec.source.as_str();
        let t0 = rec.t[0];
        let end = rec.t.partition_point(|t| *t < t0 + opts.init_rest);
        if end >= rec.len() {
            return Err(SelfCalError::TooShort {
                file: source.into(),
                len: rec.t[rec.len() - 1] - t0,
                rest: opts.init_rest,
            });
        }
        // The quantisation's variance floors every variance: identical codes are not silence.
        let floor = statics::floor(statics::quantum(&rec.acc));
        // One-sample glitches (a converter's or a link's misread): samples far outside the
        // rest's robust spread, too few and too short to be motion. They are left out of the
        // rest and named; real motion moves many samples, and is refused below.
        let glitches = glitches(&rec.acc[..end], floor);
        let kept: Vec<[f64; 3]> = (0..end)
            .filter(|i| glitches.binary_search(i).is_err())
            .map(|i| rec.acc[i])
            .collect();
        // The rest must be still: no second of it far noisier than its quietest.
        let second = ((rec.rate()).round() as usize).max(1);
        let blocks: Vec<(usize, f64)> = (0..end / second)
            .map(|b| {
                let block: Vec<[f64; 3]> = (b * second..(b + 1) * second)
                    .filter(|i| glitches.binary_search(i).is_err())
                    .map(|i| rec.acc[i])
                    .collect();
                (b * second, statics::rest_level(&block, floor))
            })
            .collect();
        let quietest = blocks
            .iter()
            .map(|b| b.1)
            .fold(f64::INFINITY, f64::min)
            .max(1e-12);
        if let Some(&(at, level)) = blocks.iter().find(|b| b.1 > 25.0 * quietest) {
            return Err(SelfCalError::RestNotStill {
                file: source.into(),
                at: rec.t[at] - t0,
                rest: opts.init_rest,
                ratio: level / quietest,
            });
        }
        Ok(Self {
            end,
            floor,
            level: statics::rest_level(&kept, floor),
            tol: statics::variances(&kept, floor).map(|v| 8.0 * v.sqrt()),
            glitches,
        })
    }
}

/// The samples of a rest `acc` (in order) that are glitches: on some axis more than 30
/// robust standard deviations (the scaled MAD, floored by a quantisation step) from the rest's median,
/// in runs of at most 3 samples, and at most one in 1,000 of the rest (at least 3). Anything
/// more is motion, and none are returned.
fn glitches(acc: &[[f64; 3]], floor: [f64; 3]) -> Vec<usize> {
    let n = acc.len();
    let mut far = vec![false; n];
    for j in 0..3 {
        let x: Vec<f64> = acc.iter().map(|a| a[j]).collect();
        let (median, mad) = crate::stats::robust::median_mad(&x);
        let sigma = mad.max((12.0 * floor[j]).sqrt());
        for (f, a) in far.iter_mut().zip(acc) {
            *f |= (a[j] - median).abs() > 30.0 * sigma;
        }
    }
    let found: Vec<usize> = (0..n).filter(|&i| far[i]).collect();
    let longest_run = found
        .chunk_by(|a, b| b - a == 1)
        .map(<[usize]>::len)
        .max()
        .unwrap_or(0);
    let allowed = (n / 1000).max(3);
    if found.len() <= allowed && longest_run <= 3 {
        found
    } else {
        Vec::new()
    }
}
