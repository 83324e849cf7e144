//! The calibration report: one HTML file with inline SVG figures, the verdict first.

use super::Error;
use std::fmt::Write as _;

use super::page::{STYLE, esc};
use super::plot::{Figure, Series, Sheet, figure};
use super::terminal::{num, pval};
use crate::sensor::{AxisFit, Calibrated};

/// Renders the report.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn render(c: &Calibrated, data_file: &str) -> Result<String, Error> {
    let id = &c.data.identity;
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Calibration {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        esc(id.serial.as_str())
    );
    summary(&mut h, c, data_file);
    model(&mut h, c)?;
    for (a, axis) in c.points[c.reference].axes.iter().enumerate() {
        axis_section(&mut h, c, a, axis)?;
    }
    // With a continuous temperature model its section draws bias and scale over the whole
    // span; the table's few points would only repeat it.
    temperature_section(&mut h, c)?;
    h.push_str(&super::spin::section(c)?);
    h.push_str(&super::thermal::section(c)?);
    if let Some(m) = &c.mission {
        h.push_str(&super::mission::judged_html(m)?);
    }
    let _ = writeln!(
        h,
        "<h2>Device</h2>\n<p>The blob holds {} coefficient set{} with covariance factors; the device's f32 correction differs from the f64 correction by at most {}.</p>",
        c.points.len(),
        if c.points.len() == 1 { "" } else { "s" },
        num(c.device_error)
    );
    let _ = writeln!(h, "</body>\n</html>");
    Ok(super::page::with_contents(&h))
}

/// The unit, its codes, the verdict and its findings, and where the data came from.
fn summary(h: &mut String, c: &Calibrated, data_file: &str) {
    let id = &c.data.identity;
    let verdict = c.verdict();
    let _ = writeln!(
        h,
        "<h1>Calibration of unit {}</h1>",
        esc(id.serial.as_str())
    );
    let rails = c.data.sensor.rails();
    let _ = writeln!(
        h,
        "<p>Codes {} (rails {} and {}); the device takes the samples as <code>{}</code>.</p>",
        esc(&crate::obs::codes::name(rails)),
        rails.lo,
        rails.hi,
        rails.format.name()
    );
    let _ = writeln!(
        h,
        "<p class=\"verdict {}\">{}</p>",
        verdict.word().to_lowercase(),
        verdict.word()
    );
    // What needs a person first; the checks that passed folded under one line.
    let (passed, open): (Vec<_>, Vec<_>) = c
        .findings
        .iter()
        .partition(|f| f.verdict == crate::sensor::finding::Verdict::Accept);
    if !open.is_empty() {
        let _ = writeln!(h, "<ul>");
        for f in &open {
            let _ = writeln!(h, "<li><b>{}</b>: {}</li>", f.verdict.word(), esc(&f.text));
        }
        let _ = writeln!(h, "</ul>");
    }
    if !passed.is_empty() {
        let _ = writeln!(
            h,
            "<details><summary>{} check(s) passed (ACCEPT)</summary><ul>",
            passed.len()
        );
        for f in &passed {
            let _ = writeln!(h, "<li>{}</li>", esc(&f.text));
        }
        let _ = writeln!(h, "</ul></details>");
    }
    // The datasheet's figures, as the terminal prints them.
    let sheet = super::engineering::lines(c);
    if !sheet.is_empty() {
        let _ = writeln!(
            h,
            "<p><b>In engineering units</b> (bias: the reading at zero input from the converter's mid-scale; 1-sigma in brackets):</p><ul>"
        );
        for line in &sheet {
            let _ = writeln!(h, "<li>{}</li>", esc(line.trim()));
        }
        let _ = writeln!(h, "</ul>");
    }
    let hash: String = id.data_hash.iter().map(|b| format!("{b:02x}")).collect();
    let _ = writeln!(
        h,
        "<p>Data {} (SHA-256 {}&#8230;), {} observations {}; calflash {}.{}.{}; blob {} bytes.</p>",
        esc(data_file),
        hash,
        // Each observation once: a continuous temperature model fits every observation at
        // each of the device's breakpoints.
        c.points
            .iter()
            .flat_map(|p| p.axes[0].lines.iter())
            .collect::<std::collections::HashSet<_>>()
            .len(),
        if c.thermal.is_empty() {
            format!(
                "at {} table point{}",
                c.points.len(),
                if c.points.len() == 1 { "" } else { "s" }
            )
        } else {
            format!(
                "in one model continuous in temperature (the device holds it as {} coefficient set{})",
                c.points.len(),
                if c.points.len() == 1 { "" } else { "s" }
            )
        },
        id.tool_version[0],
        id.tool_version[1],
        id.tool_version[2],
        c.blob.len()
    );
}

/// The notes on the model, and each test that decided a term (with the residuals without it).
fn model(h: &mut String, c: &Calibrated) -> Result<(), Error> {
    let _ = writeln!(h, "<h2>Model</h2>\n<ul>");
    for n in &c.notes {
        let _ = writeln!(h, "<li>{}</li>", esc(n));
    }
    let _ = writeln!(h, "</ul>");
    for d in &c.decisions {
        let _ = writeln!(
            h,
            "<h2>{}</h2>\n<p>Partial F = {} on ({}, {}) dof, p = {}: {}. {}.</p>",
            esc(&d.name),
            num(d.test.f),
            d.test.df_num,
            d.test.df_den,
            pval(d.test.p),
            if d.kept {
                "kept in the device model"
            } else {
                "not in the device model"
            },
            esc(&d.detail)
        );
        if !d.figure.is_empty() {
            let series = d
                .figure
                .iter()
                .enumerate()
                .map(|(k, (name, pts))| Series::dots(name, pts, k))
                .collect();
            let unit = c.units.first().copied().unwrap_or("");
            residual_figure(
                (h, &mut Sheet::new(false)),
                (
                    &format!("{}: residuals without the term", d.name),
                    &format!("input ({unit})"),
                ),
                (series, unit),
                None,
            )?;
        }
    }

    Ok(())
}

/// One output axis at the reference point: its fit, its residuals and its calibration error
/// over the range.
fn axis_section(h: &mut String, c: &Calibrated, a: usize, axis: &AxisFit) -> Result<(), Error> {
    let reference = &c.points[c.reference];
    let unit = c.units[a];
    let _ = writeln!(h, "<h2>{} at the reference point</h2>", esc(&axis.output));
    let f = &axis.fit;
    let _ = writeln!(
        h,
        "<p>{}: residual sigma {} counts ({} {unit}), R&#178; {}, inversion error {} {unit}.</p>",
        esc(&axis.formula.to_string()),
        num(f.sigma2.sqrt()),
        num(reference.noise[a]),
        num(f.r2),
        num(reference.inversion_error[a])
    );
    let _ = writeln!(
        h,
        "<table><tr><th>term</th><th>coefficient</th><th>std error</th><th>t</th><th>p</th></tr>"
    );
    for j in 0..f.p {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&f.names[j]),
            num(f.coefficients[j]),
            num(f.std_errors[j]),
            num(f.t[j]),
            pval(f.p_values[j])
        );
    }
    let _ = writeln!(h, "</table>");
    // A triad's or an IMU's outputs: each one's figures as a row of small multiples.
    let mut sheet = Sheet::new(reference.axes.len() > 1);
    residual_figures(h, &mut sheet, c, a, axis)?;
    error_figure(h, &mut sheet, c, a, axis)?;
    sheet.finish(h);
    Ok(())
}

/// The residuals of axis `a` at every table point, against the input and in test order.
fn residual_figures(
    h: &mut String,
    sheet: &mut Sheet,
    c: &Calibrated,
    a: usize,
    axis: &AxisFit,
) -> Result<(), Error> {
    let unit = c.units[a];
    // Residuals against the input, every table point. A model continuous in temperature is
    // one fit of every observation, which each of the device's points carries: drawn once
    // (issue 68: each residual was drawn once per point, at temperatures it was not taken at).
    let points: &[crate::sensor::PointFit] = if c.thermal.is_empty() {
        &c.points
    } else {
        std::slice::from_ref(&c.points[c.reference])
    };
    // In the input's unit: each point's residual counts over its own scale factor.
    let by_point: Vec<Vec<(f64, f64)>> = points
        .iter()
        .map(|p| {
            let scale = p.axes[a].coef(&axis.own);
            p.axes[a]
                .input
                .iter()
                .copied()
                .zip(p.axes[a].fit.residuals.iter().map(|r| r / scale))
                .collect()
        })
        .collect();
    // A legend names the table points; with only one, it says what the marks are.
    let names: Vec<String> = points
        .iter()
        .map(|p| {
            if points.len() == 1 {
                "observations".to_string()
            } else {
                crate::sensor::table::describe(&crate::sensor::table::Point {
                    temp: p.temp,
                    volt: p.volt,
                    rows: vec![],
                })
            }
        })
        .collect();
    let series = by_point
        .iter()
        .zip(&names)
        .enumerate()
        .map(|(k, (pts, name))| Series::dots(name, pts, k))
        .collect();
    let range = c.ranges[a];
    let title = titled(sheet, &axis.output, "residuals against the input");
    residual_figure(
        (h, sheet),
        (&title, &format!("{} ({unit})", axis.own)),
        (series, unit),
        Some((f64::from(range.lo), f64::from(range.hi))),
    )?;
    let order: Vec<Vec<(f64, f64)>> = points
        .iter()
        .map(|p| {
            let scale = p.axes[a].coef(&axis.own);
            p.axes[a]
                .lines
                .iter()
                .map(|l| *l as f64)
                .zip(p.axes[a].fit.residuals.iter().map(|r| r / scale))
                .collect()
        })
        .collect();
    let series = order
        .iter()
        .zip(&names)
        .enumerate()
        .map(|(k, (pts, name))| Series::dots(name, pts, k))
        .collect();
    let title = titled(sheet, &axis.output, "residuals in test order");
    residual_figure(
        (h, sheet),
        (&title, "line of the data file"),
        (series, unit),
        None,
    )?;
    Ok(())
}

/// A figure's title: `what` alone in a row of small multiples under the output's heading,
/// "output: what" on its own.
fn titled(sheet: &Sheet, output: &str, what: &str) -> String {
    if sheet.small() {
        what.to_string()
    } else {
        format!("{output}: {what}")
    }
}

/// A figure of residuals about zero in the input's `unit` (each residual count over the scale
/// factor), titled and with its x axis as `(title, x)`, and the calibrated range when `range`
/// is given.
fn residual_figure(
    (h, sheet): (&mut String, &mut Sheet),
    (title, x): (&str, &str),
    (series, unit): (Vec<Series<'_>>, &str),
    range: Option<(f64, f64)>,
) -> Result<(), Error> {
    let y = format!("residual ({unit})");
    sheet.add(
        h,
        &Figure {
            title,
            x,
            y: &y,
            series,
            bands: range.into_iter().collect(),
            band_label: if range.is_some() {
                "calibrated range"
            } else {
                ""
            },
            zero_line: true,
            x_names: None,
        },
    )
}

/// The calibration's own 1-sigma error of axis `a` over its calibrated range and half a range
/// beyond each end.
fn error_figure(
    h: &mut String,
    sheet: &mut Sheet,
    c: &Calibrated,
    a: usize,
    axis: &AxisFit,
) -> Result<(), Error> {
    let unit = c.units[a];
    let f = &axis.fit;
    let range = c.ranges[a];
    // The calibration's own error over and beyond the calibrated range.
    let (lo, hi) = (f64::from(range.lo), f64::from(range.hi));
    let w = hi - lo;
    let slope = axis.coef(&axis.own).abs();
    let curve: Vec<(f64, f64)> = (0..=200)
        .map(|k| {
            let x = lo - 0.5 * w + 2.0 * w * f64::from(k) / 200.0;
            let mut row = Vec::new();
            axis.formula.row(
                |v| {
                    if v == axis.own {
                        x
                    } else if v == crate::sensor::single::KINK {
                        (x - c.breakpoint).abs() - c.breakpoint.abs()
                    } else {
                        0.0
                    }
                },
                &mut row,
            );
            (x, f.predict(&row).variance.sqrt() / slope)
        })
        .collect();
    sheet.add(
        h,
        &Figure {
            title: &titled(
                sheet,
                &axis.output,
                "1-sigma calibration error over the range",
            ),
            x: &format!("{} ({unit})", axis.own),
            y: &format!("1-sigma ({unit})"),
            series: vec![Series::curve("prediction standard error", &curve, 0)],
            bands: vec![(lo, hi)],
            band_label: "calibrated range",
            zero_line: true,
            x_names: None,
        },
    )?;
    Ok(())
}

/// One output's bias and scale factor at each temperature with their 1-sigma, as changes from
/// the reference point's (the datasheet summary gives their values there): the bias at zero
/// input in the output's own unit, the scale factor in ppm.
struct AgainstTemperature {
    bias: Vec<(f64, f64)>,
    bias_err: Vec<f64>,
    scale: Vec<(f64, f64)>,
    scale_err: Vec<f64>,
}

/// [`AgainstTemperature`] of axis `a`: `None` without two temperatures or a usable reference
/// scale factor.
fn against_temperature(c: &Calibrated, a: usize, axis: &AxisFit) -> Option<AgainstTemperature> {
    // In the units a datasheet reads: the bias at zero input from the converter's mid-scale,
    // through the scale factor at that temperature.
    let mid = super::engineering::mid_scale(c, &axis.output);
    let own = axis.own.as_str();
    let s_ref = c
        .points
        .get(c.reference)
        .map(|p| p.axes[a].coef(own))
        .filter(|s| s.is_finite() && *s != 0.0)?;
    if c.temps.len() < 2 {
        return None;
    }
    let se = |p: &crate::sensor::PointFit, term: &str| {
        p.axes[a]
            .index(term)
            .map_or(0.0, |i| p.axes[a].fit.std_errors[i])
    };
    let at: Vec<&crate::sensor::PointFit> = c.points.iter().filter(|p| p.temp.is_some()).collect();
    let bias = |p: &crate::sensor::PointFit| (p.axes[a].coef("1") - mid) / p.axes[a].coef(own);
    let b_ref = c.points.get(c.reference).map(bias)?;
    Some(AgainstTemperature {
        bias: at
            .iter()
            .filter_map(|p| Some((p.temp?, bias(p) - b_ref)))
            .collect(),
        bias_err: at
            .iter()
            .map(|p| se(p, "1") / p.axes[a].coef(own).abs())
            .collect(),
        scale: at
            .iter()
            .filter_map(|p| Some((p.temp?, (p.axes[a].coef(own) / s_ref - 1.0) * 1e6)))
            .collect(),
        scale_err: at.iter().map(|p| se(p, own) / s_ref.abs() * 1e6).collect(),
    })
}

/// The outputs' bias and scale factor against temperature, a figure of each per unit (the
/// three accelerometers together, the three gyros together), each output a series with its
/// 1-sigma bars: where the table's temperatures are the only thermal model.
fn temperature_section(h: &mut String, c: &Calibrated) -> Result<(), Error> {
    if c.temps.len() < 2 || !c.thermal.is_empty() {
        return Ok(());
    }
    let axes = &c.points[c.reference].axes;
    let each: Vec<(usize, AgainstTemperature)> = axes
        .iter()
        .enumerate()
        .filter_map(|(a, axis)| Some((a, against_temperature(c, a, axis)?)))
        .collect();
    if each.is_empty() {
        return Ok(());
    }
    let t_ref = c
        .points
        .get(c.reference)
        .and_then(|p| p.temp)
        .map_or(String::new(), |t| format!(" {t:.1} C"));
    let _ = writeln!(
        h,
        "<h2>Bias and scale factor against temperature</h2>\n<p>At each table point, as changes from the reference point's{t_ref} (their values there are in the summary above): the bias at zero input (from the converter's mid-scale, through that point's scale factor) in the output's unit, and the scale factor in ppm; the bars are each point's 1-sigma.</p>"
    );
    for unit in super::plot::units_in_order(each.iter().map(|(a, _)| c.units[*a])) {
        let of_unit: Vec<&(usize, AgainstTemperature)> =
            each.iter().filter(|(a, _)| c.units[*a] == unit).collect();
        let bias_label = format!("bias change from{t_ref} ({unit})");
        let scale_label = format!("scale factor change from{t_ref} (ppm)");
        for (what, bias) in [(bias_label.as_str(), true), (scale_label.as_str(), false)] {
            let series = of_unit
                .iter()
                .enumerate()
                .map(|(k, (a, t))| {
                    let (pts, errs) = if bias {
                        (&t.bias, &t.bias_err)
                    } else {
                        (&t.scale, &t.scale_err)
                    };
                    Series {
                        errors: Some(errs),
                        ..Series::curve(&axes[*a].output, pts, k)
                    }
                })
                .collect();
            let names: Vec<&str> = of_unit
                .iter()
                .map(|(a, _)| axes[*a].output.as_str())
                .collect();
            figure(
                h,
                &Figure {
                    title: &format!("{}: {what} against temperature", names.join(", ")),
                    x: "temperature (C)",
                    y: what,
                    series,
                    bands: Vec::new(),
                    band_label: "",
                    zero_line: false,
                    x_names: None,
                },
            )?;
        }
    }
    Ok(())
}
