//! The report's section on a continuous temperature model: each coefficient against the
//! temperature with its 95 % band (the bias with the observations' partial residuals), the
//! corrected input's 1-sigma over the temperature with the calibrated range marked, and how far
//! the device's series or table departs from the model (a triad's or an IMU's: each output
//! along its own axis; the departure for models without nonlinear terms or lever arms).

use super::Error;
use std::fmt::Write as _;

use spincal::correct::AnyAxisCorrector;
use spincal::model::TemperatureModel;

use super::page::esc;
use super::plot::{Figure, Series, Sheet, figure};
use super::terminal::num;
use crate::sensor::Calibrated;
use crate::sensor::single::coefficients::{bias_slope_cov, own_of};
use crate::sensor::thermal::ThermalFit;

/// Temperatures each curve is drawn at.
const STEPS: usize = 160;

fn grid(tf: &ThermalFit, beyond: f64) -> Vec<f64> {
    let (lo, hi) = (tf.scale.lo, tf.scale.hi);
    let pad = beyond * (hi - lo);
    (0..=STEPS)
        .map(|i| lo - pad + (hi - lo + 2.0 * pad) * i as f64 / STEPS as f64)
        .collect()
}

/// The section, or an empty string when the calibration has no continuous model.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn section(c: &Calibrated) -> Result<String, Error> {
    let Some(first) = c.thermal.first() else {
        return Ok(String::new());
    };
    let mut h = String::new();
    let _ = writeln!(h, "<h2>Temperature</h2>");
    let several = c.thermal.len() > 1;
    for tf in &c.thermal {
        let axis = if several {
            format!("{}: ", tf.fit.output)
        } else {
            String::new()
        };
        // Several outputs: each one's coefficients as small multiples under its name.
        let mut sheet = Sheet::new(several);
        if several {
            let _ = writeln!(h, "<h3>{}</h3>", esc(&tf.fit.output));
        }
        let _ = writeln!(h, "<ul>");
        for r in &tf.reasons {
            let _ = writeln!(h, "<li>{}temperature order of {}</li>", esc(&axis), esc(r));
        }
        let _ = writeln!(h, "</ul>");
        coefficient_figures(&mut h, &mut sheet, c, tf, &axis)?;
        sheet.finish(&mut h);
    }
    if several || !matches!(c.data.sensor, spincal::model::Sensor::Single { .. }) {
        h.push_str(&triad_figures(c)?);
        return Ok(h);
    }
    let tf = first;
    let names = tf.base.term_names();
    let temps = grid(tf, 0.0);
    let range = vec![(tf.scale.lo, tf.scale.hi)];
    let unit = c.units.first().copied().unwrap_or("");
    let range_in = c
        .ranges
        .first()
        .map_or((0.0, 0.0), |r| (f64::from(r.lo), f64::from(r.hi)));
    let names_ref = &names;
    let sigma_at = |t: f64, x: f64| {
        let (b, cov) = tf.coefficients_at(t);
        let own = own_of(names_ref, &b, c.breakpoint);
        // At the middle of the supply's span, as `own_of`.
        let [vb, cbs, vs] = bias_slope_cov(names_ref, &cov, 0.0);
        (vb + 2.0 * x * cbs + x * x * vs).max(0.0).sqrt() / own.slope.abs()
    };
    let wide = grid(tf, 0.15);
    let at_zero: Vec<(f64, f64)> = wide.iter().map(|t| (*t, sigma_at(*t, 0.0))).collect();
    let at_top: Vec<(f64, f64)> = wide
        .iter()
        .map(|t| (*t, sigma_at(*t, range_in.1)))
        .collect();
    let top = format!("input {}", num(range_in.1));
    figure(
        &mut h,
        &Figure {
            title: "1-sigma calibration error of the corrected input over the temperature",
            x: "temperature (C)",
            y: &format!("1-sigma ({unit})"),
            series: vec![
                Series::curve("input 0", &at_zero, 0),
                Series::curve(&top, &at_top, 1),
            ],
            bands: range.clone(),
            band_label: "calibrated range",
            zero_line: true,
            x_names: None,
        },
    )?;
    // The device against the model: its correction of the model's own codes (none when the
    // device refused the calibration).
    if c.blob.is_empty() {
        return Ok(h);
    }
    let cal = spincal::blob::decode(&c.blob)?;
    let mut device = AnyAxisCorrector::new(&cal)?;
    let volt =
        0.5 * (cal.data().environment.voltage_span.lo + cal.data().environment.voltage_span.hi);
    let departure: Vec<(f64, f64)> = temps
        .iter()
        .map(|t| {
            let (b, _) = tf.coefficients_at(*t);
            let own = own_of(&names, &b, c.breakpoint);
            device.set_environment(*t as f32, volt);
            let worst = (0..=20)
                .map(|k| {
                    let x = range_in.0 + (range_in.1 - range_in.0) * f64::from(k) / 20.0;
                    let code = own.output(x).round();
                    let want = own.input_for(code, x);
                    let got = f64::from(device.correct(code as i32).values[0]);
                    (got - want).abs() / sigma_at(*t, want)
                })
                .fold(0.0, f64::max);
            (*t, worst)
        })
        .collect();
    departure_figure(
        &mut h,
        c,
        cal.data().environment.temperature_model,
        "the inputs",
        &departure,
    )?;
    Ok(h)
}

/// How a coefficient is shown at a temperature: `(t, value, 1-sigma)` to `(value, 1-sigma)`.
type Shown<'a> = dyn Fn(f64, f64, f64) -> (f64, f64) + 'a;

/// Each coefficient of `tf` against the temperature with its 95 % band (the bias with the
/// observations' partial residuals), titled with `axis`, in a datasheet's units: the bias at
/// zero input in the input's unit (from the converter's mid-scale, through the scale factor at
/// that temperature), the scale factor as its change in ppm from its value mid-span, every
/// other coefficient in counts per unit of its term.
fn coefficient_figures(
    h: &mut String,
    sheet: &mut Sheet,
    c: &Calibrated,
    tf: &ThermalFit,
    axis: &str,
) -> Result<(), Error> {
    let names = tf.base.term_names();
    let temps = grid(tf, 0.0);
    let own = names.iter().position(|n| *n == tf.fit.own);
    let unit = c
        .points
        .get(c.reference)
        .and_then(|p| p.axes.iter().position(|x| x.output == tf.fit.output))
        .and_then(|a| c.units.get(a))
        .copied()
        .unwrap_or("");
    let mid = super::engineering::mid_scale(c, &tf.fit.output);
    let t_mid = temps.get(temps.len() / 2).copied().unwrap_or(25.0);
    let scale_at = |t: f64| own.map(|o| tf.coefficients_at(t).0[o]);
    let s_mid = scale_at(t_mid).filter(|s| s.is_finite() && *s != 0.0);
    // Small multiples draw what changes with the temperature; a coefficient of order 0 is a
    // flat line, said in words.
    let mut constant = Vec::new();
    for (j, name) in names.iter().enumerate() {
        if sheet.small() && name != "1" && tf.orders.get(j) == Some(&0) {
            let (b, cov) = tf.coefficients_at(t_mid);
            constant.push(format!(
                "{name} {} ({}) {}",
                num(b[j]),
                num(cov[(j, j)].max(0.0).sqrt()),
                crate::report::page::term_unit(name, unit)
            ));
            continue;
        }
        // How a coefficient is shown at temperature t: its value, its 1-sigma.
        let (what, show): (String, Box<Shown<'_>>) = match (name.as_str(), own, s_mid) {
            ("1", Some(_), Some(_)) => (
                format!("bias at zero input ({unit})"),
                Box::new(|t: f64, v: f64, se: f64| {
                    let s = scale_at(t).unwrap_or(1.0);
                    ((v - mid) / s, se / s.abs())
                }),
            ),
            (_, Some(o), Some(sm)) if o == j => (
                format!("scale factor change from {t_mid:.0} C (ppm)"),
                Box::new(move |_t: f64, v: f64, se: f64| {
                    ((v / sm - 1.0) * 1e6, se / sm.abs() * 1e6)
                }),
            ),
            _ => (
                format!(
                    "{} coefficient ({})",
                    crate::report::page::term_words(name),
                    crate::report::page::term_unit(name, unit)
                ),
                Box::new(|_t: f64, v: f64, se: f64| (v, se)),
            ),
        };
        let mut mid_line = Vec::new();
        let mut upper = Vec::new();
        let mut lower = Vec::new();
        for t in &temps {
            let (b, cov) = tf.coefficients_at(*t);
            let (v, se) = show(*t, b[j], cov[(j, j)].max(0.0).sqrt());
            mid_line.push((*t, v));
            upper.push((*t, v + 1.96 * se));
            lower.push((*t, v - 1.96 * se));
        }
        // The bias with each observation's partial residual: its residual about the model
        // plus the bias at its temperature.
        let observed: Vec<(f64, f64)> = if name == "1" {
            tf.temps
                .iter()
                .zip(&tf.fit.fit.residuals)
                .map(|(t, e)| (*t, show(*t, tf.coefficients_at(*t).0[j] + e, 0.0).0))
                .collect()
        } else {
            Vec::new()
        };
        let title = if sheet.small() {
            what.clone()
        } else {
            format!("{axis}{what} against temperature")
        };
        let mut series = vec![
            Series::curve("model", &mid_line, 0),
            Series::curve("95 % band", &upper, 1),
            Series::curve("", &lower, 1),
        ];
        if !observed.is_empty() {
            series.push(Series::dots("observations", &observed, 2));
        }
        sheet.add(
            h,
            &Figure {
                title: &title,
                x: "temperature (C)",
                y: if sheet.small() { "" } else { &what },
                series,
                bands: Vec::new(),
                band_label: "",
                zero_line: false,
                x_names: None,
            },
        )?;
    }
    if !constant.is_empty() {
        let _ = writeln!(
            h,
            "<p>Constant over the temperature (order 0, not drawn): {}.</p>",
            esc(&constant.join(", "))
        );
    }
    Ok(())
}

/// A triad's or an IMU's model at temperature `t`: per output axis its bias, its sensitivity
/// row over its triad's inputs, and the 1-sigma of its corrected input along its own axis at
/// `x`. `None` when a model has other terms than the bias, the sensitivity row and the
/// g-sensitivity (nonlinear terms, lever arms): the device's departure is drawn for linear
/// models only.
fn linear_at(tf: &ThermalFit, t: f64) -> Option<([f64; 4], impl Fn(f64) -> f64)> {
    use crate::columns as col;
    let names = tf.base.term_names();
    let inputs = if col::F.contains(&tf.fit.own.as_str()) {
        col::F
    } else {
        col::W
    };
    let linear = names
        .iter()
        .all(|n| n == "1" || inputs.contains(&n.as_str()) || col::F.contains(&n.as_str()));
    if !linear {
        return None;
    }
    let (b, cov) = tf.coefficients_at(t);
    let at = |n: &str| names.iter().position(|m| m == n);
    let (i1, io) = (at("1")?, at(&tf.fit.own)?);
    let row = [
        b[i1],
        b[at(inputs[0])?],
        b[at(inputs[1])?],
        b[at(inputs[2])?],
    ];
    // The g-sensitivity's terms stay at rest (no specific force).
    let slope = b[io];
    let (c11, c1o, coo) = (cov[(i1, i1)], cov[(i1, io)], cov[(io, io)]);
    Some((row, move |x: f64| {
        (c11 + 2.0 * x * c1o + x * x * coo).max(0.0).sqrt() / slope.abs()
    }))
}

/// A triad's or an IMU's figures: each output's 1-sigma along its own axis over the
/// temperature (at the top of its range), and the device's departure from the model.
fn triad_figures(c: &Calibrated) -> Result<String, Error> {
    let mut h = String::new();
    let Some(first) = c.thermal.first() else {
        return Ok(h);
    };
    let wide = grid(first, 0.15);
    let top = |k: usize| c.ranges.get(k).map_or(0.0, |r| f64::from(r.hi));
    let unit = |k: usize| c.units.get(k).copied().unwrap_or("output units");
    // (output index, name, 1-sigma over temperature)
    type Curve = (usize, String, Vec<(f64, f64)>);
    let sigma: Vec<Curve> = c
        .thermal
        .iter()
        .enumerate()
        .filter_map(|(k, tf)| {
            let points = wide
                .iter()
                .map(|t| linear_at(tf, *t).map(|(_, s)| (*t, s(top(k)))))
                .collect::<Option<Vec<_>>>()?;
            Some((k, tf.fit.output.clone(), points))
        })
        .collect();
    if sigma.len() == c.thermal.len() {
        // One figure per unit: an IMU's accelerometers and gyros apart.
        let families = super::plot::units_in_order(sigma.iter().map(|(k, _, _)| unit(*k)));
        for family in families {
            let y = format!("1-sigma ({family})");
            figure(
                &mut h,
                &Figure {
                    title: "1-sigma calibration error of each corrected output along its own axis, at the top of its range",
                    x: "temperature (C)",
                    y: &y,
                    series: sigma
                        .iter()
                        .filter(|(k, _, _)| unit(*k) == family)
                        .enumerate()
                        .map(|(j, (_, name, p))| Series::curve(name, p, j))
                        .collect(),
                    bands: vec![(first.scale.lo, first.scale.hi)],
                    band_label: "calibrated range",
                    zero_line: true,
                    x_names: None,
                },
            )?;
        }
    }
    if c.blob.is_empty() {
        return Ok(h);
    }
    let cal = spincal::blob::decode(&c.blob)?;
    let env = &cal.data().environment;
    let volt = 0.5 * (env.voltage_span.lo + env.voltage_span.hi);
    if matches!(cal.data().sensor, spincal::model::Sensor::Single { .. }) {
        return Ok(h);
    }
    let mut triad = spincal::correct::AnyTriadCorrector::new(&cal).ok();
    let mut imu = spincal::correct::AnyImuCorrector::new(&cal, 1000.0).ok();
    let temps = grid(first, 0.0);
    let mut departure = Vec::new();
    for t in &temps {
        let Some(models) = c
            .thermal
            .iter()
            .map(|tf| linear_at(tf, *t))
            .collect::<Option<Vec<_>>>()
        else {
            return Ok(h);
        };
        if let Some(d) = triad.as_mut() {
            d.set_environment(*t as f32, volt);
        }
        if let Some(d) = imu.as_mut() {
            d.set_environment(*t as f32, volt);
        }
        let mut worst = 0.0f64;
        for k in 0..models.len() {
            let part = k / 3 * 3;
            for x in [f64::from(c.ranges[k].lo), f64::from(c.ranges[k].hi)] {
                // Codes for input x along axis k alone (the other triad at rest).
                let codes: Vec<i32> = (0..models.len())
                    .map(|j| {
                        let (row, _) = &models[j];
                        let u = if j / 3 * 3 == part {
                            row[0] + row[1 + k - part] * x
                        } else {
                            row[0]
                        };
                        u.round() as i32
                    })
                    .collect();
                let got = if let Some(d) = triad.as_ref() {
                    f64::from(d.correct([codes[0], codes[1], codes[2]]).values[k])
                } else if let Some(d) = imu.as_mut() {
                    let raw = [codes[0], codes[1], codes[2], codes[3], codes[4], codes[5]];
                    d.reset();
                    let _ = d.correct(raw);
                    f64::from(d.correct(raw).values[k])
                } else {
                    return Ok(h);
                };
                // The model's own correction of the rounded codes.
                let s = nalgebra::Matrix3::from_fn(|i, j| models[part + i].0[1 + j]);
                let b = nalgebra::Vector3::from_fn(|i, _| models[part + i].0[0]);
                let u = nalgebra::Vector3::from_fn(|i, _| f64::from(codes[part + i]));
                let Some(inv) = s.try_inverse() else {
                    return Ok(h);
                };
                let want = (inv * (u - b))[k - part];
                worst = worst.max((got - want).abs() / (models[k].1)(want));
            }
        }
        departure.push((*t, worst));
    }
    departure_figure(
        &mut h,
        c,
        env.temperature_model,
        "the outputs and the ends of their ranges",
        &departure,
    )?;
    Ok(h)
}

/// The figure of the device's departure from the model over the temperature (worst over
/// `over`, in the model's 1-sigma).
fn departure_figure(
    h: &mut String,
    c: &Calibrated,
    model: TemperatureModel,
    over: &str,
    departure: &[(f64, f64)],
) -> Result<(), Error> {
    let what = match model {
        TemperatureModel::Chebyshev(n) => format!("Chebyshev series of {n} terms"),
        TemperatureModel::Table => format!("table of {} temperatures", c.temps.len()),
    };
    figure(
        h,
        &Figure {
            title: &format!(
                "the device's {what} against the model: worst departure over {over}, in the model's 1-sigma"
            ),
            x: "temperature (C)",
            y: "departure / 1-sigma",
            series: vec![Series::curve("device - model", departure, 3)],
            bands: Vec::new(),
            band_label: "",
            zero_line: true,
            x_names: None,
        },
    )?;
    Ok(())
}
