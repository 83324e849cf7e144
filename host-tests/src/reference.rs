//! An independent `f64` implementation of the correction model (written from the model's
//! documentation in `spincal::model`, not from the firmware's code), for property tests that
//! bound the difference of the device's `f32` arithmetic.

use spincal::model::{
    AxisNonlinearity, CalibrationData, Channel, Environment, ImuSet, Rails, Sensor, SingleSet,
    TriadSet,
};

/// Where `x` falls among `points` (clamped), as `(lo, hi, t)`; NaN goes to the middle of `span`.
fn bracket(points: &[f32], lo: f32, hi: f32, x: f64) -> (usize, usize, f64) {
    let x = if x.is_nan() {
        0.5 * (f64::from(lo) + f64::from(hi))
    } else {
        x
    };
    if points.is_empty() {
        return (0, 0, 0.0);
    }
    let p: Vec<f64> = points.iter().map(|v| f64::from(*v)).collect();
    if x <= p[0] {
        return (0, 0, 0.0);
    }
    let last = p.len() - 1;
    if x >= p[last] {
        return (last, last, 0.0);
    }
    let i = p.windows(2).position(|w| w[0] <= x && x <= w[1]).unwrap();
    (i, i + 1, (x - p[i]) / (p[i + 1] - p[i]))
}

/// Bilinear weights over the table: `(set index, weight)` for up to four sets.
#[must_use]
pub fn weights(env: &Environment, t: f64, v: f64) -> Vec<(usize, f64)> {
    let (t0, t1, ft) = bracket(
        &env.temperatures,
        env.temperature_span.lo,
        env.temperature_span.hi,
        t,
    );
    let (v0, v1, fv) = bracket(&env.voltages, env.voltage_span.lo, env.voltage_span.hi, v);
    let nv = env.voltage_points();
    vec![
        (t0 * nv + v0, (1.0 - ft) * (1.0 - fv)),
        (t0 * nv + v1, (1.0 - ft) * fv),
        (t1 * nv + v0, ft * (1.0 - fv)),
        (t1 * nv + v1, ft * fv),
    ]
}

fn mix(w: &[(usize, f64)], f: impl Fn(usize) -> f64) -> f64 {
    w.iter().map(|(i, wt)| wt * f(*i)).sum()
}

/// The linearised output `u(v)` of one axis, and the sum of the magnitudes of its terms.
fn axis_u(n: &[AxisNonlinearity], w: &[(usize, f64)], v: f64) -> (f64, f64) {
    let q = mix(w, |i| f64::from(n[i].quadratic));
    let k = mix(w, |i| f64::from(n[i].cubic));
    let o = mix(w, |i| f64::from(n[i].odd_quadratic));
    let s = mix(w, |i| f64::from(n[i].asymmetry));
    let b = mix(w, |i| f64::from(n[i].asymmetry_break));
    let terms = [
        v,
        q * v * v,
        k * v * v * v,
        o * v * v.abs(),
        s * (v - b).abs(),
    ];
    (terms.iter().sum(), terms.iter().map(|x| x.abs()).sum())
}

fn half_span(rails: &Rails, channel: &Channel) -> f64 {
    let c = f64::from(channel.center);
    (f64::from(rails.lo) - c)
        .abs()
        .max((f64::from(rails.hi) - c).abs())
}

fn clamp(raw: i32, rails: &Rails) -> i32 {
    raw.clamp(rails.lo, rails.hi)
}

/// A reference output: the value and the magnitude of the terms that made it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Value {
    /// The corrected value.
    pub y: f64,
    /// Sum of the magnitudes of its terms (the scale of rounding error to expect).
    pub mag: f64,
    /// The output's full scale: the largest linear term the rails allow,
    /// `sum_j |scale_ij| max(|rail - center_j|)`.
    pub full_scale: f64,
}

fn triad(
    sets: &[TriadSet],
    w: &[(usize, f64)],
    channels: &[Channel; 3],
    rails: &Rails,
    raw: [i32; 3],
) -> ([Value; 3], [f64; 3]) {
    let mut u = [0.0; 3];
    let mut umag = [0.0; 3];
    for j in 0..3 {
        let v = f64::from(clamp(raw[j], rails)) - f64::from(channels[j].center);
        let axes: Vec<AxisNonlinearity> = sets.iter().map(|s| s.axes[j]).collect();
        (u[j], umag[j]) = axis_u(&axes, w, v);
    }
    let y = std::array::from_fn(|i| {
        let off = mix(w, |s| f64::from(sets[s].offset[i]));
        let mut y = off;
        let mut mag = off.abs();
        let mut full_scale = 0.0;
        for j in 0..3 {
            let m = mix(w, |s| f64::from(sets[s].matrix[i][j]));
            y += m * u[j];
            mag += (m * umag[j]).abs();
            full_scale += m.abs() * half_span(rails, &channels[j]);
        }
        Value { y, mag, full_scale }
    });
    (y, u)
}

/// A reference correction of one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Output values with the magnitudes of their terms.
    pub values: Vec<Value>,
    /// Some raw code at or beyond a rail.
    pub saturated: bool,
    /// Some range-checked value outside its calibrated range.
    pub out_of_range: bool,
    /// Smallest distance of a range-checked value to a range boundary, relative to its
    /// magnitude: the range flag of an f32 computation can only differ when this is tiny.
    pub range_margin: f64,
}

fn margin(v: &Value, lo: f32, hi: f32) -> f64 {
    let d = (v.y - f64::from(lo)).abs().min((v.y - f64::from(hi)).abs());
    d / v.mag.max(1e-30)
}

/// Reference correction of one sample by the model's definitions. `prev_rate` is the previous
/// corrected rate for the lever arm's derivative (IMU only).
#[must_use]
pub fn correct(
    data: &CalibrationData,
    t: f64,
    volt: f64,
    raw: &[i32],
    sample_rate: f64,
    prev_rate: Option<[f64; 3]>,
) -> Reference {
    let (values, saturated, out_of_range, range_margin) =
        correct_parts(data, t, volt, raw, sample_rate, prev_rate);
    Reference {
        values,
        saturated,
        out_of_range,
        range_margin,
    }
}

fn correct_parts(
    data: &CalibrationData,
    t: f64,
    volt: f64,
    raw: &[i32],
    sample_rate: f64,
    prev_rate: Option<[f64; 3]>,
) -> (Vec<Value>, bool, bool, f64) {
    let w = weights(&data.environment, t, volt);
    match &data.sensor {
        Sensor::Single {
            rails,
            channel,
            sets,
            ..
        } => {
            let v = f64::from(clamp(raw[0], rails)) - f64::from(channel.center);
            let axes: Vec<AxisNonlinearity> = sets.iter().map(|s: &SingleSet| s.axis).collect();
            let (u, umag) = axis_u(&axes, &w, v);
            let scale = mix(&w, |i| f64::from(sets[i].scale));
            let off = mix(&w, |i| f64::from(sets[i].offset));
            let y = off + scale * u;
            let out = !(f64::from(channel.range.lo) <= y && y <= f64::from(channel.range.hi));
            let value = Value {
                y,
                mag: off.abs() + (scale * umag).abs(),
                full_scale: scale.abs() * half_span(rails, channel),
            };
            let m = margin(&value, channel.range.lo, channel.range.hi);
            (vec![value], rails.saturated(raw[0]), out, m)
        }
        Sensor::Triad {
            rails,
            channels,
            sets,
            ..
        } => {
            let raw3 = [raw[0], raw[1], raw[2]];
            let (y, _) = triad(sets, &w, channels, rails, raw3);
            let out = y
                .iter()
                .zip(channels)
                .any(|(v, c)| !(f64::from(c.range.lo) <= v.y && v.y <= f64::from(c.range.hi)));
            let sat = raw3.iter().any(|r| rails.saturated(*r));
            let m = y
                .iter()
                .zip(channels)
                .map(|(v, c)| margin(v, c.range.lo, c.range.hi))
                .fold(f64::INFINITY, f64::min);
            (y.to_vec(), sat, out, m)
        }
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            lever_arm,
            sets,
            ..
        } => {
            let acc: Vec<TriadSet> = sets.iter().map(|s: &ImuSet| s.accel).collect();
            let gyr: Vec<TriadSet> = sets.iter().map(|s| s.gyro).collect();
            let (a, _) = triad(&acc, &w, accel, accel_rails, [raw[0], raw[1], raw[2]]);
            let (mut g, _) = triad(&gyr, &w, gyro, gyro_rails, [raw[3], raw[4], raw[5]]);
            for (i, gi) in g.iter_mut().enumerate() {
                for (j, aj) in a.iter().enumerate() {
                    let gs = mix(&w, |s| f64::from(sets[s].g_sensitivity[i][j]));
                    gi.y -= gs * aj.y;
                    gi.mag += (gs * aj.y).abs();
                    gi.full_scale += (gs * aj.full_scale).abs();
                }
            }
            let out = a
                .iter()
                .zip(accel)
                .chain(g.iter().zip(gyro))
                .any(|(v, c)| !(f64::from(c.range.lo) <= v.y && v.y <= f64::from(c.range.hi)));
            let sat = raw[..3].iter().any(|r| accel_rails.saturated(*r))
                || raw[3..].iter().any(|r| gyro_rails.saturated(*r));
            let m = a
                .iter()
                .zip(accel)
                .chain(g.iter().zip(gyro))
                .map(|(v, c)| margin(v, c.range.lo, c.range.hi))
                .fold(f64::INFINITY, f64::min);
            let mut a_ref = a;
            if let Some(r) = lever_arm {
                let om = [g[0].y, g[1].y, g[2].y];
                let dw = match prev_rate {
                    Some(p) => [
                        (om[0] - p[0]) * sample_rate,
                        (om[1] - p[1]) * sample_rate,
                        (om[2] - p[2]) * sample_rate,
                    ],
                    None => [0.0; 3],
                };
                for (i, ai) in a_ref.iter_mut().enumerate() {
                    let ri = r[i].map(f64::from);
                    let cross = |x: [f64; 3], y: [f64; 3]| {
                        [
                            x[1] * y[2] - x[2] * y[1],
                            x[2] * y[0] - x[0] * y[2],
                            x[0] * y[1] - x[1] * y[0],
                        ]
                    };
                    let centripetal = cross(om, cross(om, ri));
                    let tangential = cross(dw, ri);
                    let corr = centripetal[i] + tangential[i];
                    ai.y -= corr;
                    ai.mag += corr.abs()
                        + om.iter().map(|x| x * x).sum::<f64>()
                            * ri.iter().map(|x| x.abs()).sum::<f64>();
                }
            }
            let mut v = a_ref.to_vec();
            v.extend_from_slice(&g);
            (v, sat, out, m)
        }
    }
}
