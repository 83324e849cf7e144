//! The one model of an IMU under rotation: what each axis senses when the unit spins, and how
//! the device undoes it. The simulator (`calflash::sim::truth`), the fit's regressors
//! (`calflash::sensor::triad`) and the correction ([`ImuCorrector`](crate::correct::ImuCorrector))
//! all follow this page; a test holds the three together (`host-tests/tests/rotation.rs`).
//!
//! # The forward model (what the sensor outputs, in counts)
//!
//! The body turns at the rate `w` (rad/s, inertial, Earth's rate included) with the angular
//! acceleration `dw` (rad/s^2), the same everywhere on the rigid body. The specific force at
//! the reference point is `f` (m/s^2, body axes).
//!
//! Accelerometer axis `i` sits at `r_i` (metres from the reference point) and senses along
//! `s_i`, row `i` of the scale-misalignment matrix `S` (counts per m/s^2). It feels the whole
//! specific force at its own position ([`force_at`]) and its nonlinearity acts on what it
//! senses:
//!
//! ```text
//! F_i   = f + w x (w x r_i) + dw x r_i          the specific force at the axis (centripetal, tangential)
//! z_i   = s_i . F_i                             what the axis senses, counts
//! out_i = b_i + z_i + S_ii n_i(z_i / S_ii)      n_i(x) = K2 x^2 + K3 x^3 + Koq x|x|
//! ```
//!
//! Gyro axis `i` senses along `s_i` (row `i` of the gyro's `S`), with the g-sensitivity row
//! `g_i` (counts per m/s^2) acting on the specific force at the **reference point**:
//!
//! ```text
//! z_i   = s_i . w + g_i . f
//! out_i = b_i + z_i + S_ii n_i(z_i / S_ii)
//! ```
//!
//! `z_i / S_ii` is the input along the axis in SI units (for an accelerometer axis, the
//! specific force along its sensitive direction at its position, centripetal included), so a
//! K2 of `1e-6 /(m/s^2)` means the same thing on a tumble and on a spinning round.
//!
//! # The device's inverse, per sample
//!
//! Each axis' linearisation ([`AxisNonlinearity`](super::AxisNonlinearity)) inverts `n_i` on
//! the raw code, so `u_i = z_i` up to the affine map the stored matrix and offset absorb. Then:
//!
//! ```text
//! a = M_a u_a + off_a                 = S_a^-1 (z - b)  = f + e(w, dw)
//! w = M_g u_g + off_g - G f           G = S_g^-1 g: rad/s per m/s^2
//! f = a - e(w, dw)
//! e(w, dw) = N^-1 [ n_i . (w x (w x r_i) + dw x r_i) ]_i
//! ```
//!
//! where `n_i = s_i / S_ii` are the sensitive directions normalised to a unit own component
//! (`N` has them as rows). Per axis the centripetal and tangential terms are what the axis
//! senses of them (`n_i . ...`), subtracted in the sensed domain before `S^-1` mixes the axes:
//! that is the exact inverse, misalignment included. `N` comes from the stored matrix alone:
//! `M = S^-1 D` for some diagonal `D`, so the rows of `M^-1` normalised by their diagonal are
//! `n_i`, and `N^-1 = M diag(M^-1)`. [`LeverTerms`] precomputes `e` as six quadratic
//! coefficients (on `w0^2, w1^2, w2^2, w0 w1, w0 w2, w1 w2`) and three tangential ones per
//! output.
//!
//! `w` needs `f` (g-sensitivity) and `f` needs `w` (lever arm). The device breaks the loop with
//! the previous sample's lever term: `w = M_g u_g + off_g - G (a - e_prev)`, exact whenever
//! `e` does not change between samples (a steady spin, any rate), off by `G (e - e_prev)` while
//! the spin changes (a spin-up of 1900 rad/s^2 at 1 kHz with 3 mm arms: about `4e-3` rad/s).
//! On the first sample (and after [`reset`](crate::correct::ImuCorrector::reset)) it iterates
//! to the fixed point instead. `dw` is the backward difference of `w` at the sample rate.
//!
//! The calibrated accelerometer range applies to `a` (the sensor-domain force, centripetal
//! included): what the axes sensed on the bench, not the reference force.

use core::ops::{Add, Mul, Neg, Sub};

/// The arithmetic the model needs, for `f32` (the device) and `f64` (the host).
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// Zero.
    const ZERO: Self;
    /// `self / other`.
    #[must_use]
    fn div(self, other: Self) -> Self;
    /// `|self|`.
    #[must_use]
    fn abs(self) -> Self;
    /// True when neither NaN nor infinite.
    #[must_use]
    fn is_finite(self) -> bool;
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    fn div(self, other: Self) -> Self {
        self / other
    }
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    fn div(self, other: Self) -> Self {
        self / other
    }
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

/// `a . b`.
#[must_use]
pub fn dot<T: Real>(a: &[T; 3], b: &[T; 3]) -> T {
    let [a0, a1, a2] = *a;
    let [b0, b1, b2] = *b;
    a0 * b0 + a1 * b1 + a2 * b2
}

/// `a x b`.
#[must_use]
pub fn cross<T: Real>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    let [a0, a1, a2] = *a;
    let [b0, b1, b2] = *b;
    [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]
}

/// The specific force at position `r` of a rigid body whose reference point feels `f`, turning
/// at `w` with angular acceleration `dw`: `f + w x (w x r) + dw x r`.
#[must_use]
pub fn force_at<T: Real>(f: &[T; 3], w: &[T; 3], dw: &[T; 3], r: &[T; 3]) -> [T; 3] {
    let c = cross(w, &cross(w, r));
    let t = cross(dw, r);
    let [f0, f1, f2] = *f;
    let [c0, c1, c2] = c;
    let [t0, t1, t2] = t;
    [f0 + c0 + t0, f1 + c1 + t1, f2 + c2 + t2]
}

/// The gradient in the lever arm `r` of what an axis sensing along `s` senses of the spin,
/// `s . (w x (w x r) + dw x r)`: `w (s . w) - s |w|^2 + s x dw` (the expression is linear in
/// `r`, so it equals `gradient . r`).
#[must_use]
pub fn lever_gradient<T: Real>(s: &[T; 3], w: &[T; 3], dw: &[T; 3]) -> [T; 3] {
    let sw = dot(s, w);
    let ww = dot(w, w);
    let [t0, t1, t2] = cross(s, dw);
    let [w0, w1, w2] = *w;
    let [s0, s1, s2] = *s;
    [
        w0 * sw - s0 * ww + t0,
        w1 * sw - s1 * ww + t1,
        w2 * sw - s2 * ww + t2,
    ]
}

/// The quadratic monomials of `w` the lever term uses: `w0^2, w1^2, w2^2, w0 w1, w0 w2, w1 w2`.
#[must_use]
pub fn monomials<T: Real>(w: &[T; 3]) -> [T; 6] {
    let [w0, w1, w2] = *w;
    [w0 * w0, w1 * w1, w2 * w2, w0 * w1, w0 * w2, w1 * w2]
}

/// The inverse of a 3x3 matrix by cofactors; `None` when its determinant is zero or not
/// finite.
#[must_use]
pub fn inverse3<T: Real + PartialEq>(m: &[[T; 3]; 3]) -> Option<[[T; 3]; 3]> {
    let [[a, b, c], [d, e, f], [g, h, i]] = *m;
    let c00 = e * i - f * h;
    let c01 = f * g - d * i;
    let c02 = d * h - e * g;
    let det = a * c00 + b * c01 + c * c02;
    if det == T::ZERO || !det.is_finite() {
        return None;
    }
    let inv = |x: T| x.div(det);
    Some([
        [inv(c00), inv(c * h - b * i), inv(b * f - c * e)],
        [inv(c01), inv(a * i - c * g), inv(c * d - a * f)],
        [inv(c02), inv(b * g - a * h), inv(a * e - b * d)],
    ])
}

/// The sensitive directions `n_i` of a triad whose device matrix is `m` (`S^-1` up to a
/// diagonal): the rows of `m^-1` over their diagonal elements, which are returned too (so that
/// `N^-1 = m diag(m^-1)`). `None` when `m` is singular or a diagonal element of `m^-1` is zero.
#[must_use]
pub fn directions<T: Real + PartialEq>(m: &[[T; 3]; 3]) -> Option<([[T; 3]; 3], [T; 3])> {
    let minv = inverse3(m)?;
    let mut n = [[T::ZERO; 3]; 3];
    let mut diag = [T::ZERO; 3];
    for (i, ((row, d), out)) in minv
        .iter()
        .zip(diag.iter_mut())
        .zip(n.iter_mut())
        .enumerate()
    {
        let ii = *row.get(i)?;
        if ii == T::ZERO {
            return None;
        }
        *d = ii;
        *out = row.map(|x| x.div(ii));
    }
    Some((n, diag))
}

/// The lever-arm term `e(w, dw)` of the device's inverse for one accelerometer matrix and set
/// of lever arms, per output `j`:
/// `e_j = quad_j . monomials(w) + tangential_j . dw_scaled`, where `dw_scaled` is whatever the
/// caller multiplied the tangential coefficients by the inverse of (the device passes the rate
/// difference `w - w_prev` and folds the sample rate in; the host passes `dw`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverTerms<T> {
    /// Quadratic coefficients per output, on [`monomials`].
    pub quad: [[T; 6]; 3],
    /// Tangential coefficients per output.
    pub tangential: [[T; 3]; 3],
}

impl<T: Real + PartialEq> LeverTerms<T> {
    /// No lever arm.
    pub const NONE: Self = Self {
        quad: [[T::ZERO; 6]; 3],
        tangential: [[T::ZERO; 3]; 3],
    };

    /// The terms for the accelerometer's device matrix `m` (`S^-1` up to a diagonal), lever
    /// arms `lever` (row `i`: axis `i`'s position, metres) and `rate_scale` folded into the
    /// tangential coefficients. `None` when `m` is singular or an axis does not sense mainly
    /// along itself (a diagonal element of `m^-1` is zero).
    #[must_use]
    pub fn new(m: &[[T; 3]; 3], lever: &[[T; 3]; 3], rate_scale: T) -> Option<Self> {
        let (n, diag) = directions(m)?;
        // Per axis i: the centripetal part n_i . (w x (w x r_i)) = (n_i . w)(r_i . w) -
        // (n_i . r_i)|w|^2 on the monomials, and the tangential n_i . (dw x r_i) =
        // dw . (r_i x n_i).
        let mut q = [[T::ZERO; 6]; 3];
        let mut t = [[T::ZERO; 3]; 3];
        for ((qi, ti), (ni, ri)) in q.iter_mut().zip(t.iter_mut()).zip(n.iter().zip(lever)) {
            let [n0, n1, n2] = *ni;
            let [r0, r1, r2] = *ri;
            let nr = dot(ni, ri);
            *qi = [
                n0 * r0 - nr,
                n1 * r1 - nr,
                n2 * r2 - nr,
                n0 * r1 + n1 * r0,
                n0 * r2 + n2 * r0,
                n1 * r2 + n2 * r1,
            ];
            *ti = cross(ri, ni).map(|x| x * rate_scale);
        }
        // Row j of N^-1 is m_ji diag_i; output j mixes the axes' terms with it.
        let [d0, d1, d2] = diag;
        let [q0, q1, q2] = q;
        let [t0, t1, t2] = t;
        let mix = |row: &[T; 3]| {
            let [m0, m1, m2] = *row;
            let (c0, c1, c2) = (m0 * d0, m1 * d1, m2 * d2);
            let quad: [T; 6] = core::array::from_fn(|k| match (q0.get(k), q1.get(k), q2.get(k)) {
                (Some(a), Some(b), Some(c)) => c0 * *a + c1 * *b + c2 * *c,
                _ => T::ZERO,
            });
            let tangential: [T; 3] =
                core::array::from_fn(|k| match (t0.get(k), t1.get(k), t2.get(k)) {
                    (Some(a), Some(b), Some(c)) => c0 * *a + c1 * *b + c2 * *c,
                    _ => T::ZERO,
                });
            (quad, tangential)
        };
        let [r0, r1, r2] = m;
        let (a, ta) = mix(r0);
        let (b, tb) = mix(r1);
        let (c, tc) = mix(r2);
        Some(Self {
            quad: [a, b, c],
            tangential: [ta, tb, tc],
        })
    }

    /// `e(w, d)`, accumulated left to right in the order the device's kernels use: per output,
    /// the six quadratic terms, then the three tangential ones.
    #[must_use]
    #[inline(always)]
    pub fn eval(&self, w: &[T; 3], d: &[T; 3]) -> [T; 3] {
        let [m0, m1, m2, m3, m4, m5] = monomials(w);
        let [d0, d1, d2] = *d;
        let one = |q: &[T; 6], t: &[T; 3]| {
            let [q0, q1, q2, q3, q4, q5] = *q;
            let [t0, t1, t2] = *t;
            q0 * m0 + q1 * m1 + q2 * m2 + q3 * m3 + q4 * m4 + q5 * m5 + t0 * d0 + t1 * d1 + t2 * d2
        };
        let [q0, q1, q2] = &self.quad;
        let [t0, t1, t2] = &self.tangential;
        [one(q0, t0), one(q1, t1), one(q2, t2)]
    }
}

#[cfg(test)]
#[expect(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    reason = "test arithmetic on fixed arrays"
)]
mod tests {
    use super::*;

    /// The lever term from the definition, for a sensing matrix `s` (rows `s_i`).
    fn by_definition(s: &[[f64; 3]; 3], r: &[[f64; 3]; 3], w: [f64; 3], dw: [f64; 3]) -> [f64; 3] {
        // z_i - s_i . f = s_i . (F_i - f); e = S^-1 [that].
        let zero = [0.0; 3];
        let d: [f64; 3] = core::array::from_fn(|i| dot(&s[i], &force_at(&zero, &w, &dw, &r[i])));
        let sinv = inverse3(s).unwrap();
        core::array::from_fn(|j| dot(&sinv[j], &d))
    }

    #[test]
    fn lever_terms_are_the_exact_sensed_domain_inverse() {
        let s = [
            [412.0 * 1.002, 412.0 * 2.0e-3, -412.0 * 0.8e-3],
            [-412.0 * 1.5e-3, 409.0, 412.0 * 2.1e-3],
            [412.0 * 1.1e-3, -412.0 * 1.7e-3, 415.0],
        ];
        // The device's matrix is S^-1 up to a diagonal (the linearisation's gamma).
        let sinv = inverse3(&s).unwrap();
        let gamma = [0.999, 1.002, 1.0005];
        let m: [[f64; 3]; 3] =
            core::array::from_fn(|i| core::array::from_fn(|j| sinv[i][j] * gamma[j]));
        let r = [
            [0.0005, 0.003, -0.001],
            [0.002, -0.0015, 0.0025],
            [-0.001, 0.001, 0.0012],
        ];
        let terms = LeverTerms::new(&m, &r, 1.0).unwrap();
        for (w, dw) in [
            ([1885.0, 3.0, -2.0], [0.0, 0.0, 0.0]),
            ([40.0, -1200.0, 700.0], [900.0, -50.0, 20.0]),
            ([-300.0, 5.0, 1900.0], [-10.0, 2000.0, 3.0]),
        ] {
            let want = by_definition(&s, &r, w, dw);
            let got = terms.eval(&w, &dw);
            for j in 0..3 {
                assert!(
                    (got[j] - want[j]).abs() < 1e-9 * want[j].abs().max(1.0),
                    "{got:?} {want:?}"
                );
            }
        }
    }

    #[test]
    fn with_no_misalignment_the_term_is_the_own_component() {
        let m = [[0.01, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.03]];
        let r = [
            [0.001, 0.002, 0.003],
            [0.004, 0.005, 0.006],
            [0.007, 0.008, 0.009],
        ];
        let terms = LeverTerms::new(&m, &r, 1.0).unwrap();
        let (w, dw) = ([3.0, -4.0, 5.0], [0.5, 0.25, -2.0]);
        let e = terms.eval(&w, &dw);
        for i in 0..3 {
            let c = force_at(&[0.0; 3], &w, &dw, &r[i]);
            assert!((e[i] - c[i]).abs() < 1e-15, "{e:?}");
        }
    }

    #[test]
    fn singular_or_axis_free_matrices_have_no_terms() {
        let r = [[0.001; 3]; 3];
        assert!(
            LeverTerms::new(
                &[[1.0f32, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
                &r,
                1.0
            )
            .is_none()
        );
        // A permutation: axis 0 senses along y only, so M^-1 has a zero diagonal.
        let p = [[0.0f32, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(LeverTerms::new(&p, &r, 1.0).is_none());
        assert!(inverse3(&[[f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
