//! One corrector for whatever calibration a unit holds: the kind the calibration states
//! (single axis, triad, IMU) at its sample format, behind one interface with up to six outputs.
//! For code that handles any calibration (a device's self-test, golden vectors, the host's
//! `apply`); a firmware that knows its sensor uses the typed corrector directly.

use super::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector, Corrected};
use crate::Error;
use crate::model::{Calibration, Sensor};

/// A corrector of any sensor kind and sample format.
#[expect(
    clippy::large_enum_variant,
    reason = "made once per calibration and kept in place, never moved per sample"
)]
pub enum AnyCorrector<'a> {
    /// A single axis.
    Axis(AnyAxisCorrector<'a>),
    /// A triad.
    Triad(AnyTriadCorrector<'a>),
    /// An IMU.
    Imu(AnyImuCorrector<'a>),
}

impl<'a> AnyCorrector<'a> {
    /// The corrector for `cal`'s sensor kind and sample format (an IMU's at `sample_rate_hz`).
    ///
    /// # Errors
    /// The typed corrector's.
    pub fn new(cal: &'a Calibration, sample_rate_hz: f32) -> Result<Self, Error> {
        Ok(match cal.data().sensor {
            Sensor::Single { .. } => Self::Axis(AnyAxisCorrector::new(cal)?),
            Sensor::Triad { .. } => Self::Triad(AnyTriadCorrector::new(cal)?),
            Sensor::Imu { .. } => Self::Imu(AnyImuCorrector::new(cal, sample_rate_hz)?),
        })
    }

    /// How many codes a sample has and how many values it gives: 1, 3 or 6.
    #[must_use]
    pub fn outputs(&self) -> usize {
        match self {
            Self::Axis(_) => 1,
            Self::Triad(_) => 3,
            Self::Imu(_) => 6,
        }
    }

    /// Sets the temperature and supply voltage the coefficients are taken at.
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        match self {
            Self::Axis(c) => c.set_environment(temperature, voltage),
            Self::Triad(c) => c.set_environment(temperature, voltage),
            Self::Imu(c) => c.set_environment(temperature, voltage),
        }
    }

    /// An IMU's largest angular acceleration
    /// ([`ImuCorrector::set_max_angular_acceleration`](super::ImuCorrector::set_max_angular_acceleration));
    /// nothing for the others.
    ///
    /// # Errors
    /// As that.
    pub fn set_max_angular_acceleration(&mut self, rad_per_s2: f32) -> Result<(), Error> {
        match self {
            Self::Imu(c) => c.set_max_angular_acceleration(rad_per_s2),
            Self::Axis(_) | Self::Triad(_) => Ok(()),
        }
    }

    /// Forgets the previous sample (an IMU's rate derivative); nothing for the others.
    pub fn reset(&mut self) {
        if let Self::Imu(c) = self {
            c.reset();
        }
    }

    /// Corrects one sample of [`outputs`](Self::outputs) codes: its values in the first
    /// `outputs()` places (the rest 0). `None` when `raw` has another length.
    pub fn correct(&mut self, raw: &[i32]) -> Option<Corrected<6>> {
        fn widen<const N: usize>(c: Corrected<N>) -> Corrected<6> {
            let mut out = Corrected::<6> {
                values: [0.0; 6],
                flags: c.flags,
            };
            for (o, v) in out.values.iter_mut().zip(c.values) {
                *o = v;
            }
            out
        }
        Some(match self {
            Self::Axis(c) => match raw {
                [r] => widen(c.correct(*r)),
                _ => return None,
            },
            Self::Triad(c) => widen(c.correct(raw.try_into().ok()?)),
            Self::Imu(c) => c.correct(raw.try_into().ok()?),
        })
    }

    /// The 1-sigma calibration error of each value of the sample `raw` whose correction gave
    /// `values` (as [`correct`](Self::correct) returned them), in their places; `None` without
    /// covariance factors or for a sample of another length.
    #[must_use]
    pub fn sigma(&self, raw: &[i32], values: &[f32; 6]) -> Option<[f32; 6]> {
        let mut out = [0.0f32; 6];
        match self {
            Self::Axis(c) => match raw {
                [r] => {
                    if let Some(o) = out.first_mut() {
                        *o = c.sigma(*r)?;
                    }
                }
                _ => return None,
            },
            Self::Triad(c) => {
                for (o, s) in out.iter_mut().zip(c.sigma(raw.try_into().ok()?)?) {
                    *o = s;
                }
            }
            Self::Imu(c) => {
                if raw.len() != 6 {
                    return None;
                }
                out = c.sigma(values)?;
            }
        }
        Some(out)
    }
}
