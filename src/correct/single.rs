//! The single-axis corrector.

use super::environment::effective_set;
use super::kernel::{linearize, search_window};
use super::{Corrected, Flags, factor_norm};
use crate::Error;
use crate::model::interval::{Bound, axis_bound};
use crate::model::{Calibration, Channel, Environment, Rails, Sensor, SingleCovariance, SingleSet};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Identity,
    Linear,
    Nonlinear,
}

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
        rails: Rails {
            lo: i32::MIN,
            hi: i32::MAX,
        },
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
    fn value<const NONLINEAR: bool>(&self, w: i32) -> f32 {
        if NONLINEAR {
            self.off + self.scale * linearize(&self.nl, self.delta, w)
        } else {
            self.off_lin + self.scale * w as f32
        }
    }
}

/// Corrects a single-axis sensor (see the [module docs](super)).
#[derive(Debug, Clone)]
pub struct AxisCorrector<'a> {
    source: Option<(&'a Environment, &'a [SingleSet], &'a Channel, Rails)>,
    mode: Mode,
    kernel: AxisKernel,
    env_flags: Flags,
    covariance: Option<SingleCovariance>,
}

impl<'a> AxisCorrector<'a> {
    /// A corrector for a single-axis calibration, at an unknown environment.
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not a single axis.
    pub fn new(cal: &'a Calibration) -> Result<Self, Error> {
        let data = cal.data();
        let Sensor::Single {
            rails,
            channel,
            sets,
            ..
        } = &data.sensor
        else {
            return Err(Error::CorrectorWrongSensor);
        };
        let linear = sets.iter().all(|s| s.axis.is_linear());
        let mut out = Self {
            source: Some((&data.environment, sets, channel, *rails)),
            mode: if linear {
                Mode::Linear
            } else {
                Mode::Nonlinear
            },
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
            mode: Mode::Identity,
            kernel: AxisKernel::IDENTITY,
            env_flags: Flags::NO_CALIBRATION,
            covariance: None,
        }
    }

    /// Interpolates the coefficients at `temperature` (C) and `voltage` (V); see
    /// [`TriadCorrector::set_environment`](super::TriadCorrector::set_environment).
    pub fn set_environment(&mut self, temperature: f32, voltage: f32) {
        let Some((env, sets, channel, rails)) = self.source else {
            return;
        };
        let Some((set, flags)) = effective_set(env, sets, temperature, voltage) else {
            *self = Self::identity();
            return;
        };
        self.kernel = AxisKernel::new(&set, channel, &rails);
        self.env_flags = flags;
        self.covariance = set.covariance;
    }

    /// The flags that the current environment puts on every sample.
    #[must_use]
    pub const fn environment_flags(&self) -> Flags {
        self.env_flags
    }

    /// Corrects one sample.
    #[must_use]
    #[inline]
    pub fn correct(&self, raw: i32) -> Corrected<1> {
        match self.mode {
            Mode::Linear => self.step::<false>(raw),
            Mode::Nonlinear => self.step::<true>(raw),
            Mode::Identity => self.identity_step(raw),
        }
    }

    /// Corrects `raw` into `out` and returns how many samples were corrected.
    pub fn correct_batch(&self, raw: &[i32], out: &mut [Corrected<1>]) -> usize {
        let pairs = raw.iter().zip(out.iter_mut());
        let n = pairs.len();
        match self.mode {
            Mode::Linear => pairs.for_each(|(r, o)| *o = self.step::<false>(*r)),
            Mode::Nonlinear => pairs.for_each(|(r, o)| *o = self.step::<true>(*r)),
            Mode::Identity => pairs.for_each(|(r, o)| *o = self.identity_step(*r)),
        }
        n
    }

    /// The 1-sigma calibration error for `raw` at the current environment; `None` without a
    /// covariance factor.
    #[must_use]
    pub fn sigma(&self, raw: i32) -> Option<f32> {
        let cov = self.covariance.as_ref()?;
        let k = &self.kernel;
        let clamped = raw.max(k.rails.lo).min(k.rails.hi);
        let u = linearize(&k.nl, k.delta, clamped.wrapping_sub(k.base));
        Some(factor_norm(cov, &[1.0, u]))
    }

    #[inline(always)]
    fn step<const NONLINEAR: bool>(&self, raw: i32) -> Corrected<1> {
        let k = &self.kernel;
        let w = raw.wrapping_sub(k.base);
        let value = k.value::<NONLINEAR>(w);
        if (w as u32) < k.limit {
            Corrected {
                values: [value],
                flags: self.env_flags,
            }
        } else {
            self.slow::<NONLINEAR>(raw)
        }
    }

    #[cold]
    #[inline(never)]
    fn slow<const NONLINEAR: bool>(&self, raw: i32) -> Corrected<1> {
        let k = &self.kernel;
        let clamped = raw.max(k.rails.lo).min(k.rails.hi);
        let value = k.value::<NONLINEAR>(clamped.wrapping_sub(k.base));
        let flags = self
            .env_flags
            .with_if(Flags::SATURATED, k.rails.saturated(raw))
            .with_if(
                Flags::OUT_OF_RANGE,
                !(k.range_lo <= value && value <= k.range_hi),
            );
        Corrected {
            values: [value],
            flags,
        }
    }

    #[inline(always)]
    fn identity_step(&self, raw: i32) -> Corrected<1> {
        Corrected {
            values: [raw as f32],
            flags: self.env_flags,
        }
    }
}
