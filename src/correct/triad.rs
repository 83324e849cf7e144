//! The triad corrector: three axes of one quantity.

use super::environment::effective_set;
use super::kernel::{Shape, TriadKernel};
use super::sample::{self, Sample};
use super::{Corrected, Flags, factor_norm};
use core::marker::PhantomData;

use crate::Error;
use crate::model::interval::Bound;
use crate::model::{Calibration, Channel, Environment, Rails, Sensor, TriadCovariance, TriadSet};

#[derive(Debug, Clone, Copy)]
struct Source<'a> {
    env: &'a Environment,
    sets: &'a [TriadSet],
    channels: &'a [Channel; 3],
    rails: Rails,
    covariance: Option<&'a [TriadCovariance]>,
}

/// Corrects an accelerometer or gyro triad (see the [module docs](super)).
#[derive(Debug, Clone)]
pub struct TriadCorrector<'a, S: Sample> {
    source: Option<Source<'a>>,
    sample: PhantomData<fn(S)>,
    shape: Shape,
    kernel: TriadKernel,
    env_flags: Flags,
    covariance: Option<TriadCovariance>,
}

impl<'a, S: Sample> TriadCorrector<'a, S> {
    /// A corrector for a triad calibration whose samples come as `[S; 3]`, at an unknown
    /// environment (see the module docs).
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not a triad;
    /// [`Error::CorrectorWrongFormat`] when it states another sample format than `S`.
    pub fn new(cal: &'a Calibration) -> Result<Self, Error> {
        let data = cal.data();
        let Sensor::Triad {
            rails,
            channels,
            sets,
            covariance,
            ..
        } = &data.sensor
        else {
            return Err(Error::CorrectorWrongSensor);
        };
        sample::check::<S>(rails)?;
        let mut out = Self {
            sample: PhantomData,
            source: Some(Source {
                env: &data.environment,
                sets,
                channels,
                rails: *rails,
                covariance: covariance.as_deref(),
            }),
            shape: Shape::of(sets.iter().flat_map(|s| &s.axes)),
            kernel: TriadKernel::IDENTITY,
            env_flags: Flags::NONE,
            covariance: None,
        };
        out.set_environment(f32::NAN, f32::NAN);
        Ok(out)
    }

    /// The fallback when no valid calibration exists: outputs are the raw codes and every
    /// sample is flagged [`Flags::NO_CALIBRATION`].
    #[must_use]
    pub const fn identity() -> Self {
        Self {
            source: None,
            sample: PhantomData,
            shape: Shape::Identity,
            kernel: TriadKernel::IDENTITY,
            env_flags: Flags::NO_CALIBRATION,
            covariance: None,
        }
    }

    /// Interpolates the coefficients at `temperature` (C) and `voltage` (V) and precomputes the
    /// per-sample path. Outside the calibrated spans (or NaN) the table edge is used and every
    /// sample is flagged.
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        let Some(src) = self.source else {
            return;
        };
        let Some((set, flags)) = effective_set(src.env, src.sets, temperature, voltage) else {
            *self = Self::identity();
            return;
        };
        self.kernel = TriadKernel::new(&set, src.channels, &src.rails, &[Bound::point(0.0); 3]);
        self.env_flags = flags;
        self.covariance = src
            .covariance
            .and_then(|table| effective_set(src.env, table, temperature, voltage))
            .map(|(c, _)| c);
    }

    /// The flags that the current environment puts on every sample.
    #[must_use]
    pub const fn environment_flags(&self) -> Flags {
        self.env_flags
    }

    /// Corrects one sample.
    #[must_use]
    #[inline]
    pub fn correct(&self, raw: [S; 3]) -> Corrected<3> {
        let raw = sample::codes(raw);
        let mut out = Corrected::default();
        let o = &mut out;
        match self.shape {
            Shape::Linear => self.step::<false, false>(raw, o),
            Shape::Polynomial => self.step::<true, false>(raw, o),
            Shape::Asymmetric => self.step::<true, true>(raw, o),
            Shape::Identity => *o = self.passthrough(&raw),
        }
        out
    }

    /// Corrects `raw` into `out`, sample by sample, and returns how many were corrected (the
    /// shorter of the two lengths).
    pub fn correct_batch(&self, raw: &[[S; 3]], out: &mut [Corrected<3>]) -> usize {
        let pairs = raw.iter().map(|r| sample::codes(*r)).zip(out.iter_mut());
        let n = pairs.len();
        match self.shape {
            Shape::Linear => pairs.for_each(|(r, o)| self.step::<false, false>(r, o)),
            Shape::Polynomial => pairs.for_each(|(r, o)| self.step::<true, false>(r, o)),
            Shape::Asymmetric => pairs.for_each(|(r, o)| self.step::<true, true>(r, o)),
            Shape::Identity => pairs.for_each(|(r, o)| *o = self.passthrough(&r)),
        }
        n
    }

    /// The 1-sigma calibration error of each output for `raw` at the current environment, from
    /// the stored covariance factor; `None` when the calibration has none.
    #[must_use]
    pub fn sigma(&self, raw: [S; 3]) -> Option<[f32; 3]> {
        let cov = self.covariance.as_ref()?;
        let raw = sample::codes(raw);
        let (w, _) = self.kernel.offsets(self.kernel.clamp(raw));
        let [u0, u1, u2] = self.kernel.linearized::<true>(w);
        let f = [1.0, u0, u1, u2];
        Some(cov.map(|l| factor_norm(&l, &f)))
    }

    #[inline(always)]
    fn passthrough(&self, r: &[i32; 3]) -> Corrected<3> {
        Corrected {
            values: r.map(|x| x as f32),
            flags: self.env_flags,
        }
    }

    #[inline(always)]
    fn step<const NONLINEAR: bool, const ASYM: bool>(&self, raw: [i32; 3], out: &mut Corrected<3>) {
        let k = &self.kernel;
        let (w, acc) = k.offsets(raw);
        out.values = k.outputs::<NONLINEAR, ASYM>(w);
        out.flags = self.env_flags;
        if acc >= k.limit {
            self.slow::<NONLINEAR, ASYM>(raw, out);
        }
    }

    #[cold]
    #[inline(never)]
    fn slow<const NONLINEAR: bool, const ASYM: bool>(&self, raw: [i32; 3], out: &mut Corrected<3>) {
        let k = &self.kernel;
        let (w, _) = k.offsets(k.clamp(raw));
        let values = k.outputs::<NONLINEAR, ASYM>(w);
        out.flags = self
            .env_flags
            .with_if(Flags::SATURATED, k.saturated(&raw))
            .with_if(Flags::OUT_OF_RANGE, k.out_of_range(&values));
        out.values = values;
    }
}
