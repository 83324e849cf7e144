//! Strapdown navigation for high rates: attitude by quaternion from the rotation vector of
//! each step with the two-sample coning correction, velocity and position in the local level
//! frame of [`Earth`] with gravity and the Coriolis term.
//!
//! The inputs are corrected samples (rates and specific forces at instants, as the corrector
//! gives them), not the integrated increments of a navigation-grade IMU. Between two samples
//! the rate is taken as linear: the rotation vector of the step is the trapezoid of the rates
//! plus the coning term `w0 x w1 dt^2 / 12` (Bortz's equation to second order), exact for a
//! constant axis however fast the spin (a round at 300 rev/s turns 0.94 rad per sample at
//! 2 kHz). Each specific force is carried into the level frame by the attitude at its own
//! instant and the level-frame force is integrated by the trapezoid: the rotation of the
//! force within the step, which sculling corrects when increments are held at the step's
//! start, is followed by the attitude itself.

use nalgebra::{Matrix3, RealField, UnitQuaternion, Vector3};

use super::earth::Earth;
use super::real::{Real, normalised, rotation};

/// Where the navigator is: attitude (body to level frame), velocity and position (east,
/// north, up; m/s and m from the origin).
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
    roll: T,
    /// What the rounding of the roll's sum left out (Kahan).
    roll_carry: T,
    /// Time over which the level frame's turn with the Earth is still to be applied, s.
    earth_pending: T,
    /// The rotation by `roll` about `axis`, kept with it.
    spin: UnitQuaternion<T>,
    axis: Vector3<T>,
    /// Velocity, m/s.
    pub v: Vector3<T>,
    /// Position, m.
    pub p: Vector3<T>,
    /// What the rounding of each step's increment of `v` and `p` left out (Kahan's
    /// compensated sum): in `f32` a shell's 800 m/s takes a step's 0.04 m/s to within
    /// 3e-5 m/s, which over a minute at 2 kHz would walk well past the filter's sigma.
    carry: (Vector3<T>, Vector3<T>),
    /// `despun * spin` and its rotation matrix, kept with them: the attitude every sample
    /// reads several times.
    attitude: UnitQuaternion<T>,
    matrix: Matrix3<T>,
    /// The last step's second rate, its de-spun part and the de-spun rate a sample before:
    /// the next step's first rate when it starts where this one ended (same reading; the
    /// de-spun part depends on the roll alone), and the rates' kink ([`hidden`](Self::hidden)).
    rate_end: Option<RateEnd<T>>,
    /// The last step's second specific force and that force in the level frame, while the
    /// attitude has not been turned since. Work saved, not state.
    force_end: Option<(Vector3<T>, Vector3<T>)>,
    /// The angle the last step could not integrate (1-sigma, rad): see
    /// [`hidden`](Self::hidden).
    hidden: T,
}

/// What a step's end rate gives the next step ([`Navigation::propagate`]).
#[derive(Debug, Clone, Copy)]
struct RateEnd<T: RealField + Copy> {
    w: Vector3<T>,
    despun_rate: Vector3<T>,
    before: Vector3<T>,
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
            && self.spin == other.spin
            && self.axis == other.axis
            && self.v == other.v
            && self.p == other.p
            && self.carry == other.carry
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
    /// `axis` (normalised here; a zero axis means the body x axis).
    #[must_use]
    pub fn at_rest(q: UnitQuaternion<T>, axis: Vector3<T>) -> Self {
        let axis = axis
            .try_normalize(T::default_epsilon())
            .unwrap_or_else(Vector3::x);
        let mut nav = Self {
            despun: q,
            roll: T::zero(),
            roll_carry: T::zero(),
            earth_pending: T::zero(),
            spin: UnitQuaternion::identity(),
            axis,
            v: Vector3::zeros(),
            p: Vector3::zeros(),
            carry: (Vector3::zeros(), Vector3::zeros()),
            attitude: q,
            matrix: Matrix3::identity(),
            rate_end: None,
            force_end: None,
            hidden: T::zero(),
        };
        nav.keep_attitude();
        nav
    }

    /// Keeps the attitude and its matrix with `despun` and `spin`.
    fn keep_attitude(&mut self) {
        self.attitude = self.despun * self.spin;
        self.matrix = self.attitude.to_rotation_matrix().into_inner();
    }

    /// The attitude's rotation matrix, body to level frame.
    #[must_use]
    pub fn attitude_matrix(&self) -> Matrix3<T> {
        self.matrix
    }

    /// The attitude, body to level frame.
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

    /// Turns the attitude by `r` in the level frame (`q <- r q`).
    pub fn turn(&mut self, r: &UnitQuaternion<T>) {
        self.despun = r * self.despun;
        self.keep_attitude();
        self.force_end = None;
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

    /// The rate `w` without its part about the spin axis, seen in the de-spun frame at the
    /// roll whose rotation is `spin`.
    fn despun_rate(&self, w: &Vector3<T>, spin: &UnitQuaternion<T>) -> Vector3<T> {
        let across = w - self.axis * self.axis.dot(w);
        spin * across
    }

    /// Advances by one step over `earth`; returns the specific force of the step's two ends in
    /// the level frame (what the error model integrates).
    pub fn propagate(&mut self, earth: &Earth<T>, step: &Step<T>) -> [Vector3<T>; 2] {
        let half: T = nalgebra::convert(0.5);
        let two: T = nalgebra::convert(2.0);
        let dt = step.dt.seconds_of();
        let omega = earth.rate();
        let before = self.attitude();
        let lag0 = omega * self.earth_pending;
        let [w0, w1] = step.w;
        // The roll by Kahan's compensated sum: a step adds about 1 rad at 300 rev/s, and in
        // f32 the plain sum's rounding would drift it by 5e-5 rad/s.
        let increment =
            ((self.axis.dot(&w0) + self.axis.dot(&w1)) * (half * step.dt.ticks)) * step.dt.tick;
        let mut roll1 = self.roll;
        kahan_add(&mut roll1, &mut self.roll_carry, increment);
        let pi = T::pi();
        if roll1 > pi || roll1 < -pi {
            // 2 pi in two parts (Cody and Waite): in f32 the rounded 2 pi is 1.7e-7 off; the
            // first part times a small whole number is exact.
            let turns = (roll1 / T::two_pi()).round();
            let high: T = nalgebra::convert(6.281_25);
            let low: T = nalgebra::convert(core::f64::consts::TAU - 6.281_25);
            roll1 -= turns * high;
            kahan_add(&mut roll1, &mut self.roll_carry, -(turns * low));
        }
        let spin1 = rotation(&(self.axis * roll1));
        let rate_end = self.rate_end.take().filter(|e| e.w == w0);
        let d0 = match rate_end {
            Some(e) => e.despun_rate,
            None => self.despun_rate(&w0, &self.spin),
        };
        let d1 = self.despun_rate(&w1, &spin1);
        self.hidden = match rate_end {
            Some(e) => (d1 - d0 * two + e.before).norm() * dt * nalgebra::convert::<f64, T>(KINK),
            None => T::zero(),
        };
        self.rate_end = Some(RateEnd {
            w: w1,
            despun_rate: d1,
            before: d0,
        });
        let body = rotation(&rotation_vector(&d0, &d1, dt));
        // The level frame turns with the Earth by 3.6e-8 rad in a 0.5 ms step, under the
        // resolution of an f32 quaternion (6e-8): the turn is gathered and applied once it
        // reaches 1e-5 rad (every 0.14 s; the attitude lags it by at most that, and the
        // specific force is turned by the lag to first order, 5e-11 off).
        self.earth_pending += dt;
        let turn = omega * self.earth_pending;
        let despun = if turn.norm_squared() >= nalgebra::convert(1e-10) {
            self.earth_pending = T::zero();
            rotation(&(-turn)) * self.despun * body
        } else {
            self.despun * body
        };
        // Renormalised every step: in f32 the rounding of a product of unit quaternions
        // would otherwise walk the norm away over a flight's 10^5 steps.
        self.despun = normalised(despun.into_inner());
        self.roll = roll1;
        self.spin = spin1;
        self.keep_attitude();
        let after = self.attitude;
        let lag1 = omega * self.earth_pending;
        let [f0, f1] = step.f;
        let b0 = match self.force_end.take() {
            Some((f, level)) if f == f0 => level,
            _ => before * f0,
        };
        let b1 = after * f1;
        self.force_end = Some((f1, b1));
        let forces = [b0 - lag0.cross(&b0), b1 - lag1.cross(&b1)];
        let [n0, n1] = forces;
        let mid = self.p + self.v * (half * dt);
        let g = earth.gravity(&mid);
        let coriolis = omega.cross(&(self.v + (n0 + g) * (half * dt))) * two;
        let v0 = self.v;
        let dv = ((n0 + n1) * half + g - coriolis) * dt;
        kahan(&mut self.v, &mut self.carry.0, &dv);
        let dp = (v0 + self.v) * (half * dt);
        kahan(&mut self.p, &mut self.carry.1, &dp);
        forces
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn earth() -> Earth<f64> {
        Earth::new(0.6, 0.0)
    }

    #[test]
    fn a_unit_at_rest_stays_at_rest_when_it_feels_gravity_and_the_earth_rate() {
        let e = earth();
        let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        let mut nav = Navigation::at_rest(q, Vector3::x());
        let f = q.inverse() * (-e.gravity(&Vector3::zeros()));
        let w = q.inverse() * e.rate();
        let step = Step {
            w: [w; 2],
            f: [f; 2],
            dt: Interval::seconds(0.01),
        };
        for _ in 0..6000 {
            nav.propagate(&e, &step);
        }
        // Sixty seconds: the vertical channel's instability and second-order terms only.
        assert!(
            nav.p.norm() < 1e-3 && nav.v.norm() < 1e-4,
            "{:?} {:?}",
            nav.p,
            nav.v
        );
        assert!(nav.settled_attitude(&e).angle_to(&q) < 1e-9);
    }

    #[test]
    fn coning_motion_is_followed_at_high_spin() {
        // A body spinning at 1885 rad/s (300 rev/s) about its x axis while that axis cones at
        // 5 rad/s about the level x axis, half-angle 0.05 rad: attitude after one second,
        // sampled at 2 kHz, against the closed form.
        let (spin, cone, half_angle) = (1885.0_f64, 5.0_f64, 0.05_f64);
        let truth = |t: f64| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), cone * t)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), half_angle)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t)
        };
        // Body rate of that motion: the spin and the cone's rate seen in body axes.
        let rate = |t: f64| {
            let q = truth(t);
            q.inverse() * (Vector3::x() * cone)
                + UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t).inverse()
                    * (Vector3::x() * (spin - cone))
        };
        let dt = 1.0 / 2000.0;
        let e = Earth::new(0.0, 0.0);
        // The closed form turns against the level frame: the gyros also feel the Earth's rate.
        let mut with = Navigation::at_rest(truth(0.0), Vector3::x());
        let mut plain = truth(0.0);
        for k in 0..2000 {
            let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
            let earth_rate = |t: f64| truth(t).inverse() * e.rate();
            let w = [rate(t0) + earth_rate(t0), rate(t1) + earth_rate(t1)];
            let f = [Vector3::zeros(); 2];
            with.propagate(
                &e,
                &Step {
                    w,
                    f,
                    dt: Interval::seconds(dt),
                },
            );
            let theta = (w[0] + w[1]) * (dt / 2.0);
            plain = UnitQuaternion::from_scaled_axis(e.rate() * -dt)
                * plain
                * UnitQuaternion::from_scaled_axis(theta);
        }
        let err_with = with.settled_attitude(&e).angle_to(&truth(1.0));
        let err_without = plain.angle_to(&truth(1.0));
        assert!(
            err_with < 1e-6,
            "de-spun with the coning term: {err_with} rad, plain {err_without}"
        );
        assert!(err_without > 10.0 * err_with, "{err_without} vs {err_with}");
    }
}
