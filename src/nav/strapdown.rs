//! Strapdown navigation for high rates, in two speeds (Savage's structure): at the sample rate
//! the roll about the spin axis and the de-spun increments of angle and velocity with their
//! coning and sculling terms; at a lower rate ([`Navigation::with_interval`]) the de-spun
//! attitude, the velocity and position in the local level frame of [`Earth`] with gravity and
//! the Coriolis term, and the error model's integrals.
//!
//! The inputs are corrected samples (rates and specific forces at instants, as the corrector
//! gives them), not the integrated increments of a navigation-grade IMU. Between two samples
//! the rate is taken as linear: the rotation vector of the step is the trapezoid of the rates
//! plus the coning term `w0 x w1 dt^2 / 12` (Bortz's equation to second order).
//!
//! A round at 300 rev/s turns 0.94 rad per sample at 2 kHz, so the roll is integrated exactly
//! at every sample and both the rate across the spin axis and the specific force are turned
//! into the de-spun frame by it (one sine and cosine a sample). The de-spun frame turns only
//! with the round's slow nutation and precession: within one lower-rate interval it turns by
//! `phi`, gathered by Bortz's equation (`phi' = w + phi x w / 2`), and each sample's specific
//! force is carried into the interval's starting frame to second order in `phi`
//! (`f + phi x f + phi x (phi x f) / 2`) before it is summed into the velocity's increment
//! (the sculling and rotation terms) and that increment into the position's (scrolling). The
//! interval ends at its stated length, or sooner when `phi` reaches [`MAX_TURN`], so the third
//! order left out stays under 2e-5 of the force.
//!
//! The error model's integrals (`int C`, `int C diag(f)`, `int C diag(w)`, `int f_n`, see
//! [`super::filter`]) are gathered the same way: a turn about the spin axis is
//! `cos r I + sin r [k x] + (1 - cos r) k k'`, so the sample rate sums only `cos r`, `sin r`
//! and their products with the force and the rate (14 numbers), and the lower rate puts them
//! together with the de-spun attitude's mean over the interval.

use nalgebra::{Matrix3, RealField, UnitQuaternion, Vector3};

use super::earth::Earth;
use super::real::{Real, normalised, rotation};

mod sweep;

pub use sweep::Swept;
use sweep::{End, Sweep};

/// The largest turn of the de-spun frame within one lower-rate interval, rad: the interval
/// ends when it is reached, so that carrying the forces to second order leaves out at most
/// `MAX_TURN^3 / 6` (2e-5) of them.
pub const MAX_TURN: f64 = 0.05;

/// Where the navigator is: attitude (body to level frame), velocity and position (east,
/// north, up; m/s and m from the origin), as of the end of its last lower-rate interval
/// ([`flush`](Self::flush)).
///
/// The attitude is held as a de-spun attitude and a roll about the body's spin axis
/// (`q = despun * R(axis, roll)`): the roll is the integral of the rate about the axis, the
/// de-spun attitude turns with the rest of the rate seen in the de-spun frame. On a spinning
/// round the transverse rates turn through a revolution every few samples in the body but are
/// slow in the de-spun frame (the nutation and precession), so the coning correction works
/// on slow rates; on a body that does not spin it is the plain quaternion.
#[derive(Debug, Clone, Copy)]
pub struct Navigation<T: RealField + Copy> {
    despun: UnitQuaternion<T>,
    /// The de-spun attitude's rotation matrix, kept with it.
    despun_matrix: Matrix3<T>,
    roll: T,
    /// What the rounding of the roll's sum left out (Kahan).
    roll_carry: T,
    /// Time over which the level frame's turn with the Earth is still to be applied, s.
    earth_pending: T,
    axis: Vector3<T>,
    /// Velocity, m/s.
    pub v: Vector3<T>,
    /// Position, m.
    pub p: Vector3<T>,
    /// What the rounding of each interval's increment of `v` and `p` left out (Kahan's
    /// compensated sum): in `f32` a shell's 800 m/s takes a step's 0.04 m/s to within
    /// 3e-5 m/s, which over a minute at 2 kHz would walk well past the filter's sigma.
    carry: (Vector3<T>, Vector3<T>),
    /// `despun * R(axis, roll)` at the last flush.
    attitude: UnitQuaternion<T>,
    /// The lower rate's interval, s (zero: every step).
    interval: T,
    /// The sample rate's sums since the last flush.
    sweep: Sweep<T>,
    /// The last step's second sample, as the next step starts from it, and how many samples
    /// have been taken (up to two): work saved, not state.
    end: End<T>,
    taken: u8,
    /// The rate across the spin axis in the de-spun frame a sample before `end`'s (the
    /// rates' kink).
    before: Vector3<T>,
    /// The angle the last step could not integrate (1-sigma, rad): see
    /// [`hidden`](Self::hidden).
    hidden: T,
}

/// A step in the rate at an unknown instant of a sample interval hides up to its size times
/// the interval in angle: uniform over the interval, `|step| dt / sqrt(12)` 1-sigma. The
/// second difference of the sampled rates sees a step twice (`+step`, then `-step`), so each
/// counts half: `1 / (2 sqrt(12))`.
const KINK: f64 = 0.144_337_567_297_406_4;

/// Equal where it navigates: the kept attitude and the step's ends are work saved.
impl<T: RealField + Copy> PartialEq for Navigation<T> {
    fn eq(&self, other: &Self) -> bool {
        self.despun == other.despun
            && self.roll == other.roll
            && self.roll_carry == other.roll_carry
            && self.earth_pending == other.earth_pending
            && self.axis == other.axis
            && self.v == other.v
            && self.p == other.p
            && self.carry == other.carry
            && self.interval == other.interval
            && self.sweep == other.sweep
    }
}

/// `sum += x` with Kahan's compensation `carry`, for a scalar.
fn kahan_add<T: RealField + Copy>(sum: &mut T, carry: &mut T, x: T) {
    let y = x - *carry;
    let t = *sum + y;
    *carry = (t - *sum) - y;
    *sum = t;
}

/// `sum += x` with Kahan's compensation `carry`.
fn kahan<T: RealField + Copy>(sum: &mut Vector3<T>, carry: &mut Vector3<T>, x: &Vector3<T>) {
    let y = x - *carry;
    let t = *sum + y;
    *carry = (t - *sum) - y;
    *sum = t;
}

/// One step between two corrected samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step<T: RealField + Copy> {
    /// Rate at the step's start and end, body axes, rad/s.
    pub w: [Vector3<T>; 2],
    /// Specific force at the step's start and end, body axes, m/s^2.
    pub f: [Vector3<T>; 2],
    /// Its length.
    pub dt: Interval<T>,
}

/// A time step as a count of a clock's ticks: `ticks * tick` seconds.
///
/// The roll of a spinning round is integrated as `(w0 + w1) * (ticks / 2) * tick`, so that
/// a step that is a whole number of microseconds carries no rounding of its own: in `f32`,
/// 500 us as seconds is 4.7e-8 off, a roll drift of 9e-5 rad/s at 300 rev/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval<T> {
    /// Ticks of the clock.
    pub ticks: T,
    /// One tick, s.
    pub tick: T,
}

impl<T: RealField + Copy> Interval<T> {
    /// `dt` seconds.
    #[must_use]
    pub fn seconds(dt: T) -> Self {
        Self {
            ticks: dt,
            tick: T::one(),
        }
    }

    /// `us` microseconds.
    #[must_use]
    pub fn micros(us: T) -> Self {
        Self {
            ticks: us,
            tick: nalgebra::convert(1e-6),
        }
    }

    /// In seconds.
    #[must_use]
    pub fn seconds_of(&self) -> T {
        self.ticks * self.tick
    }
}

/// The rotation vector of a step whose rate goes linearly from `w0` to `w1` over `dt`: the
/// trapezoid and the two-sample coning term (Bortz's equation to second order).
#[must_use]
pub fn rotation_vector<T: RealField + Copy>(w0: &Vector3<T>, w1: &Vector3<T>, dt: T) -> Vector3<T> {
    let half: T = nalgebra::convert(0.5);
    let twelfth: T = nalgebra::convert(1.0 / 12.0);
    (w0 + w1) * (half * dt) + w0.cross(w1) * (twelfth * dt * dt)
}

impl<T: Real> Navigation<T> {
    /// At rest at the origin with attitude `q`, spinning (if at all) about the body axis
    /// `axis` (normalised here; a zero axis means the body x axis); the attitude, velocity and
    /// position stepped with every sample ([`with_interval`](Self::with_interval) sets a
    /// lower rate).
    #[must_use]
    pub fn at_rest(q: UnitQuaternion<T>, axis: Vector3<T>) -> Self {
        let axis = axis
            .try_normalize(T::default_epsilon())
            .unwrap_or_else(Vector3::x);
        let mut nav = Self {
            despun: q,
            despun_matrix: Matrix3::identity(),
            roll: T::zero(),
            roll_carry: T::zero(),
            earth_pending: T::zero(),
            axis,
            v: Vector3::zeros(),
            p: Vector3::zeros(),
            carry: (Vector3::zeros(), Vector3::zeros()),
            attitude: q,
            interval: T::zero(),
            sweep: Sweep::empty(),
            end: End::at(
                &Vector3::zeros(),
                &Vector3::zeros(),
                &axis,
                (T::zero(), T::one()),
                &Vector3::zeros(),
                T::zero(),
            ),
            taken: 0,
            before: Vector3::zeros(),
            hidden: T::zero(),
        };
        nav.keep_attitude();
        nav
    }

    /// This navigation with its attitude, velocity and position stepped every `seconds`
    /// (or sooner, when the de-spun frame has turned by [`MAX_TURN`]), the samples between
    /// gathered at their own rate; zero: every step.
    #[must_use]
    pub fn with_interval(mut self, seconds: T) -> Self {
        self.interval = seconds;
        self
    }

    /// Keeps the de-spun attitude's matrix and the attitude with `despun` and the roll.
    fn keep_attitude(&mut self) {
        self.despun_matrix = self.despun.to_rotation_matrix().into_inner();
        self.attitude = self.despun * rotation(&(self.axis * self.roll));
    }

    /// The attitude, body to level frame (at the last flush).
    #[must_use]
    pub fn attitude(&self) -> UnitQuaternion<T> {
        self.attitude
    }

    /// The attitude with the level frame's turn with the Earth that is still gathering
    /// applied ([`attitude`](Self::attitude) lags it by at most 1e-5 rad).
    #[must_use]
    pub fn settled_attitude(&self, earth: &Earth<T>) -> UnitQuaternion<T> {
        rotation(&(earth.rate() * (-self.earth_pending))) * self.attitude()
    }

    /// Turns the attitude by `r` in the level frame (`q <- r q`): the samples gathered since
    /// the last flush are carried from the turned frame.
    pub fn turn(&mut self, r: &UnitQuaternion<T>) {
        self.despun = r * self.despun;
        self.keep_attitude();
    }

    /// The angle the last step could not integrate, 1-sigma (rad). The steps take the rate
    /// as linear between two samples, exact for a ramp however steep; where the de-spun rate
    /// kinks or steps between samples (the transverse rate a round takes at the muzzle, in
    /// one instant) the step cannot know when, and that many radians of attitude are not
    /// known: the second difference of the last three de-spun rates times the interval
    /// times `1 / (2 sqrt(12))`. The filter adds it to the attitude's variance. Zero while the
    /// rates are smooth to the sample rate.
    #[must_use]
    pub fn hidden(&self) -> T {
        self.hidden
    }

    /// Time gathered at the sample rate since the last flush, s.
    #[must_use]
    pub fn pending(&self) -> T {
        self.sweep.dt
    }

    /// Advances by one step over `earth`. When the step ends a lower-rate interval, the
    /// attitude, velocity and position are stepped ([`flush`](Self::flush)) and the
    /// interval's error-model integrals returned.
    pub fn propagate(&mut self, earth: &Earth<T>, step: &Step<T>) -> Option<Swept<T>> {
        let half: T = nalgebra::convert(0.5);
        let two: T = nalgebra::convert(2.0);
        let dt = step.dt.seconds_of();
        let [w0, w1] = step.w;
        let [f0, f1] = step.f;
        if self.taken == 0 || self.end.w != w0 || self.end.f != f0 {
            self.restart(&w0, &f0, dt);
        }
        // The roll by Kahan's compensated sum: a step adds about 1 rad at 300 rev/s, and in
        // f32 the plain sum's rounding would drift it by 5e-5 rad/s.
        let increment =
            ((self.axis.dot(&w0) + self.axis.dot(&w1)) * (half * step.dt.ticks)) * step.dt.tick;
        let mut roll = self.roll;
        kahan_add(&mut roll, &mut self.roll_carry, increment);
        let pi = T::pi();
        if roll > pi || roll < -pi {
            // 2 pi in two parts (Cody and Waite): in f32 the rounded 2 pi is 1.7e-7 off; the
            // first part times a small whole number is exact.
            let turns = (roll / T::two_pi()).round();
            let high: T = nalgebra::convert(6.281_25);
            let low: T = nalgebra::convert(core::f64::consts::TAU - 6.281_25);
            roll -= turns * high;
            kahan_add(&mut roll, &mut self.roll_carry, -(turns * low));
        }
        self.roll = roll;
        let mut end = End::at(
            &w1,
            &f1,
            &self.axis,
            roll.sin_cos_libm(),
            &self.sweep.phi,
            dt,
        );
        self.hidden = if self.taken >= 2 {
            let kink = end.rate - self.end.rate * two + self.before;
            kink.norm_squared().sqrt_libm() * dt * nalgebra::convert::<f64, T>(KINK)
        } else {
            T::zero()
        };
        self.sweep.step(&self.end, &mut end);
        self.before = self.end.rate;
        self.end = end;
        self.taken = 2;
        let most: T = nalgebra::convert(MAX_TURN * MAX_TURN);
        if self.sweep.dt >= self.interval || self.sweep.phi.norm_squared() >= most {
            self.flush(earth)
        } else {
            None
        }
    }

    /// Starts afresh from the sample `(w, f)`: not where the last step ended.
    #[cold]
    fn restart(&mut self, w: &Vector3<T>, f: &Vector3<T>, dt: T) {
        self.end = End::at(
            w,
            f,
            &self.axis,
            self.roll.sin_cos_libm(),
            &self.sweep.phi,
            dt,
        );
        if self.sweep.dt <= T::zero() {
            self.sweep = Sweep::open(&self.end);
        }
        self.taken = 1;
    }

    /// Ends the lower-rate interval now: the de-spun attitude turned by what the samples
    /// gathered, the velocity and position stepped with gravity and the Coriolis term over it;
    /// returns the interval's error-model integrals (`None` when nothing was gathered).
    pub fn flush(&mut self, earth: &Earth<T>) -> Option<Swept<T>> {
        let mut s = self.sweep;
        if s.dt <= T::zero() {
            return None;
        }
        s.close(&self.end);
        self.end.carried = self.end.force;
        self.sweep = Sweep::open(&self.end);
        let half: T = nalgebra::convert(0.5);
        let two: T = nalgebra::convert(2.0);
        let t = s.dt;
        let omega = earth.rate();
        let start = self.despun_matrix;
        // The forces were felt while the level frame's turn with the Earth was `lag` behind
        // (at the interval's middle): turned back by it to first order.
        let lag = omega * (self.earth_pending + half * t);
        // The level frame turns with the Earth by 3.6e-8 rad in a 0.5 ms step, under the
        // resolution of an f32 quaternion (6e-8): the turn is gathered and applied once it
        // reaches 1e-5 rad (every 0.14 s; the attitude lags it by at most that).
        self.earth_pending += t;
        let turn = omega * self.earth_pending;
        let body = rotation(&s.phi);
        let despun = if turn.norm_squared() >= nalgebra::convert(1e-10) {
            self.earth_pending = T::zero();
            rotation(&(-turn)) * self.despun * body
        } else {
            self.despun * body
        };
        // Renormalised every interval: in f32 the rounding of a product of unit quaternions
        // would otherwise walk the norm away over a flight's 10^5 steps.
        self.despun = normalised(despun.into_inner());
        self.keep_attitude();
        let level = start * s.dv;
        let level = level - lag.cross(&level);
        let moved = start * s.dp;
        let moved = moved - lag.cross(&moved);
        let mid = self.p + self.v * (half * t);
        let g = earth.gravity(&mid);
        let coriolis = omega.cross(&(self.v + (level + g * t) * half)) * two;
        let free = g - coriolis;
        let v0 = self.v;
        let dv = level + free * t;
        kahan(&mut self.v, &mut self.carry.0, &dv);
        let dp = v0 * t + moved + free * (half * t * t);
        kahan(&mut self.p, &mut self.carry.1, &dp);
        let mean = (start + self.despun_matrix) * half;
        Some(s.swept(&mean, &self.axis, level))
    }
}

#[cfg(test)]
mod tests;
