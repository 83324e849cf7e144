//! Calibrating an IMU without external equipment, from a recording of a unit turned by hand
//! through still poses: find the poses (the threshold searched for the best accelerometer fit),
//! fit the accelerometer to gravity's magnitude, keep its quadratic terms if a partial F test
//! wants them, validate on poses left out, and fit the gyro to the rotations between poses.

use std::ops::Range;

use nalgebra::Matrix3;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use super::gravity::{self, AccelFit};
use super::lm::LmError;
use super::rotation::{self, GyroFit};
use super::statics;
use crate::obs::recording::Recording;

mod few_poses;
mod segments;

/// Whether to fit the accelerometer's quadratic terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Quadratic {
    /// Keep them when the partial F test says they are significant at 5 %.
    Auto,
    /// Never.
    Off,
    /// Always.
    On,
}

/// Where the gyro bias comes from during each rotation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum GyroBias {
    /// The still poses on either side, interpolated in time (follows a drifting bias).
    Poses,
    /// The initial rest only (as most published tools do).
    Rest,
}

/// Settings; the defaults suit a recording at about 100 Hz with still poses of a few seconds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Options {
    /// Local gravity, m/s^2.
    pub g: f64,
    /// Length of the initial rest, s.
    pub init_rest: f64,
    /// Window of the still measure, s.
    pub window: f64,
    /// Shortest still pose, s.
    pub min_still: f64,
    /// Threshold multiples of the initial rest's level to try.
    pub multipliers: Vec<f64>,
    /// The accelerometer's quadratic terms.
    pub quadratic: Quadratic,
    /// The gyro bias during rotations.
    pub gyro_bias: GyroBias,
    /// Hold-out folds for validation.
    pub folds: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            g: 9.81,
            init_rest: 30.0,
            window: 1.0,
            min_still: 1.0,
            multipliers: (1..=10).map(f64::from).collect(),
            quadratic: Quadratic::Auto,
            gyro_bias: GyroBias::Poses,
            folds: 5,
        }
    }
}

/// Fewest poses for the accelerometer fit (9 parameters and 3 degrees of freedom).
pub const MIN_POSES: usize = 12;
/// Fewest rotations for the gyro fit (9 parameters, 2 independent angles per rotation).
pub const MIN_ROTATIONS: usize = 6;

/// Why it failed.
#[derive(Debug, thiserror::Error)]
pub enum SelfCalError {
    /// The recording is shorter than its initial rest.
    #[error(
        "{file}: the recording lasts {len:.1} s, no longer than the initial rest of {rest:.1} s (--init-rest); record the rest, then turn the unit through still poses"
    )]
    TooShort {
        /// File(s).
        file: String,
        /// Duration.
        len: f64,
        /// Rest.
        rest: f64,
    },
    /// The initial rest moves.
    #[error(
        "{file}: the unit moves at {at:.1} s, inside the initial rest of {rest:.1} s (--init-rest): the accelerometer varies {ratio:.0} times more there than in the quietest second; give the length of the real rest with --init-rest, or record one"
    )]
    RestNotStill {
        /// File(s).
        file: String,
        /// Time.
        at: f64,
        /// Rest.
        rest: f64,
        /// How much more it varies.
        ratio: f64,
    },
    /// Too few still poses at every threshold.
    #[error(
        "{file}: too few still poses: {tried}; the accelerometer fit needs at least {needed}. Found: {found}. {advice}"
    )]
    TooFewPoses {
        /// File(s).
        file: String,
        /// What each threshold found.
        tried: String,
        /// The poses the most the thresholds found: how long they hold, at what rate.
        found: String,
        /// What would work: shorter holds accepted, or more poses recorded.
        advice: String,
        /// How many are needed.
        needed: usize,
    },
    /// Too few usable rotations.
    #[error(
        "{file}: {usable} usable rotations between still poses ({skipped} skipped: {why}); the gyro fit needs at least {needed}"
    )]
    TooFewRotations {
        /// File(s).
        file: String,
        /// Usable.
        usable: usize,
        /// Skipped.
        skipped: usize,
        /// Why they were skipped.
        why: String,
        /// Needed.
        needed: usize,
    },
    /// A fit failed.
    #[error("{file}: the {what} fit failed: {err}")]
    Fit {
        /// File(s).
        file: String,
        /// Which.
        what: &'static str,
        /// Why.
        err: LmError,
    },
}

/// One threshold tried.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Trial {
    /// Multiple of the rest level.
    pub multiplier: f64,
    /// Still poses found.
    pub poses: usize,
    /// RMS of `|a| - g` of the linear fit, m/s^2 (`None` with too few poses).
    pub rms: Option<f64>,
}

/// The partial F test for the quadratic terms.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct QuadraticTest {
    /// F statistic (3 and n - 12 degrees of freedom).
    pub f: f64,
    /// Its p value.
    pub p: f64,
    /// Kept.
    pub kept: bool,
}

/// Hold-out validation: each pose predicted by a fit that did not see it.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Holdout {
    /// Folds.
    pub folds: usize,
    /// RMS of `|a| - g` on held-out poses, m/s^2.
    pub rms: f64,
    /// Largest, m/s^2.
    pub max: f64,
}

/// A rotation left out of the gyro fit.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Skipped {
    /// Between poses `pose` and `pose + 1`.
    pub pose: usize,
    /// Why.
    pub why: String,
}

/// Everything the calibration found.
#[derive(Debug, Clone)]
pub struct SelfCal {
    /// The options used.
    pub options: Options,
    /// Sampling rate, Hz.
    pub rate: f64,
    /// Samples of the initial rest.
    pub rest: Range<usize>,
    /// The still measure of the initial rest.
    pub rest_level: f64,
    /// The still measure per sample (for the plot).
    pub measure: Vec<f64>,
    /// Thresholds tried.
    pub trials: Vec<Trial>,
    /// The threshold chosen (index into `trials`).
    pub chosen: usize,
    /// The still poses (sample ranges).
    pub poses: Vec<Range<usize>>,
    /// Accelerometer mean counts at each pose.
    pub pose_means: Vec<[f64; 3]>,
    /// The accelerometer fit.
    pub accel: AccelFit,
    /// The quadratic test (unless `--quadratic on|off`).
    pub quadratic_test: Option<QuadraticTest>,
    /// Hold-out validation.
    pub holdout: Holdout,
    /// The gyro fit.
    pub gyro: GyroFit,
    /// Gyro bias the device stores (counts): the mean over all poses (or the rest).
    pub gyro_bias: [f64; 3],
    /// Spread of the gyro's mean at the poses (max - min, counts) per axis.
    pub gyro_bias_spread: [f64; 3],
    /// RMS of the gyro's mean at the poses about the stored bias (counts) per axis: the 1-sigma
    /// error of the constant bias the device stores.
    pub gyro_bias_rms: [f64; 3],
    /// Gravity-direction error of each rotation with the stored constant bias, radians.
    pub constant_bias_angles: Vec<f64>,
    /// Rotations used: between pose `k` and `k + 1`.
    pub rotations: Vec<usize>,
    /// Rotations left out.
    pub skipped: Vec<Skipped>,
    /// Times (s from the start) of one-sample glitches in the initial rest, left out of it.
    pub rest_glitches: Vec<f64>,
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|r| r * r).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

fn fit_err(source: &str, what: &'static str) -> impl FnOnce(LmError) -> SelfCalError {
    let source = source.to_string();
    move |err| SelfCalError::Fit {
        file: source,
        what,
        err,
    }
}

/// Fits the accelerometer to `means`, linear then (by `q`) quadratic.
fn accel_fit(
    means: &[[f64; 3]],
    g: f64,
    q: Quadratic,
) -> Result<(AccelFit, Option<QuadraticTest>), LmError> {
    let (center, start) = gravity::center_and_start(means, g);
    let lin = gravity::fit(means, g, center, &start, false)?;
    let try_quad = q != Quadratic::Off && means.len() > 12;
    if !try_quad {
        return Ok((lin, None));
    }
    let mut s = lin.params.clone();
    s.extend([0.0; 3]);
    let quad = gravity::fit(means, g, center, &s, true)?;
    let (rss0, rss1) = (
        lin.residuals.iter().map(|r| r * r).sum::<f64>(),
        quad.residuals.iter().map(|r| r * r).sum::<f64>(),
    );
    let dof = (means.len() - 12) as f64;
    let f = ((rss0 - rss1) / 3.0) / (rss1 / dof).max(f64::MIN_POSITIVE);
    let p = FisherSnedecor::new(3.0, dof).map_or(f64::NAN, |d| 1.0 - d.cdf(f.max(0.0)));
    let kept = match q {
        Quadratic::On => true,
        _ => p < 0.05,
    };
    let test = (q == Quadratic::Auto).then_some(QuadraticTest { f, p, kept });
    Ok((if kept { quad } else { lin }, test))
}

fn holdout(means: &[[f64; 3]], g: f64, quadratic: bool, folds: usize) -> Result<Holdout, LmError> {
    let mut errs = Vec::new();
    for f in 0..folds {
        let (train, test): (Vec<_>, Vec<_>) =
            means.iter().enumerate().partition(|(k, _)| k % folds != f);
        let train: Vec<[f64; 3]> = train.into_iter().map(|(_, m)| *m).collect();
        let (center, start) = gravity::center_and_start(&train, g);
        let mut fit = gravity::fit(&train, g, center, &start, false)?;
        if quadratic {
            let mut s = fit.params.clone();
            s.extend([0.0; 3]);
            fit = gravity::fit(&train, g, center, &s, true)?;
        }
        for (_, m) in test {
            let a = fit.model.apply(*m);
            errs.push((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - g);
        }
    }
    Ok(Holdout {
        folds,
        rms: rms(&errs),
        max: errs.iter().fold(0.0f64, |m, e| m.max(e.abs())),
    })
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// How much more than the accelerometer, relative to each one's rest, the gyro must vary for
/// its motion to end a pose.
const GYRO_MARGIN: f64 = 100.0;

/// The gyro's still-measure window, s.
const GYRO_WINDOW: f64 = 0.2;

/// Calibrates the IMU of `rec`.
///
/// # Errors
/// A [`SelfCalError`] saying what is wrong with the recording and what to do.
pub fn calibrate(rec: &Recording, opts: &Options) -> Result<SelfCal, SelfCalError> {
    let source = rec.source.as_str();
    let rate = rec.rate();
    let samples = |s: f64| ((s * rate).round() as usize).max(1);
    let rest = Rest::checked(rec, opts)?;
    // The rest's glitches take the rest's median: they move no pose's mean, no measure.
    let cleaned;
    let rec = if rest.glitches.is_empty() {
        rec
    } else {
        let mut r = rec.clone();
        let median: [f64; 3] = std::array::from_fn(|j| {
            let x: Vec<f64> = rec.acc[..rest.end].iter().map(|a| a[j]).collect();
            crate::stats::robust::median_mad(&x).0
        });
        for &i in &rest.glitches {
            r.acc[i] = median;
        }
        cleaned = r;
        &cleaned
    };
    let rest_level = rest.level;
    // A turn about the vertical barely moves the accelerometer, but the gyro sees it: the
    // gyro's measure, put in the accelerometer's units by the ratio of the two rest levels and
    // divided by GYRO_MARGIN (a hand holding a pose trembles: the gyro sees that too, and it
    // is not a turn), counts where it is the larger, and marks where the unit turned.
    let window = samples(opts.window) | 1;
    let gfloor = statics::floor(statics::quantum(&rec.gyro));
    let scale = rest_level / statics::rest_level(&rec.gyro[..rest.end], gfloor) / GYRO_MARGIN;
    // A short window: a turn's edges must not bleed into a short hold.
    let gyro: Vec<f64> = statics::measure(&rec.gyro, samples(GYRO_WINDOW) | 1, gfloor)
        .into_iter()
        .map(|g| g * scale)
        .collect();
    let turned: Vec<bool> = gyro.iter().map(|g| *g > 10.0 * rest_level).collect();
    let measure: Vec<f64> = statics::measure(&rec.acc, window, rest.floor)
        .into_iter()
        .zip(&gyro)
        .map(|(a, g)| a.max(*g))
        .collect();
    let finder = few_poses::Finder {
        rec,
        tol: rest.tol,
        turned: &turned,
    };
    let (trials, best) = threshold_trials(&finder, &measure, rest_level, opts);
    let Some((chosen, poses)) = best else {
        return Err(few_poses::diagnose(
            &finder, opts, &trials, &measure, rest_level, rest.floor,
        ));
    };
    let pose_means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.acc, r)).collect();
    let (accel, quadratic_test) =
        accel_fit(&pose_means, opts.g, opts.quadratic).map_err(fit_err(source, "accelerometer"))?;
    let quadratic = accel.params.len() == 12;
    let holdout = holdout(
        &pose_means,
        opts.g,
        quadratic,
        opts.folds.clamp(2, pose_means.len()),
    )
    .map_err(fit_err(source, "hold-out accelerometer"))?;

    // The gyro.
    let gyro_means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.gyro, r)).collect();
    let rest_gyro = statics::mean(&rec.gyro, &(0..rest.end));
    let gyro_bias = match opts.gyro_bias {
        GyroBias::Poses => std::array::from_fn(|j| {
            gyro_means.iter().map(|m| m[j]).sum::<f64>() / gyro_means.len() as f64
        }),
        GyroBias::Rest => rest_gyro,
    };
    let (gyro_bias_spread, gyro_bias_rms) = spread_and_rms(&gyro_means, gyro_bias);
    let dirs: Vec<[f64; 3]> = pose_means
        .iter()
        .map(|m| unit(accel.model.apply(*m)))
        .collect();
    let turns = segments::turns(
        rec,
        opts.gyro_bias,
        &poses,
        &dirs,
        &gyro_means,
        rest_gyro,
        gyro_bias,
    );
    let (gyro, constant_bias_angles) = gyro_fit(source, &turns, &accel, &pose_means)?;
    Ok(SelfCal {
        options: opts.clone(),
        rate,
        rest: 0..rest.end,
        rest_level,
        measure,
        trials,
        chosen,
        poses,
        pose_means,
        accel,
        quadratic_test,
        holdout,
        gyro,
        gyro_bias,
        gyro_bias_spread,
        gyro_bias_rms,
        constant_bias_angles,
        rotations: turns.rotations,
        skipped: turns.skipped,
        rest_glitches: rest.glitches.iter().map(|&i| rec.t[i] - rec.t[0]).collect(),
    })
}

/// The initial rest, checked: long enough and still.
struct Rest {
    /// The first sample after it.
    end: usize,
    /// The accelerometer's quantisation variance, which floors every variance.
    floor: [f64; 3],
    /// Its level of motion (the accelerometer's measure at rest).
    level: f64,
    /// Two still runs whose means agree within this (8 sigma of the rest's noise, per axis),
    /// a window apart at most, are one hold.
    tol: [f64; 3],
    /// One-sample glitches inside it, left out of its level (sample indices).
    glitches: Vec<usize>,
}

impl Rest {
    /// The rest of `opts.init_rest` seconds at the start of `rec`.
    ///
    /// # Errors
    /// A recording shorter than the rest, or a rest with a second far noisier than its
    /// quietest (the unit was moved).
    fn checked(rec: &Recording, opts: &Options) -> Result<Self, SelfCalError> {
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

/// The chosen threshold's index among the trials, and the poses it found.
type Chosen = (usize, Vec<Range<usize>>);

/// Every threshold of `opts.multipliers` tried, and the one chosen with its poses: the multiple
/// whose poses face the most distinct directions (a threshold too low for the noise misses
/// holds, and the fit of fewer poses looks better only because it has fewer to fit; one too
/// high merges holds across short turns); ties go to the best linear accelerometer fit. `None`
/// when no threshold finds enough poses for a fit.
fn threshold_trials(
    finder: &few_poses::Finder<'_>,
    measure: &[f64],
    rest_level: f64,
    opts: &Options,
) -> (Vec<Trial>, Option<Chosen>) {
    let rec = finder.rec;
    let samples = |s: f64| ((s * rec.rate()).round() as usize).max(1);
    let min_len = samples(opts.min_still);
    let mut trials = Vec::new();
    let mut found: Vec<(usize, f64, usize, Vec<Range<usize>>)> = Vec::new();
    for &m in &opts.multipliers {
        let poses = finder.poses(measure, m * rest_level, min_len, samples(opts.window));
        let means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.acc, r)).collect();
        let rms_m = if poses.len() >= MIN_POSES {
            let (center, start) = gravity::center_and_start(&means, opts.g);
            gravity::fit(&means, opts.g, center, &start, false)
                .ok()
                .map(|f| f.rms())
        } else {
            None
        };
        let count = poses.len();
        if let Some(r) = rms_m {
            found.push((trials.len(), r, directions(&means, rest_level), poses));
        }
        trials.push(Trial {
            multiplier: m,
            poses: count,
            rms: rms_m,
        });
    }
    let best = found
        .into_iter()
        .max_by(|a, b| a.2.cmp(&b.2).then(b.1.total_cmp(&a.1)))
        .map(|(k, _, _, poses)| (k, poses));
    (trials, best)
}

/// Per axis, the spread (largest less smallest) of the pose means `means` and their RMS
/// about `bias`.
fn spread_and_rms(means: &[[f64; 3]], bias: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let spread = std::array::from_fn(|j| {
        let (lo, hi) = means
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
                (lo.min(m[j]), hi.max(m[j]))
            });
        hi - lo
    });
    let rms = std::array::from_fn(|j| {
        (means.iter().map(|m| (m[j] - bias[j]).powi(2)).sum::<f64>() / means.len() as f64).sqrt()
    });
    (spread, rms)
}

/// The gyro's fit to the rotations between poses (`turns`), its covariance including the
/// accelerometer's error in the rotations' end directions, and the angle each rotation of the
/// constant-bias check turned through.
///
/// # Errors
/// Too few usable rotations (each skipped one says why), or a fit that fails.
fn gyro_fit(
    source: &str,
    turns: &segments::Turns,
    accel: &AccelFit,
    pose_means: &[[f64; 3]],
) -> Result<(GyroFit, Vec<f64>), SelfCalError> {
    let segments::Turns {
        segments,
        const_segments,
        rotations,
        skipped,
    } = turns;
    if segments.len() < MIN_ROTATIONS {
        let why = if skipped.is_empty() {
            "none".into()
        } else {
            skipped
                .iter()
                .map(|s| s.why.clone())
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Err(SelfCalError::TooFewRotations {
            file: source.into(),
            usable: segments.len(),
            skipped: skipped.len(),
            why,
            needed: MIN_ROTATIONS,
        });
    }
    let start = segments::gyro_start(segments);
    let mut gyro = rotation::fit(segments, start).map_err(fit_err(source, "gyro"))?;
    // The rotations' ends are the accelerometer's gravity directions: its error is the gyro's.
    if let Some(cov_a) = &accel.covariance {
        let center = accel.model.center;
        let ends = |q: &[f64]| {
            let model = gravity::AccelModel::from_params(center, q);
            rotations
                .iter()
                .map(|&k| {
                    (
                        unit(model.apply(pose_means[k])),
                        unit(model.apply(pose_means[k + 1])),
                    )
                })
                .collect::<Vec<_>>()
        };
        if let Some(c) = rotation::with_direction_error(segments, &gyro, &accel.params, cov_a, ends)
        {
            gyro.covariance = Some(c);
        }
    }
    let m = Matrix3::from_fn(|i, j| gyro.matrix[i][j]);
    let constant_bias_angles = const_segments
        .iter()
        .map(|s| rotation::angle(&m, s))
        .collect();
    Ok((gyro, constant_bias_angles))
}

/// How many of the pose means `means` (counts) face directions at least 10 degrees from each
/// other: the poses a fit can tell apart. The directions are taken about the middle of the
/// means' range; means that spread less than 100 times the noise (`rest_level`, a variance)
/// face one direction.
fn directions(means: &[[f64; 3]], rest_level: f64) -> usize {
    if means.is_empty() {
        return 0;
    }
    let span = |j: usize| {
        let (lo, hi) = means
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
                (lo.min(m[j]), hi.max(m[j]))
            });
        (lo, hi)
    };
    let ranges: [(f64, f64); 3] = std::array::from_fn(span);
    let widest = ranges.iter().map(|(lo, hi)| hi - lo).fold(0.0f64, f64::max);
    if widest < 100.0 * rest_level.sqrt().max(1.0) {
        return 1;
    }
    let center: [f64; 3] = std::array::from_fn(|j| (ranges[j].0 + ranges[j].1) / 2.0);
    let cos_limit = 10f64.to_radians().cos();
    let mut seen: Vec<[f64; 3]> = Vec::new();
    for m in means {
        let d: [f64; 3] = std::array::from_fn(|j| m[j] - center[j]);
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if n == 0.0 {
            continue;
        }
        let u = d.map(|x| x / n);
        if seen
            .iter()
            .all(|s| s[0] * u[0] + s[1] * u[1] + s[2] * u[2] < cos_limit)
        {
            seen.push(u);
        }
    }
    seen.len().max(1)
}
