//! The IMU corrector: an accelerometer triad and a gyro triad sampled together, with gyro
//! g-sensitivity and the accelerometer size effect (lever arm).

mod doubt;
#[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
mod fast;
mod uncertainty;

use doubt::{lever_bound, step_sq};

use super::environment::{effective_covariance_into, effective_set};
use super::kernel::{Shape, TriadKernel, affine, range_bounds};
use super::sample::{self, Sample};
use super::{Corrected, Flags};
use core::marker::PhantomData;

use crate::Error;
use crate::model::interval::{Bound, affine_bound};
use crate::model::rotation::{self, LeverTerms};
use crate::model::{Calibration, Channel, Environment, ImuCovariance, ImuSet, Rails, Sensor};

pub use crate::model::MAX_SAMPLE_RATE_HZ;
pub use uncertainty::REST_FEATURES;

/// Fixed-point iterations of the first sample (and the first after a reset), which has no
/// previous lever term to feed the g-sensitivity: each shrinks the error by `|G de/dw|`, about
/// `2e-3` for a high-g unit at 300 Hz of spin.
const PRIMING_ITERATIONS: usize = 3;

/// The largest angular acceleration (rad/s^2) a sample's rate may imply before it is flagged
/// [`Flags::RATE_STEP`], unless [`ImuCorrector::set_max_angular_acceleration`] says otherwise:
/// above a shell's spin-up in the bore (3.5e5 at peak pressure in `calflash simulate --flight
/// shell`: 15,000 g of setback, 300 rev/s at the muzzle) and far above a rocket's or a spin
/// rig's. At 1 kHz it is a step of 80 Hz of spin between two samples.
pub const DEFAULT_MAX_ANGULAR_ACCELERATION: f32 = 5.0e5;

/// The per-sample arithmetic: the axis [`Shape`] (with g-sensitivity whenever it is not
/// `Linear`) and whether the lever arm is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Mode {
    shape: Shape,
    lever: bool,
}

/// Refined biases applied over the calibration, never written into it (the in-use health
/// check's overlay, [`crate::health`]): the corrector subtracts them from its outputs and its
/// [`sigma`](ImuCorrector::sigma) takes their variances in place of the factory biases'.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Overlay {
    /// Per output `[ax, ay, az, wx, wy, wz]`, the bias subtracted (m/s^2, rad/s).
    pub bias: [f32; 6],
    /// Per output, that bias's variance.
    pub variance: [f32; 6],
}

impl Overlay {
    /// Moves the set's offsets by the refined biases: the accelerometer's straight, the
    /// gyro's also by what the g-sensitivity sees of the accelerometer's.
    fn apply(&self, set: &mut ImuSet) {
        let [a0, a1, a2, g0, g1, g2] = self.bias;
        let ba = [a0, a1, a2];
        for (o, b) in set.accel.offset.iter_mut().zip(ba) {
            *o -= b;
        }
        for ((o, b), row) in set
            .gyro
            .offset
            .iter_mut()
            .zip([g0, g1, g2])
            .zip(&set.g_sensitivity)
        {
            *o -= b + rotation::dot(row, &ba);
        }
    }
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

/// Corrects a 6-axis IMU sample `[ax, ay, az, gx, gy, gz]` (see the [module docs](super) and
/// the model under rotation in [`rotation`]).
///
/// The gyro's g-sensitivity acts on the specific force at the reference point; the
/// accelerometer outputs are moved to the reference point by removing what each axis sensed of
/// the centripetal and tangential accelerations at its position, `dw/dt` being the backward
/// difference of the corrected gyro rate at the sample rate given to [`ImuCorrector::new`].
/// The g-sensitivity uses the previous sample's lever term (exact in a steady spin). The
/// calibrated accelerometer range applies to the specific force the axes sense, before that
/// correction.
#[derive(Debug, Clone)]
// The per-sample state and the kernel's block first, so that the fast path reaches them with
// short immediate offsets; the rest (coefficients for the slow path, covariance, overlay)
// after.
#[repr(C)]
pub struct ImuCorrector<'a, S: Sample> {
    mode: Mode,
    env_flags: Flags,
    primed: bool,
    /// The previous rate was inside the gyro's calibrated range, so the lever term lies inside
    /// the bound the gyro window was proven with.
    prev_in_range: bool,
    /// The previous corrected gyro rate.
    prev_rate: [f32; 3],
    /// The previous lever term `e` (m/s^2), fed to the g-sensitivity.
    prev_lever: [f32; 3],
    /// The Cortex-M4F kernel's coefficient block for the environment (`fast.rs`).
    #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
    hot: super::m4f::Hot,
    accel: TriadKernel,
    gyro: TriadKernel,
    /// Window limits computed for the environment (the accelerometer's is 0 until the lever
    /// state is primed and inside its bound).
    limits: [u32; 2],
    /// Negated g-sensitivity, rad/s per m/s^2.
    neg_g: [[f32; 3]; 3],
    /// Lever arm rows `r_i`, metres (zero without one).
    lever: [[f32; 3]; 3],
    /// The sample rate, Hz.
    rate: f32,
    /// The square of the largest rate change between two samples (rad/s) before a sample is
    /// flagged [`Flags::RATE_STEP`].
    max_step_sq: f32,
    /// The lever term's coefficients at the environment, the sample rate folded into the
    /// tangential ones.
    terms: LeverTerms<f32>,
    /// The sensitive directions `n_i` of the accelerometer and the gyro at the environment
    /// (for [`sigma`](Self::sigma)).
    directions: [[[f32; 3]; 3]; 2],
    covariance: Option<ImuCovariance>,
    /// The temperature and voltage of the last [`set_environment`](Self::set_environment).
    environment: [f32; 2],
    overlay: Option<Overlay>,
    /// The health check found the calibration SUSPECT: every sample is flagged.
    suspect: bool,
    source: Option<Source<'a>>,
    sample: PhantomData<fn(S)>,
}

impl<'a, S: Sample> ImuCorrector<'a, S> {
    /// A corrector for an IMU calibration whose samples come as `[S; 6]` at
    /// `sample_rate_hz`, at an unknown environment.
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not an IMU;
    /// [`Error::CorrectorWrongFormat`] when it states another sample format than `S`;
    /// [`Error::CorrectorBadSampleRate`] when the rate is not finite, positive and at most
    /// [`MAX_SAMPLE_RATE_HZ`]; [`Error::CorrectorUnboundedFeedback`] when the g-sensitivity's
    /// feedback of the lever term is not bounded at that rate
    /// ([`Calibration::max_sample_rate_hz`](crate::model::Calibration::max_sample_rate_hz)).
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
        sample::check::<S>(accel_rails)?;
        if !(sample_rate_hz > 0.0 && sample_rate_hz <= MAX_SAMPLE_RATE_HZ) {
            return Err(Error::CorrectorBadSampleRate);
        }
        if let Some(f) = cal.feedback()
            && !f.bounded_at(sample_rate_hz)
        {
            return Err(f.error());
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
            lever,
            rate: sample_rate_hz,
            max_step_sq: step_sq(DEFAULT_MAX_ANGULAR_ACCELERATION, sample_rate_hz),
            env_flags: Flags::NONE,
            ..Self::identity()
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
            mode: Mode {
                shape: Shape::Identity,
                lever: false,
            },
            accel: TriadKernel::IDENTITY,
            gyro: TriadKernel::IDENTITY,
            limits: [0; 2],
            neg_g: [[0.0; 3]; 3],
            lever: [[0.0; 3]; 3],
            rate: 1.0,
            max_step_sq: f32::INFINITY,
            terms: LeverTerms::NONE,
            directions: [[[0.0; 3]; 3]; 2],
            prev_rate: [0.0; 3],
            prev_lever: [0.0; 3],
            primed: false,
            prev_in_range: false,
            env_flags: Flags::NO_CALIBRATION,
            covariance: None,
            environment: [f32::NAN; 2],
            overlay: None,
            suspect: false,
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
        self.environment = [temperature, voltage];
        let Some((mut set, mut flags)) = effective_set(src.env, src.sets, temperature, voltage)
        else {
            *self = Self::identity();
            return;
        };
        if let Some(overlay) = &self.overlay {
            overlay.apply(&mut set);
        }
        flags = flags.with_if(Flags::CALIBRATION_SUSPECT, self.suspect);
        let terms = if self.mode.lever {
            match LeverTerms::new(&set.accel.matrix, &self.lever, self.rate) {
                Some(t) => t,
                None => {
                    *self = Self::identity();
                    return;
                }
            }
        } else {
            LeverTerms::NONE
        };
        let none = [Bound::point(0.0); 3];
        self.accel = TriadKernel::new(&set.accel, src.accel, &src.accel_rails, &none);
        // Inside both windows the specific force the accelerometer senses lies in its
        // calibrated range and the previous lever term inside the bound that the gyro's range
        // gives it, so those bound the g-sensitivity term the gyro window must allow for.
        let a = range_bounds(src.accel);
        let e = lever_bound(&terms, src.gyro);
        let x: [Bound; 3] = core::array::from_fn(|j| match (a.get(j), e.get(j)) {
            (Some(a), Some(e)) => a.add(*e),
            _ => Bound::point(0.0),
        });
        let neg_g = set.g_sensitivity.map(|row| row.map(|g| -g));
        let g_term = neg_g.map(|row| affine_bound(&row, 0.0, &x));
        self.gyro = TriadKernel::new(&set.gyro, src.gyro, &src.gyro_rails, &g_term);
        self.limits = [self.accel.limit, self.gyro.limit];
        if self.mode.lever && !(self.primed && self.prev_in_range) {
            self.accel.limit = 0;
        }
        self.neg_g = neg_g;
        self.terms = terms;
        if src.covariance.is_some() {
            let unit = |m: &[[f32; 3]; 3]| rotation::directions(m).map_or([[0.0; 3]; 3], |d| d.0);
            self.directions = [unit(&set.accel.matrix), unit(&set.gyro.matrix)];
        }
        self.env_flags = flags;
        match src.covariance {
            Some(table) => {
                let c = self.covariance.get_or_insert(ImuCovariance {
                    accel: [[[0.0; 11]; 6]; 3],
                    gyro: [[[0.0; 11]; 6]; 3],
                });
                if !effective_covariance_into(src.env, table, temperature, voltage, c) {
                    self.covariance = None;
                }
            }
            None => self.covariance = None,
        }
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        self.refresh_m4f();
    }

    /// Applies refined biases over the calibration (`None` removes them); the coefficients are
    /// rebuilt at the current environment. The calibration itself is never changed.
    pub fn set_overlay(&mut self, overlay: Option<Overlay>) {
        self.overlay = overlay;
        let [t, v] = self.environment;
        self.set_environment(t, v);
    }

    /// The refined biases applied, if any.
    #[must_use]
    pub const fn overlay(&self) -> Option<&Overlay> {
        self.overlay.as_ref()
    }

    /// Flags every sample [`Flags::CALIBRATION_SUSPECT`] (or stops).
    pub fn set_suspect(&mut self, suspect: bool) {
        self.suspect = suspect;
        let [t, v] = self.environment;
        self.set_environment(t, v);
    }

    /// Whether every sample is flagged [`Flags::CALIBRATION_SUSPECT`].
    #[must_use]
    pub const fn suspect(&self) -> bool {
        self.suspect
    }

    /// Sets the largest angular acceleration (rad/s^2) the airframe makes: with a lever arm, a
    /// sample whose corrected rate changed by more than that over one sample period is flagged
    /// [`Flags::RATE_STEP`] (its tangential lever term, from the rate's difference, cannot be
    /// trusted). [`DEFAULT_MAX_ANGULAR_ACCELERATION`] until set. Without a lever arm no rate
    /// difference enters the correction and nothing is flagged.
    ///
    /// # Errors
    /// [`Error::CorrectorBadAngularAcceleration`] when `rad_per_s2` is not finite and
    /// positive; the corrector is then unchanged.
    pub fn set_max_angular_acceleration(&mut self, rad_per_s2: f32) -> Result<(), Error> {
        if !(rad_per_s2.is_finite() && rad_per_s2 > 0.0) {
            return Err(Error::CorrectorBadAngularAcceleration);
        }
        if self.source.is_some() {
            self.max_step_sq = step_sq(rad_per_s2, self.rate);
            let [t, v] = self.environment;
            self.set_environment(t, v);
        }
        Ok(())
    }

    /// Forgets the previous gyro sample (after a gap in the stream): the next sample's rate
    /// derivative is unknown and flagged.
    pub fn reset(&mut self) {
        self.primed = false;
        if self.mode.lever {
            self.accel.limit = 0;
        }
    }

    /// The temperature and supply voltage last set ([`set_environment`](Self::set_environment)).
    #[must_use]
    pub const fn environment(&self) -> [f32; 2] {
        self.environment
    }

    /// The flags that the current environment puts on every sample.
    #[must_use]
    pub const fn environment_flags(&self) -> Flags {
        self.env_flags
    }

    /// Corrects one sample `[ax, ay, az, gx, gy, gz]`.
    #[must_use]
    #[inline]
    pub fn correct(&mut self, raw: [S; 6]) -> Corrected<6> {
        let mut out = Corrected::default();
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        if self.one_m4f(raw, &mut out) {
            return out;
        }
        let raw = sample::codes(raw);
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
    pub fn correct_batch(&mut self, raw: &[[S; 6]], out: &mut [Corrected<6>]) -> usize {
        let n = raw.len().min(out.len());
        #[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
        if self.batch_m4f(raw, out) {
            return n;
        }
        let pairs = raw.iter().map(|r| sample::codes(*r)).zip(out.iter_mut());
        let Mode { shape, lever } = self.mode;
        match (shape, lever) {
            (Shape::Linear, _) => pairs.for_each(|(r, o)| self.step::<false, false, false>(r, o)),
            (Shape::Polynomial, false) => {
                pairs.for_each(|(r, o)| self.step::<true, false, false>(r, o));
            }
            (Shape::Polynomial, true) => {
                pairs.for_each(|(r, o)| self.step::<true, false, true>(r, o));
            }
            (Shape::Asymmetric, false) => {
                pairs.for_each(|(r, o)| self.step::<true, true, false>(r, o));
            }
            (Shape::Asymmetric, true) => {
                pairs.for_each(|(r, o)| self.step::<true, true, true>(r, o));
            }
            (Shape::Identity, _) => pairs.for_each(|(r, o)| *o = self.passthrough(r)),
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

    /// The sensor-domain specific force and the gyro's rate before g-sensitivity.
    #[inline(always)]
    fn triads<const NONLINEAR: bool, const ASYM: bool>(
        &self,
        wa: [i32; 3],
        wg: [i32; 3],
    ) -> ([f32; 3], [f32; 3]) {
        (
            self.accel.outputs::<NONLINEAR, ASYM>(wa),
            self.gyro.outputs::<NONLINEAR, ASYM>(wg),
        )
    }

    /// `w = ws - G x`: the g-sensitivity on the specific force `x`.
    #[inline(always)]
    fn g_sensitivity(&self, ws: [f32; 3], x: &[f32; 3]) -> [f32; 3] {
        let [n0, n1, n2] = &self.neg_g;
        let [o0, o1, o2] = ws;
        [affine(n0, o0, x), affine(n1, o1, x), affine(n2, o2, x)]
    }

    /// The reference-point force and the rate for sensor-domain force `a` and gyro output
    /// `ws`, with the lever term `prev` fed to the g-sensitivity and `prev_rate` for the rate
    /// difference; returns them with the new lever term and whether the rate stepped beyond
    /// the largest angular acceleration (the Cortex-M4F kernel forms the same sum in the same
    /// order).
    #[inline(always)]
    fn lever_step(
        &self,
        a: [f32; 3],
        ws: [f32; 3],
        prev: [f32; 3],
        prev_rate: [f32; 3],
    ) -> ([f32; 3], [f32; 3], [f32; 3], bool) {
        let [a0, a1, a2] = a;
        let [e0, e1, e2] = prev;
        let x = [a0 - e0, a1 - e1, a2 - e2];
        let w = self.g_sensitivity(ws, &x);
        let [w0, w1, w2] = w;
        let [p0, p1, p2] = prev_rate;
        let d = [w0 - p0, w1 - p1, w2 - p2];
        let e = self.terms.eval(&w, &d);
        let [d0, d1, d2] = d;
        let stepped = d0 * d0 + d1 * d1 + d2 * d2 > self.max_step_sq;
        let [e0, e1, e2] = e;
        ([a0 - e0, a1 - e1, a2 - e2], w, e, stepped)
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
            let (a, ws) = self.triads::<NONLINEAR, ASYM>(wa, wg);
            let (f, w, stepped) = if LEVER {
                let (f, w, e, stepped) = self.lever_step(a, ws, self.prev_lever, self.prev_rate);
                self.prev_rate = w;
                self.prev_lever = e;
                (f, w, stepped)
            } else if NONLINEAR {
                (a, self.g_sensitivity(ws, &a), false)
            } else {
                (a, ws, false)
            };
            out.values = join(f, w);
            out.flags = self.env_flags.with_if(Flags::RATE_STEP, stepped);
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
        let (a, ws) = self.triads::<NONLINEAR, ASYM>(wa, wg);
        let mut flags = self.env_flags.with_if(
            Flags::SATURATED,
            self.accel.saturated(&ra) | self.gyro.saturated(&rg),
        );
        let (f, w) = if LEVER {
            if !self.primed {
                // No previous sample: iterate to the lever term's fixed point with no rate
                // difference (flagged), then take the ordinary step from it.
                let mut e = [0.0; 3];
                let mut w = ws;
                for _ in 0..PRIMING_ITERATIONS {
                    let [a0, a1, a2] = a;
                    let [e0, e1, e2] = e;
                    w = self.g_sensitivity(ws, &[a0 - e0, a1 - e1, a2 - e2]);
                    e = self.terms.eval(&w, &[0.0; 3]);
                }
                self.prev_lever = e;
                self.prev_rate = w;
                self.primed = true;
                flags |= Flags::RATE_DERIVATIVE_UNKNOWN;
            }
            let (f, w, e, stepped) = self.lever_step(a, ws, self.prev_lever, self.prev_rate);
            self.prev_rate = w;
            self.prev_lever = e;
            flags = flags.with_if(Flags::RATE_STEP, stepped);
            (f, w)
        } else if NONLINEAR {
            (a, self.g_sensitivity(ws, &a))
        } else {
            (a, ws)
        };
        let in_range = !self.gyro.out_of_range(&w);
        flags = flags.with_if(Flags::OUT_OF_RANGE, self.accel.out_of_range(&a) | !in_range);
        if LEVER {
            // The fast path may resume only when this lever term and the next are inside the
            // bound the gyro window was proven with: both rates in range.
            let [la, _] = self.limits;
            self.accel.limit = if in_range && self.prev_in_range {
                la
            } else {
                0
            };
            self.prev_in_range = in_range;
        }
        out.values = join(f, w);
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
