//! Correctors for codes held as `i32` whatever container the calibration states: for the host
//! tool's files and the update protocol's test vectors, which carry every format's codes as
//! `i32`. Each wraps the corrector of the calibration's own format; a code beyond that
//! container is clamped to it (it is beyond the rails too, so it is corrected at the rail and
//! flagged, exactly as the device does with its own samples).
//!
//! On the device, take the samples as the part delivers them with [`AxisCorrector`],
//! [`TriadCorrector`] or [`ImuCorrector`] of that type instead.

use super::sample::Sample;
use super::{AxisCorrector, Corrected, Flags, ImuCorrector, TriadCorrector};
use crate::Error;
#[cfg(doc)]
use crate::model::Sensor;
use crate::model::{Calibration, SampleFormat};

/// Runs `$body` with `$c` bound to the wrapped corrector (and `$s` to its sample type).
macro_rules! each {
    ($self:expr, |$c:ident| $body:expr) => {
        match $self {
            Self::U16($c) => $body,
            Self::I16($c) => $body,
            Self::I32($c) => $body,
        }
    };
    ($self:expr, |$c:ident, $s:ident| $body:expr) => {
        match $self {
            Self::U16($c) => {
                type $s = u16;
                $body
            }
            Self::I16($c) => {
                type $s = i16;
                $body
            }
            Self::I32($c) => {
                type $s = i32;
                $body
            }
        }
    };
}

/// The sample format `cal` states ([`Sensor::sample_format`]).
#[must_use]
pub fn format_of(cal: &Calibration) -> SampleFormat {
    cal.data().sensor.sample_format()
}

/// Samples converted into the container `S`, a block at a time.
const BLOCK: usize = 32;

/// Corrects `raw` through `f` in blocks of [`BLOCK`] samples converted by `convert`.
fn in_blocks<T: Copy, U: Copy, O>(
    raw: &[T],
    out: &mut [O],
    convert: impl Fn(T) -> U,
    mut f: impl FnMut(&[U], &mut [O]) -> usize,
) -> usize {
    let mut done = 0;
    for (r, o) in raw.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
        let Some(&first) = r.first() else {
            break;
        };
        let mut buf = [convert(first); BLOCK];
        for (b, x) in buf.iter_mut().zip(r) {
            *b = convert(*x);
        }
        let n = r.len().min(o.len());
        done += f(buf.get(..n).unwrap_or_default(), o);
    }
    done
}

/// An [`ImuCorrector`] of the calibration's own format, fed `i32` codes.
#[derive(Debug, Clone)]
pub enum AnyImuCorrector<'a> {
    /// `u16` samples.
    U16(ImuCorrector<'a, u16>),
    /// `i16` samples.
    I16(ImuCorrector<'a, i16>),
    /// `i32` samples.
    I32(ImuCorrector<'a, i32>),
}

impl<'a> AnyImuCorrector<'a> {
    /// The corrector of `cal`'s format (see [`ImuCorrector::new`]).
    ///
    /// # Errors
    /// As [`ImuCorrector::new`], never [`Error::CorrectorWrongFormat`].
    pub fn new(cal: &'a Calibration, sample_rate_hz: f32) -> Result<Self, Error> {
        Ok(match format_of(cal) {
            SampleFormat::U16 => Self::U16(ImuCorrector::new(cal, sample_rate_hz)?),
            SampleFormat::I16 => Self::I16(ImuCorrector::new(cal, sample_rate_hz)?),
            SampleFormat::I32 => Self::I32(ImuCorrector::new(cal, sample_rate_hz)?),
        })
    }

    /// The identity fallback (codes passed through, every sample flagged).
    #[must_use]
    pub const fn identity() -> Self {
        Self::I32(ImuCorrector::identity())
    }

    /// See [`ImuCorrector::set_environment`].
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        each!(self, |c| c.set_environment(temperature, voltage));
    }

    /// See [`ImuCorrector::reset`].
    pub fn reset(&mut self) {
        each!(self, |c| c.reset());
    }

    /// See [`ImuCorrector::set_max_angular_acceleration`].
    ///
    /// # Errors
    /// As that.
    pub fn set_max_angular_acceleration(&mut self, rad_per_s2: f32) -> Result<(), crate::Error> {
        each!(self, |c| c.set_max_angular_acceleration(rad_per_s2))
    }

    /// See [`ImuCorrector::environment_flags`].
    #[must_use]
    pub fn environment_flags(&self) -> Flags {
        each!(self, |c| c.environment_flags())
    }

    /// Corrects one sample (see [`ImuCorrector::correct`]).
    #[must_use]
    pub fn correct(&mut self, raw: [i32; 6]) -> Corrected<6> {
        each!(self, |c, S| c.correct(raw.map(S::clamped)))
    }

    /// Corrects `raw` into `out` (see [`ImuCorrector::correct_batch`]).
    pub fn correct_batch(&mut self, raw: &[[i32; 6]], out: &mut [Corrected<6>]) -> usize {
        each!(self, |c, S| in_blocks(
            raw,
            out,
            |x| x.map(S::clamped),
            |r, o| c.correct_batch(r, o)
        ))
    }

    /// See [`ImuCorrector::sigma`].
    #[must_use]
    pub fn sigma(&self, values: &[f32; 6]) -> Option<[f32; 6]> {
        each!(self, |c| c.sigma(values))
    }

    /// See [`ImuCorrector::error_features`].
    #[must_use]
    pub fn error_features(&self, values: &[f32; 6]) -> [[f32; crate::model::IMU_FEATURES]; 6] {
        each!(self, |c| c.error_features(values))
    }

    /// See [`ImuCorrector::covariance_factors`].
    #[must_use]
    pub fn covariance_factors(&self) -> Option<&crate::model::ImuCovariance> {
        each!(self, |c| c.covariance_factors())
    }

    /// See [`ImuCorrector::set_overlay`].
    pub fn set_overlay(&mut self, overlay: Option<crate::correct::Overlay>) {
        each!(self, |c| c.set_overlay(overlay));
    }

    /// See [`ImuCorrector::overlay`].
    #[must_use]
    pub fn overlay(&self) -> Option<crate::correct::Overlay> {
        each!(self, |c| c.overlay().copied())
    }

    /// See [`ImuCorrector::set_suspect`].
    pub fn set_suspect(&mut self, suspect: bool) {
        each!(self, |c| c.set_suspect(suspect));
    }

    /// Gives a corrected sample to the health check
    /// ([`RestMonitor::observe_rest`](crate::health::RestMonitor::observe_rest)).
    pub fn observe_rest(
        &mut self,
        monitor: &mut crate::health::RestMonitor,
        out: &Corrected<6>,
    ) -> crate::health::Verdict {
        each!(self, |c| monitor.observe_rest(c, out))
    }
}

/// A [`TriadCorrector`] of the calibration's own format, fed `i32` codes.
#[derive(Debug, Clone)]
pub enum AnyTriadCorrector<'a> {
    /// `u16` samples.
    U16(TriadCorrector<'a, u16>),
    /// `i16` samples.
    I16(TriadCorrector<'a, i16>),
    /// `i32` samples.
    I32(TriadCorrector<'a, i32>),
}

impl<'a> AnyTriadCorrector<'a> {
    /// The corrector of `cal`'s format (see [`TriadCorrector::new`]).
    ///
    /// # Errors
    /// As [`TriadCorrector::new`], never [`Error::CorrectorWrongFormat`].
    pub fn new(cal: &'a Calibration) -> Result<Self, Error> {
        Ok(match format_of(cal) {
            SampleFormat::U16 => Self::U16(TriadCorrector::new(cal)?),
            SampleFormat::I16 => Self::I16(TriadCorrector::new(cal)?),
            SampleFormat::I32 => Self::I32(TriadCorrector::new(cal)?),
        })
    }

    /// See [`TriadCorrector::set_environment`].
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        each!(self, |c| c.set_environment(temperature, voltage));
    }

    /// See [`TriadCorrector::environment_flags`].
    #[must_use]
    pub fn environment_flags(&self) -> Flags {
        each!(self, |c| c.environment_flags())
    }

    /// Corrects one sample (see [`TriadCorrector::correct`]).
    #[must_use]
    pub fn correct(&self, raw: [i32; 3]) -> Corrected<3> {
        each!(self, |c, S| c.correct(raw.map(S::clamped)))
    }

    /// Corrects `raw` into `out` (see [`TriadCorrector::correct_batch`]).
    pub fn correct_batch(&self, raw: &[[i32; 3]], out: &mut [Corrected<3>]) -> usize {
        each!(self, |c, S| in_blocks(
            raw,
            out,
            |x| x.map(S::clamped),
            |r, o| c.correct_batch(r, o)
        ))
    }

    /// See [`TriadCorrector::sigma`].
    #[must_use]
    pub fn sigma(&self, raw: [i32; 3]) -> Option<[f32; 3]> {
        each!(self, |c, S| c.sigma(raw.map(S::clamped)))
    }
}

/// An [`AxisCorrector`] of the calibration's own format, fed `i32` codes.
#[derive(Debug, Clone)]
pub enum AnyAxisCorrector<'a> {
    /// `u16` samples.
    U16(AxisCorrector<'a, u16>),
    /// `i16` samples.
    I16(AxisCorrector<'a, i16>),
    /// `i32` samples.
    I32(AxisCorrector<'a, i32>),
}

impl<'a> AnyAxisCorrector<'a> {
    /// The corrector of `cal`'s format (see [`AxisCorrector::new`]).
    ///
    /// # Errors
    /// As [`AxisCorrector::new`], never [`Error::CorrectorWrongFormat`].
    pub fn new(cal: &'a Calibration) -> Result<Self, Error> {
        Ok(match format_of(cal) {
            SampleFormat::U16 => Self::U16(AxisCorrector::new(cal)?),
            SampleFormat::I16 => Self::I16(AxisCorrector::new(cal)?),
            SampleFormat::I32 => Self::I32(AxisCorrector::new(cal)?),
        })
    }

    /// See [`AxisCorrector::set_environment`].
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        each!(self, |c| c.set_environment(temperature, voltage));
    }

    /// See [`AxisCorrector::environment_flags`].
    #[must_use]
    pub fn environment_flags(&self) -> Flags {
        each!(self, |c| c.environment_flags())
    }

    /// Corrects one sample (see [`AxisCorrector::correct`]).
    #[must_use]
    pub fn correct(&self, raw: i32) -> Corrected<1> {
        each!(self, |c, S| c.correct(S::clamped(raw)))
    }

    /// Corrects `raw` into `out` (see [`AxisCorrector::correct_batch`]).
    pub fn correct_batch(&self, raw: &[i32], out: &mut [Corrected<1>]) -> usize {
        each!(self, |c, S| in_blocks(raw, out, S::clamped, |r, o| c
            .correct_batch(r, o)))
    }

    /// See [`AxisCorrector::sigma`].
    #[must_use]
    pub fn sigma(&self, raw: i32) -> Option<f32> {
        each!(self, |c, S| c.sigma(S::clamped(raw)))
    }
}
