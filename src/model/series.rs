//! What validation proves of a temperature series of sets (`TemperatureModel::Chebyshev`):
//! the device sums `c_0 + c_1 T_1(x) + ...` with `|T_k(x)| <= 1`, so at any temperature every
//! coefficient is within the sum of the magnitudes of its terms (the series' envelope), and a
//! matrix is within `sum_k>=1 |C_k|` of its head `C_0`. From these: the scale factor or matrix
//! stays invertible, and the output stays bounded, at every temperature, with nothing summed on
//! the device beyond what validation saw.

use super::interval::{Bound, affine_bound, axis_bound};
use super::sets::{AxisNonlinearity, ImuSet, TriadSet};
use super::{Channel, Rails};
use crate::Error;
use crate::error::Part;

/// The terms of the series at voltage point `v` of `voltages` (sets are temperature-major).
pub(super) fn terms<T>(sets: &[T], v: usize, voltages: usize) -> impl Iterator<Item = &T> + Clone {
    sets.iter().skip(v).step_by(voltages.max(1))
}

/// The envelope of axis nonlinearities: each coefficient the sum of the magnitudes of its
/// terms, the break 0 (its share is [`break_sum`]'s).
pub(super) fn axis_envelope<'a>(
    axes: impl Iterator<Item = &'a AxisNonlinearity> + Clone,
) -> AxisNonlinearity {
    let sum = |f: fn(&AxisNonlinearity) -> f32| axes.clone().map(|a| libm::fabsf(f(a))).sum();
    AxisNonlinearity {
        quadratic: sum(|a| a.quadratic),
        cubic: sum(|a| a.cubic),
        odd_quadratic: sum(|a| a.odd_quadratic),
        asymmetry: sum(|a| a.asymmetry),
        asymmetry_break: 0.0,
    }
}

/// The sum of the magnitudes of the asymmetry breaks.
pub(super) fn break_sum<'a>(axes: impl Iterator<Item = &'a AxisNonlinearity>) -> f32 {
    axes.map(|a| libm::fabsf(a.asymmetry_break)).sum()
}

/// Bound on `|u(v)|` for `v` over the rails' offsets under any set within the envelope `n`
/// (breaks up to `breaks` in magnitude): `|v - b| <= |v| + |b|`, the kink's share of the break
/// added apart.
pub(super) fn axis_magnitude(n: &AxisNonlinearity, breaks: f32, v_lo: f32, v_hi: f32) -> f32 {
    axis_bound(n, v_lo, v_hi).mag + n.asymmetry * breaks
}

/// The largest row sum of magnitudes of a matrix (the induced infinity norm).
fn norm_inf(m: &[[f32; 3]; 3]) -> f32 {
    m.iter()
        .map(|r| r.iter().map(|x| libm::fabsf(*x)).sum::<f32>())
        .fold(0.0, libm::fmaxf)
}

/// The bound on each output of a triad's series at any temperature, its matrix invertible at
/// every one: `|C_0^-1| sum_k>=1 |C_k| < 1` (infinity norms) keeps `C_0 + E` invertible for
/// every `|E| <= sum_k>=1 |C_k|`.
///
/// # Errors
/// `InvalidSingularMatrix` (set: the voltage point) when invertibility cannot be shown.
pub(super) fn triad_bound<'a>(
    series: impl Iterator<Item = &'a TriadSet> + Clone,
    channels: &[Channel; 3],
    rails: &Rails,
    (part, first): (Part, u8),
) -> Result<[Bound; 3], Error> {
    let singular = Error::InvalidSingularMatrix { part, set: first };
    let head = series.clone().next().ok_or(singular)?;
    let inverse = super::rotation::inverse3(&head.matrix).ok_or(singular)?;
    let rest: f32 = series.clone().skip(1).map(|s| norm_inf(&s.matrix)).sum();
    // Values are finite here, so the comparison is total.
    if norm_inf(&inverse) * rest >= 1.0 {
        return Err(singular);
    }
    let mut u = [Bound::point(0.0); 3];
    for (a, (b, c)) in u.iter_mut().zip(channels).enumerate() {
        let axes = series.clone().filter_map(move |s| s.axes.get(a));
        let (lo, hi) = c.rail_offsets(rails);
        *b = Bound::point(axis_magnitude(
            &axis_envelope(axes.clone()),
            break_sum(axes),
            lo,
            hi,
        ));
    }
    let mut y = [Bound::point(0.0); 3];
    for (i, b) in y.iter_mut().enumerate() {
        let row: [f32; 3] = core::array::from_fn(|j| {
            series
                .clone()
                .map(|s| libm::fabsf(element(&s.matrix, i, j)))
                .sum::<f32>()
        });
        let offset: f32 = series
            .clone()
            .map(|s| libm::fabsf(s.offset.get(i).copied().unwrap_or(0.0)))
            .sum();
        *b = symmetric(affine_bound(&row, offset, &u).mag);
    }
    Ok(y)
}

/// The bound on the gyro outputs of an IMU's series, the g-sensitivity's envelope applied to
/// the accelerometer's bound `a`.
pub(super) fn g_sensitivity_bound<'a>(
    series: impl Iterator<Item = &'a ImuSet> + Clone,
    gyro: [Bound; 3],
    a: &[Bound; 3],
) -> [Bound; 3] {
    let mut w = gyro;
    for (i, wi) in w.iter_mut().enumerate() {
        let row: [f32; 3] = core::array::from_fn(|j| {
            series
                .clone()
                .map(|s| libm::fabsf(element(&s.g_sensitivity, i, j)))
                .sum::<f32>()
        });
        *wi = symmetric(wi.add(affine_bound(&row, 0.0, a)).mag);
    }
    w
}

fn element(m: &[[f32; 3]; 3], i: usize, j: usize) -> f32 {
    m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
}

/// `[-mag, mag]`.
pub(super) fn symmetric(mag: f32) -> Bound {
    Bound {
        lo: -mag,
        hi: mag,
        mag,
    }
}
