//! The turns between still poses, as the gyro fit takes them: the gyro's counts over each
//! turn less its bias, between the gravity directions seen where the turn leaves one pose and
//! where it reaches the next; turns over a saturated sample or dropped samples are skipped and
//! said; and the gyro matrix the fit starts from.
//!
//! A hand-held pose is not quite still: on the real MPU-9150 logs the accelerometer's direction
//! moves 0.1-0.35 deg within a pose, the size of the gyro's whole error. A turn is therefore
//! taken from the middle of the last half second of one pose to the middle of the first half second
//! of the next, between the gravity directions of those two windows, not between the poses'
//! means (held out, 0.29 -> 0.11 and 0.31 -> 0.10 deg on the two logs).

use std::ops::Range;

use nalgebra::Matrix3;

use super::super::gravity::AccelModel;
use super::super::rotation::{self, Segment};
use super::super::statics;
use super::{GyroBias, Skipped};
use crate::obs::recording::Recording;

/// The usable turns.
pub(super) struct Turns {
    /// Each turn with the bias as `--gyro-bias` says (between the poses' means, or the rest's).
    pub segments: Vec<Segment>,
    /// Each turn as a device with the stored constant bias sees it between the poses' means
    /// (from the end of one pose to the start of the next): the reference tools' measure.
    pub const_segments: Vec<Segment>,
    /// The pose each turn starts from.
    pub rotations: Vec<usize>,
    /// The accelerometer's mean counts over the windows each turn runs between.
    pub ends: Vec<[[f64; 3]; 2]>,
    /// The turns left out, and why.
    pub skipped: Vec<Skipped>,
}

/// Where the turns run: the `window` samples that end each pose and start it.
pub(super) struct Ends<'a> {
    /// The still poses.
    pub poses: &'a [Range<usize>],
    /// Samples of the window at each end (a shorter pose gives all of itself).
    pub window: usize,
    /// The accelerometer's model: the windows' gravity directions.
    pub accel: &'a AccelModel,
}

impl Ends<'_> {
    /// The samples that end pose `k` and the samples that start pose `k + 1`.
    fn windows(&self, k: usize) -> (Range<usize>, Range<usize>) {
        let (a, b) = (&self.poses[k], &self.poses[k + 1]);
        (
            a.end - self.window.min(a.len())..a.end,
            b.start..b.start + self.window.min(b.len()),
        )
    }
}

/// The turns between consecutive poses of `ends`; `gyro_means` are the gyro's means at the
/// poses, `rest_gyro` its mean at the initial rest, `gyro_bias` the constant bias.
pub(super) fn turns(
    rec: &Recording,
    gyro_bias_of: GyroBias,
    ends: &Ends<'_>,
    gyro_means: &[[f64; 3]],
    rest_gyro: [f64; 3],
    gyro_bias: [f64; 3],
) -> Turns {
    let poses = ends.poses;
    let unit = |m: [f64; 3]| super::unit(ends.accel.apply(m));
    let mid = |r: &Range<usize>| 0.5 * (rec.t[r.start] + rec.t[r.end - 1]);
    let mut segments = Vec::new();
    let mut const_segments = Vec::new();
    let mut rotations = Vec::new();
    let mut end_means = Vec::new();
    let mut skipped = Vec::new();
    for k in 0..poses.len().saturating_sub(1) {
        let (leave, reach) = ends.windows(k);
        let span = (leave.start + leave.end - 1) / 2..(reach.start + reach.end - 1) / 2 + 1;
        if rec.saturated[span.clone()].iter().any(|s| *s) {
            skipped.push(Skipped {
                pose: k,
                why: "a saturated sample".into(),
            });
            continue;
        }
        if let Some(gap) = rec
            .gaps
            .iter()
            .find(|g| g.from >= rec.t[span.start] && g.to <= rec.t[span.end - 1])
        {
            skipped.push(Skipped {
                pose: k,
                why: format!("{} samples dropped at line {}", gap.missing, gap.line),
            });
            continue;
        }
        let (ta, tb) = (mid(&poses[k]), mid(&poses[k + 1]));
        let bias_at = |t: f64| -> [f64; 3] {
            match gyro_bias_of {
                GyroBias::Poses => {
                    let w = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
                    std::array::from_fn(|j| {
                        gyro_means[k][j] + w * (gyro_means[k + 1][j] - gyro_means[k][j])
                    })
                }
                GyroBias::Rest => rest_gyro,
                GyroBias::Constant => gyro_bias,
            }
        };
        let dt: Vec<f64> = rec.t[span.clone()]
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        let x: Vec<[f64; 3]> = span
            .clone()
            .map(|i| {
                let b = bias_at(rec.t[i]);
                std::array::from_fn(|j| rec.gyro[i][j] - b[j])
            })
            .collect();
        // The device's view, as the reference tools judge it: the stored constant bias from
        // the end of one pose to the start of the next, between the poses' mean directions.
        let edge = poses[k].end - 1..poses[k + 1].start + 1;
        let xc: Vec<[f64; 3]> = edge
            .clone()
            .map(|i| std::array::from_fn(|j| rec.gyro[i][j] - gyro_bias[j]))
            .collect();
        let means = [
            statics::mean(&rec.acc, &leave),
            statics::mean(&rec.acc, &reach),
        ];
        let (from, to) = (unit(means[0]), unit(means[1]));
        segments.push(Segment { dt, x, from, to });
        const_segments.push(Segment {
            dt: rec.t[edge].windows(2).map(|w| w[1] - w[0]).collect(),
            x: xc,
            from: unit(statics::mean(&rec.acc, &poses[k])),
            to: unit(statics::mean(&rec.acc, &poses[k + 1])),
        });
        rotations.push(k);
        end_means.push(means);
    }
    Turns {
        segments,
        const_segments,
        rotations,
        ends: end_means,
        skipped,
    }
}

/// A starting gyro matrix: a diagonal scale from the angles between the gravity directions
/// and the integrated counts (hand rotations turn about one axis, roughly), with the axis signs
/// that explain the first rotations best; a logarithmic search over scales if that start
/// explains them poorly.
pub(super) fn gyro_start(segments: &[Segment]) -> [[f64; 3]; 3] {
    let probe = &segments[..segments.len().min(8)];
    let cost = |m: &Matrix3<f64>| {
        probe
            .iter()
            .map(|s| rotation::angle(m, s).powi(2))
            .sum::<f64>()
    };
    let mut ratios: Vec<f64> = segments
        .iter()
        .filter_map(|s| {
            let turned = (s.from[0] * s.to[0] + s.from[1] * s.to[1] + s.from[2] * s.to[2])
                .clamp(-1.0, 1.0)
                .acos();
            let sum: [f64; 3] = std::array::from_fn(|j| {
                s.x.iter()
                    .zip(s.dt.iter().chain([&0.0]))
                    .map(|(x, dt)| x[j] * dt)
                    .sum()
            });
            let counts = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
            (turned > 0.2 && counts > 0.0).then(|| turned / counts)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    // The angle between gravity directions understates a rotation: try a little above it too.
    let scales: Vec<f64> = ratios.get(ratios.len() / 2).map_or_else(Vec::new, |r| {
        (-2..=6)
            .map(|k| r * 2f64.powf(f64::from(k) / 4.0))
            .collect()
    });
    let mut best = (f64::INFINITY, Matrix3::identity());
    let search = |scales: &[f64], best: &mut (f64, Matrix3<f64>)| {
        for signs in 0..8u32 {
            let sign = |k: u32| if signs >> k & 1 == 1 { -1.0 } else { 1.0 };
            for &c in scales {
                let m = Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    sign(0) * c,
                    sign(1) * c,
                    sign(2) * c,
                ));
                let v = cost(&m);
                if v < best.0 {
                    *best = (v, m);
                }
            }
        }
    };
    search(&scales, &mut best);
    // Poorly explained (an RMS above 10 degrees): search the scale.
    if best.0 > probe.len() as f64 * 0.03 {
        let grid: Vec<f64> = (0..=48)
            .map(|e| 10f64.powf(-7.0 + f64::from(e) / 8.0))
            .collect();
        search(&grid, &mut best);
    }
    std::array::from_fn(|i| std::array::from_fn(|j| best.1[(i, j)]))
}
