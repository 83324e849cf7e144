//! Calibrating an IMU without external equipment, from a recording of a unit turned by hand
//! through still poses: find the poses (the threshold searched for the best accelerometer fit),
//! fit the accelerometer to gravity's magnitude, keep its quadratic terms if a partial F test
//! wants them, validate on poses left out, and fit the gyro to the rotations between poses.

use std::ops::Range;

use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use super::gravity::{self, AccelFit};
use super::lm::LmError;
use super::rotation::GyroFit;
use super::statics;
use crate::obs::recording::Recording;

pub mod ferraris;
mod few_poses;
mod gyro;
mod rest;

use gyro::{directions, gyro_fit};
use rest::Rest;
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
    /// One bias through every rotation, the one the device stores: the mean of the still poses
    /// the gyro did not turn through. A hand-held pose drifts, and its mean carries that
    /// drift; held out on the real MPU-9150 logs this predicts the rotations not seen best
    /// (0.11 and 0.10 deg against 0.17 and 0.16 with the poses' means interpolated).
    Constant,
    /// The still poses on either side, interpolated in time (follows a drifting bias).
    Poses,
    /// The initial rest only (as most published tools do).
    Rest,
}

impl GyroBias {
    /// Where the bias came from, in words.
    #[must_use]
    pub fn words(self) -> &'static str {
        match self {
            Self::Constant => "one constant bias, the still poses' mean",
            Self::Poses => "bias from the poses on either side",
            Self::Rest => "bias from the initial rest",
        }
    }
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
    /// A Ferraris session's annotated faces and turns (imucal's section list), if given.
    pub sections: Option<ferraris::Sections>,
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
            gyro_bias: GyroBias::Constant,
            folds: 5,
            sections: None,
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
    /// A Ferraris session's faces do not span three axes.
    #[error(
        "{file}: the faces of the section list do not span three axes (each axis' up and down face must differ): {why}"
    )]
    Faces {
        /// File(s).
        file: String,
        /// What was found.
        why: String,
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
    /// The poses held out (the same folds as [`Holdout`]): RMS of `|a| - g` without and with
    /// the quadratic terms, m/s^2 (`None` where a fold could not fit them).
    pub holdout: Option<[f64; 2]>,
    /// Kept: significant, and the poses held out predicted better with them.
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
    /// Folds whose training poses could not fit the model (too few for it): not judged.
    pub unfitted: usize,
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
    /// The poses the gyro turned through (their mean far from the others'): left out of the
    /// bias, the rotations on either side taking the constant bias there.
    pub turning_poses: Vec<usize>,
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
    folds: usize,
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
    if q == Quadratic::On {
        return Ok((quad, None));
    }
    let (rss0, rss1) = (
        lin.residuals.iter().map(|r| r * r).sum::<f64>(),
        quad.residuals.iter().map(|r| r * r).sum::<f64>(),
    );
    let dof = (means.len() - 12) as f64;
    let f = ((rss0 - rss1) / 3.0) / (rss1 / dof).max(f64::MIN_POSITIVE);
    let p = FisherSnedecor::new(3.0, dof).map_or(f64::NAN, |d| 1.0 - d.cdf(f.max(0.0)));
    // Significant on the poses fitted is not enough on a few poses: the terms must also
    // predict the poses held out better (on the first real MPU-9150 log's first 15 poses
    // the F test kept them, and the poses held out were 441 times worse than the fit).
    let folds = folds.clamp(2, means.len());
    let holdout = match (
        holdout(means, g, false, folds),
        holdout(means, g, true, folds),
    ) {
        (Ok(l), Ok(h)) if h.unfitted == 0 && l.unfitted == 0 => Some([l.rms, h.rms]),
        _ => None,
    };
    let kept = p < 0.05 && holdout.is_some_and(|[l, h]| h < l);
    let test = QuadraticTest {
        f,
        p,
        holdout,
        kept,
    };
    Ok((if kept { quad } else { lin }, Some(test)))
}

fn holdout(means: &[[f64; 3]], g: f64, quadratic: bool, folds: usize) -> Result<Holdout, LmError> {
    holdout_with(means, g, folds, &|train| {
        let (center, start) = gravity::center_and_start(train, g);
        gravity::fit(train, g, center, &start, false).and_then(|fit| {
            if quadratic {
                let mut s = fit.params.clone();
                s.extend([0.0; 3]);
                gravity::fit(train, g, center, &s, true)
            } else {
                Ok(fit)
            }
        })
    })
}

/// An accelerometer fit to a set of pose means.
type PoseFit<'a> = dyn Fn(&[[f64; 3]]) -> Result<AccelFit, LmError> + 'a;

/// Each pose of `folds` predicted by `fit` on the poses beside it.
fn leave_one_out(
    folds: &[([f64; 3], Vec<[f64; 3]>)],
    g: f64,
    fit: &PoseFit<'_>,
) -> Result<Holdout, LmError> {
    let errs = folds
        .iter()
        .map(|(m, train)| fit(train).map(|f| misfit(&f, *m, g)))
        .collect::<Result<Vec<f64>, _>>()?;
    Ok(Holdout::of(&errs, folds.len(), 0))
}

/// `|a| - g` at the pose mean `m` through `fit`, m/s^2.
fn misfit(fit: &AccelFit, m: [f64; 3], g: f64) -> f64 {
    let a = fit.model.apply(m);
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - g
}

impl Holdout {
    /// The figures of the held-out errors `errs` over `folds`, `unfitted` of them not judged.
    fn of(errs: &[f64], folds: usize, unfitted: usize) -> Self {
        Self {
            folds,
            rms: rms(errs),
            max: errs.iter().fold(0.0f64, |m, e| m.max(e.abs())),
            unfitted,
        }
    }
}

/// Each pose of `means` predicted by `fit` on the other folds' poses.
fn holdout_with(
    means: &[[f64; 3]],
    g: f64,
    folds: usize,
    fit: &PoseFit<'_>,
) -> Result<Holdout, LmError> {
    let mut errs = Vec::new();
    let mut unfitted = 0;
    let mut last_error = None;
    for f in 0..folds {
        let (train, test): (Vec<_>, Vec<_>) =
            means.iter().enumerate().partition(|(k, _)| k % folds != f);
        let train: Vec<[f64; 3]> = train.into_iter().map(|(_, m)| *m).collect();
        let fitted = fit(&train);
        // A fold whose poses cannot fit the model (the quadratic one on a few poses does not
        // converge) is not judged, and is counted: the verdict names it.
        let fit = match fitted {
            Ok(fit) => fit,
            Err(e) => {
                unfitted += 1;
                last_error = Some(e);
                continue;
            }
        };
        errs.extend(test.into_iter().map(|(_, m)| misfit(&fit, *m, g)));
    }
    if let (true, Some(e)) = (errs.is_empty(), last_error) {
        return Err(e);
    }
    Ok(Holdout::of(&errs, folds, unfitted))
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// How much more than the accelerometer, relative to each one's rest, the gyro must vary for
/// its motion to end a pose.
const GYRO_MARGIN: f64 = 100.0;

/// How much of a pose's end gives the gravity direction a turn leaves from (and of its start
/// the one it reaches), s: long enough to average the accelerometer's noise, short enough that
/// the gyro's bias (orientation-dependent on the Xsens MTi) is not integrated over long.
const END_WINDOW: f64 = 0.5;

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
    let (chosen, poses) = match (best, &opts.sections) {
        (Some(best), _) => best,
        // A six-face session: the poses the still test finds at the threshold that finds the
        // most (the faces if it finds fewer), for the gyro's gravity directions.
        (None, Some(s)) => most_poses(&finder, &measure, rest_level, opts)
            .filter(|(_, p)| p.len() >= 6)
            .unwrap_or_else(|| (0, ferraris::face_poses(s))),
        (None, None) => {
            return Err(few_poses::diagnose(
                &finder, opts, &trials, &measure, rest_level, rest.floor,
            ));
        }
    };
    let pose_means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.acc, r)).collect();
    let folds = opts.folds.clamp(2, pose_means.len());
    let (accel, quadratic_test, holdout, box_frame) = if let Some(s) = &opts.sections {
        let (accel, q) = ferraris::accel(rec, s, &pose_means, opts.g)?;
        // Each pose left out in turn, but for a direction's only pose (without it the axis
        // cannot be fitted: it is one of the faces that define the axis).
        let facing = directions(&pose_means, rest_level);
        let folds: Vec<([f64; 3], Vec<[f64; 3]>)> = (0..pose_means.len())
            .map(|k| {
                let others: Vec<[f64; 3]> = (0..pose_means.len())
                    .filter(|&i| i != k)
                    .map(|i| pose_means[i])
                    .collect();
                (pose_means[k], others)
            })
            .filter(|(_, others)| directions(others, rest_level) == facing)
            .collect();
        let held = leave_one_out(&folds, opts.g, &|train| {
            gravity::fit_held_cross(train, opts.g, accel.model.center, &accel.params, opts.g)
        })
        .map_err(fit_err(source, "hold-out accelerometer"))?;
        (accel, None, held, Some(q))
    } else {
        let (accel, quadratic_test) = accel_fit(&pose_means, opts.g, opts.quadratic, opts.folds)
            .map_err(fit_err(source, "accelerometer"))?;
        let quadratic = accel.params.len() == 12;
        let held = holdout(&pose_means, opts.g, quadratic, folds)
            .map_err(fit_err(source, "hold-out accelerometer"))?;
        (accel, quadratic_test, held, None)
    };

    // The gyro.
    let gyro_means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.gyro, r)).collect();
    let rest_gyro = statics::mean(&rec.gyro, &(0..rest.end));
    let turning = turning_poses(&gyro_means);
    let steady: Vec<[f64; 3]> = gyro_means
        .iter()
        .zip(&turning)
        .filter(|(_, t)| !**t)
        .map(|(m, _)| *m)
        .collect();
    let gyro_bias = match opts.gyro_bias {
        GyroBias::Poses | GyroBias::Constant => {
            std::array::from_fn(|j| steady.iter().map(|m| m[j]).sum::<f64>() / steady.len() as f64)
        }
        GyroBias::Rest => rest_gyro,
    };
    let (gyro_bias_spread, gyro_bias_rms) = spread_and_rms(&steady, gyro_bias);
    // A pose the gyro turned through is not the bias: the rotations on either side take the
    // constant bias there. (It stays a rotation's end: leaving it out, so that a rotation runs
    // across it, held 0.29 -> 0.32 and 0.31 -> 0.39 deg worse on the two real MPU-9150 logs.)
    let bias_means: Vec<[f64; 3]> = gyro_means
        .iter()
        .zip(&turning)
        .map(|(m, t)| if *t { gyro_bias } else { *m })
        .collect();
    let ends = segments::Ends {
        poses: &poses,
        window: samples(END_WINDOW),
        accel: &accel.model,
    };
    let turns = segments::turns(
        rec,
        opts.gyro_bias,
        &ends,
        &bias_means,
        rest_gyro,
        gyro_bias,
    );
    let known = match (&opts.sections, &box_frame) {
        (Some(s), Some(q)) => {
            let known = ferraris::known_turns(rec, s, q, gyro_bias);
            let start = ferraris::gyro_start(&known, s.angle_deg, q)
                .unwrap_or_else(|| segments::gyro_start(&turns.segments));
            Some((known, start))
        }
        _ => None,
    };
    let (gyro, constant_bias_angles) = gyro_fit(source, &turns, &accel, known.as_ref())?;
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
        turning_poses: (0..turning.len()).filter(|&k| turning[k]).collect(),
    })
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

/// The multiple of `opts.multipliers` whose poses face the most directions (then the most
/// poses), whatever an accelerometer fit of its own would make of them; `None` when none finds
/// a pose.
fn most_poses(
    finder: &few_poses::Finder<'_>,
    measure: &[f64],
    rest_level: f64,
    opts: &Options,
) -> Option<Chosen> {
    let samples = |s: f64| ((s * finder.rec.rate()).round() as usize).max(1);
    opts.multipliers
        .iter()
        .enumerate()
        .map(|(k, &m)| {
            let poses = finder.poses(
                measure,
                m * rest_level,
                samples(opts.min_still),
                samples(opts.window),
            );
            let means: Vec<[f64; 3]> = poses
                .iter()
                .map(|r| statics::mean(&finder.rec.acc, r))
                .collect();
            (directions(&means, rest_level), poses.len(), k, poses)
        })
        .filter(|c| c.1 > 0)
        .max_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)).then(b.2.cmp(&a.2)))
        .map(|(_, _, k, poses)| (k, poses))
}

/// Beyond this many robust standard deviations (1.4826 median absolute deviations) of the
/// poses' gyro means from their median, on any axis, a pose's gyro mean is a turn, not the
/// bias: the accelerometer's still test passes a slow turn (a real MPU-9150 log held poses
/// whose gyro read 70 mrad/s beside a bias steady to 2 mrad/s).
const TURNING_SIGMAS: f64 = 6.0;

/// Per pose, whether the gyro turned through it: its mean is more than [`TURNING_SIGMAS`]
/// robust standard deviations from the poses' median on an axis. Never more than a third of
/// the poses (a bias that drifts is followed, not refused).
fn turning_poses(means: &[[f64; 3]]) -> Vec<bool> {
    let robust: [(f64, f64); 3] = std::array::from_fn(|j| {
        let (centre, sd) =
            crate::stats::robust::median_mad(&means.iter().map(|m| m[j]).collect::<Vec<_>>());
        (centre, sd.max(1e-12 * (1.0 + centre.abs())))
    });
    let score = |m: &[f64; 3]| -> f64 {
        (0..3)
            .map(|j| (m[j] - robust[j].0).abs() / robust[j].1)
            .fold(0.0, f64::max)
    };
    let flagged: Vec<bool> = means.iter().map(|m| score(m) > TURNING_SIGMAS).collect();
    if flagged.iter().filter(|f| **f).count() * 3 > means.len() {
        vec![false; means.len()]
    } else {
        flagged
    }
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

#[cfg(test)]
mod tests {
    use super::turning_poses;

    /// A pose whose gyro mean sits 70 mrad/s off a bias steady to 1 mrad/s is a turn; a bias
    /// drifting linearly over the poses is followed, not called a turn.
    #[test]
    fn a_turn_through_a_pose_is_found_and_a_drift_is_not() {
        let steady = |k: usize| [-0.0105 + 1e-3 * ((k * 7) % 5) as f64 / 5.0, 0.019, 0.0056];
        let mut means: Vec<[f64; 3]> = (0..20).map(steady).collect();
        means[4][0] = -0.080;
        let turning = turning_poses(&means);
        assert_eq!((0..20).filter(|&k| turning[k]).collect::<Vec<_>>(), vec![4]);
        let drift: Vec<[f64; 3]> = (0..20)
            .map(|k| [0.01 + 2e-3 * k as f64, 0.0, 0.0])
            .collect();
        assert!(turning_poses(&drift).iter().all(|t| !t));
        // Exact means (a simulation without noise) flag nothing.
        assert!(turning_poses(&[[0.1; 3]; 12]).iter().all(|t| !t));
    }
}
