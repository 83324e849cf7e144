//! An independent `f64` implementation of the correction model (written from the model's
//! documentation in `spincal::model`, not from the firmware's code), for property tests that
//! bound the difference of the device's `f32` arithmetic.

use spincal::model::{
    AxisNonlinearity, CalibrationData, Channel, Environment, ImuSet, Rails, Sensor, SingleSet,
    TemperatureModel, TriadSet,
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

/// Weights of the sets: bilinear over a table (up to four sets); for a Chebyshev series,
/// `T_k(x) = cos(k acos x)` of the clamped scaled temperature for each term, blended along
/// voltage. `(set index, weight)`.
#[must_use]
pub fn weights(env: &Environment, t: f64, v: f64) -> Vec<(usize, f64)> {
    if let TemperatureModel::Chebyshev(n) = env.temperature_model {
        let (lo, hi) = (
            f64::from(env.temperature_span.lo),
            f64::from(env.temperature_span.hi),
        );
        let x = if t.is_nan() {
            0.0
        } else {
            ((t - 0.5 * (lo + hi)) / (0.5 * (hi - lo))).clamp(-1.0, 1.0)
        };
        let (v0, v1, fv) = bracket(&env.voltages, env.voltage_span.lo, env.voltage_span.hi, v);
        let nv = env.voltage_points();
        return (0..usize::from(n))
            .flat_map(|k| {
                let tk = (k as f64 * x.acos()).cos();
                [(k * nv + v0, tk * (1.0 - fv)), (k * nv + v1, tk * fv)]
            })
            .collect();
    }
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
    /// IMU: the state the next sample's lever term needs (see [`LeverState`]).
    pub lever: Option<LeverState>,
}

/// What an IMU correction carries from one sample to the next: the corrected rate and the
/// lever term (`spincal::model::rotation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverState {
    /// The corrected rate, rad/s.
    pub rate: [f64; 3],
    /// The lever term `e`, m/s^2.
    pub lever: [f64; 3],
}

fn margin(v: &Value, lo: f32, hi: f32) -> f64 {
    let d = (v.y - f64::from(lo)).abs().min((v.y - f64::from(hi)).abs());
    d / v.mag.max(1e-30)
}

/// Reference correction of one sample by the model's definitions. `prev` is what the previous
/// sample left (IMU only); without it the sample is the first, whose lever term is solved to
/// its fixed point with no rate difference.
#[must_use]
pub fn correct(
    data: &CalibrationData,
    t: f64,
    volt: f64,
    raw: &[i32],
    sample_rate: f64,
    prev: Option<LeverState>,
) -> Reference {
    let (values, saturated, out_of_range, range_margin, lever) =
        correct_parts(data, t, volt, raw, sample_rate, prev);
    Reference {
        values,
        saturated,
        out_of_range,
        range_margin,
        lever,
    }
}

/// The lever term by its definition (`spincal::model::rotation`): with `m` the device's
/// accelerometer matrix (`S^-1` up to a diagonal), `N` the rows of `m^-1` normalised to a unit
/// diagonal, `e = N^-1 [n_i . (w x (w x r_i) + dw x r_i)]_i`.
fn lever_term(
    m: &nalgebra::Matrix3<f64>,
    r: &[[f32; 3]; 3],
    w: [f64; 3],
    dw: [f64; 3],
) -> [f64; 3] {
    use nalgebra::{Matrix3, Vector3};
    let minv = m.try_inverse().expect("validated matrix");
    let n = Matrix3::from_fn(|i, j| minv[(i, j)] / minv[(i, i)]);
    let om = Vector3::from(w);
    let d = Vector3::from_fn(|i, _| {
        let ri = Vector3::from(r[i].map(f64::from));
        let at = om.cross(&om.cross(&ri)) + Vector3::from(dw).cross(&ri);
        n.row(i).transpose().dot(&at)
    });
    let e = n.try_inverse().expect("normalised directions") * d;
    [e[0], e[1], e[2]]
}

fn correct_parts(
    data: &CalibrationData,
    t: f64,
    volt: f64,
    raw: &[i32],
    sample_rate: f64,
    prev: Option<LeverState>,
) -> (Vec<Value>, bool, bool, f64, Option<LeverState>) {
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
            (vec![value], rails.saturated(raw[0]), out, m, None)
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
            (y.to_vec(), sat, out, m, None)
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
            let (ws, _) = triad(&gyr, &w, gyro, gyro_rails, [raw[3], raw[4], raw[5]]);
            let gs: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| mix(&w, |s| f64::from(sets[s].g_sensitivity[i][j])))
            });
            // w = ws - G x for the specific force x at the reference point.
            let rate = |x: &[f64; 3], xmag: &[f64; 3]| -> [Value; 3] {
                std::array::from_fn(|i| {
                    let mut v = ws[i];
                    for j in 0..3 {
                        v.y -= gs[i][j] * x[j];
                        v.mag += (gs[i][j] * xmag[j]).abs();
                        v.full_scale += (gs[i][j] * a[j].full_scale).abs();
                    }
                    v
                })
            };
            let ay = [a[0].y, a[1].y, a[2].y];
            let amag = [a[0].mag, a[1].mag, a[2].mag];
            let (g, a_ref, state) = match lever_arm {
                None => (rate(&ay, &amag), a, None),
                Some(r) => {
                    let m = nalgebra::Matrix3::from_fn(|i, j| {
                        mix(&w, |s| f64::from(sets[s].accel.matrix[i][j]))
                    });
                    let prev = prev.unwrap_or_else(|| {
                        // The first sample: the fixed point of e = e(w(a - e)), no rate
                        // difference.
                        let mut e = [0.0; 3];
                        let mut om = [0.0; 3];
                        for _ in 0..50 {
                            let x = [ay[0] - e[0], ay[1] - e[1], ay[2] - e[2]];
                            let g = rate(&x, &amag);
                            om = [g[0].y, g[1].y, g[2].y];
                            e = lever_term(&m, r, om, [0.0; 3]);
                        }
                        LeverState { rate: om, lever: e }
                    });
                    let x = std::array::from_fn(|j| ay[j] - prev.lever[j]);
                    let xmag = std::array::from_fn(|j| amag[j] + prev.lever[j].abs());
                    let g = rate(&x, &xmag);
                    let om = [g[0].y, g[1].y, g[2].y];
                    let dw = std::array::from_fn(|k| (om[k] - prev.rate[k]) * sample_rate);
                    let e = lever_term(&m, r, om, dw);
                    // The rounding scale of e: its terms' magnitudes.
                    let ww: f64 = om.iter().map(|x| x * x).sum();
                    let dd: f64 = dw.iter().map(|x| x.abs()).sum();
                    let rr: f64 = r.iter().flatten().map(|x| f64::from(x.abs())).sum();
                    let a_ref = std::array::from_fn(|i| Value {
                        y: a[i].y - e[i],
                        mag: a[i].mag + e[i].abs() + 4.0 * (ww + dd) * rr,
                        full_scale: a[i].full_scale,
                    });
                    (g, a_ref, Some(LeverState { rate: om, lever: e }))
                }
            };
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
            let mut v = a_ref.to_vec();
            v.extend_from_slice(&g);
            (v, sat, out, m, state)
        }
    }
}
