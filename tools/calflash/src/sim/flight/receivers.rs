//! What flies with the IMU to check it: a GNSS receiver (fixes at its rate with noise, a
//! latency and an outage after launch) and a barometer (the standard atmosphere's pressure at
//! the flight's height, with noise), and a launch shift of the unit's own errors at setback,
//! so a simulated flight carries the truth of what an in-flight check should find.

use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::Sample;
use super::atmosphere;
use super::site::Site;

/// A GNSS receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receiver {
    /// Fixes per second.
    pub rate: f64,
    /// 1-sigma noise of a fix, m: horizontal (each axis) and vertical.
    pub noise: (f64, f64),
    /// 1-sigma noise of the velocity, m/s, each axis.
    pub velocity_noise: f64,
    /// How late a fix is stamped after the instant it describes, s.
    pub latency: f64,
    /// No fix for this long after launch (the antenna tumbling, the receiver re-acquiring), s.
    pub outage: f64,
    /// No fix on the pad: the receiver acquires only in flight (a shell's GNSS fuze), its
    /// first fix after [`outage`](Self::outage).
    pub in_flight_only: bool,
    /// The receiver's slowly varying position error per axis (east, north, up): 1-sigma, m,
    /// and time constant, s (a first-order Gauss-Markov process started from its stationary
    /// distribution; atmosphere, orbits and multipath), beside the white [`noise`](Self::noise).
    pub correlated: (f64, f64),
    /// The antenna from the IMU, body axes, m: a fix is the antenna's position, and its
    /// velocity the unit's plus the arm's turn `C (w x l)` averaged over the fix's interval
    /// (the receiver's tracking smooths what changes faster than its rate: on a spinning round
    /// the arm's turn averages out, on a pitching rocket it does not).
    pub antenna: [f64; 3],
}

impl Default for Receiver {
    fn default() -> Self {
        Self {
            rate: 10.0,
            noise: (2.0, 4.0),
            velocity_noise: 0.1,
            latency: 0.0,
            outage: 1.0,
            in_flight_only: false,
            correlated: (0.0, 60.0),
            antenna: [0.0; 3],
        }
    }
}

/// The header of a GNSS file as the simulator writes it (`calflash flight --gnss` reads it).
pub const GNSS_HEADER: &str = "t,latitude,longitude,height,v_east,v_north,v_up,satellites";

/// Writes the fixes of `samples` (flight frame) at `site`: one row per fix.
///
/// # Errors
/// The writer's.
pub fn write_gnss(
    samples: &[Sample],
    site: &Site,
    rx: &Receiver,
    rng: &mut impl Rng,
    mut w: impl std::io::Write,
) -> std::io::Result<()> {
    writeln!(w, "{GNSS_HEADER}")?;
    let Some(first) = samples.first() else {
        return Ok(());
    };
    let (h, v, dv) = (
        noise(rx.noise.0)?,
        noise(rx.noise.1)?,
        noise(rx.velocity_noise)?,
    );
    let to_level = site.to_level();
    let arm = Vector3::from(rx.antenna);
    // The slowly varying error, stepped once per fix interval.
    let (gm_sigma, gm_tau) = rx.correlated;
    let phi = (-1.0 / (rx.rate * gm_tau.max(1e-9))).exp();
    let gm = noise(gm_sigma)?;
    let mut slow = Vector3::new(gm.sample(rng), gm.sample(rng), gm.sample(rng));
    let step = (1.0 - phi * phi).sqrt();
    let mut next = (first.t * rx.rate).ceil() / rx.rate;
    // The arm's velocity summed since the last fix, and how many samples.
    let (mut sum, mut n) = (Vector3::zeros(), 0.0);
    for s in samples {
        let c = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            s.q[0], s.q[1], s.q[2], s.q[3],
        ));
        sum += c * Vector3::from(s.w).cross(&arm);
        n += 1.0;
        if s.t + 1e-9 < next {
            continue;
        }
        next += 1.0 / rx.rate;
        let antenna_v = Vector3::from(s.v) + sum / n;
        (sum, n) = (Vector3::zeros(), 0.0);
        slow = slow * phi + Vector3::new(gm.sample(rng), gm.sample(rng), gm.sample(rng)) * step;
        if (0.0..rx.outage).contains(&s.t) || (rx.in_flight_only && s.t < 0.0) {
            continue;
        }
        let level = to_level * (Vector3::from(s.r) + c * arm);
        let noisy = level + slow + Vector3::new(h.sample(rng), h.sample(rng), v.sample(rng));
        let flight = to_level.transpose() * noisy;
        let (lat, lon, height) = site.geodetic(&flight);
        // The velocity in east, north and up at the receiver's own position, as receivers
        // give it (the site's level frame turned by the distance over the Earth's radius).
        let vel = site.local_enu(lat, lon) * antenna_v
            + Vector3::new(dv.sample(rng), dv.sample(rng), dv.sample(rng));
        writeln!(
            w,
            "{},{lat:.9},{lon:.9},{height:.3},{:.3},{:.3},{:.3},12",
            s.t + rx.latency,
            vel.x,
            vel.y,
            vel.z
        )?;
    }
    Ok(())
}

/// Zero-mean noise of 1-sigma `sd` (a negative or non-finite one is refused).
fn noise(sd: f64) -> std::io::Result<Normal<f64>> {
    Normal::new(0.0, sd).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))
}

/// Writes a barometer's readings of `samples` at `altitude` m above sea level for the launch
/// point: `t`, `T` (the unit's temperature, C), `P` (Pa, with noise of 1-sigma `noise_pa`),
/// at `rate` Hz.
///
/// # Errors
/// The writer's.
pub fn write_baro(
    samples: &[Sample],
    altitude: f64,
    rate: f64,
    noise_pa: f64,
    rng: &mut impl Rng,
    mut w: impl std::io::Write,
) -> std::io::Result<()> {
    writeln!(w, "t,T,P")?;
    let Some(first) = samples.first() else {
        return Ok(());
    };
    let n = noise(noise_pa)?;
    let mut next = (first.t * rate).ceil() / rate;
    for s in samples {
        if s.t + 1e-9 < next {
            continue;
        }
        next += 1.0 / rate;
        let p = atmosphere::standard(altitude + s.r[2]).pressure + n.sample(rng);
        writeln!(w, "{},{:.2},{p:.2}", s.t, s.temp)?;
    }
    Ok(())
}

/// A shift of the unit's errors at launch, in SI units on what it senses: biases (m/s^2,
/// rad/s) and scale factors (relative) per axis, from the first instant of flight on.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LaunchShift {
    /// Accelerometer biases, m/s^2.
    pub accel_bias: [f64; 3],
    /// Gyro biases, rad/s.
    pub gyro_bias: [f64; 3],
    /// Accelerometer scale factors.
    pub accel_scale: [f64; 3],
    /// Gyro scale factors.
    pub gyro_scale: [f64; 3],
}

/// The keys of `--launch-shift`.
pub const SHIFT_KEYS: &str = "ax ay az (accelerometer biases, m/s^2), wx wy wz (gyro biases, rad/s), sax say saz, swx swy swz (scale factors, relative: 0.003 is 0.3 %)";

/// A `--launch-shift` that cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShiftError {
    /// An item without `=`.
    #[error("--launch-shift `{0}`: expected KEY=VALUE")]
    NotKeyValue(String),
    /// A value that is not a finite number.
    #[error("--launch-shift `{0}`: not a number")]
    NotNumber(String),
    /// A key that is none of [`SHIFT_KEYS`].
    #[error("--launch-shift: no key `{0}`; the keys: {SHIFT_KEYS}")]
    NoKey(String),
    /// A value beyond what a launch shift can be.
    #[error("--launch-shift `{item}`: at most {limit} in size; the keys: {SHIFT_KEYS}")]
    TooLarge {
        /// The item.
        item: String,
        /// Its kind's limit.
        limit: f64,
    },
}

impl LaunchShift {
    /// Reads `KEY=VALUE,...`.
    ///
    /// # Errors
    /// An unknown key or a value that is not a finite number (or beyond 10 % or 100 units).
    pub fn parse(text: &str) -> Result<Self, ShiftError> {
        let mut out = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| ShiftError::NotKeyValue(item.to_string()))?;
            let v: f64 = value
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| ShiftError::NotNumber(item.to_string()))?;
            let key = key.trim();
            let axis = match key.chars().last() {
                Some('x') => 0,
                Some('y') => 1,
                Some('z') => 2,
                _ => usize::MAX,
            };
            let (slot, limit) = match key.get(..key.len().saturating_sub(1)) {
                Some("a") => (&mut out.accel_bias, 100.0),
                Some("w") => (&mut out.gyro_bias, 100.0),
                Some("sa") => (&mut out.accel_scale, 0.1),
                Some("sw") => (&mut out.gyro_scale, 0.1),
                _ => return Err(ShiftError::NoKey(key.to_string())),
            };
            if v.abs() > limit || axis > 2 {
                return Err(ShiftError::TooLarge {
                    item: item.to_string(),
                    limit,
                });
            }
            slot[axis] = v;
        }
        Ok(out)
    }

    /// What the unit senses after launch of the true specific force `f` and rate `w`.
    #[must_use]
    pub fn apply(&self, f: [f64; 3], w: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        (
            std::array::from_fn(|i| (1.0 + self.accel_scale[i]) * f[i] + self.accel_bias[i]),
            std::array::from_fn(|i| (1.0 + self.gyro_scale[i]) * w[i] + self.gyro_bias[i]),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_launch_shift_reads_its_keys_and_refuses_others() {
        let s = LaunchShift::parse("ax=0.05, swx=0.003").unwrap();
        assert_eq!((s.accel_bias[0], s.gyro_scale[0]), (0.05, 0.003));
        let (f, w) = s.apply([1.0, 2.0, 3.0], [100.0, 0.0, 0.0]);
        assert!((f[0] - 1.05).abs() < 1e-12 && (w[0] - 100.3).abs() < 1e-9);
        for (text, says) in [
            ("bx=1", "no key"),
            ("ax", "expected KEY=VALUE"),
            ("swx=0.5", "at most 0.1"),
            ("ax=nan", "not a number"),
        ] {
            let e = LaunchShift::parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }
}
