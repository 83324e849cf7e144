//! The noise terms in the form Kalibr's `imu.yaml` takes (the camera-IMU calibration toolbox of
//! ETH Zurich's ASL): per sensor, one continuous-time white-noise density and one bias random
//! walk, in SI units.
//!
//! Kalibr takes one value per sensor: the largest of the three axes is given, so that no axis
//! is trusted beyond what it showed. A bias random walk the record does not resolve (too short
//! for its +1/2 slope) is given as the bound the longest cluster time sets, `K <= sigma(tau)
//! sqrt(3 / tau)` (the +1/2 line through the last point lies on or above the curve), and the
//! file says so.

use std::fmt::Write as _;

use super::allan::{NoiseTerms, Point};

/// One sensor's axes: their curves and noise terms, in SI units.
pub struct Sensor<'a> {
    /// The curves, x, y, z.
    pub curves: &'a [Vec<Point>],
    /// Their noise terms.
    pub terms: &'a [NoiseTerms],
}

/// The largest white-noise density and bias random walk of the axes, and whether the walk is
/// a bound (not resolved on some axis).
fn largest(s: &Sensor<'_>) -> (f64, f64, bool) {
    let mut white = 0.0f64;
    let mut walk = 0.0f64;
    let mut bound = false;
    for (t, c) in s.terms.iter().zip(s.curves) {
        white = white.max(t.random_walk);
        if t.rate_random_walk > 0.0 {
            walk = walk.max(t.rate_random_walk);
        } else if let Some(last) = c.last() {
            bound = true;
            walk = walk.max(last.adev * (3.0 / last.tau).sqrt());
        }
    }
    (white, walk, bound)
}

/// The `imu.yaml` text of `accel` and `gyro` (in m/s^2 and rad/s) at `rate` Hz, from `source`.
#[must_use]
pub fn imu_yaml(accel: &Sensor<'_>, gyro: &Sensor<'_>, rate: f64, source: &str) -> String {
    let (na, ka, ba) = largest(accel);
    let (ng, kg, bg) = largest(gyro);
    let note = |bound: bool| {
        if bound {
            "  # not resolved on every axis: the bound the longest cluster time sets"
        } else {
            ""
        }
    };
    let mut y = String::new();
    let _ = writeln!(
        y,
        "# Kalibr imu.yaml from calflash allan of {source}: the largest of the three axes of each sensor.\n\
         # Kalibr's own advice is to inflate these for the motion and temperature of a real run."
    );
    let _ = writeln!(y, "#Accelerometers");
    let _ = writeln!(
        y,
        "accelerometer_noise_density: {na:.6e}  # [m/s^2/sqrt(Hz)] (velocity random walk N)"
    );
    let _ = writeln!(
        y,
        "accelerometer_random_walk: {ka:.6e}  # [m/s^3/sqrt(Hz)] (bias random walk K){}",
        note(ba)
    );
    let _ = writeln!(y, "#Gyroscopes");
    let _ = writeln!(
        y,
        "gyroscope_noise_density: {ng:.6e}  # [rad/s/sqrt(Hz)] (angle random walk N)"
    );
    let _ = writeln!(
        y,
        "gyroscope_random_walk: {kg:.6e}  # [rad/s^2/sqrt(Hz)] (bias random walk K){}",
        note(bg)
    );
    let _ = writeln!(y, "rostopic: /imu0");
    let _ = writeln!(y, "update_rate: {rate:.3}  # [Hz]");
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    fn terms(n: f64, k: f64) -> NoiseTerms {
        NoiseTerms {
            quantization: 0.0,
            random_walk: n,
            bias_instability: 0.0,
            rate_random_walk: k,
            rate_ramp: 0.0,
        }
    }

    /// Kalibr's keys, each value the largest axis', a walk not resolved given as its bound and
    /// said to be one.
    #[test]
    fn the_yaml_has_kalibrs_keys_and_the_largest_axis() {
        let curve = vec![Point {
            tau: 300.0,
            adev: 1e-4,
            rel_error: 0.3,
        }];
        let curves = vec![curve.clone(), curve.clone(), curve];
        let a = [terms(1e-3, 2e-5), terms(3e-3, 1e-5), terms(2e-3, 4e-5)];
        let g = [terms(2e-4, 0.0), terms(1e-4, 1e-6), terms(1e-4, 2e-7)];
        let y = imu_yaml(
            &Sensor {
                curves: &curves,
                terms: &a,
            },
            &Sensor {
                curves: &curves,
                terms: &g,
            },
            400.0,
            "still.csv",
        );
        let value = |key: &str| -> f64 {
            y.lines()
                .find_map(|l| l.strip_prefix(&format!("{key}: ")))
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{key} in {y}"))
        };
        assert_eq!(value("accelerometer_noise_density"), 3e-3);
        assert_eq!(value("accelerometer_random_walk"), 4e-5);
        assert_eq!(value("gyroscope_noise_density"), 2e-4);
        // x not resolved: its bound 1e-4 sqrt(3/300) = 1e-5 is above the others.
        assert!((value("gyroscope_random_walk") / 1e-5 - 1.0).abs() < 1e-6);
        assert!(
            y.lines()
                .any(|l| l.starts_with("gyroscope_random_walk") && l.contains("not resolved"))
        );
        assert!(
            !y.lines()
                .any(|l| l.starts_with("accelerometer_random_walk") && l.contains("not resolved"))
        );
        assert_eq!(value("update_rate"), 400.0);
        assert!(y.contains("rostopic: /imu0"));
    }
}
