//! Why a recording gave too few poses, and what would do: the thresholds tried and what each
//! found, the poses of the best one and how long they held, and whether shorter holds would
//! give enough.

use std::ops::Range;

use super::super::{gravity, statics};
use super::gyro::directions;
use super::{MIN_POSES, Options, SelfCalError, Trial};
use crate::obs::recording::Recording;

/// Finds the still poses of a recording: what [`statics::poses`] needs besides the measure.
pub(super) struct Finder<'a> {
    /// The recording.
    pub rec: &'a Recording,
    /// The largest difference of two runs' means, per axis, that still makes them one hold.
    pub tol: [f64; 3],
    /// Samples where the gyro turned.
    pub turned: &'a [bool],
}

impl Finder<'_> {
    /// The poses where `measure` stays under `threshold` for `min_len` samples, runs up to
    /// `window` samples apart joined.
    pub(super) fn poses(
        &self,
        measure: &[f64],
        threshold: f64,
        min_len: usize,
        window: usize,
    ) -> Vec<Range<usize>> {
        let join = statics::Join {
            acc: &self.rec.acc,
            gap: window,
            tol: self.tol,
            turned: self.turned,
        };
        statics::poses(measure, &self.rec.saturated, threshold, min_len, &join)
    }

    /// Samples in `s` seconds (at least one).
    pub(super) fn samples(&self, s: f64) -> usize {
        ((s * self.rec.rate()).round() as usize).max(1)
    }
}

/// The error of a recording in which no threshold found enough poses, with what was tried,
/// what the best threshold found, and the advice.
pub(super) fn diagnose(
    finder: &Finder<'_>,
    opts: &Options,
    trials: &[Trial],
    measure: &[f64],
    rest_level: f64,
    floor: [f64; 3],
) -> SelfCalError {
    let rec = finder.rec;
    let t0 = rec.t[0];
    let min_len = finder.samples(opts.min_still);
    // Runs of thresholds that found the same number: "7 at 1 x, 8 at 2 x to 10 x".
    let mut runs: Vec<(usize, f64, f64)> = Vec::new();
    for t in trials {
        match runs.last_mut() {
            Some(r) if r.0 == t.poses => r.2 = t.multiplier,
            _ => runs.push((t.poses, t.multiplier, t.multiplier)),
        }
    }
    let tried = runs
        .iter()
        .map(|(n, a, b)| {
            if a == b {
                format!("{n} at {a} x")
            } else {
                format!("{n} at {a} x to {b} x")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
        + " the initial rest's level";
    // The poses of the threshold that found the most directions, and how long they hold.
    let most = opts
        .multipliers
        .iter()
        .map(|&m| {
            finder.poses(
                measure,
                m * rest_level,
                min_len,
                finder.samples(opts.window),
            )
        })
        .max_by_key(|p| {
            let means: Vec<[f64; 3]> = p.iter().map(|r| statics::mean(&rec.acc, r)).collect();
            (directions(&means, rest_level), p.len())
        })
        .unwrap_or_default();
    let mut holds: Vec<f64> = most.iter().map(|r| r.len() as f64 * rec.period).collect();
    holds.sort_by(f64::total_cmp);
    let most_means: Vec<[f64; 3]> = most.iter().map(|r| statics::mean(&rec.acc, r)).collect();
    let found = format!(
        "{} pose(s) facing {} distinct directions{} at {:.1} Hz over {:.1} s after a {:.1} s rest",
        most.len(),
        directions(&most_means, rest_level),
        match (holds.first(), holds.last()) {
            (Some(a), Some(b)) => format!(" held {a:.1} to {b:.1} s"),
            _ => String::new(),
        },
        rec.rate(),
        rec.t.last().copied().unwrap_or(t0) - t0 - opts.init_rest,
        opts.init_rest
    );
    // Would shorter holds do? Only if they give poses the fit takes (not a rest split by
    // noise into poses that all face one way).
    let fits = |poses: &[Range<usize>]| {
        let means: Vec<[f64; 3]> = poses.iter().map(|r| statics::mean(&rec.acc, r)).collect();
        let (center, start) = gravity::center_and_start(&means, opts.g);
        poses.len() >= MIN_POSES
            && directions(&means, rest_level) >= MIN_POSES
            && gravity::fit(&means, opts.g, center, &start, false).is_ok()
    };
    let shorter = [0.5, 0.25]
        .into_iter()
        .filter(|s| *s < opts.min_still)
        .find_map(|s| {
            // The still measure's window no longer than the hold.
            let measure = statics::measure(&rec.acc, finder.samples(s.min(opts.window)) | 1, floor);
            opts.multipliers
                .iter()
                .map(|&m| {
                    finder.poses(
                        &measure,
                        m * rest_level,
                        finder.samples(s),
                        finder.samples(s.min(opts.window)),
                    )
                })
                .filter(|p| fits(p))
                .map(|p| p.len())
                .max()
                .map(|n| (s, n))
        });
    let advice = match shorter {
        Some((s, n)) => format!(
            "Holds of {s} s would give {n}: run again with --min-still {s}{} (shorter \
             holds average less noise), or record more poses",
            if s < opts.window {
                format!(" --window {s}")
            } else {
                String::new()
            }
        ),
        None => format!(
            "Record it again with {MIN_POSES} or more poses (30 are better), spread over all \
             directions, each held still for at least {:.1} s (--min-still)",
            opts.min_still
        ),
    };
    // Enough poses, too few directions: say so, not only "too few".
    let facing = directions(&most_means, rest_level);
    let advice = if most.len() >= MIN_POSES && facing < MIN_POSES {
        format!(
            "The {} poses face only {facing} distinct directions: |a| = g alone cannot separate \
             the accelerometer's 9 parameters on so few. A six-face session with turns (imucal's \
             Ferraris method) is calibrated from its section list: give it with --sections \
             FILE (and --turn-angle if its turns are not -360 deg). {advice}",
            most.len()
        )
    } else {
        advice
    };
    SelfCalError::TooFewPoses {
        file: rec.source.as_str().into(),
        tried,
        found,
        advice,
        needed: MIN_POSES,
    }
}
