//! The single-axis corrector.

use super::environment::effective_set;
use super::kernel::{Shape, linearize, search_window};
use super::sample::{self, Sample};
use super::{Corrected, Flags, factor_norm};
use core::marker::PhantomData;

use crate::Error;
use crate::model::interval::{Bound, axis_bound};
use crate::model::{Calibration, Channel, Environment, Rails, Sensor, SingleCovariance, SingleSet};

#[derive(Debug, Clone, Copy, PartialEq)]
struct AxisKernel {
    base: i32,
    limit: u32,
    scale: f32,
    off_lin: f32,
    off: f32,
    delta: f32,
    nl: [f32; 5],
    range_lo: f32,
    range_hi: f32,
    rails: Rails,
}

impl AxisKernel {
    const IDENTITY: Self = Self {
        base: 0,
        limit: 0,
        scale: 1.0,
        off_lin: 0.0,
        off: 0.0,
        delta: 0.0,
        nl: [0.0; 5],
        range_lo: f32::NEG_INFINITY,
        range_hi: f32::INFINITY,
        rails: Rails::new(i32::MIN, i32::MAX),
    };

    fn new(set: &SingleSet, channel: &Channel, rails: &Rails) -> Self {
        let window = search_window(core::array::from_ref(channel), rails, |lo, hi| {
            let [lo] = *lo;
            let [hi] = *hi;
            Bound::point(set.offset)
                .add(axis_bound(&set.axis, lo, hi).scale(set.scale))
                .inside(channel.range.lo, channel.range.hi)
        });
        let [base] = window.base;
        let delta = channel.center - base as f32;
        Self {
            base,
            limit: window.limit,
            scale: set.scale,
            off_lin: set.offset - set.scale * delta,
            off: set.offset,
            delta,
            nl: set.axis.to_array(),
            range_lo: channel.range.lo,
            range_hi: channel.range.hi,
            rails: *rails,
        }
    }

    #[inline(always)]
    fn value<const NONLINEAR: bool, const ASYM: bool>(&self, w: i32) -> f32 {
        if NONLINEAR {
            self.off + self.scale * linearize::<ASYM>(&self.nl, self.delta, w)
        } else {
            self.off_lin + self.scale * w as f32
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Source<'a> {
    env: &'a Environment,
    sets: &'a [SingleSet],
    channel: &'a Channel,
    rails: Rails,
    covariance: Option<&'a [SingleCovariance]>,
}

/// Corrects a single-axis sensor (see the [module docs](super)).
#[derive(Debug, Clone)]
pub struct AxisCorrector<'a, S: Sample> {
    source: Option<Source<'a>>,
    sample: PhantomData<fn(S)>,
    shape: Shape,
    kernel: AxisKernel,
    env_flags: Flags,
    covariance: Option<SingleCovariance>,
}

impl<'a, S: Sample> AxisCorrector<'a, S> {
    /// A corrector for a single-axis calibration whose samples come as `S`, at an unknown
    /// environment.
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not a single axis;
    /// [`Error::CorrectorWrongFormat`] when it states another sample format than `S`.
    pub fn new(cal: &'a Calibration) -> Result<Self, Error> {
        let data = cal.data();
        let Sensor::Single {
            rails,
            channel,
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
                channel,
                rails: *rails,
                covariance: covariance.as_deref(),
            }),
            shape: Shape::of(sets.iter().map(|s| &s.axis)),
            kernel: AxisKernel::IDENTITY,
            env_flags: Flags::NONE,
            covariance: None,
        };
        out.set_environment(f32::NAN, f32::NAN);
        Ok(out)
    }

    /// The fallback when no valid calibration exists: the output is the raw code and every
    /// sample is flagged [`Flags::NO_CALIBRATION`].
    #[must_use]
    pub const fn identity() -> Self {
        Self {
            source: None,
            sample: PhantomData,
            shape: Shape::Identity,
            kernel: AxisKernel::IDENTITY,
            env_flags: Flags::NO_CALIBRATION,
            covariance: None,
        }
    }

    /// Interpolates the coefficients at `temperature` (C) and `voltage` (V); see
    /// [`TriadCorrector::set_environment`](super::TriadCorrector::set_environment).
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        let Some(src) = self.source else {
            return;
        };
        let Some((set, flags)) = effective_set(src.env, src.sets, temperature, voltage) else {
            *self = Self::identity();
            return;
        };
        self.kernel = AxisKernel::new(&set, src.channel, &src.rails);
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
    pub fn correct(&self, raw: S) -> Corrected<1> {
        let mut out = Corrected::default();
        self.correct_batch(core::slice::from_ref(&raw), core::slice::from_mut(&mut out));
        out
    }

    /// Corrects `raw` into `out` and returns how many samples were corrected.
    pub fn correct_batch(&self, raw: &[S], out: &mut [Corrected<1>]) -> usize {
        let pairs = raw.iter().map(|r| r.code()).zip(out.iter_mut());
        let n = pairs.len();
        match self.shape {
            Shape::Linear => pairs.for_each(|(r, o)| self.step::<false, false>(r, o)),
            Shape::Polynomial => pairs.for_each(|(r, o)| self.step::<true, false>(r, o)),
            Shape::Asymmetric => pairs.for_each(|(r, o)| self.step::<true, true>(r, o)),
            Shape::Identity => pairs.for_each(|(r, o)| *o = self.passthrough(r)),
        }
        n
    }

    /// The 1-sigma calibration error for `raw` at the current environment; `None` without a
    /// covariance factor.
    #[must_use]
    pub fn sigma(&self, raw: S) -> Option<f32> {
        let cov = self.covariance.as_ref()?;
        let raw = raw.code();
        let k = &self.kernel;
        let clamped = raw.max(k.rails.lo).min(k.rails.hi);
        let u = linearize::<true>(&k.nl, k.delta, clamped.wrapping_sub(k.base));
        Some(factor_norm(cov, &[1.0, u]))
    }

    #[inline(always)]
    fn passthrough(&self, r: i32) -> Corrected<1> {
        Corrected {
            values: [r as f32],
            flags: self.env_flags,
        }
    }

    #[inline(always)]
    fn step<const NONLINEAR: bool, const ASYM: bool>(&self, raw: i32, out: &mut Corrected<1>) {
        let k = &self.kernel;
        let w = raw.wrapping_sub(k.base);
        out.values = [k.value::<NONLINEAR, ASYM>(w)];
        out.flags = self.env_flags;
        if (w as u32) >= k.limit {
            self.slow::<NONLINEAR, ASYM>(raw, out);
        }
    }

    #[cold]
    #[inline(never)]
    fn slow<const NONLINEAR: bool, const ASYM: bool>(&self, raw: i32, out: &mut Corrected<1>) {
        let k = &self.kernel;
        let clamped = raw.max(k.rails.lo).min(k.rails.hi);
        let value = k.value::<NONLINEAR, ASYM>(clamped.wrapping_sub(k.base));
        out.flags = self
            .env_flags
            .with_if(Flags::SATURATED, k.rails.saturated(raw))
            .with_if(
                Flags::OUT_OF_RANGE,
                !(k.range_lo <= value && value <= k.range_hi),
            );
        out.values = [value];
    }
}
