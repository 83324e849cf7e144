//! A spin rig: the unit turns about an axis of its own (its roll axis, x, unless told another)
//! at a rate that follows a profile (steady spins, spin-up and spin-down ramps), that axis
//! horizontal so that gravity is transverse, with an optional coning motion; sampled at a fixed
//! rate into raw counts through an IMU's truth (`spincal::model::rotation`), with the true
//! specific force, rate and angular acceleration beside every sample.
//!
//! The attitude is `R(t) = Rx(Wt) Ry(theta) Rx(-Wt) Rx(phi(t))` (body to rig): the roll axis
//! cones at `W` rad/s with half-angle `theta` about the rig's horizontal x axis while the body
//! rolls by `phi`, `phi' = p(t)`. Body rates and angular accelerations are exact (no numerical
//! differentiation): `w = W Q' e_x + (p - W) e_x` and `dw = -W (p - W) e_x x Q' e_x + p' e_x`
//! with `Q = Ry(theta) Rx(phi - Wt)`. The rig turns about the reference point, so the specific
//! force there is gravity's reaction alone, `R' (0, 0, g)`.

use nalgebra::{Rotation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::plan::G;
use super::truth::ImuTruth;

/// One stretch of the spin profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// A steady spin at `hz` revolutions per second for `seconds`.
    Steady {
        /// Spin rate, Hz.
        hz: f64,
        /// Duration, s.
        seconds: f64,
    },
    /// A linear ramp of the spin rate from `from_hz` to `to_hz` over `seconds`.
    Ramp {
        /// Start rate, Hz.
        from_hz: f64,
        /// End rate, Hz.
        to_hz: f64,
        /// Duration, s.
        seconds: f64,
    },
}

impl Segment {
    /// Its duration, s.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        match *self {
            Segment::Steady { seconds, .. } | Segment::Ramp { seconds, .. } => seconds,
        }
    }

    /// Spin rate (Hz), its derivative (Hz/s) and the roll angle gained (revolutions) at `t`
    /// seconds into the segment.
    fn at(&self, t: f64) -> (f64, f64, f64) {
        match *self {
            Segment::Steady { hz, .. } => (hz, 0.0, hz * t),
            Segment::Ramp {
                from_hz,
                to_hz,
                seconds,
            } => {
                let a = (to_hz - from_hz) / seconds;
                (from_hz + a * t, a, from_hz * t + 0.5 * a * t * t)
            }
        }
    }
}

/// A profile that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("spin profile `{text}`: {why}")]
pub struct ProfileError {
    /// The text.
    pub text: String,
    /// What is wrong.
    pub why: String,
}

/// Reads a profile: comma-separated `HZ:SECONDS` (steady) and `FROM-TO:SECONDS` (ramp), e.g.
/// `50:1,50-150:0.2,150:1,150-300:0.5,300:1`. Each segment starts at the spin the one before it
/// ends at: a spin that jumps in one sample has an angular acceleration no rig and no airframe
/// makes (and that the truth would not hold), so a profile whose segments do not join is
/// refused, naming the two and the ramp that joins them.
///
/// # Errors
/// A [`ProfileError`] naming the piece and what was expected.
pub fn profile(text: &str) -> Result<Vec<Segment>, ProfileError> {
    let err = |why: String| ProfileError {
        text: text.into(),
        why,
    };
    let num = |s: &str, what: &str| -> Result<f64, ProfileError> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(err(format!("`{s}` is not a number ({what})"))),
        }
    };
    let mut out = Vec::new();
    let mut previous_end: Option<f64> = None;
    for piece in text.split(',') {
        let Some((rate, secs)) = piece.split_once(':') else {
            return Err(err(format!(
                "`{piece}`: expected HZ:SECONDS or FROM-TO:SECONDS"
            )));
        };
        let seconds = num(secs, "seconds")?;
        if seconds <= 0.0 || seconds > 3600.0 {
            return Err(err(format!(
                "`{piece}`: a segment lasts more than 0 and at most 3600 s"
            )));
        }
        // A ramp's `-` separates two rates; a leading `-` is a sign.
        let split = rate.get(1..).and_then(|r| r.find('-')).map(|i| i + 1);
        let seg = match split {
            Some(i) => Segment::Ramp {
                from_hz: num(&rate[..i], "ramp start, Hz")?,
                to_hz: num(&rate[i + 1..], "ramp end, Hz")?,
                seconds,
            },
            None => Segment::Steady {
                hz: num(rate, "spin rate, Hz")?,
                seconds,
            },
        };
        let fastest = match seg {
            Segment::Steady { hz, .. } => hz.abs(),
            Segment::Ramp { from_hz, to_hz, .. } => from_hz.abs().max(to_hz.abs()),
        };
        if fastest > MAX_SPIN_HZ {
            return Err(err(format!(
                "`{piece}`: a spin rig turns at most {MAX_SPIN_HZ} Hz"
            )));
        }
        let (starts, ends) = match seg {
            Segment::Steady { hz, .. } => (hz, hz),
            Segment::Ramp { from_hz, to_hz, .. } => (from_hz, to_hz),
        };
        if let Some(before) = previous_end
            && (starts - before).abs() > 1e-9 * before.abs().max(1.0)
        {
            return Err(err(format!(
                "`{piece}` starts at {starts} Hz but the spin before it ends at {before} Hz: a \
                 spin cannot jump in one sample; join them with a ramp, e.g. `{before}-{starts}:0.1`"
            )));
        }
        previous_end = Some(ends);
        out.push(seg);
    }
    Ok(out)
}

/// The fastest spin a profile may ask for, Hz: several times a spin-stabilised shell's.
pub const MAX_SPIN_HZ: f64 = 2_000.0;

/// A spin-rig run.
#[derive(Debug, Clone, PartialEq)]
pub struct SpinRun {
    /// The spin profile.
    pub segments: Vec<Segment>,
    /// The unit's axis it spins about, in its own axes (any direction; normalised).
    pub axis: [f64; 3],
    /// Samples per second.
    pub sample_rate: f64,
    /// Coning half-angle, radians (0: none).
    pub cone_angle: f64,
    /// Coning rate, Hz.
    pub cone_hz: f64,
    /// Chamber temperature, C.
    pub temp: f64,
    /// Supply voltage, V.
    pub volt: f64,
    /// Noise seed.
    pub seed: u64,
}

/// One sample: the truth and the raw counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub t: f64,
    /// Specific force at the reference point, m/s^2.
    pub f: [f64; 3],
    /// Rate, rad/s.
    pub w: [f64; 3],
    /// Angular acceleration, rad/s^2.
    pub dw: [f64; 3],
    /// Raw counts: accelerometer x y z, gyro x y z (rounded, noisy).
    pub raw: [f64; 6],
}

/// A fixed rotation taking the unit's spin axis to the rig frame's x (the spin frame); the
/// identity for a roll about x.
fn mount(axis: [f64; 3]) -> Rotation3<f64> {
    let a = Vector3::from(axis);
    Rotation3::rotation_between(&a, &Vector3::x()).unwrap_or_else(|| {
        // Antiparallel: half a turn about an axis perpendicular to x.
        Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
    })
}

/// The body rate, angular acceleration and specific force at time `t` with spin rate `p`
/// (rad/s), its derivative `dp` and roll angle `phi`, in the unit's axes.
fn kinematics(run: &SpinRun, t: f64, p: f64, dp: f64, phi: f64) -> Sample {
    let s = spin_frame(run, t, p, dp, phi);
    let back = mount(run.axis).inverse();
    let to_body = |v: [f64; 3]| {
        let b = back * Vector3::from(v);
        [b.x, b.y, b.z]
    };
    Sample {
        f: to_body(s.f),
        w: to_body(s.w),
        dw: to_body(s.dw),
        ..s
    }
}

/// [`kinematics`] in the spin frame, whose x is the spin axis.
fn spin_frame(run: &SpinRun, t: f64, p: f64, dp: f64, phi: f64) -> Sample {
    let x = Vector3::x_axis();
    let cone = 2.0 * std::f64::consts::PI * run.cone_hz;
    let psi = phi - cone * t;
    let q = Rotation3::from_axis_angle(&Vector3::y_axis(), run.cone_angle)
        * Rotation3::from_axis_angle(&x, psi);
    let r = Rotation3::from_axis_angle(&x, cone * t) * q;
    let u = q.inverse() * x.into_inner();
    let w = u * cone + x.into_inner() * (p - cone);
    let dw = -(x.into_inner().cross(&u)) * (cone * (p - cone)) + x.into_inner() * dp;
    let f = r.inverse() * Vector3::new(0.0, 0.0, G);
    Sample {
        t,
        f: [f.x, f.y, f.z],
        w: [w.x, w.y, w.z],
        dw: [dw.x, dw.y, dw.z],
        raw: [0.0; 6],
    }
}

/// Writes a flight as CSV: `t`, the true `f_*`, `w_*`, `dw_*`, then the raw `a_*`, `g_*`.
///
/// # Errors
/// The writer's.
pub fn write_csv(samples: &[Sample], mut w: impl std::io::Write) -> std::io::Result<()> {
    use crate::columns as col;
    let names: Vec<&str> = std::iter::once("t")
        .chain(col::F)
        .chain(col::W)
        .chain(col::DW)
        .chain(col::A)
        .chain(col::GYRO)
        .collect();
    writeln!(w, "{}", names.join(","))?;
    let mut line = String::new();
    for s in samples {
        use std::fmt::Write as _;
        line.clear();
        let _ = write!(line, "{}", s.t);
        for v in s.f.iter().chain(&s.w).chain(&s.dw).chain(&s.raw) {
            let _ = write!(line, ",{v}");
        }
        writeln!(w, "{line}")?;
    }
    Ok(())
}

/// Runs the profile through `truth`: one sample every `1 / sample_rate` s, counts with the
/// truth's noise, rounded.
#[must_use]
pub fn run(truth: &ImuTruth, run: &SpinRun) -> Vec<Sample> {
    let mut rng = ChaCha8Rng::seed_from_u64(run.seed);
    let tau = 2.0 * std::f64::consts::PI;
    let mut out = Vec::new();
    let (mut start, mut turns) = (0.0, 0.0);
    let dt = 1.0 / run.sample_rate;
    let mut k: u64 = 0;
    for seg in &run.segments {
        let end = start + seg.seconds();
        loop {
            let t = k as f64 * dt;
            if t >= end {
                break;
            }
            let (hz, dhz, gained) = seg.at(t - start);
            let mut s = kinematics(run, t, tau * hz, tau * dhz, tau * (turns + gained));
            s.raw = truth.codes((s.f, s.w, s.dw), (run.temp, run.volt), &mut rng);
            out.push(s);
            k += 1;
        }
        turns += seg.at(seg.seconds()).2;
        start = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_read_steady_spins_and_ramps() {
        assert_eq!(
            profile("150:1,150-300:0.5,300-20:2,20:1").unwrap(),
            vec![
                Segment::Steady {
                    hz: 150.0,
                    seconds: 1.0
                },
                Segment::Ramp {
                    from_hz: 150.0,
                    to_hz: 300.0,
                    seconds: 0.5
                },
                Segment::Ramp {
                    from_hz: 300.0,
                    to_hz: 20.0,
                    seconds: 2.0
                },
                Segment::Steady {
                    hz: 20.0,
                    seconds: 1.0
                },
            ]
        );
        // Segments that do not join: the spin would jump in one sample.
        for jump in ["300:0.5,150-300:0.5", "50:1,150:1", "150-300:0.5,-20:2"] {
            let e = profile(jump).unwrap_err().to_string();
            assert!(
                e.contains("cannot jump") && e.contains("join them with a ramp"),
                "{e}"
            );
        }
        assert!(
            profile("50")
                .unwrap_err()
                .to_string()
                .contains("HZ:SECONDS")
        );
        assert!(profile("50:0").is_err());
        assert!(
            profile("x:1")
                .unwrap_err()
                .to_string()
                .contains("spin rate")
        );
    }

    #[test]
    fn rates_and_accelerations_are_the_derivatives_of_the_attitude() {
        let run = SpinRun {
            segments: vec![],
            axis: [1.0, 0.0, 0.0],
            sample_rate: 1000.0,
            cone_angle: 0.05,
            cone_hz: 7.0,
            temp: 25.0,
            volt: 3.3,
            seed: 1,
        };
        let tau = 2.0 * std::f64::consts::PI;
        // A ramp: p = p0 + a t.
        let (p0, a) = (tau * 150.0, tau * 300.0);
        let state = |t: f64| {
            let phi = p0 * t + 0.5 * a * t * t;
            kinematics(&run, t, p0 + a * t, a, phi)
        };
        let attitude = |t: f64| {
            let phi = p0 * t + 0.5 * a * t * t;
            let cone = tau * run.cone_hz;
            Rotation3::from_axis_angle(&Vector3::x_axis(), cone * t)
                * Rotation3::from_axis_angle(&Vector3::y_axis(), run.cone_angle)
                * Rotation3::from_axis_angle(&Vector3::x_axis(), phi - cone * t)
        };
        let t = 0.0123;
        let h = 1e-7;
        // Body rate from R' dR/dt by central differences.
        let d = (attitude(t + h).matrix() - attitude(t - h).matrix()) / (2.0 * h);
        let omega = attitude(t).matrix().transpose() * d;
        let s = state(t);
        let num = [omega[(2, 1)], omega[(0, 2)], omega[(1, 0)]];
        for k in 0..3 {
            assert!(
                (num[k] - s.w[k]).abs() < 1e-4 * (1.0 + s.w[k].abs()),
                "w {k}: {num:?} {:?}",
                s.w
            );
        }
        let dw: Vec<f64> = (0..3)
            .map(|k| (state(t + h).w[k] - state(t - h).w[k]) / (2.0 * h))
            .collect();
        for k in 0..3 {
            assert!(
                (dw[k] - s.dw[k]).abs() < 1e-3 * (1.0 + s.dw[k].abs()),
                "dw {k}: {dw:?} {:?}",
                s.dw
            );
        }
        // Gravity is transverse to the roll axis, up to the cone.
        let fnorm = s.f.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((fnorm - G).abs() < 1e-9 && s.f[0].abs() <= G * run.cone_angle.sin() + 1e-9);
        // About another axis of the unit: the same motion, seen in its axes.
        let axis = [0.0, 0.6, -0.8];
        let tilted = SpinRun {
            axis,
            ..run.clone()
        };
        let phi = p0 * t + 0.5 * a * t * t;
        let u = kinematics(&tilted, t, p0 + a * t, a, phi);
        let along = |v: [f64; 3]| v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2];
        assert!(
            (along(u.w) - s.w[0]).abs() < 1e-9 * s.w[0].abs(),
            "{:?} {:?}",
            u.w,
            s.w
        );
        assert!((along(u.dw) - s.dw[0]).abs() < 1e-6 * (1.0 + s.dw[0].abs()));
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((norm(u.w) - norm(s.w)).abs() < 1e-9 * norm(s.w));
        assert!((along(u.f) - s.f[0]).abs() < 1e-9);
    }
}
