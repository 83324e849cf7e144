//! A calibration in the units a test engineer reads a datasheet in: each output's bias (its
//! reading at zero input, from the converter's mid-scale) in mg or deg/h at every temperature
//! point, its scale factor's 1-sigma in ppm and its misalignment in mrad, with 1-sigma.

use crate::sensor::Calibrated;
use spincal::model::Sensor;

/// m/s^2 in one mg.
const MG: f64 = 9.806_65e-3;
/// deg/h in one rad/s.
const DEG_PER_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// The unit a value of SI unit `si` is shown in, and the factor from SI.
fn engineering(si: &str) -> (&'static str, f64) {
    match si {
        "m/s^2" => ("mg", 1.0 / MG),
        "rad/s" => ("deg/h", DEG_PER_H),
        _ => ("", 1.0),
    }
}

/// The converter's mid-scale code of output `output` (`a_*` an accelerometer's, `g_*` a
/// gyro's, anything else the single axis's).
pub(crate) fn mid_scale(c: &Calibrated, output: &str) -> f64 {
    let rails = match &c.data.sensor {
        Sensor::Single { rails, .. } | Sensor::Triad { rails, .. } => *rails,
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            ..
        } => {
            if output.starts_with("g_") {
                *gyro_rails
            } else {
                *accel_rails
            }
        }
    };
    (f64::from(rails.lo) + f64::from(rails.hi) + 1.0) / 2.0
}

/// Output `a`'s bias at table point `p` in SI units (its reading at zero input from the
/// converter's mid-scale) and its 1-sigma; `None` without an offset or own-input term.
fn bias(c: &Calibrated, p: &crate::sensor::PointFit, a: usize) -> Option<(f64, f64)> {
    let axis = p.axes.get(a)?;
    let fit = &axis.fit;
    let coef = |name: &str| {
        fit.names
            .iter()
            .position(|n| n == name)
            .map(|i| (fit.coefficients[i], fit.std_errors[i]))
    };
    let ((b0, e0), (s, _)) = (coef("1")?, coef(&axis.own)?);
    let mid = mid_scale(c, &axis.output);
    Some(((b0 - mid) / s, e0 / s.abs()))
}

/// One line for a batch's index: each output's bias at the reference point in mg or deg/h
/// ("a_x +1.2 mg"), and the largest misalignment in mrad.
#[must_use]
pub fn brief(c: &Calibrated) -> String {
    let Some(reference) = c.points.get(c.reference) else {
        return String::new();
    };
    let mut parts = Vec::new();
    let mut worst: Option<(f64, String)> = None;
    for (a, axis) in reference.axes.iter().enumerate() {
        let (unit, k) = engineering(c.units.get(a).copied().unwrap_or(""));
        if let Some((b, _)) = bias(c, reference, a) {
            let v = b * k;
            // Four significant figures at most: a gyro's bias of 77,000 deg/h needs no decimals.
            let decimals = if v.abs() >= 100.0 { 0 } else { 2 };
            parts.push(format!("{} {v:+.decimals$} {unit}", axis.output));
        }
        let fit = &axis.fit;
        let kind = axis.own.get(..2).unwrap_or("");
        let Some(s) = fit
            .names
            .iter()
            .position(|n| *n == axis.own)
            .map(|i| fit.coefficients[i])
        else {
            continue;
        };
        for (j, n) in fit.names.iter().enumerate() {
            if *n != axis.own && n.len() == 3 && kind.len() == 2 && n.starts_with(kind) {
                let m = (fit.coefficients[j] / s * 1e3).abs();
                if worst.as_ref().is_none_or(|(w, _)| m > *w) {
                    worst = Some((m, format!("{} from {n}", axis.output)));
                }
            }
        }
    }
    let mut line = parts.join(", ");
    if let Some((m, which)) = worst {
        line.push_str(&format!("; misalignment up to {m:.2} mrad ({which})"));
    }
    line
}

/// The lines, one per output: the bias at each temperature point, then the scale factor's
/// 1-sigma and the misalignment at the reference point (whose temperature they name).
#[must_use]
pub fn lines(c: &Calibrated) -> Vec<String> {
    let Some(reference) = c.points.get(c.reference) else {
        return Vec::new();
    };
    let at = |t: Option<f64>| t.map_or(String::new(), |t| format!(" at {t:.1} C"));
    let mut out = Vec::new();
    for (a, axis) in reference.axes.iter().enumerate() {
        let si = c.units.get(a).copied().unwrap_or("");
        let (unit, k) = engineering(si);
        let mut biases = Vec::new();
        for p in &c.points {
            if let Some((b, e)) = bias(c, p, a) {
                biases.push(format!("{:+.3} ({:.3}){}", b * k, e * k, at(p.temp)));
            }
        }
        let fit = &axis.fit;
        let own = fit.names.iter().position(|n| *n == axis.own);
        let mut tail = String::new();
        if let Some(i) = own {
            let s = fit.coefficients[i];
            tail.push_str(&format!(
                "; scale factor {} counts per {si} ({:.0} ppm)",
                crate::report::terminal::num(s),
                fit.std_errors[i] / s.abs() * 1e6
            ));
            // Cross terms: the other axes' inputs of the same kind (f_* for f_x, w_* for w_x).
            let kind = axis.own.get(..2).unwrap_or("");
            let cross: Vec<String> = fit
                .names
                .iter()
                .enumerate()
                .filter(|(j, n)| *j != i && n.len() == 3 && n.starts_with(kind) && kind.len() == 2)
                .map(|(j, n)| {
                    format!(
                        "{n} {:+.3} ({:.3})",
                        fit.coefficients[j] / s * 1e3,
                        fit.std_errors[j] / s.abs() * 1e3
                    )
                })
                .collect();
            if !cross.is_empty() {
                tail.push_str(&format!("; misalignment {} mrad", cross.join(", ")));
            }
        }
        out.push(format!(
            "{}: bias ({unit}) {}{tail}{}",
            axis.output,
            biases.join(", "),
            if c.points.len() > 1 {
                format!(" (scale factor and misalignment{})", at(reference.temp))
            } else {
                String::new()
            }
        ));
    }
    out
}
