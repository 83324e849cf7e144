//! The error-state Kalman filter: the navigation's errors (position, velocity, attitude) and
//! the corrected samples' residual sensor errors (per axis the accelerometer's and the gyro's
//! bias and scale factor), the barometer's bias and the GNSS receiver's correlated position
//! error, 25 states, propagated with the navigation and corrected by scalar measurements
//! (GNSS position and velocity, barometric height), fed back into the navigation after each
//! group of updates.
//!
//! A receiver's position error is not white: most of it is a slow wander (the satellites'
//! geometry, the atmosphere's delays) over tens of seconds, as long as a shell's flight. Taken
//! as white, ten fixes a second average it away and the filter believes its track to a
//! fraction of the wander. It is carried as three first-order Gauss-Markov states
//! ([`NavNoise::receiver_sigma`], [`NavNoise::receiver_tau`]); at zero sigma they stay zero and
//! change nothing.
//!
//! Errors are true minus estimated; the attitude error `psi` is the small rotation, in the
//! level frame, from the estimated attitude to the true one (`C = (I + [psi x]) C_hat`). A
//! corrected sample holds `f_meas = (1 + s_a) f + b_a` per axis (the gyro alike), which the
//! filter compensates with its estimates before navigating.
//!
//! The covariance is not propagated per sample: a round sampled at 2 kHz and spinning at
//! 300 rev/s turns its transverse errors through a revolution in seven samples. The
//! navigation gathers, per sample, what the error model needs (`int C`, `int C diag(f)`,
//! `int C diag(w)`, `int f_n`; [`Swept`], from the roll's sine and cosine at the sample rate and
//! the de-spun attitude at the lower rate, see [`super::strapdown`]) and the filter steps the
//! covariance with them over the interval (`Phi = I + F dt + (F dt)^2 / 2` with `F` the
//! interval's mean), so what the spin averages out is averaged exactly and the cost is a few
//! 22 x 22 products per interval.

use nalgebra::{Matrix3, RealField, SMatrix, SVector, Vector3};

use super::earth::Earth;
use super::real::Real;
use super::strapdown::{Interval, Navigation, Step, Swept};

pub use super::estimate::{Estimate, SensorErrors};

mod rows;
mod step;

/// The number of error states.
pub const STATES: usize = 25;

/// Where each error state block starts.
pub mod index {
    /// Position error, m (east, north, up).
    pub const POSITION: usize = 0;
    /// Velocity error, m/s.
    pub const VELOCITY: usize = 3;
    /// Attitude error, rad (level frame).
    pub const ATTITUDE: usize = 6;
    /// Accelerometer biases, m/s^2 (body axes).
    pub const ACCEL_BIAS: usize = 9;
    /// Gyro biases, rad/s.
    pub const GYRO_BIAS: usize = 12;
    /// Accelerometer scale factors (relative).
    pub const ACCEL_SCALE: usize = 15;
    /// Gyro scale factors (relative).
    pub const GYRO_SCALE: usize = 18;
    /// The barometer's height bias, m.
    pub const BARO: usize = 21;
    /// The GNSS receiver's correlated position error, m (east, north, up).
    pub const RECEIVER: usize = 22;
}

/// A square matrix over the error states.
pub type StateMatrix<T> = SMatrix<T, STATES, STATES>;

/// The navigation's error states (position, velocity, attitude): the rows of the error model
/// that are not zero.
pub const NAV: usize = 9;

/// The navigation's rows of a matrix over the error states.
pub type NavRows<T> = SMatrix<T, NAV, STATES>;

/// The transition of the errors over one covariance step: the identity but for its first
/// [`NAV`] rows and the receiver's error, which decays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition<T: RealField + Copy> {
    /// The first [`NAV`] rows.
    pub top: NavRows<T>,
    /// The receiver error's decay over the step, `exp(-dt / tau)` (1 without one).
    pub receiver_decay: T,
}

impl<T: RealField + Copy> Transition<T> {
    /// The whole matrix.
    #[must_use]
    pub fn matrix(&self) -> StateMatrix<T> {
        let mut phi = StateMatrix::identity();
        phi.fixed_rows_mut::<NAV>(0).copy_from(&self.top);
        for i in index::RECEIVER..index::RECEIVER + 3 {
            if let Some(x) = phi.get_mut((i, i)) {
                *x = self.receiver_decay;
            }
        }
        phi
    }
}
/// A vector over the error states.
pub type StateVector<T> = SVector<T, STATES>;

/// The noise that drives the errors between measurements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavNoise<T> {
    /// The accelerometers' white-noise density, m/s^2/sqrt(Hz) (velocity random walk).
    pub accel_white: T,
    /// The gyros' white-noise density, rad/s/sqrt(Hz) (angle random walk).
    pub gyro_white: T,
    /// The accelerometer biases' random walk, m/s^2/sqrt(s).
    pub accel_walk: T,
    /// The gyro biases' random walk, rad/s/sqrt(s).
    pub gyro_walk: T,
    /// The scale factors' random walk, 1/sqrt(s).
    pub scale_walk: T,
    /// The barometer bias's random walk, m/sqrt(s) (the weather and the air's temperature
    /// against the standard atmosphere's).
    pub baro_walk: T,
    /// The GNSS receiver's correlated position error, 1-sigma (east, north, up, m): its
    /// stationary spread, which fixes cannot average away within
    /// [`receiver_tau`](Self::receiver_tau). Zero for a receiver whose error is white.
    pub receiver_sigma: Vector3<T>,
    /// The receiver error's time constant, s (not positive: constant over the flight).
    pub receiver_tau: T,
}

impl<T: Real> NavNoise<T> {
    /// `exp(-dt / tau)`: what is left of the receiver's error after `dt` s.
    fn receiver_decay(&self, dt: T) -> T {
        if self.receiver_tau > T::zero() {
            (-dt / self.receiver_tau).exp_libm()
        } else {
            T::one()
        }
    }
}

/// The prior of the errors: the covariance at the start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior<T: RealField + Copy> {
    /// The covariance over the error states.
    pub covariance: StateMatrix<T>,
}

/// One scalar measurement's innovation and its variance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation<T> {
    /// Measured minus predicted.
    pub value: T,
    /// Its predicted variance (`h' P h + r`).
    pub variance: T,
}

/// What the error model integrates between covariance steps.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Integrals<T: RealField + Copy> {
    c: Matrix3<T>,
    cf: Matrix3<T>,
    cw: Matrix3<T>,
    f: Vector3<T>,
    dt: T,
    /// Standard deviations of what flagged samples may have hidden, summed over them:
    /// velocity (m/s) and angle (rad).
    lost: (T, T),
}

impl<T: RealField + Copy> Integrals<T> {
    /// Adds one of the navigation's lower-rate intervals.
    fn add(&mut self, s: &Swept<T>) {
        self.c += s.c;
        self.cf += s.cf;
        self.cw += s.cw;
        self.f += s.f;
        self.dt += s.dt;
    }

    fn zero() -> Self {
        Self {
            c: Matrix3::zeros(),
            cf: Matrix3::zeros(),
            cw: Matrix3::zeros(),
            f: Vector3::zeros(),
            dt: T::zero(),
            lost: (T::zero(), T::zero()),
        }
    }
}

/// A sample the corrector could not vouch for: the specific force and rate that may hide
/// behind it (1-sigma, m/s^2 and rad/s; zero for a sensor whose reading is good), over which
/// the filter widens its covariance, and which readings are replaced by their last trusted
/// ones. A reading widened but not replaced is navigated as read: a round's gyros keep
/// counting its spin while setback saturates the accelerometers their g-sensitivity is
/// corrected with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Doubt<T> {
    /// Specific force, m/s^2.
    pub force: T,
    /// Rate, rad/s.
    pub rate: T,
    /// Whether the accelerometer's and the gyro's readings are replaced by their last
    /// trusted ones.
    pub replaced: [bool; 2],
}

impl<T: Real> Doubt<T> {
    /// The doubt of a sample whose accelerometer and gyro are in doubt as `doubted` says
    /// ([`crate::flight::doubted`]), what may hide behind a doubted reading being `force` and
    /// `rate`: a doubted reading is replaced and widened by its own; a gyro read beside a
    /// doubted accelerometer is widened by `rate` too (its g-sensitivity was corrected with
    /// the doubted force).
    #[must_use]
    pub fn of(doubted: [bool; 2], force: T, rate: T) -> Self {
        Self {
            force: if doubted[0] { force } else { T::zero() },
            rate: if doubted[0] || doubted[1] {
                rate
            } else {
                T::zero()
            },
            replaced: doubted,
        }
    }
}

/// The filter.
#[derive(Debug, Clone)]
pub struct ErrorFilter<T: RealField + Copy> {
    /// The estimate (navigation and sensor errors) after the last feedback.
    pub estimate: Estimate<T>,
    /// The error covariance.
    pub covariance: StateMatrix<T>,
    /// The launch point.
    pub earth: Earth<T>,
    /// The process noise.
    pub noise: NavNoise<T>,
    dx: StateVector<T>,
    acc: Integrals<T>,
    /// The error model's velocity rows over the last covariance step (`d dv / dt` as a row
    /// over the errors): what a late fix's velocity and position are compared through.
    velocity_rates: SMatrix<T, 3, STATES>,
    /// The last sample, compensated: rate and specific force.
    last: Option<(Vector3<T>, Vector3<T>)>,
}

/// `p <- (p + p') / 2`.
fn symmetrise<T: RealField + Copy>(p: &mut StateMatrix<T>) {
    let half: T = nalgebra::convert(0.5);
    for j in 1..STATES {
        for i in 0..j {
            if let (Some(x), Some(y)) = (p.get((i, j)).copied(), p.get((j, i)).copied()) {
                let m = (x + y) * half;
                if let Some(v) = p.get_mut((i, j)) {
                    *v = m;
                }
                if let Some(v) = p.get_mut((j, i)) {
                    *v = m;
                }
            }
        }
    }
}

fn skew<T: RealField + Copy>(v: &Vector3<T>) -> Matrix3<T> {
    v.cross_matrix()
}

impl<T: Real> ErrorFilter<T> {
    /// A filter from an estimate, its prior covariance, the launch point and the noise.
    #[must_use]
    pub fn new(
        estimate: Estimate<T>,
        prior: &Prior<T>,
        earth: Earth<T>,
        noise: NavNoise<T>,
    ) -> Self {
        Self {
            estimate,
            covariance: prior.covariance,
            earth,
            noise,
            dx: StateVector::zeros(),
            acc: Integrals::zero(),
            velocity_rates: SMatrix::zeros(),
            last: None,
        }
    }

    /// Time integrated since the last covariance step, s.
    #[must_use]
    pub fn pending(&self) -> T {
        self.acc.dt + self.estimate.nav.pending()
    }

    /// Navigates one corrected sample `dt` s after the previous one. A sample with a
    /// [`Doubt`] is not navigated as read: the last trusted one stands in for it and the
    /// covariance widens by what it may hide.
    pub fn sample(
        &mut self,
        f: &Vector3<T>,
        w: &Vector3<T>,
        step: Interval<T>,
        doubt: Option<Doubt<T>>,
    ) {
        let dt = step.seconds_of();
        let (mut fc, mut wc) = self.estimate.sensors.compensate(f, w);
        if let (Some(d), Some((w0, f0))) = (doubt, self.last) {
            if d.replaced[0] {
                fc = f0;
            }
            if d.replaced[1] {
                wc = w0;
            }
        }
        let Some((w0, f0)) = self.last.replace((wc, fc)) else {
            return;
        };
        if dt <= T::zero() {
            return;
        }
        let swept = self.estimate.nav.propagate(
            &self.earth,
            &Step {
                w: [w0, wc],
                f: [f0, fc],
                dt: step,
            },
        );
        let a = &mut self.acc;
        if let Some(s) = swept {
            a.add(&s);
        }
        if let Some(d) = doubt {
            a.lost.0 += d.force * dt;
            a.lost.1 += d.rate * dt;
        }
        a.lost.1 += self.estimate.nav.hidden();
    }

    /// The navigation carried through further samples, the filter left as it is: each
    /// compensated by the sensor errors as estimated, a doubted reading replaced by the last
    /// trusted one as [`sample`](Self::sample) does. What a filter run on a delayed horizon
    /// gives as the navigation now.
    #[must_use]
    pub fn carried<I>(&self, samples: I) -> Navigation<T>
    where
        I: IntoIterator<Item = (Vector3<T>, Vector3<T>, Interval<T>, [bool; 2])>,
    {
        let mut nav = self.estimate.nav;
        let mut last = self.last;
        for (f, w, step, doubted) in samples {
            let (mut fc, mut wc) = self.estimate.sensors.compensate(&f, &w);
            if let Some((w0, f0)) = last {
                if doubted[0] {
                    fc = f0;
                }
                if doubted[1] {
                    wc = w0;
                }
            }
            let Some((w0, f0)) = last.replace((wc, fc)) else {
                continue;
            };
            if step.seconds_of() > T::zero() {
                let _ = nav.propagate(
                    &self.earth,
                    &Step {
                        w: [w0, wc],
                        f: [f0, fc],
                        dt: step,
                    },
                );
            }
        }
        let _ = nav.flush(&self.earth);
        nav
    }

    /// What a scalar measurement's innovation would be, without taking it (to gate it):
    /// `innovation` less what the pending errors already explain, and its variance.
    #[must_use]
    pub fn innovation(&self, h: &StateVector<T>, innovation: T, variance: T) -> Innovation<T> {
        Innovation {
            value: innovation - h.dot(&self.dx),
            variance: h.dot(&(self.covariance * h)) + variance,
        }
    }

    /// One scalar measurement: `h` its sensitivity to the errors, `innovation` the measured
    /// minus the value predicted from the estimate (before [`feedback`](Self::feedback)),
    /// `variance` the measurement's own. `None` when its predicted variance is not positive
    /// (nothing changes).
    pub fn update(
        &mut self,
        h: &StateVector<T>,
        innovation: T,
        variance: T,
    ) -> Option<Innovation<T>> {
        let nu = innovation - h.dot(&self.dx);
        // P h over the sensitivity's few non-zero entries.
        let mut u = StateVector::<T>::zeros();
        for (j, hj) in h.iter().enumerate() {
            if *hj != T::zero() {
                u.axpy(*hj, &self.covariance.column(j), T::one());
            }
        }
        let s = h.dot(&u) + variance;
        if s <= T::zero() || !s.is_finite() || !nu.is_finite() {
            return None;
        }
        let k = u / s;
        self.dx += k * nu;
        // Joseph's form, (I - k h') P (I - k h')' + r k k', as two rank-one steps: A = P - k u'
        // (u = P h), then A - (A h) k' + r k k' with A h taken from the rounded A, so that the
        // second step corrects the first's rounding. Expanded into one step it would lose a
        // variance that falls by six orders of magnitude (a fix after the setback's doubt) to
        // the rounding of f32.
        let (ks, us) = (k.as_slice(), u.as_slice());
        for (column, uj) in self
            .covariance
            .as_mut_slice()
            .chunks_exact_mut(STATES)
            .zip(us)
        {
            for (x, ki) in column.iter_mut().zip(ks) {
                *x -= *ki * *uj;
            }
        }
        let mut ah = StateVector::<T>::zeros();
        for (j, hj) in h.iter().enumerate() {
            if *hj != T::zero() {
                ah.axpy(*hj, &self.covariance.column(j), T::one());
            }
        }
        let ahs = ah.as_slice();
        for ((column, kj), _) in self
            .covariance
            .as_mut_slice()
            .chunks_exact_mut(STATES)
            .zip(ks)
            .zip(us)
        {
            for ((x, ki), ai) in column.iter_mut().zip(ks).zip(ahs) {
                *x = *x - *ai * *kj + variance * (*ki * *kj);
            }
        }
        symmetrise(&mut self.covariance);
        Some(Innovation {
            value: nu,
            variance: s,
        })
    }

    /// Whether the navigation has lost track: a velocity 1-sigma above `sigma` (m/s) on any
    /// axis, as a saturated setback leaves it (then a fix puts it back,
    /// [`reset_position_velocity`](Self::reset_position_velocity)).
    pub fn velocity_lost(&self, sigma: T) -> bool {
        let lost = sigma * sigma;
        (index::VELOCITY..index::VELOCITY + 3)
            .any(|i| self.covariance.get((i, i)).is_some_and(|var| *var > lost))
    }

    /// Puts the navigation at position `p` and velocity `v` with the variances `variances`
    /// (position then velocity, each axis), independent of every other error: for a first
    /// fix after the navigation lost track (a saturated setback), where the update would ask
    /// the covariance to fall by more orders of magnitude than `f32` holds.
    ///
    /// `p` is a fix's position (the antenna's, carried to the unit): the receiver's estimated
    /// error is taken out of it, and what is not known of that error stays in the position's
    /// variance, shared with the receiver's state (`p = z - e_hat`: the position's error is
    /// the fix's white error less the receiver error's).
    pub fn reset_position_velocity(&mut self, p: &Vector3<T>, v: &Vector3<T>, variances: [T; 6]) {
        self.estimate.nav.p = *p - self.estimate.receiver;
        self.estimate.nav.v = *v;
        for (i, var) in variances.iter().enumerate() {
            if let Some(x) = self.dx.get_mut(i) {
                *x = T::zero();
            }
            for j in 0..STATES {
                let value = if i == j { *var } else { T::zero() };
                if let Some(x) = self.covariance.get_mut((i, j)) {
                    *x = value;
                }
                if let Some(x) = self.covariance.get_mut((j, i)) {
                    *x = value;
                }
            }
        }
        for axis in 0..3 {
            let (p, r) = (index::POSITION + axis, index::RECEIVER + axis);
            let known = self.covariance.get((r, r)).copied().unwrap_or_else(T::zero);
            if let Some(x) = self.covariance.get_mut((p, p)) {
                *x += known;
            }
            for (i, j) in [(p, r), (r, p)] {
                if let Some(x) = self.covariance.get_mut((i, j)) {
                    *x = -known;
                }
            }
            if let Some(x) = self.dx.get_mut(r) {
                *x = T::zero();
            }
        }
    }

    /// Feeds the estimated errors back into the navigation and the sensor errors.
    pub fn feedback(&mut self) {
        self.estimate.correct(&self.dx);
        self.dx = StateVector::zeros();
    }
}
