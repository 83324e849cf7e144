//! From a temperature and a voltage to the effective coefficient set: bracket each value in its
//! breakpoints, clamp (and flag) outside the calibrated span, blend the sets bilinearly.

use super::Flags;
use crate::model::{Blend, Environment, ImuCovariance, Span, TemperatureModel};

/// Where a value falls in a list of breakpoints.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bracket {
    lo: usize,
    hi: usize,
    t: f32,
    clamped: bool,
}

fn bracket(points: &[f32], span: &Span, x: f32) -> Bracket {
    let clamped = !span.contains(x);
    // A NaN reading is replaced by the middle of the span: the least bad guess, and flagged.
    let x = if x.is_nan() {
        0.5 * (span.lo + span.hi)
    } else {
        x
    };
    let edge = |i: usize| Bracket {
        lo: i,
        hi: i,
        t: 0.0,
        clamped,
    };
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return edge(0);
    };
    if x <= *first {
        return edge(0);
    }
    if x >= *last {
        return edge(points.len() - 1);
    }
    let mut i = 0;
    for (k, pair) in points.windows(2).enumerate() {
        if let [a, b] = pair
            && *a <= x
            && x <= *b
        {
            i = k;
            break;
        }
    }
    let (a, b) = match (points.get(i), points.get(i + 1)) {
        (Some(a), Some(b)) => (*a, *b),
        _ => return edge(i),
    };
    Bracket {
        lo: i,
        hi: i + 1,
        t: (x - a) / (b - a),
        clamped,
    }
}

/// The effective set at `(temperature, voltage)` and the environment flags, or `None` if the
/// table does not have the shape validation guarantees (never, for a validated calibration).
pub(crate) fn effective_set<S: Blend>(
    env: &Environment,
    sets: &[S],
    temperature: f32,
    voltage: f32,
) -> Option<(S, Flags)> {
    let vb = bracket(&env.voltages, &env.voltage_span, voltage);
    let nv = env.voltage_points();
    let at = |t: usize, v: usize| sets.get(t * nv + v);
    if let TemperatureModel::Chebyshev(n) = env.temperature_model {
        // Kinds of set that are never a series keep no code, and no stack, for one.
        if !S::SERIES {
            return None;
        }
        return series_set(env, sets, usize::from(n), temperature, &vb);
    }
    let tb = bracket(&env.temperatures, &env.temperature_span, temperature);
    let lo = at(tb.lo, vb.lo)?.blend(at(tb.lo, vb.hi)?, vb.t);
    let hi = at(tb.hi, vb.lo)?.blend(at(tb.hi, vb.hi)?, vb.t);
    let flags = Flags::NONE
        .with_if(Flags::TEMPERATURE_CLAMPED, tb.clamped)
        .with_if(Flags::VOLTAGE_CLAMPED, vb.clamped);
    Some((lo.blend(&hi, tb.t), flags))
}

/// [`effective_set`] of a series of `n` terms, voltage bracket `vb`. Kept out of line: the
/// recurrence's copies of a set (an IMU's are 252 bytes) would otherwise be in the stack
/// frame of every table's blend too.
#[inline(never)]
fn series_set<S: Blend>(
    env: &Environment,
    sets: &[S],
    n: usize,
    temperature: f32,
    vb: &Bracket,
) -> Option<(S, Flags)> {
    let nv = env.voltage_points();
    let at = |t: usize, v: usize| sets.get(t * nv + v);
    let (x, clamped) = series_x(&env.temperature_span, temperature);
    let coefficient = |k: usize| Some(at(k, vb.lo)?.blend(at(k, vb.hi)?, vb.t));
    let flags = Flags::NONE
        .with_if(Flags::TEMPERATURE_CLAMPED, clamped)
        .with_if(Flags::VOLTAGE_CLAMPED, vb.clamped);
    Some((clenshaw(n, x, coefficient)?, flags))
}

/// Where a temperature falls in a series' span: `x` in [-1, 1] (clamped, and a NaN reading at
/// the middle) and whether it was clamped.
fn series_x(span: &Span, temperature: f32) -> (f32, bool) {
    let clamped = !span.contains(temperature);
    let half = 0.5 * (span.hi - span.lo);
    let x = (temperature - 0.5 * (span.lo + span.hi)) / half;
    let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
    (x, clamped)
}

/// `sum c_k T_k(x)` for `k < n` by Clenshaw's recurrence, `b_k = c_k + 2x b_(k+1) - b_(k+2)`,
/// the sum `c_0 + x b_1 - b_2`; `None` if a coefficient is missing or `n` is 0.
fn clenshaw<S: Blend>(n: usize, x: f32, c: impl Fn(usize) -> Option<S>) -> Option<S> {
    let last = n.checked_sub(1)?;
    if last == 0 {
        return c(0);
    }
    // (b_(k+1), b_(k+2)), starting from b_last = c_last.
    let mut b1 = c(last)?;
    let mut b2: Option<S> = None;
    for k in (1..last).rev() {
        let twice = match &b2 {
            Some(b2) => b1.lincomb(2.0 * x, b2, -1.0),
            None => b1.lincomb(2.0 * x, &b1, 0.0),
        };
        let bk = c(k)?.lincomb(1.0, &twice, 1.0);
        b2 = Some(b1);
        b1 = bk;
    }
    let head = match &b2 {
        Some(b2) => b1.lincomb(x, b2, -1.0),
        None => b1.lincomb(x, &b1, 0.0),
    };
    Some(c(0)?.lincomb(1.0, &head, 1.0))
}

/// [`effective_set`] for the IMU's covariance factors, blended in place into `out` (they are
/// 864 bytes: the by-value blend would hold several copies on the stack). Returns false, and
/// leaves `out` alone, if the table does not have the shape validation guarantees.
pub(crate) fn effective_covariance_into(
    env: &Environment,
    sets: &[ImuCovariance],
    temperature: f32,
    voltage: f32,
    out: &mut ImuCovariance,
) -> bool {
    let vb = bracket(&env.voltages, &env.voltage_span, voltage);
    let nv = env.voltage_points();
    let at = |t: usize, v: usize| sets.get(t * nv + v);
    // The same arithmetic as `Blend`: lo and hi along voltage, then along temperature.
    let lerp = |x: f32, y: f32, t: f32| x + (y - x) * t;
    if let TemperatureModel::Chebyshev(n) = env.temperature_model {
        let n = usize::from(n);
        if n == 0 || sets.len() < n * nv {
            return false;
        }
        // `sum_k T_k(x) c_k`, summed in place term by term (`T_k` by its recurrence, each
        // `|T_k| <= 1`): no copy of the factors on the stack.
        let (x, _) = series_x(&env.temperature_span, temperature);
        out.floats_mut().for_each(|o| *o = 0.0);
        let (mut previous, mut current) = (1.0f32, x);
        for k in 0..n {
            let tk = match k {
                0 => 1.0,
                1 => x,
                _ => {
                    let next = 2.0 * x * current - previous;
                    previous = current;
                    current = next;
                    next
                }
            };
            let (Some(a), Some(b)) = (at(k, vb.lo), at(k, vb.hi)) else {
                return false;
            };
            for (o, (a, b)) in out.floats_mut().zip(a.floats().zip(b.floats())) {
                *o += tk * lerp(*a, *b, vb.t);
            }
        }
        return true;
    }
    let tb = bracket(&env.temperatures, &env.temperature_span, temperature);
    let (Some(a), Some(b), Some(c), Some(d)) = (
        at(tb.lo, vb.lo),
        at(tb.lo, vb.hi),
        at(tb.hi, vb.lo),
        at(tb.hi, vb.hi),
    ) else {
        return false;
    };
    for (o, (((a, b), c), d)) in out
        .floats_mut()
        .zip(a.floats().zip(b.floats()).zip(c.floats()).zip(d.floats()))
    {
        *o = lerp(lerp(*a, *b, vb.t), lerp(*c, *d, vb.t), tb.t);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bracket_interpolates_and_clamps() {
        let span = Span::new(-40.0, 85.0);
        let pts = [-40.0, 0.0, 85.0];
        assert_eq!(
            bracket(&pts, &span, -20.0),
            Bracket {
                lo: 0,
                hi: 1,
                t: 0.5,
                clamped: false
            }
        );
        assert_eq!(bracket(&pts, &span, 85.0).lo, 2);
        let below = bracket(&pts, &span, -41.0);
        assert!(below.clamped && below.lo == 0 && below.t == 0.0);
        let nan = bracket(&pts, &span, f32::NAN);
        assert!(nan.clamped && nan.lo == 1 && nan.hi == 2);
        assert!(!bracket(&[], &span, 20.0).clamped);
        assert!(bracket(&[], &span, 90.0).clamped);
    }
}
