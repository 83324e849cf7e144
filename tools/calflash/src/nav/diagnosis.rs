//! What the recording shows where a flight's filter lost its fit: the IMU's flagged samples,
//! the turn it makes between two samples, and how often the receiver gave a new fix, over the
//! span where a kind's innovations were refused, and the satellites its fixes used. Each is
//! named only past a bound that makes it able to lose a track (named as what can, not as what
//! did: that needs a flight run without it); otherwise the figures are given and the cause is
//! said to be unknown. Either way the verdict is FILTER DOES NOT FIT, never a calibration
//! shift read from a track the filter lost.

use serde::Serialize;

use super::input::{Fix, FixCounts, ImuSeries};

/// Share of a span's samples flagged before the sensors are named as the cause.
pub const FLAGGED_AT_MOST: f64 = 0.01;

/// Turn between two samples (rad) past which the sample rate is named as too low for the
/// spin: about 12 samples a turn, where a strapdown's coning and sculling terms no longer
/// hold.
pub const TURN_PER_SAMPLE_AT_MOST: f64 = 0.5;

/// Time without a new fix (s) past which the receiver is named as holding its fix.
pub const HOLD_AT_MOST: f64 = 2.0;

/// Satellites below which a fix is named as weak: four fix a position with no redundancy
/// (and no check on it), five with one.
pub const SATELLITES_AT_LEAST: f64 = 6.0;

/// The fixes in a span hold together when they lie within this many of their stated 1-sigma
/// (RMS, each horizontal axis) of one smooth path: a cubic in time through them.
pub const SMOOTH_WITHIN_SIGMA: f64 = 3.0;

/// The fewest fixes in a span for their smoothness to be judged (four fit the cubic exactly).
pub const SMOOTH_AT_LEAST: usize = 8;

/// The fixes judged for smoothness reach this far beyond the span on each side, s: a receiver
/// whose every fix in the span is off by the same amount (a fault with a start and an end)
/// steps there.
pub const SMOOTH_MARGIN: f64 = 2.0;

/// What was seen over one span.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// The span, s.
    pub from: f64,
    /// End of the span, s.
    pub to: f64,
    /// IMU samples in the span.
    pub samples: usize,
    /// Of them, with the accelerometers' and the gyros' readings flagged.
    pub flagged: [usize; 2],
    /// The largest rate in the span, rad/s, and the turn between two samples there, rad.
    pub largest_rate: (f64, f64),
    /// The longest time in the span between two new fixes, s, from when.
    pub longest_without_fix: (f64, f64),
    /// Rows of the GNSS file that repeated the fix before them (the whole file).
    pub repeated_rows: usize,
    /// The fixes in the span that name their satellites, and the fewest of them.
    pub satellites: Option<(usize, f64)>,
    /// Of those fixes, how many used fewer than [`SATELLITES_AT_LEAST`].
    pub weak_fixes: usize,
    /// The fixes in the span and their RMS distance (m, each horizontal axis) from one cubic
    /// in time through them, when there are at least [`SMOOTH_AT_LEAST`].
    pub fixes_from_smooth_path: Option<(usize, f64)>,
    /// What the recording shows did not lose the track (the receiver, when its fixes hold
    /// together), a sentence.
    pub finding: Option<String>,
    /// The causes found, each a sentence; empty when none passes its bound.
    pub causes: Vec<String>,
}

impl Diagnosis {
    /// The sentence a verdict gives: the causes found, or the figures and that none is.
    #[must_use]
    pub fn sentence(&self) -> String {
        let span = format!("from {:.1} to {:.1} s", self.from, self.to);
        if let Some(finding) = &self.finding {
            return if self.causes.is_empty() {
                format!("{span} {finding}")
            } else {
                format!(
                    "{span} {finding}; also seen there: {}",
                    self.causes.join("; ")
                )
            };
        }
        if self.causes.is_empty() {
            format!(
                "{span} no sensor was flagged past {:.0} % of {} samples ({} accelerometer, {} gyro), the IMU turned at most {:.3} rad between samples ({:.0} deg/s) and the receiver gave a new fix at least every {:.1} s: the cause is not known",
                100.0 * FLAGGED_AT_MOST,
                self.samples,
                self.flagged[0],
                self.flagged[1],
                self.largest_rate.1,
                self.largest_rate.0.to_degrees(),
                self.longest_without_fix.0,
            )
        } else {
            format!(
                "{span} the recording shows what can lose a track (not shown to be what lost this one): {}",
                self.causes.join("; ")
            )
        }
    }
}

/// What `imu` and `fixes` show over `[from, to]` (s), `counts` being the GNSS file's and
/// `noise` the fixes' stated horizontal 1-sigma, m.
#[must_use]
pub fn diagnose(
    (from, to): (f64, f64),
    imu: &ImuSeries,
    fixes: &[Fix],
    counts: &FixCounts,
    noise: f64,
) -> Diagnosis {
    let mut samples = 0;
    let mut flagged = [0; 2];
    let mut largest = (0.0_f64, 0.0_f64);
    for i in 0..imu.t.len() {
        let t = imu.t[i];
        if t < from || t > to {
            continue;
        }
        samples += 1;
        for (n, f) in flagged.iter_mut().zip(imu.flagged[i]) {
            *n += usize::from(f);
        }
        let rate = imu.w[i].iter().map(|x| x * x).sum::<f64>().sqrt();
        let dt = if i > 0 { t - imu.t[i - 1] } else { 0.0 };
        if rate > largest.0 {
            largest = (rate, rate * dt);
        }
    }
    // The fixes around the span too: a hold that began before it counts.
    // The time without a new fix inside the span, a hold that began before it counted from
    // the span's start.
    let mut longest = (0.0_f64, from);
    let mut before = fixes.iter().rev().find(|f| f.t <= from).map(|f| f.t);
    for f in fixes.iter().filter(|f| f.t > from) {
        let since = before.map_or(from, |b| b.max(from));
        let inside = f.t.min(to) - since;
        if inside > longest.0 {
            longest = (inside, since);
        }
        before = Some(f.t);
        if f.t >= to {
            break;
        }
    }
    let in_span: Vec<f64> = fixes
        .iter()
        .filter(|f| f.t >= from && f.t <= to)
        .filter_map(|f| f.satellites)
        .collect();
    let satellites = in_span
        .iter()
        .copied()
        .reduce(f64::min)
        .map(|fewest| (in_span.len(), fewest));
    let weak_fixes = in_span.iter().filter(|s| **s < SATELLITES_AT_LEAST).count();
    let smooth = smooth_path(fixes, (from - SMOOTH_MARGIN, to + SMOOTH_MARGIN));
    let holds_together = smooth.is_some_and(|(_, rms)| rms <= SMOOTH_WITHIN_SIGMA * noise);
    let finding = smooth.filter(|_| holds_together).map(|(n, rms)| {
        format!(
            "the receiver's {n} fixes from {:.1} to {:.1} s hold together (within {rms:.1} m RMS of one smooth path, a cubic in time, against their stated {noise} m) while the track left them: the receiver did not lose the track, the IMU's prediction did (its attitude, or errors beyond the prior the filter was given), and the filter then refused the fixes that would have brought it back{}",
            from - SMOOTH_MARGIN,
            to + SMOOTH_MARGIN,
            if weak_fixes * 2 > in_span.len() {
                format!(
                    " ({weak_fixes} of them used fewer than {SATELLITES_AT_LEAST:.0} satellites, and still agree)"
                )
            } else {
                String::new()
            }
        )
    });
    let mut causes = Vec::new();
    if weak_fixes * 2 > in_span.len() && !holds_together {
        causes.push(format!(
            "{weak_fixes} of the {} fixes there used fewer than {SATELLITES_AT_LEAST:.0} satellites (as few as {:.0}): a position from so few has no check on it and a geometry that can put it hundreds of metres off, which the fixes' stated noise does not cover",
            in_span.len(),
            satellites.map_or(0.0, |s| s.1)
        ));
    }
    for (k, what) in ["accelerometers'", "gyros'"].iter().enumerate() {
        let share = flagged[k] as f64 / samples.max(1) as f64;
        if share > FLAGGED_AT_MOST {
            causes.push(format!(
                "the {what} readings were flagged at {} of {} samples ({:.1} %: at their rails or beyond their calibration)",
                flagged[k],
                samples,
                100.0 * share
            ));
        }
    }
    if largest.1 > TURN_PER_SAMPLE_AT_MOST {
        causes.push(format!(
            "the IMU turned {:.2} rad between two samples at {:.0} deg/s ({:.0} samples a turn, at most {:.2} rad a sample is navigated as measured): its rate is too low for the spin",
            largest.1,
            largest.0.to_degrees(),
            std::f64::consts::TAU / largest.1,
            TURN_PER_SAMPLE_AT_MOST
        ));
    }
    if longest.0 > HOLD_AT_MOST {
        causes.push(format!(
            "the receiver gave no new fix for {:.1} s from {:.1} s ({} rows of its file repeat the fix before them): it held its fix",
            longest.0, longest.1, counts.repeated
        ));
    }
    Diagnosis {
        from,
        to,
        samples,
        flagged,
        largest_rate: largest,
        longest_without_fix: longest,
        repeated_rows: counts.repeated,
        satellites,
        weak_fixes,
        fixes_from_smooth_path: smooth,
        finding,
        causes,
    }
}

/// The new fixes in `[from, to]` and their RMS distance (m, each horizontal axis) from the
/// least-squares cubic in time through them (by SVD, time scaled to the span), or `None`
/// with fewer than [`SMOOTH_AT_LEAST`].
fn smooth_path(fixes: &[Fix], (from, to): (f64, f64)) -> Option<(usize, f64)> {
    let inside: Vec<&Fix> = fixes.iter().filter(|f| f.t >= from && f.t <= to).collect();
    if inside.len() < SMOOTH_AT_LEAST {
        return None;
    }
    let first = inside[0];
    let origin = (
        first.lat_lon.0,
        first.lat_lon.1,
        first.height.unwrap_or(0.0),
    );
    let (mid, half) = ((from + to) / 2.0, ((to - from) / 2.0).max(1e-9));
    let a = nalgebra::DMatrix::from_fn(inside.len(), 4, |i, j| {
        ((inside[i].t - mid) / half).powi(j as i32)
    });
    let svd = a.clone().svd(true, true);
    let mut sq = 0.0;
    for axis in 0..2 {
        let y = nalgebra::DVector::from_iterator(
            inside.len(),
            inside
                .iter()
                .map(|f| super::frame::level_position(f, origin)[axis]),
        );
        let c = svd.solve(&y, 1e-12).ok()?;
        sq += (&a * c - y).norm_squared();
    }
    Some((inside.len(), (sq / (2 * inside.len()) as f64).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn imu(rate: f64, hz: f64, seconds: f64, flag_from: Option<f64>) -> ImuSeries {
        let n = (seconds * hz) as usize;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / hz).collect();
        ImuSeries {
            flagged: t
                .iter()
                .map(|&t| [flag_from.is_some_and(|f| t >= f && t < f + 1.0), false])
                .collect(),
            f: vec![[0.0, 0.0, 9.8]; n],
            w: vec![[rate, 0.0, 0.0]; n],
            t,
            temperature: None,
        }
    }

    /// Fixes every `every` s moving east, each up to 33 m north or south of the path (a
    /// receiver whose fixes do not hold together), but for a `hold`.
    fn fixes(every: f64, seconds: f64, hold: Option<(f64, f64)>) -> Vec<Fix> {
        jittered(every, seconds, hold, 3e-4)
    }

    fn jittered(every: f64, seconds: f64, hold: Option<(f64, f64)>, jitter: f64) -> Vec<Fix> {
        let n = (seconds / every) as usize;
        (0..n)
            .map(|i| (i, i as f64 * every))
            .filter(|(_, t)| hold.is_none_or(|(a, b)| *t <= a || *t >= b))
            .map(|(i, t)| Fix {
                t,
                lat_lon: (jitter * (((i * 7919) % 13) as f64 - 6.0) / 6.0, t * 1e-5),
                height: None,
                velocity: None,
                satellites: Some(if (14.0..16.0).contains(&t) { 4.0 } else { 9.0 }),
            })
            .collect()
    }

    #[test]
    fn a_clean_span_names_no_cause_and_says_so() {
        let d = diagnose(
            (10.0, 20.0),
            &imu(10.0, 100.0, 30.0, None),
            &fixes(0.2, 30.0, None),
            &FixCounts::default(),
            2.5,
        );
        assert!(d.causes.is_empty(), "{d:?}");
        assert!(
            d.sentence().contains("the cause is not known"),
            "{}",
            d.sentence()
        );
        // Weak fixes, but under half of those in the span.
        assert_eq!(d.weak_fixes, 10);
        assert_eq!(d.satellites, Some((51, 4.0)));
        let d = diagnose(
            (13.0, 17.0),
            &imu(10.0, 100.0, 30.0, None),
            &fixes(0.2, 30.0, None),
            &FixCounts::default(),
            2.5,
        );
        assert!(d.causes.is_empty(), "{d:?}");
        let d = diagnose(
            (13.9, 16.1),
            &imu(10.0, 100.0, 30.0, None),
            &fixes(0.2, 30.0, None),
            &FixCounts::default(),
            2.5,
        );
        assert_eq!(d.causes.len(), 1, "{d:?}");
        assert!(
            d.causes[0]
                .contains("10 of the 11 fixes there used fewer than 6 satellites (as few as 4)"),
            "{d:?}"
        );
        assert!((d.largest_rate.1 - 0.1).abs() < 1e-9);
        assert!((d.longest_without_fix.0 - 0.2).abs() < 1e-6, "{d:?}");
    }

    /// Fixes of few satellites that lie on one smooth path (1 m of jitter against a stated
    /// 2.5 m) are the receiver holding the track: that is the finding, and their satellites
    /// are not named as a cause; jittered by 33 m they are not.
    #[test]
    fn fixes_that_hold_together_clear_the_receiver() {
        let d = diagnose(
            (13.9, 16.1),
            &imu(10.0, 100.0, 30.0, None),
            &jittered(0.2, 30.0, None, 1e-5),
            &FixCounts::default(),
            2.5,
        );
        let (n, rms) = d.fixes_from_smooth_path.unwrap();
        assert_eq!(n, 31);
        assert!(rms < 1.0, "{rms}");
        assert!(d.causes.is_empty(), "{d:?}");
        let said = d.sentence();
        assert!(
            said.contains("the receiver's 31 fixes from 11.9 to 18.1 s hold together")
                && said.contains("the receiver did not lose the track, the IMU's prediction did")
                && said.contains("10 of them used fewer than 6 satellites, and still agree"),
            "{said}"
        );
        let d = diagnose(
            (13.9, 16.1),
            &imu(10.0, 100.0, 30.0, None),
            &fixes(0.2, 30.0, None),
            &FixCounts::default(),
            2.5,
        );
        assert!(
            d.finding.is_none() && d.fixes_from_smooth_path.unwrap().1 > 7.5,
            "{d:?}"
        );
    }

    #[test]
    fn each_cause_is_named_past_its_bound() {
        let counts = FixCounts {
            repeated: 40,
            ..FixCounts::default()
        };
        let d = diagnose(
            (10.0, 20.0),
            &imu(10.0, 100.0, 30.0, None),
            &fixes(0.2, 30.0, Some((12.0, 15.0))),
            &counts,
            2.5,
        );
        assert_eq!(d.causes.len(), 1, "{d:?}");
        assert!(
            d.causes[0].contains("no new fix for 3.0 s from 12.0 s"),
            "{d:?}"
        );
        let d = diagnose(
            (10.0, 20.0),
            &imu(60.0, 100.0, 30.0, Some(14.0)),
            &fixes(0.2, 30.0, None),
            &counts,
            2.5,
        );
        assert_eq!(d.causes.len(), 2, "{d:?}");
        assert!(d.causes[0].contains("accelerometers' readings were flagged at 100 of"));
        assert!(d.causes[1].contains("too low for the spin"), "{d:?}");
    }
}
