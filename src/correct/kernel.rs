//! The arithmetic of the hot path, shared by the single-axis, triad and IMU correctors, and the
//! safe-window search that lets the hot path skip the exact flag checks.
//!
//! # The safe window
//!
//! Exact flags need two comparisons per axis against the rails and two per output against the
//! calibrated range. Instead, for each sensor the corrector precomputes, per environment, a
//! window of raw codes `[base_j, base_j + 2^k)` per axis, the largest power of two for which an
//! interval bound of the correction *proves* that no code in it is saturated and every output
//! lies inside the calibrated range (with a margin for single-precision rounding). The hot path
//! then tests the window with one OR per axis (`w_j = raw_j - base_j`, all `w_j < 2^k` exactly
//! when `(w_0 | w_1 | w_2) < 2^k` as unsigned) and only a sample outside it takes the slow path
//! that computes the flags exactly. Both paths compute the outputs with the same code, so they
//! agree to the bit.

use crate::model::interval::{Bound, affine_bound, axis_bound};
use crate::model::{AxisNonlinearity, Channel, Rails, TriadSet};

/// Largest window exponent: codes up to `2^24` convert to `f32` exactly.
const MAX_WINDOW_BITS: u32 = 24;

/// Per-axis linearisation: `u = v + v (v (q + k v) + o |v|) + s |v - b|` with `v = w - delta`.
/// Without `ASYM` the asymmetry term is left out (the corrector only does so when every
/// coefficient set has `s = 0`).
#[inline(always)]
pub(crate) fn linearize<const ASYM: bool>(n: &[f32; 5], delta: f32, w: i32) -> f32 {
    let [q, k, o, s, b] = *n;
    let v = w as f32 - delta;
    let inner = v * (q + k * v) + o * v.abs();
    let u = v + v * inner;
    if ASYM { u + s * (v - b).abs() } else { u }
}

/// `offset + row . u`, accumulated left to right (one multiply-accumulate per term).
#[inline(always)]
pub(crate) fn affine(row: &[f32; 3], offset: f32, u: &[f32; 3]) -> f32 {
    let [m0, m1, m2] = *row;
    let [u0, u1, u2] = *u;
    offset + m0 * u0 + m1 * u1 + m2 * u2
}

/// A triad's effective coefficients at the current environment, laid out for the hot path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TriadKernel {
    /// Window base code per axis.
    pub base: [i32; 3],
    /// `2^k`: a sample is inside the window when `(w0 | w1 | w2) < limit`; 0 = never.
    pub limit: u32,
    /// Scale-misalignment matrix, row-major.
    pub m: [[f32; 3]; 3],
    /// Offset for the linear kernel: `offset - M delta`.
    pub off_lin: [f32; 3],
    /// Offset for the nonlinear kernel.
    pub off: [f32; 3],
    /// Axis center minus window base, per axis.
    pub delta: [f32; 3],
    /// Nonlinearity per axis: `[q, k, o, s, b]`.
    pub nl: [[f32; 5]; 3],
    /// Calibrated output range.
    pub range_lo: [f32; 3],
    /// Calibrated output range.
    pub range_hi: [f32; 3],
    /// ADC rails.
    pub rails: Rails,
}

impl TriadKernel {
    /// A kernel that outputs the raw codes (the identity fallback's arithmetic).
    pub const IDENTITY: Self = Self {
        base: [0; 3],
        limit: 0,
        m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        off_lin: [0.0; 3],
        off: [0.0; 3],
        delta: [0.0; 3],
        nl: [[0.0; 5]; 3],
        range_lo: [f32::NEG_INFINITY; 3],
        range_hi: [f32::INFINITY; 3],
        rails: Rails::new(i32::MIN, i32::MAX),
    };

    /// The kernel of `set` for the given channels and rails; `extra` adds a bound to each
    /// output (the gyro's g-sensitivity term) when the window is searched.
    pub fn new(set: &TriadSet, channels: &[Channel; 3], rails: &Rails, extra: &[Bound; 3]) -> Self {
        let nl = set.axes.map(|a| a.to_array());
        let window = search_window(channels, rails, |v_lo, v_hi| {
            let mut u = [Bound::point(0.0); 3];
            for (((b, n), lo), hi) in u.iter_mut().zip(&set.axes).zip(v_lo).zip(v_hi) {
                *b = axis_bound(n, *lo, *hi);
            }
            set.matrix
                .iter()
                .zip(&set.offset)
                .zip(extra)
                .zip(channels)
                .all(|(((row, o), e), ch)| {
                    affine_bound(row, *o, &u)
                        .add(*e)
                        .inside(ch.range.lo, ch.range.hi)
                })
        });
        let delta: [f32; 3] =
            core::array::from_fn(|j| match (channels.get(j), window.base.get(j)) {
                (Some(ch), Some(base)) => ch.center - *base as f32,
                _ => 0.0,
            });
        let off_lin = core::array::from_fn(|i| match (set.matrix.get(i), set.offset.get(i)) {
            (Some(row), Some(o)) => affine(&row.map(|m| -m), *o, &delta),
            _ => 0.0,
        });
        Self {
            base: window.base,
            limit: window.limit,
            m: set.matrix,
            off_lin,
            off: set.offset,
            delta,
            nl,
            range_lo: channels.map(|c| c.range.lo),
            range_hi: channels.map(|c| c.range.hi),
            rails: *rails,
        }
    }

    /// Codes relative to the window base, and their OR for the window test.
    #[inline(always)]
    pub fn offsets(&self, raw: [i32; 3]) -> ([i32; 3], u32) {
        let [r0, r1, r2] = raw;
        let [b0, b1, b2] = self.base;
        let w = [
            r0.wrapping_sub(b0),
            r1.wrapping_sub(b1),
            r2.wrapping_sub(b2),
        ];
        let [w0, w1, w2] = w;
        (w, (w0 | w1 | w2) as u32)
    }

    /// Outputs for a triad with no nonlinear terms.
    #[inline(always)]
    fn linear(&self, w: [i32; 3]) -> [f32; 3] {
        let u = w.map(|x| x as f32);
        let [r0, r1, r2] = &self.m;
        let [o0, o1, o2] = self.off_lin;
        [affine(r0, o0, &u), affine(r1, o1, &u), affine(r2, o2, &u)]
    }

    /// Linearised per-axis outputs `u` (counts from the center).
    #[inline(always)]
    pub fn linearized<const ASYM: bool>(&self, w: [i32; 3]) -> [f32; 3] {
        let [w0, w1, w2] = w;
        let [n0, n1, n2] = &self.nl;
        let [d0, d1, d2] = self.delta;
        [
            linearize::<ASYM>(n0, d0, w0),
            linearize::<ASYM>(n1, d1, w1),
            linearize::<ASYM>(n2, d2, w2),
        ]
    }

    /// Outputs: with the nonlinear terms when `NONLINEAR` (and the asymmetry term when `ASYM`),
    /// else bias and matrix only.
    #[inline(always)]
    pub fn outputs<const NONLINEAR: bool, const ASYM: bool>(&self, w: [i32; 3]) -> [f32; 3] {
        if !NONLINEAR {
            return self.linear(w);
        }
        let u = self.linearized::<ASYM>(w);
        let [r0, r1, r2] = &self.m;
        let [o0, o1, o2] = self.off;
        [affine(r0, o0, &u), affine(r1, o1, &u), affine(r2, o2, &u)]
    }

    /// `raw` moved inside the rails (what the slow path corrects).
    #[inline]
    pub fn clamp(&self, raw: [i32; 3]) -> [i32; 3] {
        raw.map(|r| r.max(self.rails.lo).min(self.rails.hi))
    }

    /// True when any code is at or beyond a rail.
    #[inline]
    pub fn saturated(&self, raw: &[i32; 3]) -> bool {
        raw.iter().any(|r| self.rails.saturated(*r))
    }

    /// True when any output is outside the calibrated range (or NaN).
    #[inline]
    pub fn out_of_range(&self, y: &[f32; 3]) -> bool {
        y.iter()
            .zip(self.range_lo.iter().zip(&self.range_hi))
            .any(|(v, (lo, hi))| !(*lo <= *v && *v <= *hi))
    }
}

/// Bounds of each output of a triad when every output lies in its calibrated range.
pub(crate) fn range_bounds(channels: &[Channel; 3]) -> [Bound; 3] {
    channels.map(|c| Bound::new(c.range.lo, c.range.hi))
}

/// The result of a window search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Window<const N: usize> {
    pub base: [i32; N],
    pub limit: u32,
}

/// Finds the largest `k <= 24` such that the window of `2^k` codes per axis around the rounded
/// centers lies strictly inside the rails and `fits(v_lo, v_hi)` (the bound over it proves the
/// outputs in range). Windows grow with `k` and bounds are monotone, so a binary search works.
pub(crate) fn search_window<const N: usize>(
    channels: &[Channel; N],
    rails: &Rails,
    fits: impl Fn(&[f32; N], &[f32; N]) -> bool,
) -> Window<N> {
    let centers = channels.map(|c| libm::roundf(c.center) as i64);
    let bases = |k: u32| centers.map(|c| c - ((1i64 << k) >> 1));
    let ok = |k: u32| {
        let width = (1i64 << k) - 1;
        let base = bases(k);
        let inside_rails = base
            .iter()
            .all(|b| *b > i64::from(rails.lo) && *b + width < i64::from(rails.hi));
        if !inside_rails {
            return false;
        }
        let mut v_lo = [0.0; N];
        let mut v_hi = [0.0; N];
        for (((lo, hi), b), ch) in v_lo
            .iter_mut()
            .zip(v_hi.iter_mut())
            .zip(&base)
            .zip(channels)
        {
            *lo = *b as f32 - ch.center;
            *hi = (*b + width) as f32 - ch.center;
        }
        fits(&v_lo, &v_hi)
    };
    let to_i32 = |b: [i64; N]| b.map(|x| x as i32);
    if !ok(0) {
        return Window {
            base: to_i32(centers),
            limit: 0,
        };
    }
    let (mut lo, mut hi) = (0u32, MAX_WINDOW_BITS);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    Window {
        base: to_i32(bases(lo)),
        limit: 1u32 << lo,
    }
}

/// Which arithmetic a corrector's per-sample path needs, decided once from all the coefficient
/// sets of a calibration: the fewer terms, the shorter the path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Shape {
    /// No calibration: raw codes out.
    Identity,
    /// Bias and matrix only.
    Linear,
    /// Polynomial terms, no asymmetry.
    Polynomial,
    /// Polynomial and asymmetry terms.
    Asymmetric,
}

impl Shape {
    /// The shape that covers every axis in `axes`.
    pub fn of<'a>(axes: impl IntoIterator<Item = &'a AxisNonlinearity>) -> Self {
        axes.into_iter().fold(Shape::Linear, |shape, a| {
            if a.asymmetry != 0.0 {
                Shape::Asymmetric
            } else if !a.is_linear() && shape == Shape::Linear {
                Shape::Polynomial
            } else {
                shape
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Span;

    #[test]
    fn window_is_the_largest_provably_safe_power_of_two() {
        // 1 count = 0.01 units, range +-100 units = +-10,000 counts around 32,768.
        let ch = Channel {
            center: 32_768.0,
            range: Span::new(-100.0, 100.0),
        };
        let set = TriadSet {
            axes: [AxisNonlinearity::LINEAR; 3],
            matrix: [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]],
            offset: [0.0; 3],
        };
        let k = TriadKernel::new(
            &set,
            &[ch; 3],
            &Rails::unsigned(16),
            &[Bound::point(0.0); 3],
        );
        // 2^14 = 16,384 codes would reach 81.92 units: fine; 2^15 would reach 163.84: not.
        assert_eq!(k.limit, 1 << 14);
        assert_eq!(k.base, [32_768 - 8_192; 3]);
        // Every code in the window maps inside the range, the first one outside may not.
        let (w, acc) = k.offsets([32_768 + 8_191, 32_768 - 8_192, 32_768]);
        assert!(acc < k.limit);
        let edge = k.outputs::<false, false>(w);
        assert!(!k.out_of_range(&edge));
        assert!((edge[0] - 81.91).abs() < 1e-4 && (edge[1] + 81.92).abs() < 1e-4);
        let (_, acc) = k.offsets([32_768 + 8_192, 32_768, 32_768]);
        assert!(acc >= k.limit);
    }

    #[test]
    fn window_is_empty_when_even_one_code_is_unsafe() {
        let ch = Channel {
            center: 100.0,
            range: Span::new(5.0, 6.0),
        };
        let w = search_window(&[ch], &Rails::unsigned(16), |_, _| false);
        assert_eq!(w.limit, 0);
    }
}
