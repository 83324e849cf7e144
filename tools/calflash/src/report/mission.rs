//! A mission profile's summary as text.

use std::fmt::Write;

use crate::mission::Profile;
use crate::mission::summary::{BINS, Summary};

const G: f64 = 9.806_65;
const AXES: [&str; 3] = ["x", "y", "z"];

/// The summary as the terminal shows it; `k2` (ug/g^2 per axis) adds the rectification error.
#[must_use]
pub fn text(p: &Profile, s: &Summary, k2: Option<[f64; 3]>) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Mission profile {}: {} samples over {:.3} s (step {:.3e} s, {:.0} Hz)",
        p.source.display(),
        s.samples,
        s.duration,
        s.step,
        1.0 / s.step
    );
    for n in &s.notes {
        let _ = writeln!(o, "  note: {n}");
    }
    let _ = writeln!(
        o,
        "\n  {:<6} {:>12} {:>12} {:>12} {:>12}   time at each of {BINS} levels, min to max (%)",
        "", "min", "max", "mean", "rms"
    );
    for r in &s.ranges {
        let shares: Vec<String> = r
            .time_share
            .iter()
            .map(|v| format!("{:.0}", 100.0 * v))
            .collect();
        let _ = writeln!(
            o,
            "  {:<6} {:>12.4} {:>12.4} {:>12.4} {:>12.4}   {}",
            r.name,
            r.min,
            r.max,
            r.mean,
            r.rms,
            shares.join(" ")
        );
    }
    let _ = writeln!(
        o,
        "  (f in m/s^2, w in rad/s, dw in rad/s^2, temp in C, volt in V)"
    );
    if let Some(pk) = &s.peak {
        let _ = writeln!(
            o,
            "\n  Peak specific force: {:.1} m/s^2 ({:.1} g) along {}{} at t = {:.4} s",
            pk.value.abs(),
            pk.value.abs() / G,
            if pk.value < 0.0 { "-" } else { "+" },
            AXES[pk.axis],
            pk.t
        );
    }
    if let Some(sp) = &s.spin {
        let over: Vec<String> = sp
            .over_time
            .iter()
            .map(|(t, r)| format!("{t:.1} s {r:.1}"))
            .collect();
        let _ = writeln!(
            o,
            "  Spin about {}: peak {:.1} rev/s ({:.0} deg/s); over the flight (rev/s): {}",
            AXES[sp.axis],
            sp.peak_rev_s,
            sp.peak_rev_s * 360.0,
            over.join(", ")
        );
    }
    match &s.no_vibration {
        Some(why) => {
            let _ = writeln!(o, "  Vibration: not measured: {why}");
        }
        None => {
            let _ = writeln!(
                o,
                "\n  Vibration above {} Hz (specific force less its moving average; in a rolling unit the transverse\n  rigid-body forces turn at the spin rate and count here too):",
                s.vibration_above
            );
            for v in &s.vibration {
                let bands: Vec<String> = v
                    .bands
                    .iter()
                    .map(|(lo, hi, ms)| format!("{lo:.0}-{hi:.0} Hz {:.3e}", ms.sqrt()))
                    .collect();
                let rect = match k2 {
                    Some(k) => format!(
                        "K2 {} ug/g^2 rectifies {:.2} ug",
                        k[v.axis],
                        k[v.axis] * v.mean_square_g2
                    ),
                    None => format!(
                        "K2 of 1 ug/g^2 rectifies {:.3} ug",
                        v.rectification_ug_per_ug_g2
                    ),
                };
                let _ = writeln!(
                    o,
                    "    {}: rms {:.4} g, peak at {:.1} Hz; {rect}; band rms (g): {}",
                    AXES[v.axis],
                    v.mean_square_g2.sqrt(),
                    v.peak_hz,
                    bands.join(", ")
                );
                if let (Some(first), Some(last)) = (v.transients.first(), v.transients.last()) {
                    let _ = writeln!(
                        o,
                        "       {} of {} segments left out as transients (over ten times the lower quartile's mean square), from t = {first:.3} s to {last:.3} s",
                        v.transients.len(),
                        v.segments
                    );
                }
            }
        }
    }
    o
}

/// One plan over a mission, per block: the prediction's standard deviation in units of the
/// output noise, averaged (RMS) and at its worst, over the flight's moments the equipment
/// reaches and over the rest (extrapolation).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PlanOverMission {
    /// The plan.
    pub plan: String,
    /// Observations.
    pub n: usize,
    /// Per block: `tr(C B)` over the reach (the mean prediction variance, sigma^2 units).
    pub mean_inside: Vec<f64>,
    /// The largest `f' C f` there.
    pub worst_inside: Vec<f64>,
    /// `tr(C B)` beyond the reach.
    pub mean_beyond: Vec<f64>,
    /// The largest `f' C f` there.
    pub worst_beyond: Vec<f64>,
}

/// A set of plans over one mission.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OverMission {
    /// The profile.
    pub profile: String,
    /// What set the reach ("the candidates", "the plans").
    pub reach: String,
    /// Per block: its label, the share of the flight inside the reach, and what is beyond.
    pub blocks: Vec<(String, f64, String)>,
    /// Variables assumed (a flight without a temperature column).
    pub assumed: Vec<String>,
    /// The plans.
    pub plans: Vec<PlanOverMission>,
}

/// The plans over the mission as the terminal shows them: per block, each plan's RMS and worst
/// prediction error in units of the noise (1 sigma) where the bench reaches and beyond it, and
/// its mean prediction variance against the first plan's.
#[must_use]
pub fn plans_text(m: &OverMission) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "\nOver the mission {} (prediction error in units of the output noise, 1 sigma):",
        m.profile
    );
    if !m.assumed.is_empty() {
        let _ = writeln!(
            o,
            "  the profile does not give {}: the bench's value is assumed",
            m.assumed.join(", ")
        );
    }
    let width = m
        .plans
        .iter()
        .map(|p| p.plan.len())
        .max()
        .unwrap_or(8)
        .clamp(12, 40);
    for (b, (label, inside, beyond)) in m.blocks.iter().enumerate() {
        let _ = writeln!(
            o,
            "  {}{} % of the flight within what {} reach; beyond: {beyond}",
            if m.blocks.len() > 1 {
                format!("axis {label}: ")
            } else {
                String::new()
            },
            crate::design::space::percent(*inside),
            m.reach
        );
        let _ = writeln!(
            o,
            "    {:<width$} {:>5} {:>10} {:>10} {:>12} {:>10} {:>10}",
            "plan", "n", "rms", "worst", "variance/1st", "rms beyond", "worst"
        );
        let first = m.plans.first().map_or(1.0, |p| p.mean_inside[b]);
        for p in &m.plans {
            let beyond = |v: f64| {
                if *inside < 1.0 {
                    crate::report::terminal::num(v.sqrt())
                } else {
                    "-".to_string()
                }
            };
            let _ = writeln!(
                o,
                "    {:<width$} {:>5} {:>10.4} {:>10.4} {:>12.3} {:>10} {:>10}",
                clip(&p.plan, width),
                p.n,
                p.mean_inside[b].sqrt(),
                p.worst_inside[b].sqrt(),
                p.mean_inside[b] / first,
                beyond(p.mean_beyond[b]),
                beyond(p.worst_beyond[b]),
            );
        }
    }
    o
}

/// `text` cut to `width` characters, its end marked.
fn clip(text: &str, width: usize) -> String {
    if text.chars().count() <= width {
        text.to_string()
    } else {
        let head: String = text.chars().take(width.saturating_sub(3)).collect();
        format!("{head}...")
    }
}

/// A calibration judged over a mission, as the terminal shows it.
#[must_use]
pub fn judged_text(m: &crate::mission::judge::Judged) -> String {
    use crate::report::terminal::num;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "  mission {}: predicted 1-sigma error over the flight within the calibrated range",
        m.profile
    );
    if !m.assumed.is_empty() {
        let _ = writeln!(
            o,
            "    the profile does not give {}: the bench's value is assumed",
            m.assumed.join(", ")
        );
    }
    for x in &m.outputs {
        let _ = writeln!(
            o,
            "    {}: rms {} {u}, worst {} {u}{}; {} % of the flight within range{}",
            x.output,
            num(x.rms),
            num(x.worst),
            x.requirement
                .map(|r| format!(" (requirement {r})"))
                .unwrap_or_default(),
            crate::design::space::percent(x.share_inside),
            if x.share_inside < 1.0 {
                format!("; beyond: {}", x.beyond)
            } else {
                String::new()
            },
            u = x.unit,
        );
    }
    for t in m.terms.iter().take(5) {
        let unit = m
            .outputs
            .iter()
            .find(|x| x.output == t.output)
            .map_or("", |x| x.unit);
        let _ = writeln!(
            o,
            "    left-out term {} of {}: bench bound {}, up to {} {unit} over the flight",
            t.term,
            t.output,
            num(t.bound),
            num(t.worst)
        );
    }
    o
}

/// The report's section on the mission: the predicted 1-sigma error along the flight per
/// output (within the calibrated range; the times beyond it shaded), and the left-out terms.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn judged_html(m: &crate::mission::judge::Judged) -> Result<String, crate::report::Error> {
    use crate::report::page::esc;
    use crate::report::plot::{Figure, Series, figure};
    use crate::report::terminal::num;
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<h2>Over the mission</h2>\n<p>The flight {}: each output's predicted 1-sigma error from the fit's covariance at every moment of the flight; where the flight goes beyond the calibrated range (shaded) the calibration extrapolates.</p>",
        esc(&m.profile)
    );
    // One figure per unit (an IMU's accelerometers and gyros apart), each shaded where its
    // first output goes beyond the calibrated range.
    let families = crate::report::plot::units_in_order(m.outputs.iter().map(|x| x.unit));
    for unit in families {
        let outputs: Vec<&crate::mission::judge::Output> =
            m.outputs.iter().filter(|x| x.unit == unit).collect();
        let series: Vec<(String, Vec<(f64, f64)>)> = outputs
            .iter()
            .map(|x| {
                (
                    x.output.clone(),
                    x.timeline
                        .iter()
                        .filter(|p| p.2)
                        .map(|p| (p.0, p.1))
                        .collect(),
                )
            })
            .collect();
        let y = format!("predicted 1-sigma error, {unit}");
        // The requirement across the flight, so the figure says how far inside it the error is.
        let span = outputs
            .iter()
            .flat_map(|x| x.timeline.iter().map(|p| p.0))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
        let requirements: Vec<(String, Vec<(f64, f64)>)> = outputs
            .iter()
            .filter_map(|x| {
                x.requirement.filter(|_| span.0 < span.1).map(|r| {
                    (
                        format!("requirement, {}", x.output),
                        vec![(span.0, r), (span.1, r)],
                    )
                })
            })
            .fold(Vec::new(), |mut v, (name, pts)| {
                // One line for a requirement the outputs share.
                if let Some(same) = v
                    .iter_mut()
                    .find(|(_, p): &&mut (String, Vec<(f64, f64)>)| p == &pts)
                {
                    same.0 = format!("requirement {} {unit}", num(pts[0].1));
                } else {
                    v.push((name, pts));
                }
                v
            });
        let title = format!("Predicted error along the flight, {unit}");
        figure(
            &mut h,
            &Figure {
                title: &title,
                x: "time, s",
                y: &y,
                series: series
                    .iter()
                    .enumerate()
                    .map(|(k, (name, pts))| Series::curve(name, pts, k))
                    .chain(
                        requirements
                            .iter()
                            .enumerate()
                            .map(|(k, (name, pts))| Series::curve(name, pts, series.len() + k)),
                    )
                    .collect(),
                bands: outputs.first().map_or_else(Vec::new, |x| beyond(x)),
                band_label: "beyond the calibrated range",
                zero_line: false,
                x_names: None,
            },
        )?;
    }
    h.push_str("<table class=\"terms\">\n<tr><th>output</th><th>unit</th><th>rms</th><th>worst</th><th>within range</th><th>requirement</th></tr>\n");
    for x in &m.outputs {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} %</td><td>{}</td></tr>",
            esc(&x.output),
            esc(x.unit),
            num(x.rms),
            num(x.worst),
            crate::design::space::percent(x.share_inside),
            x.requirement.map_or("-".to_string(), num),
        );
    }
    h.push_str("</table>\n");
    left_out_figure(&mut h, m)?;
    if !m.terms.is_empty() {
        h.push_str("<p>Terms the model leaves out, at their bench bound (the upper confidence bound of the coefficient with the term added), over the flight; the estimate and the bound are in counts per unit of the term, what they may cost in the output's unit:</p>\n<table class=\"terms\">\n<tr><th>output</th><th>term</th><th>estimate</th><th>bound</th><th>up to, over the flight</th><th>unit</th></tr>\n");
        for t in &m.terms {
            let unit = m
                .outputs
                .iter()
                .find(|x| x.output == t.output)
                .map_or("", |x| x.unit);
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&t.output),
                esc(&t.term),
                num(t.estimate),
                num(t.bound),
                num(t.worst),
                esc(unit)
            );
        }
        h.push_str("</table>\n");
    }
    Ok(h)
}

/// Left-out terms the figure names on its axis (the table lists them all).
const LEFT_OUT_SHOWN: usize = 8;

/// The terms the model leaves out, each at what it may cost over the flight, beside each
/// output's worst predicted error and its requirement, one figure per unit: what makes a
/// mission's verdict REVIEW when the predicted error alone is within the requirement.
///
/// # Errors
/// A figure that cannot be drawn.
fn left_out_figure(
    h: &mut String,
    m: &crate::mission::judge::Judged,
) -> Result<(), crate::report::Error> {
    use crate::report::plot::{Figure, Series, figure};
    for unit in crate::report::plot::units_in_order(m.outputs.iter().map(|x| x.unit)) {
        let outputs: Vec<&crate::mission::judge::Output> =
            m.outputs.iter().filter(|x| x.unit == unit).collect();
        // The costliest first (the judge's order), as many as the axis can name.
        let all: Vec<_> = m
            .terms
            .iter()
            .filter(|t| outputs.iter().any(|x| x.output == t.output))
            .collect();
        if all.is_empty() {
            continue;
        }
        let terms = &all[..all.len().min(LEFT_OUT_SHOWN)];
        let names: Vec<String> = terms
            .iter()
            .map(|t| format!("{}: {}", t.output, t.term))
            .collect();
        let labels: Vec<&str> = names.iter().map(String::as_str).collect();
        let costs: Vec<(f64, f64)> = terms
            .iter()
            .enumerate()
            .map(|(k, t)| ((k + 1) as f64, t.worst))
            .collect();
        // Each term's output's figure `of`, at the term's place on the axis.
        let per_output = |of: &dyn Fn(&crate::mission::judge::Output) -> Option<f64>| {
            terms
                .iter()
                .enumerate()
                .filter_map(|(k, t)| {
                    outputs
                        .iter()
                        .find(|x| x.output == t.output)
                        .and_then(|x| of(x))
                        .map(|v| ((k + 1) as f64, v))
                })
                .collect::<Vec<(f64, f64)>>()
        };
        let predicted = per_output(&|x| Some(x.worst));
        let requirement = per_output(&|x| x.requirement);
        let mut series = vec![
            Series::dots("what the left-out term may cost", &costs, 0),
            Series::dots("the output's worst predicted 1-sigma error", &predicted, 1),
        ];
        if !requirement.is_empty() {
            series.push(Series::dots("the output's requirement", &requirement, 3));
        }
        let title = if all.len() > terms.len() {
            format!(
                "The {} costliest of {} left-out terms over the flight, {unit}",
                terms.len(),
                all.len()
            )
        } else {
            format!("Left-out terms over the flight, {unit}")
        };
        let y = format!("error over the flight, {unit}");
        figure(
            h,
            &Figure {
                title: &title,
                x: "output: term left out",
                y: &y,
                series,
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: Some(&labels),
            },
        )?;
    }
    Ok(())
}

/// The stretches of the flight where `x` is beyond its calibrated range: (start, end) times.
fn beyond(x: &crate::mission::judge::Output) -> Vec<(f64, f64)> {
    let mut bands = Vec::new();
    let mut start: Option<f64> = None;
    for w in x.timeline.windows(2) {
        match (start, w[0].2) {
            (None, false) => start = Some(w[0].0),
            (Some(s), true) => {
                bands.push((s, w[0].0));
                start = None;
            }
            _ => {}
        }
    }
    if let (Some(s), Some(last)) = (start, x.timeline.last()) {
        bands.push((s, last.0));
    }
    bands
}
