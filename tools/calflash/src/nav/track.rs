//! The smoothed flight against its references: the trajectory beside the GNSS fixes and the
//! barometer's heights, and each sensor error along the flight with its band, thinned for the
//! report's figures.

use nalgebra::Vector3;
use spincal::nav::StateMatrix;
use spincal::nav::filter::{Estimate, index};

use super::frame;
use super::input::{Fix, Pressure};
use super::run::Pass;
use super::smooth::smooth;

/// The most epochs a figure's series keeps.
const SHOWN: usize = 2_000;

/// The smoothed flight.
#[derive(Debug, Clone, Default)]
pub struct Track {
    /// Epoch times, s (thinned).
    pub t: Vec<f64>,
    /// Smoothed position (east, north, up), m.
    pub position: Vec<[f64; 3]>,
    /// Each sensor error (in [`super::verdict::TERMS`]' order) and its 1-sigma, smoothed
    /// (what the whole flight tells of it at each epoch).
    pub terms: Vec<([f64; 12], [f64; 12])>,
    /// The same from the forward pass alone (what the flight had told of it by each epoch).
    pub filtered: Vec<([f64; 12], [f64; 12])>,
    /// GNSS fixes after launch in the level frame: time and position (up 0 for a fix without
    /// a height).
    pub gnss: Vec<(f64, [f64; 3])>,
    /// The fixes after launch that carry a height: time and height above the origin, m.
    pub gnss_height: Vec<(f64, f64)>,
    /// Barometric heights above the pad after launch: time and height, m.
    pub baro: Vec<(f64, f64)>,
    /// Smoothed horizontal track against GNSS, RMS m, and the fixes compared.
    pub track_rms: Option<(f64, usize)>,
    /// Smoothed height against the barometer, RMS m, and the readings compared, after their
    /// mean difference ([`baro_offset`](Self::baro_offset)).
    pub height_rms: Option<(f64, usize)>,
    /// The mean of the smoothed height less the barometer's height above the pad, m: where
    /// the pad is in the frame (0 within the noise when a fix was made on the pad).
    pub baro_offset: Option<f64>,
    /// Every epoch's smoothed position (east, north, up about `origin`, m) and its 1-sigma.
    pub trajectory: Vec<(f64, [f64; 3], [f64; 3])>,
    /// The level frame's origin (latitude, longitude degrees, height m).
    pub origin: (f64, f64, f64),
}

/// Where the flight was.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The level frame's origin (latitude, longitude degrees, height m).
    pub origin: (f64, f64, f64),
    /// The launch, s.
    pub launch: f64,
    /// The GNSS latency, s.
    pub latency: f64,
    /// The receiver's slowly varying position error, 1-sigma, m: what the fixes share over
    /// the flight, which the filter (taking each fix's error as its own) cannot average out;
    /// added to every position's 1-sigma (the pad's too: it is known from fixes, its own or
    /// those the navigation carries back).
    pub correlated: f64,
}

/// Smooths `pass` and holds it against the fixes and the barometer.
#[must_use]
pub fn track(pass: &Pass, (fixes, baro): (&[Fix], &[Pressure]), at: &Setting) -> Track {
    let smoothed = smooth(&pass.epochs);
    let times: Vec<f64> = pass.epochs.iter().map(|e| e.t).collect();
    let position = |t: f64| -> Option<Vector3<f64>> {
        let k = times.partition_point(|x| *x < t);
        let (a, b) = (smoothed.get(k.checked_sub(1)?)?, smoothed.get(k)?);
        let (ta, tb) = (times[k - 1], times[k]);
        let u = if tb > ta { (t - ta) / (tb - ta) } else { 0.0 };
        Some(a.0.nav.p * (1.0 - u) + b.0.nav.p * u)
    };
    let gnss: Vec<(f64, [f64; 3])> = fixes
        .iter()
        .filter(|f| f.t >= at.launch)
        .map(|f| (f.t - at.latency, frame::level_position(f, at.origin)))
        .collect();
    let track: Vec<f64> = gnss
        .iter()
        .filter_map(|(t, z)| {
            let p = position(*t)?;
            Some((p.x - z[0]).powi(2) + (p.y - z[1]).powi(2))
        })
        .collect();
    let reference = frame::pad_height(baro, at.launch);
    let heights: Vec<(f64, f64)> = baro
        .iter()
        .filter(|b| b.t >= at.launch)
        .map(|b| (b.t, frame::pressure_height(b.pa) - reference))
        .collect();
    // The barometer gives heights above the pad; the frame's origin is the pad only when a fix
    // was made there: the two are held together after their mean difference (the pad's height
    // in the frame), which is said apart.
    let differences: Vec<f64> = heights
        .iter()
        .filter_map(|(t, h)| Some(position(*t)?.z - h))
        .collect();
    let offset = if differences.is_empty() {
        0.0
    } else {
        differences.iter().sum::<f64>() / differences.len() as f64
    };
    let height_errors: Vec<f64> = differences.iter().map(|d| (d - offset).powi(2)).collect();
    let rms = |v: &[f64]| {
        (!v.is_empty()).then(|| ((v.iter().sum::<f64>() / v.len() as f64).sqrt(), v.len()))
    };
    let every = smoothed.len().div_ceil(SHOWN).max(1);
    let sd = |p: &StateMatrix<f64>, i: usize| p[(i, i)].max(0.0).sqrt();
    let trajectory = smoothed
        .iter()
        .zip(&times)
        .map(|((x, p), t)| {
            let at_ = index::POSITION;
            let with = |s: f64| s.hypot(at.correlated);
            (
                *t,
                x.nav.p.into(),
                [with(sd(p, at_)), with(sd(p, at_ + 1)), with(sd(p, at_ + 2))],
            )
        })
        .collect();
    let mut out = Track {
        trajectory,
        origin: at.origin,
        track_rms: rms(&track),
        height_rms: rms(&height_errors),
        baro_offset: (!differences.is_empty()).then_some(offset),
        gnss_height: fixes
            .iter()
            .filter(|f| f.t >= at.launch && f.height.is_some())
            .map(|f| (f.t - at.latency, frame::level_position(f, at.origin)[2]))
            .collect(),
        gnss,
        baro: heights
            .iter()
            .step_by(heights.len().div_ceil(SHOWN).max(1))
            .copied()
            .collect(),
        ..Track::default()
    };
    for (k, (x, p)) in smoothed.iter().enumerate().step_by(every) {
        out.t.push(times[k]);
        out.position.push(x.nav.p.into());
        out.terms.push(terms(x, p));
        let (x, p) = &pass.epochs[k].filtered;
        out.filtered.push(terms(x, p));
    }
    out
}

/// The sensor errors of an estimate, with their 1-sigma from its covariance.
fn terms(x: &Estimate<f64>, p: &StateMatrix<f64>) -> ([f64; 12], [f64; 12]) {
    let sd = std::array::from_fn(|i| {
        let j = index::ACCEL_BIAS + i;
        p[(j, j)].max(0.0).sqrt()
    });
    (super::verdict::values(&x.sensors), sd)
}
