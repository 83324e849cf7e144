//! The launch found in a flight's IMU log, the unit levelled at rest before it, and its spin
//! after it.

use nalgebra::{UnitQuaternion, Vector3};

use super::input::ImuSeries;

/// How long the specific force must stay over the launch's threshold, s (a gun's setback lasts
/// a few ms, a rocket's boost seconds; a glitch one sample).
pub const LAUNCH_HELD: f64 = 2e-3;

/// The launch: the first sample whose specific force exceeds `force` and stays over it for
/// [`LAUNCH_HELD`] (three samples at least), and the rest before it (at least 0.2 s, up to
/// 0.1 s before the launch).
#[must_use]
pub fn launch(imu: &ImuSeries, force: f64) -> Option<(usize, usize)> {
    // Sustained: every sample over the next LAUNCH_HELD s (at least two) over `force`, or
    // flagged (a setback at the accelerometers' rails): a single glitch on the pad is no launch.
    let over = |i: usize| Vector3::from(imu.f[i]).norm() > force || imu.flagged[i][0];
    let at = (0..imu.f.len()).find(|&i| {
        if Vector3::from(imu.f[i]).norm() <= force {
            return false;
        }
        let until = imu.t[i] + LAUNCH_HELD;
        let mut j = i + 1;
        let mut count = 1;
        while j < imu.t.len() && (imu.t[j] <= until || count < 3) {
            if !over(j) {
                return false;
            }
            count += 1;
            j += 1;
        }
        count >= 3
    })?;
    let t_launch = imu.t.get(at).copied()?;
    let rest_end = imu.t.iter().position(|t| *t > t_launch - 0.1).unwrap_or(0);
    let t0 = imu.t.first().copied()?;
    (imu.t.get(rest_end).is_some_and(|t| t - t0 >= 0.2) && rest_end >= 10).then_some((rest_end, at))
}

/// The attitude of a unit at rest from its mean specific force, with heading `heading` (rad,
/// a turn about the vertical) and its body axis of greatest rate as the spin axis.
#[must_use]
pub fn levelled(imu: &ImuSeries, rest_end: usize, heading: f64) -> UnitQuaternion<f64> {
    let n = rest_end.max(1) as f64;
    let mean: Vector3<f64> = imu
        .f
        .iter()
        .take(rest_end)
        .map(|f| Vector3::from(*f))
        .sum::<Vector3<f64>>()
        / n;
    let up = UnitQuaternion::rotation_between(&mean, &Vector3::z()).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), heading) * up
}

/// The body axis about which the flight turns most after sample `from`, and the root mean
/// square rate about it there, rad/s (0 without samples).
#[must_use]
pub fn spin(imu: &ImuSeries, from: usize) -> (usize, f64) {
    let mut sum = [0.0; 3];
    for w in imu.w.iter().skip(from) {
        for (s, x) in sum.iter_mut().zip(w) {
            *s += x * x;
        }
    }
    let k = (0..3)
        .max_by(|a, b| sum[*a].total_cmp(&sum[*b]))
        .unwrap_or(0);
    let n = imu.w.len().saturating_sub(from);
    let rms = if n == 0 {
        0.0
    } else {
        (sum[k] / n as f64).sqrt()
    };
    (k, rms)
}

/// The body axis about which the flight turns most after `from`, as a unit vector ([`spin`]).
#[must_use]
pub fn spin_axis(imu: &ImuSeries, from: usize) -> Vector3<f64> {
    let mut axis = Vector3::zeros();
    axis[spin(imu, from).0] = 1.0;
    axis
}

#[cfg(test)]
mod tests {
    use super::launch;
    use crate::nav::input::ImuSeries;

    /// One second on the pad at 1 kHz, then a setback: `glitch` puts one sample of 30 g on the
    /// pad at 0.5 s, `flagged` has the setback's first samples at the rails (flagged, read
    /// low).
    fn pad_then_setback(glitch: bool, flagged: bool) -> ImuSeries {
        let n = 1_500;
        let t: Vec<f64> = (0..n).map(|k| f64::from(k) * 1e-3).collect();
        let f = t
            .iter()
            .enumerate()
            .map(|(k, t)| {
                if glitch && k == 500 {
                    [300.0, 0.0, 0.0]
                } else if *t >= 1.0 && !(flagged && (1_001..1_004).contains(&k)) {
                    [400.0, 0.0, 9.8]
                } else {
                    [0.0, 0.0, 9.8]
                }
            })
            .collect();
        let flagged = (0..n)
            .map(|k| [flagged && (1_001..1_004).contains(&k), false])
            .collect();
        ImuSeries {
            t,
            f,
            w: vec![[0.0; 3]; n as usize],
            flagged,
            temperature: None,
        }
    }

    /// A single glitch on the pad is no launch; the sustained setback is, through samples at
    /// the rails (flagged) as well.
    #[test]
    fn a_single_glitch_on_the_pad_is_not_the_launch() {
        let force = 2.0 * 9.80665;
        assert_eq!(
            launch(&pad_then_setback(false, false), force),
            Some((901, 1_000))
        );
        assert_eq!(
            launch(&pad_then_setback(true, false), force),
            Some((901, 1_000))
        );
        assert_eq!(
            launch(&pad_then_setback(true, true), force),
            Some((901, 1_000))
        );
    }
}
