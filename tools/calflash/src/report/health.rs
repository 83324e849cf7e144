//! The health report: one HTML page with the verdict first, what the check rested on, and each
//! output's refined bias held against the calibration's stated 1-sigma (a table, and a figure of
//! each bias in those sigmas with its own 1-sigma bar: one unit, the sigma, on its axis).

use std::fmt::Write as _;

use super::Error;
use super::page::{STYLE, esc};
use super::plot::{Figure, Series, figure};
use super::terminal::num;
use spincal::health::{Health, Verdict};

/// The outputs, in the health's order.
pub const OUTPUTS: [&str; 6] = ["ax", "ay", "az", "wx", "wy", "wz"];

/// The page of `h` for unit `serial`, from `source`, with `said` (how the temperature was
/// found, when the host ran the check).
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(serial: &str, source: &str, h: &Health, said: Option<&str>) -> Result<String, Error> {
    let mut p = String::new();
    let class = match h.verdict {
        Verdict::NotYet => "notyet",
        Verdict::Ok => "accept",
        Verdict::Drifted => "review",
        Verdict::Suspect => "reject",
    };
    let _ = writeln!(
        p,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Health of unit {0}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>Health of unit {0} at rest</h1>\n<p>From {1}.</p>\n<p class=\"verdict {class}\">{2}</p>\n<p>{3}</p>",
        esc(serial),
        esc(source),
        h.verdict.word(),
        esc(meaning(h.verdict))
    );
    if let Some(s) = said {
        let _ = writeln!(p, "<p>{}</p>", esc(s.trim()));
    }
    let _ = writeln!(
        p,
        "<h2>What the check rested on</h2>\n<ul><li>{:.1} s at rest in {} windows; {} windows taken as moving; {} samples left out (not a number, saturated, or beyond the calibration).</li>\n<li>The largest per-axis statistic is {} under the factory prior (threshold {}) and {} with the calibration's ageing allowed (threshold {}): the thresholds follow from the stated false-alarm rate, not from tuning.</li>\n<li>Gravity's magnitude is off the assumed value by {} m/s^2 (1-sigma {}).</li></ul>",
        h.rest_s,
        h.rest_windows,
        h.moving_windows,
        h.ignored_samples,
        num(f64::from(h.statistic[0])),
        num(f64::from(h.threshold[0])),
        num(f64::from(h.statistic[1])),
        num(f64::from(h.threshold[1])),
        num(f64::from(h.gravity_error[0])),
        num(f64::from(h.gravity_error[1]))
    );
    p.push_str("<h2>Each output's bias</h2>\n<table><tr><th>output</th><th>refined bias</th><th>its 1-sigma</th><th>the calibration's 1-sigma</th><th>bias / calibration's 1-sigma</th></tr>\n");
    let mut ratio = Vec::new();
    let mut bars = Vec::new();
    for (i, name) in OUTPUTS.iter().enumerate() {
        let unit = if i < 3 { "m/s^2" } else { "rad/s" };
        let stated = f64::from(h.stated_sigma[i]);
        let r = if stated > 0.0 {
            f64::from(h.bias[i]) / stated
        } else {
            f64::NAN
        };
        let _ = writeln!(
            p,
            "<tr><td>{name}</td><td>{} {unit}</td><td>{} {unit}</td><td>{} {unit}</td><td>{}</td></tr>",
            num(f64::from(h.bias[i])),
            num(f64::from(h.bias_sigma[i])),
            num(stated),
            if r.is_finite() {
                format!("{r:+.2}")
            } else {
                "-".to_string()
            }
        );
        if r.is_finite() {
            ratio.push(((i + 1) as f64, r));
            bars.push(f64::from(h.bias_sigma[i]) / stated);
        }
    }
    p.push_str("</table>\n");
    let wider: Vec<&str> = OUTPUTS
        .iter()
        .enumerate()
        .filter(|(i, _)| h.bias_sigma[*i] > 1.05 * h.stated_sigma[*i] && h.stated_sigma[*i] > 0.0)
        .map(|(_, name)| *name)
        .collect();
    if !wider.is_empty() {
        let _ = writeln!(
            p,
            "<p>Why the refined 1-sigma of {} is wider than the calibration's: the refined biases are those of the check that allows the calibration's ageing, so each starts from the calibration's 1-sigma widened by its bias random walk over the stated ageing time. At rest in one pose an accelerometer is observed along gravity only (a gyro on every axis, against zero rate): across gravity its bias keeps that widened start until the unit is turned to another pose.</p>",
            wider.join(", ")
        );
    }
    if !ratio.is_empty() {
        let mut s = Series::dots("refined bias, with its 1-sigma", &ratio, 0);
        s.errors = Some(&bars);
        figure(
            &mut p,
            &Figure {
                title: "Refined bias of each output, in the calibration's stated 1-sigma",
                x: "output (a: accelerometer, w: gyro)",
                y: "bias / stated 1-sigma",
                series: vec![s],
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: Some(&OUTPUTS),
            },
        )?;
    }
    p.push_str("</body>\n</html>\n");
    Ok(p)
}

/// What a verdict means to the person holding the unit.
fn meaning(v: Verdict) -> &'static str {
    match v {
        Verdict::NotYet => {
            "The unit has not rested long enough for a verdict: give it a longer stretch at rest."
        }
        Verdict::Ok => {
            "The biases at rest agree with the calibration within what its stated uncertainty explains."
        }
        Verdict::Drifted => {
            "A bias moved beyond the calibration's stated uncertainty, but within what the allowed ageing (its bias random walk) explains: the unit corrects with the refined biases."
        }
        Verdict::Suspect => {
            "A bias moved beyond what the calibration and its allowed ageing explain: the unit flags every sample; recalibrate it before it flies."
        }
    }
}
