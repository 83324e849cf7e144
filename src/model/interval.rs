//! Interval bounds of the correction over a box of raw codes.
//!
//! Used twice: validation proves that no raw code inside the rails can overflow, and the
//! corrector proves that every code inside its fast window gives an in-range output. Each bound
//! carries the sum of the magnitudes of the terms that made it (`mag`), so the single-precision
//! rounding of both the bound and the hot path can be covered by a margin relative to it.

use super::sets::AxisNonlinearity;

/// Relative margin (of `mag`) that covers the rounding of a correction evaluated in `f32`.
pub(crate) const ROUNDING_MARGIN: f32 = 1e-5;

/// A bound `[lo, hi]` on a value, with `mag` bounding the sum of the magnitudes of its terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bound {
    pub lo: f32,
    pub hi: f32,
    pub mag: f32,
}

impl Bound {
    pub const fn point(x: f32) -> Self {
        Self {
            lo: x,
            hi: x,
            mag: if x < 0.0 { -x } else { x },
        }
    }

    pub fn new(a: f32, b: f32) -> Self {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        Self {
            lo,
            hi,
            mag: libm::fmaxf(libm::fabsf(lo), libm::fabsf(hi)),
        }
    }

    pub fn add(self, other: Self) -> Self {
        Self {
            lo: self.lo + other.lo,
            hi: self.hi + other.hi,
            mag: self.mag + other.mag,
        }
    }

    pub fn scale(self, c: f32) -> Self {
        let (lo, hi) = if c >= 0.0 {
            (self.lo * c, self.hi * c)
        } else {
            (self.hi * c, self.lo * c)
        };
        Self {
            lo,
            hi,
            mag: self.mag * libm::fabsf(c),
        }
    }

    /// `|x|` over the bound.
    fn abs(self) -> Self {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            Self {
                lo: -self.hi,
                hi: -self.lo,
                mag: self.mag,
            }
        } else {
            Self {
                lo: 0.0,
                hi: libm::fmaxf(-self.lo, self.hi),
                mag: self.mag,
            }
        }
    }

    /// True when every bit of the bound is finite.
    pub fn is_finite(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite() && self.mag.is_finite()
    }

    /// True when the bound, widened by the rounding margin, lies inside `[lo, hi]`.
    pub fn inside(&self, lo: f32, hi: f32) -> bool {
        let m = self.mag * ROUNDING_MARGIN + f32::MIN_POSITIVE;
        self.is_finite() && self.lo - m >= lo && self.hi + m <= hi
    }
}

/// Bound of the linearised output `u(v)` of one axis for `v` in `[v_lo, v_hi]`.
pub(crate) fn axis_bound(n: &AxisNonlinearity, v_lo: f32, v_hi: f32) -> Bound {
    let v = Bound::new(v_lo, v_hi);
    let a = v.abs();
    // v^2 is |v|^2; v^3 and v|v| are increasing in v.
    let square = Bound::new(a.lo * a.lo, a.hi * a.hi);
    let cube = Bound::new(v.lo * v.lo * v.lo, v.hi * v.hi * v.hi);
    let odd = Bound::new(v.lo * libm::fabsf(v.lo), v.hi * libm::fabsf(v.hi));
    let kink = Bound::new(v.lo - n.asymmetry_break, v.hi - n.asymmetry_break).abs();
    v.add(square.scale(n.quadratic))
        .add(cube.scale(n.cubic))
        .add(odd.scale(n.odd_quadratic))
        .add(kink.scale(n.asymmetry))
}

/// Bound of `offset + sum_j row[j] * u[j]`.
pub(crate) fn affine_bound(row: &[f32; 3], offset: f32, u: &[Bound; 3]) -> Bound {
    row.iter()
        .zip(u.iter())
        .fold(Bound::point(offset), |acc, (m, b)| acc.add(b.scale(*m)))
}
