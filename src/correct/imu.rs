//! The IMU corrector: an accelerometer triad and a gyro triad sampled together, with gyro
//! g-sensitivity and the accelerometer size effect (lever arm).

#[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
mod fast;

use super::environment::effective_set;
use super::kernel::{Shape, TriadKernel, affine, range_bounds};
use super::{Corrected, Flags, factor_norm};
use crate::Error;
use crate::model::interval::{Bound, affine_bound};
use crate::model::{Calibration, Channel, Environment, ImuCovariance, ImuSet, Rails, Sensor};

/// The per-sample arithmetic: the axis [`Shape`] (with g-sensitivity whenever it is not
/// `Linear`) and whether the lever arm is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Mode {
    shape: Shape,
    lever: bool,
}

#[derive(Debug, Clone, Copy)]
struct Source<'a> {
    env: &'a Environment,
    sets: &'a [ImuSet],
    accel: &'a [Channel; 3],
    gyro: &'a [Channel; 3],
    accel_rails: Rails,
    gyro_rails: Rails,
    covariance: Option<&'a [ImuCovariance]>,
}

/// Corrects a 6-axis IMU sample `[ax, ay, az, gx, gy, gz]` (see the [module docs](super)).
///
/// The accelerometer outputs are moved to the reference point with the lever arm
/// `a - w x (w x r) - dw/dt x r` (per axis), `dw/dt` being the backward difference of the
/// corrected gyro rate at the sample rate given to [`ImuCorrector::new`]. The calibrated
/// accelerometer range applies to the specific force at the sensor, before that correction.
#[derive(Debug, Clone)]
pub struct ImuCorrector<'a> {
    source: Option<Source<'a>>,
    mode: Mode,
    accel: TriadKernel,
    gyro: TriadKernel,
    /// Window limits computed for the environment (the kernels hold 0 until primed).
    limits: [u32; 2],
    g: [[f32; 3]; 3],
    /// Lever arm rows `r_i`, metres.
    lever: [[f32; 3]; 3],
    /// Lever arm rows times the sample rate, for the rate-difference term.
    lever_rate: [[f32; 3]; 3],
    prev_rate: [f32; 3],
    primed: bool,
    env_flags: Flags,
    covariance: Option<ImuCovariance>,
    /// The Cortex-M4F kernel's coefficient block for the environment (`fast.rs`).
    #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
    hot: super::m4f::Hot,
}

impl<'a> ImuCorrector<'a> {
    /// A corrector for an IMU calibration sampled at `sample_rate_hz`, at an unknown
    /// environment.
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not an IMU;
    /// [`Error::CorrectorBadSampleRate`] when the rate is not finite and positive.
    pub fn new(cal: &'a Calibration, sample_rate_hz: f32) -> Result<Self, Error> {
        let data = cal.data();
        let Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            lever_arm,
            sets,
            covariance,
        } = &data.sensor
        else {
            return Err(Error::CorrectorWrongSensor);
        };
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(Error::CorrectorBadSampleRate);
        }
        let shape = Shape::of(
            sets.iter()
                .flat_map(|s| s.accel.axes.iter().chain(&s.gyro.axes)),
        );
        let g_sensitive = sets
            .iter()
            .any(|s| s.g_sensitivity.iter().flatten().any(|g| *g != 0.0));
        let lever = lever_arm.is_some();
        // g-sensitivity and the lever arm ride on the nonlinear path.
        let shape = match shape {
            Shape::Linear if g_sensitive || lever => Shape::Polynomial,
            other => other,
        };
        let mode = Mode { shape, lever };
        let lever = lever_arm.unwrap_or([[0.0; 3]; 3]);
        let mut out = Self {
            source: Some(Source {
                env: &data.environment,
                sets,
                accel,
                gyro,
                accel_rails: *accel_rails,
                gyro_rails: *gyro_rails,
                covariance: covariance.as_deref(),
            }),
            mode,
            accel: TriadKernel::IDENTITY,
            gyro: TriadKernel::IDENTITY,
            limits: [0; 2],
            g: [[0.0; 3]; 3],
            lever,
            lever_rate: lever.map(|row| row.map(|r| r * sample_rate_hz)),
            prev_rate: [0.0; 3],
            primed: false,
            env_flags: Flags::NONE,
            covariance: None,
            #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
            hot: super::m4f::Hot::None,
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
            mode: Mode {
                shape: Shape::Identity,
                lever: false,
            },
            accel: TriadKernel::IDENTITY,
            gyro: TriadKernel::IDENTITY,
            limits: [0; 2],
            g: [[0.0; 3]; 3],
            lever: [[0.0; 3]; 3],
            lever_rate: [[0.0; 3]; 3],
            prev_rate: [0.0; 3],
            primed: false,
            env_flags: Flags::NO_CALIBRATION,
            covariance: None,
            #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
            hot: super::m4f::Hot::None,
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
        let none = [Bound::point(0.0); 3];
        self.accel = TriadKernel::new(&set.accel, src.accel, &src.accel_rails, &none);
        // Inside both windows the specific force lies in the accelerometer's calibrated range,
        // so that range bounds the g-sensitivity term the gyro window must allow for.
        let a = range_bounds(src.accel);
        let g_term = set
            .g_sensitivity
            .map(|row| affine_bound(&row.map(|g| -g), 0.0, &a));
        self.gyro = TriadKernel::new(&set.gyro, src.gyro, &src.gyro_rails, &g_term);
        self.limits = [self.accel.limit, self.gyro.limit];
        if self.mode.lever && !self.primed {
            self.accel.limit = 0;
        }
        self.g = set.g_sensitivity;
        self.env_flags = flags;
        self.covariance = src
            .covariance
            .and_then(|table| effective_set(src.env, table, temperature, voltage))
            .map(|(c, _)| c);
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        self.refresh_m4f();
    }

    /// Forgets the previous gyro sample (after a gap in the stream): the next sample's rate
    /// derivative is unknown and flagged.
    pub fn reset(&mut self) {
        self.primed = false;
        if self.mode.lever {
            self.accel.limit = 0;
        }
    }

    /// The flags that the current environment puts on every sample.
    #[must_use]
    pub const fn environment_flags(&self) -> Flags {
        self.env_flags
    }

    /// Corrects one sample `[ax, ay, az, gx, gy, gz]`.
    #[must_use]
    #[inline]
    pub fn correct(&mut self, raw: [i32; 6]) -> Corrected<6> {
        let mut out = Corrected::default();
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        if self.one_m4f(raw, &mut out) {
            return out;
        }
        let o = &mut out;
        match (self.mode.shape, self.mode.lever) {
            (Shape::Linear, _) => self.step::<false, false, false>(raw, o),
            (Shape::Polynomial, false) => self.step::<true, false, false>(raw, o),
            (Shape::Polynomial, true) => self.step::<true, false, true>(raw, o),
            (Shape::Asymmetric, false) => self.step::<true, true, false>(raw, o),
            (Shape::Asymmetric, true) => self.step::<true, true, true>(raw, o),
            (Shape::Identity, _) => *o = self.passthrough(raw),
        }
        out
    }

    /// Corrects `raw` into `out`, in order, and returns how many samples were corrected.
    pub fn correct_batch(&mut self, raw: &[[i32; 6]], out: &mut [Corrected<6>]) -> usize {
        let n = raw.len().min(out.len());
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        if self.batch_m4f(raw, out) {
            return n;
        }
        let pairs = raw.iter().zip(out.iter_mut());
        let Mode { shape, lever } = self.mode;
        match (shape, lever) {
            (Shape::Linear, _) => pairs.for_each(|(r, o)| self.step::<false, false, false>(*r, o)),
            (Shape::Polynomial, false) => {
                pairs.for_each(|(r, o)| self.step::<true, false, false>(*r, o));
            }
            (Shape::Polynomial, true) => {
                pairs.for_each(|(r, o)| self.step::<true, false, true>(*r, o));
            }
            (Shape::Asymmetric, false) => {
                pairs.for_each(|(r, o)| self.step::<true, true, false>(*r, o));
            }
            (Shape::Asymmetric, true) => {
                pairs.for_each(|(r, o)| self.step::<true, true, true>(*r, o));
            }
            (Shape::Identity, _) => pairs.for_each(|(r, o)| *o = self.passthrough(*r)),
        }
        n
    }

    #[inline(always)]
    fn passthrough(&self, raw: [i32; 6]) -> Corrected<6> {
        Corrected {
            values: raw.map(|x| x as f32),
            flags: self.env_flags,
        }
    }

    /// The 1-sigma calibration error of each output for `raw` at the current environment
    /// (bias, scale and misalignment; not the nonlinear terms, g-sensitivity or lever arm);
    /// `None` when the calibration has no covariance factors.
    #[must_use]
    pub fn sigma(&self, raw: [i32; 6]) -> Option<[f32; 6]> {
        let ImuCovariance {
            accel: ca,
            gyro: cg,
        } = self.covariance.as_ref()?;
        let (ra, rg) = split(raw);
        let features = |k: &TriadKernel, r: [i32; 3]| {
            let (w, _) = k.offsets(k.clamp(r));
            let [u0, u1, u2] = k.linearized::<true>(w);
            [1.0, u0, u1, u2]
        };
        let fa = features(&self.accel, ra);
        let fg = features(&self.gyro, rg);
        let [a0, a1, a2] = ca.map(|l| factor_norm(&l, &fa));
        let [g0, g1, g2] = cg.map(|l| factor_norm(&l, &fg));
        Some([a0, a1, a2, g0, g1, g2])
    }

    /// Specific force at the sensor and the corrected rate (with g-sensitivity on the
    /// nonlinear path).
    #[inline(always)]
    fn triads<const NONLINEAR: bool, const ASYM: bool>(
        &self,
        wa: [i32; 3],
        wg: [i32; 3],
    ) -> ([f32; 3], [f32; 3]) {
        let a = self.accel.outputs::<NONLINEAR, ASYM>(wa);
        let w = self.gyro.outputs::<NONLINEAR, ASYM>(wg);
        if !NONLINEAR {
            return (a, w);
        }
        let [g0, g1, g2] = &self.g;
        let [n0, n1, n2] = [g0.map(|g| -g), g1.map(|g| -g), g2.map(|g| -g)];
        let [o0, o1, o2] = w;
        (
            a,
            [
                affine(&n0, o0, &a),
                affine(&n1, o1, &a),
                affine(&n2, o2, &a),
            ],
        )
    }

    /// Moves the specific force from each accelerometer axis to the reference point.
    #[inline(always)]
    fn lever_arm(&self, a: [f32; 3], w: [f32; 3], prev: [f32; 3]) -> [f32; 3] {
        let [w0, w1, w2] = w;
        let [p0, p1, p2] = prev;
        let (d0, d1, d2) = (w0 - p0, w1 - p1, w2 - p2);
        let ww = w0 * w0 + w1 * w1 + w2 * w2;
        let [r0, r1, r2] = &self.lever;
        let [f0, f1, f2] = &self.lever_rate;
        let [a0, a1, a2] = a;
        // Component i of w x (w x r_i) is w_i (w . r_i) - r_ii |w|^2; of dw x r_i it is the
        // usual cross product, with the sample rate folded into r_i.
        let dot = |r: &[f32; 3]| w0 * r[0] + w1 * r[1] + w2 * r[2];
        [
            a0 - w0 * dot(r0) + r0[0] * ww - d1 * f0[2] + d2 * f0[1],
            a1 - w1 * dot(r1) + r1[1] * ww - d2 * f1[0] + d0 * f1[2],
            a2 - w2 * dot(r2) + r2[2] * ww - d0 * f2[1] + d1 * f2[0],
        ]
    }

    #[inline(always)]
    fn step<const NONLINEAR: bool, const ASYM: bool, const LEVER: bool>(
        &mut self,
        raw: [i32; 6],
        out: &mut Corrected<6>,
    ) {
        let (ra, rg) = split(raw);
        let (wa, acc_a) = self.accel.offsets(ra);
        let (wg, acc_g) = self.gyro.offsets(rg);
        if (acc_a < self.accel.limit) & (acc_g < self.gyro.limit) {
            let (a, w) = self.triads::<NONLINEAR, ASYM>(wa, wg);
            let a = if LEVER {
                let moved = self.lever_arm(a, w, self.prev_rate);
                self.prev_rate = w;
                moved
            } else {
                a
            };
            out.values = join(a, w);
            out.flags = self.env_flags;
        } else {
            self.slow::<NONLINEAR, ASYM, LEVER>(raw, out);
        }
    }

    #[cold]
    #[inline(never)]
    fn slow<const NONLINEAR: bool, const ASYM: bool, const LEVER: bool>(
        &mut self,
        raw: [i32; 6],
        out: &mut Corrected<6>,
    ) {
        let (ra, rg) = split(raw);
        let (wa, _) = self.accel.offsets(self.accel.clamp(ra));
        let (wg, _) = self.gyro.offsets(self.gyro.clamp(rg));
        let (a, w) = self.triads::<NONLINEAR, ASYM>(wa, wg);
        let mut flags = self
            .env_flags
            .with_if(
                Flags::SATURATED,
                self.accel.saturated(&ra) | self.gyro.saturated(&rg),
            )
            .with_if(
                Flags::OUT_OF_RANGE,
                self.accel.out_of_range(&a) | self.gyro.out_of_range(&w),
            );
        let a = if LEVER {
            if !self.primed {
                self.prev_rate = w;
                self.primed = true;
                let [la, _] = self.limits;
                self.accel.limit = la;
                flags |= Flags::RATE_DERIVATIVE_UNKNOWN;
            }
            let moved = self.lever_arm(a, w, self.prev_rate);
            self.prev_rate = w;
            moved
        } else {
            a
        };
        out.values = join(a, w);
        out.flags = flags;
    }
}

#[inline(always)]
fn split(raw: [i32; 6]) -> ([i32; 3], [i32; 3]) {
    let [a0, a1, a2, g0, g1, g2] = raw;
    ([a0, a1, a2], [g0, g1, g2])
}

#[inline(always)]
fn join(a: [f32; 3], w: [f32; 3]) -> [f32; 6] {
    let [a0, a1, a2] = a;
    let [w0, w1, w2] = w;
    [a0, a1, a2, w0, w1, w2]
}
