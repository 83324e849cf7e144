//! From a temperature and a voltage to the effective coefficient set: bracket each value in its
//! breakpoints, clamp (and flag) outside the calibrated span, blend the sets bilinearly.

use super::Flags;
use crate::model::{Blend, Environment, ImuCovariance, Span};

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
    let tb = bracket(&env.temperatures, &env.temperature_span, temperature);
    let vb = bracket(&env.voltages, &env.voltage_span, voltage);
    let nv = env.voltage_points();
    let at = |t: usize, v: usize| sets.get(t * nv + v);
    let lo = at(tb.lo, vb.lo)?.blend(at(tb.lo, vb.hi)?, vb.t);
    let hi = at(tb.hi, vb.lo)?.blend(at(tb.hi, vb.hi)?, vb.t);
    let flags = Flags::NONE
        .with_if(Flags::TEMPERATURE_CLAMPED, tb.clamped)
        .with_if(Flags::VOLTAGE_CLAMPED, vb.clamped);
    Some((lo.blend(&hi, tb.t), flags))
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
    let tb = bracket(&env.temperatures, &env.temperature_span, temperature);
    let vb = bracket(&env.voltages, &env.voltage_span, voltage);
    let nv = env.voltage_points();
    let at = |t: usize, v: usize| sets.get(t * nv + v);
    let (Some(a), Some(b), Some(c), Some(d)) = (
        at(tb.lo, vb.lo),
        at(tb.lo, vb.hi),
        at(tb.hi, vb.lo),
        at(tb.hi, vb.hi),
    ) else {
        return false;
    };
    // The same arithmetic as `Blend`: lo and hi along voltage, then along temperature.
    let lerp = |x: f32, y: f32, t: f32| x + (y - x) * t;
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
