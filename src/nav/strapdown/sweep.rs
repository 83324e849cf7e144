//! The sample rate's half of the two-speed navigation: each sample turned into the de-spun
//! frame by its roll, the de-spun frame's turn and the velocity's and position's increments
//! in the interval's starting frame, and the sums the error model's integrals are made of.

use nalgebra::{Matrix3, RealField, Vector3};

use crate::nav::real::Real;

/// A sample as a step ends on it and the next starts from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct End<T: RealField + Copy> {
    /// The reading: rate (rad/s) and specific force (m/s^2), body axes.
    pub w: Vector3<T>,
    pub f: Vector3<T>,
    /// The roll's sine and cosine there.
    pub sin: T,
    pub cos: T,
    /// The rate across the spin axis, in the de-spun frame.
    pub rate: Vector3<T>,
    /// The specific force in the de-spun frame, and carried into the interval's starting
    /// frame.
    pub force: Vector3<T>,
    pub carried: Vector3<T>,
    /// The length of the step that ended here, s.
    pub dt: T,
}

impl<T: Real> End<T> {
    /// The sample `(w, f)` at a roll of sine `sin` and cosine `cos` about `axis`, its force
    /// carried by `phi`, after a step of `dt`.
    #[inline(always)]
    pub fn at(
        w: &Vector3<T>,
        f: &Vector3<T>,
        axis: &Vector3<T>,
        (sin, cos): (T, T),
        phi: &Vector3<T>,
        dt: T,
    ) -> Self {
        // The turn by the roll about the axis: v cos + (k x v) sin + k (k.v) (1 - cos); the
        // rate's part across the axis has no k (k.v) term.
        let across = w - axis * axis.dot(w);
        let rate = across * cos + axis.cross(w) * sin;
        let force = f * cos + axis.cross(f) * sin + axis * (axis.dot(f) * (T::one() - cos));
        Self {
            w: *w,
            f: *f,
            sin,
            cos,
            rate,
            force,
            carried: carry(phi, &force),
            dt,
        }
    }
}

/// `x` in the frame turned by `phi`, to second order: `x + phi x x + phi x (phi x x) / 2`.
pub(super) fn carry<T: RealField + Copy>(phi: &Vector3<T>, x: &Vector3<T>) -> Vector3<T> {
    let half: T = nalgebra::convert(0.5);
    let once = phi.cross(x);
    x + once + phi.cross(&once) * half
}

/// The sample rate's sums over one lower-rate interval.
///
/// The velocity's and position's increments are trapezoids. The error model's sums are
/// each sample's value times its step, with half a step of the interval's first sample added
/// when it opens and half a step of its last taken away when it closes: the trapezoid when
/// the samples are evenly spaced, at a third of its cost a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Sweep<T: RealField + Copy> {
    /// Its length so far, s.
    pub dt: T,
    /// The de-spun frame's turn since the interval's start, in the starting frame, rad.
    pub phi: Vector3<T>,
    /// The specific force's integral in the starting frame, m/s.
    pub dv: Vector3<T>,
    /// The integral of `dv`, m.
    pub dp: Vector3<T>,
    /// The integrals of the roll's cosine and sine, s.
    cos: T,
    sin: T,
    /// The integrals of the force, and of it times the roll's cosine and sine.
    force: [Vector3<T>; 3],
    /// The same of the rate.
    rate: [Vector3<T>; 3],
}

/// What the error model integrates over one lower-rate interval ([`super::super::filter`]):
/// `int C dt`, `int C diag(f) dt`, `int C diag(w) dt` (`C` the attitude, body to level
/// frame), the level-frame specific force's integral and the interval's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Swept<T: RealField + Copy> {
    /// `int C dt`.
    pub c: Matrix3<T>,
    /// `int C diag(f) dt`.
    pub cf: Matrix3<T>,
    /// `int C diag(w) dt`.
    pub cw: Matrix3<T>,
    /// The level-frame specific force's integral, m/s.
    pub f: Vector3<T>,
    /// The interval's length, s.
    pub dt: T,
}

impl<T: Real> Sweep<T> {
    /// An interval with nothing in it.
    pub fn empty() -> Self {
        Self {
            dt: T::zero(),
            phi: Vector3::zeros(),
            dv: Vector3::zeros(),
            dp: Vector3::zeros(),
            cos: T::zero(),
            sin: T::zero(),
            force: [Vector3::zeros(); 3],
            rate: [Vector3::zeros(); 3],
        }
    }

    /// An interval opening on sample `e`.
    pub fn open(e: &End<T>) -> Self {
        let mut s = Self::empty();
        s.weigh(e, e.dt * nalgebra::convert(0.5));
        s
    }

    /// Adds `weight` of sample `e` to the error model's sums.
    fn weigh(&mut self, e: &End<T>, weight: T) {
        let (c, s) = (e.cos * weight, e.sin * weight);
        self.cos += c;
        self.sin += s;
        for (sums, x) in [(&mut self.force, &e.f), (&mut self.rate, &e.w)] {
            let [plain, cos, sin] = sums;
            *plain += x * weight;
            *cos += x * c;
            *sin += x * s;
        }
    }

    /// Closes the interval on its last sample `e`.
    pub fn close(&mut self, e: &End<T>) {
        self.weigh(e, e.dt * nalgebra::convert(-0.5));
    }

    /// One step from sample `a` to sample `b` (`b.dt` long; its force is carried here).
    pub fn step(&mut self, a: &End<T>, b: &mut End<T>) {
        let half: T = nalgebra::convert(0.5);
        let dt = b.dt;
        let h = half * dt;
        let turn = super::rotation_vector(&a.rate, &b.rate, dt);
        let bortz = self.phi.cross(&turn) * half;
        self.phi += turn + bortz;
        b.carried = carry(&self.phi, &b.force);
        let dv = self.dv + (a.carried + b.carried) * h;
        self.dp += (self.dv + dv) * h;
        self.dv = dv;
        self.weigh(b, dt);
        self.dt += dt;
    }

    /// The error model's integrals over the interval, the de-spun attitude taken at its mean
    /// `mean` over it, the spin about `axis`; `level` the level-frame force's integral.
    pub fn swept(&self, mean: &Matrix3<T>, axis: &Vector3<T>, level: Vector3<T>) -> Swept<T> {
        let across = axis.cross_matrix();
        let along = axis * axis.transpose();
        let spin =
            Matrix3::identity() * self.cos + across * self.sin + along * (self.dt - self.cos);
        // Column j of `R diag(x)` is `x_j (cos e_j + sin k x e_j + (1 - cos) k_j k)`.
        let turned = |[x, x_cos, x_sin]: &[Vector3<T>; 3]| {
            let mut m = across;
            for (mut column, s) in m.column_iter_mut().zip(x_sin.iter()) {
                column *= *s;
            }
            m + Matrix3::from_diagonal(x_cos) + axis * axis.component_mul(&(x - x_cos)).transpose()
        };
        Swept {
            c: mean * spin,
            cf: mean * turned(&self.force),
            cw: mean * turned(&self.rate),
            f: level,
            dt: self.dt,
        }
    }
}
