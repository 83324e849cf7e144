//! Coefficient sets: what a calibration holds at one temperature and voltage point.

use serde::{Deserialize, Serialize};

/// Per-axis nonlinearity of the correction, in counts:
/// `u = v + quadratic v^2 + cubic v^3 + odd_quadratic v|v| + asymmetry |v - asymmetry_break|`
/// with `v` the raw code minus the axis center.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisNonlinearity {
    /// Coefficient of `v^2` (1/count).
    pub quadratic: f32,
    /// Coefficient of `v^3` (1/count^2).
    pub cubic: f32,
    /// Coefficient of `v|v|` (1/count).
    pub odd_quadratic: f32,
    /// Coefficient of `|v - asymmetry_break|` (dimensionless): the slope is `1 + asymmetry`
    /// above the breakpoint and `1 - asymmetry` below it.
    pub asymmetry: f32,
    /// The asymmetry breakpoint (counts from the center).
    pub asymmetry_break: f32,
}

impl AxisNonlinearity {
    /// No nonlinearity: `u = v`.
    pub const LINEAR: Self = Self {
        quadratic: 0.0,
        cubic: 0.0,
        odd_quadratic: 0.0,
        asymmetry: 0.0,
        asymmetry_break: 0.0,
    };

    /// True when every term is zero.
    #[must_use]
    pub fn is_linear(&self) -> bool {
        self.quadratic == 0.0
            && self.cubic == 0.0
            && self.odd_quadratic == 0.0
            && self.asymmetry == 0.0
    }

    /// The coefficients as an array, in declaration order.
    #[must_use]
    pub const fn to_array(&self) -> [f32; 5] {
        [
            self.quadratic,
            self.cubic,
            self.odd_quadratic,
            self.asymmetry,
            self.asymmetry_break,
        ]
    }
}

/// The packed lower-triangular Cholesky factor `L` of a covariance `C = L L'` over the features
/// `[1, u]` of one output: the 1-sigma calibration error of the output is `|L' f|`.
/// Layout: `[L00, L10, L11]`.
pub type SingleCovariance = [f32; 3];

/// Per output of a triad, the packed lower-triangular Cholesky factor `L` (row-major:
/// `L00; L10 L11; L20 L21 L22; L30 L31 L32 L33`) of the covariance of that output's bias and
/// matrix row over the features `f = [1, u0, u1, u2]` (counts): the output's 1-sigma
/// calibration error is `|L' f|`. The uncertainty of the nonlinear terms is not included.
pub type TriadCovariance = [[f32; 10]; 3];

/// Coefficients of a single axis at one table point: `y = offset + scale * u`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SingleSet {
    /// The axis nonlinearity.
    pub axis: AxisNonlinearity,
    /// Scale factor, SI units per count.
    pub scale: f32,
    /// Offset, SI units.
    pub offset: f32,
}

/// Coefficients of a triad at one table point: `y = matrix * u + offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TriadSet {
    /// Per-axis nonlinearity.
    pub axes: [AxisNonlinearity; 3],
    /// Scale-misalignment matrix, row-major, SI units per count.
    pub matrix: [[f32; 3]; 3],
    /// Offset, SI units (`-matrix * bias`).
    pub offset: [f32; 3],
}

impl TriadSet {
    /// True when no axis has a nonlinear term.
    #[must_use]
    pub fn is_linear(&self) -> bool {
        self.axes.iter().all(AxisNonlinearity::is_linear)
    }
}

/// Features of one IMU output's 1-sigma (SI units), [`IMU_FEATURES`] of them.
///
/// - Accelerometer output `i`: `[1, F_i0, F_i1, F_i2, G_i0, G_i1, G_i2, x_i^2, |x_i|, x_i^3,
///   x_i |x_i|]`, with `F_i` the
///   specific force at axis `i`'s position (reference force plus what the spin adds there),
///   `G_i = w (n_i . w) - n_i |w|^2` the gradient of what the axis senses of the spin in its
///   lever arm, and `x_i = n_i . F_i` what it senses along itself
///   ([`rotation`](super::rotation)).
/// - Gyro output `i`: `[1, w_0, w_1, w_2, f_0, f_1, f_2, x_i^2, |x_i|, x_i^3, x_i |x_i|]`, with
///   `f` the specific force at the reference point (g-sensitivity) and `x_i = n_i . (w + G f)`
///   what it senses.
///
/// Their coefficients are the axis' forward parameters: bias, sensitivity row, lever arm or
/// g-sensitivity row, and the nonlinear terms the correction applies (g-squared, the
/// asymmetry's kink, cubic, odd-quadratic); the factor holds their covariance scaled to the
/// output. Every term the correction carries has its own feature: folded into fewer features,
/// the nonlinear terms' error (the kink's V about zero, the odd terms' sign change) cannot be
/// stated both at zero input and across the range.
pub const IMU_FEATURES: usize = 11;

/// The packed lower-triangular Cholesky factor `L` (row-major, `L00; L10 L11; ...`, 66 values
/// for [`IMU_FEATURES`] features) of the covariance of one IMU output over its features: the
/// output's 1-sigma calibration error is `|L' phi|`. Stored as six rows of eleven (serde's
/// arrays stop at 32); read it flat with `as_flattened`.
pub type ImuOutputCovariance = [[f32; 11]; 6];

/// Covariance factors of an IMU at one table point: per output, over that output's features
/// (see [`IMU_FEATURES`]), so that the stated 1-sigma covers the lever arm and the g-squared
/// terms of a spinning unit. The cubic and odd-quadratic terms' uncertainty is not included.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuCovariance {
    /// The accelerometer outputs.
    pub accel: [ImuOutputCovariance; 3],
    /// The gyro outputs.
    pub gyro: [ImuOutputCovariance; 3],
}

/// Coefficients of an IMU at one table point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuSet {
    /// The accelerometer triad: specific force at the sensor, m/s^2.
    pub accel: TriadSet,
    /// The gyro triad before g-sensitivity, rad/s.
    pub gyro: TriadSet,
    /// Gyro g-sensitivity, row-major, rad/s per m/s^2: subtracted as `G a_s`.
    pub g_sensitivity: [[f32; 3]; 3],
}

/// Linear interpolation of coefficient sets, field by field.
pub(crate) trait Blend: Copy {
    /// `self + (other - self) * t`.
    fn blend(&self, other: &Self, t: f32) -> Self;
    /// `a self + b other`, field by field (a temperature series' recurrence).
    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self;
    /// Whether sets of this kind may be a temperature series.
    const SERIES: bool = false;
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

fn comb_array<const N: usize>(x: &[f32; N], a: f32, y: &[f32; N], b: f32) -> [f32; N] {
    let mut out = *x;
    for (o, (p, q)) in out.iter_mut().zip(x.iter().zip(y.iter())) {
        *o = a * p + b * q;
    }
    out
}

fn comb_matrix<const R: usize, const C: usize>(
    x: &[[f32; C]; R],
    a: f32,
    y: &[[f32; C]; R],
    b: f32,
) -> [[f32; C]; R] {
    let mut out = *x;
    for (o, (p, q)) in out.iter_mut().zip(x.iter().zip(y.iter())) {
        *o = comb_array(p, a, q, b);
    }
    out
}

fn lerp_array<const N: usize>(a: &[f32; N], b: &[f32; N], t: f32) -> [f32; N] {
    let mut out = *a;
    for (o, (x, y)) in out.iter_mut().zip(a.iter().zip(b.iter())) {
        *o = lerp(*x, *y, t);
    }
    out
}

fn lerp_matrix<const R: usize, const C: usize>(
    a: &[[f32; C]; R],
    b: &[[f32; C]; R],
    t: f32,
) -> [[f32; C]; R] {
    let mut out = *a;
    for (o, (x, y)) in out.iter_mut().zip(a.iter().zip(b.iter())) {
        *o = lerp_array(x, y, t);
    }
    out
}

impl Blend for AxisNonlinearity {
    fn blend(&self, other: &Self, t: f32) -> Self {
        Self {
            quadratic: lerp(self.quadratic, other.quadratic, t),
            cubic: lerp(self.cubic, other.cubic, t),
            odd_quadratic: lerp(self.odd_quadratic, other.odd_quadratic, t),
            asymmetry: lerp(self.asymmetry, other.asymmetry, t),
            asymmetry_break: lerp(self.asymmetry_break, other.asymmetry_break, t),
        }
    }

    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        Self {
            quadratic: a * self.quadratic + b * other.quadratic,
            cubic: a * self.cubic + b * other.cubic,
            odd_quadratic: a * self.odd_quadratic + b * other.odd_quadratic,
            asymmetry: a * self.asymmetry + b * other.asymmetry,
            asymmetry_break: a * self.asymmetry_break + b * other.asymmetry_break,
        }
    }
}

impl<const N: usize> Blend for [f32; N] {
    const SERIES: bool = true;

    fn blend(&self, other: &Self, t: f32) -> Self {
        lerp_array(self, other, t)
    }

    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        comb_array(self, a, other, b)
    }
}

impl<const N: usize, const M: usize> Blend for [[f32; N]; M] {
    const SERIES: bool = true;

    fn blend(&self, other: &Self, t: f32) -> Self {
        lerp_matrix(self, other, t)
    }

    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        comb_matrix(self, a, other, b)
    }
}

impl ImuCovariance {
    /// Every value, accelerometer outputs then gyro outputs.
    pub(crate) fn floats(&self) -> impl Iterator<Item = &f32> {
        self.accel
            .iter()
            .chain(&self.gyro)
            .flat_map(|f| f.as_flattened())
    }

    /// Every value, mutably, in the order of [`floats`](Self::floats).
    pub(crate) fn floats_mut(&mut self) -> impl Iterator<Item = &mut f32> {
        self.accel
            .iter_mut()
            .chain(self.gyro.iter_mut())
            .flat_map(|f| f.as_flattened_mut())
    }
}

impl Blend for SingleSet {
    const SERIES: bool = true;

    fn blend(&self, other: &Self, t: f32) -> Self {
        Self {
            axis: self.axis.blend(&other.axis, t),
            scale: lerp(self.scale, other.scale, t),
            offset: lerp(self.offset, other.offset, t),
        }
    }

    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        Self {
            axis: self.axis.lincomb(a, &other.axis, b),
            scale: a * self.scale + b * other.scale,
            offset: a * self.offset + b * other.offset,
        }
    }
}

impl Blend for TriadSet {
    const SERIES: bool = true;

    fn blend(&self, other: &Self, t: f32) -> Self {
        let mut axes = self.axes;
        for (o, (a, b)) in axes.iter_mut().zip(self.axes.iter().zip(other.axes.iter())) {
            *o = a.blend(b, t);
        }
        Self {
            axes,
            matrix: lerp_matrix(&self.matrix, &other.matrix, t),
            offset: lerp_array(&self.offset, &other.offset, t),
        }
    }

    // Only a temperature series' recurrence calls it: one copy, not one per call site.
    #[inline(never)]
    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        let mut axes = self.axes;
        for (o, (p, q)) in axes.iter_mut().zip(self.axes.iter().zip(other.axes.iter())) {
            *o = p.lincomb(a, q, b);
        }
        Self {
            axes,
            matrix: comb_matrix(&self.matrix, a, &other.matrix, b),
            offset: comb_array(&self.offset, a, &other.offset, b),
        }
    }
}

impl Blend for ImuSet {
    const SERIES: bool = true;

    fn blend(&self, other: &Self, t: f32) -> Self {
        Self {
            accel: self.accel.blend(&other.accel, t),
            gyro: self.gyro.blend(&other.gyro, t),
            g_sensitivity: lerp_matrix(&self.g_sensitivity, &other.g_sensitivity, t),
        }
    }

    // Only a temperature series' recurrence calls it: one copy, not one per call site.
    #[inline(never)]
    fn lincomb(&self, a: f32, other: &Self, b: f32) -> Self {
        Self {
            accel: self.accel.lincomb(a, &other.accel, b),
            gyro: self.gyro.lincomb(a, &other.gyro, b),
            g_sensitivity: comb_matrix(&self.g_sensitivity, a, &other.g_sensitivity, b),
        }
    }
}
