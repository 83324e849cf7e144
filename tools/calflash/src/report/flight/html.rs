//! The flight's HTML page: the verdict box, the filter's fit and its inputs, each sensor error
//! at launch as a table, and the figures drawn from the pass the table reports.

use std::fmt::Write as _;

use super::{UNSEEN_HEAD, undecided, unseen_cells};
use crate::nav::check::Checked;
use crate::nav::input::FixCounts;
use crate::nav::prior::PriorSource;
use crate::report::Error;

/// The HTML page: the verdict, then the innovations against their 95 % bounds, the trajectory
/// against GNSS and the barometer, and each sensor error along the flight with its 1-sigma.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(
    serial: &str,
    c: &Checked,
    counts: &FixCounts,
    held_out: Option<&crate::nav::consistency::HeldOut>,
) -> Result<String, Error> {
    use crate::report::page::{STYLE, esc};
    use crate::report::plot::{Figure, Series, Sheet, figure};
    let v = &c.verdict;
    let title = format!("Unit {serial} in flight: {}", v.word);
    let class = match v.word {
        "HELD" => "accept",
        "SHIFTED" => "reject",
        _ => "review",
    };
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>{0}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>Unit {1} in flight</h1>\n<p class=\"verdict {class}\">{2}</p>\n<p>{3}</p>",
        esc(&title),
        esc(serial),
        esc(v.word),
        esc(&v.why)
    );
    h.push_str(&facts_table(c, counts));
    h.push_str(&kinds_table(c, held_out));
    // A filter that does not fit (or a track the held-out fixes do not hold) names no term.
    if v.consistency.fits && v.word != crate::nav::verdict::DOES_NOT_FIT {
        h.push_str(&terms_table(c));
    }
    h.push_str("<h2>Innovations</h2>\n<p>Each kind of measurement against its own 95 % bounds: the fit is judged kind by kind, so that the barometer's many readings cannot hide a GNSS track that was lost.</p>\n");
    // Innovations over their predicted sigma, with the 95 % bounds, one panel per kind.
    let said = &c.pass.said;
    let span = said.first().map(|s| s.t).unwrap_or(0.0)..=said.last().map(|s| s.t).unwrap_or(1.0);
    let bounds = [
        vec![(*span.start(), 1.96), (*span.end(), 1.96)],
        vec![(*span.start(), -1.96), (*span.end(), -1.96)],
    ];
    let kinds = crate::nav::consistency::KINDS;
    let normalised: Vec<Vec<(f64, f64)>> = (0..kinds.len())
        .map(|k| {
            said.iter()
                .filter(|s| crate::nav::consistency::kind_of(s.kind) == Some(k) && s.sigma > 0.0)
                .map(|s| (s.t, (s.value / s.sigma).clamp(-10.0, 10.0)))
                .collect()
        })
        .collect();
    let mut sheet = Sheet::new(true);
    for (k, (name, v)) in kinds.iter().zip(&normalised).enumerate() {
        if v.is_empty() {
            continue;
        }
        let inside = v.iter().filter(|(_, z)| z.abs() <= 1.96).count();
        let title = format!(
            "{name}: {:.1} % inside",
            100.0 * inside as f64 / v.len() as f64
        );
        sheet.add(
            &mut h,
            &Figure {
                title: &title,
                x: "time, s",
                y: "innovation / sigma",
                series: vec![
                    Series::dots("innovations over their 1-sigma (clipped at 10)", v, k),
                    Series::curve("95 % bounds", &bounds[0], 4),
                    Series::curve("", &bounds[1], 4),
                ],
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: None,
            },
        )?;
    }
    sheet.finish(&mut h);
    let tr = &c.track;
    let height: Vec<(f64, f64)> =
        tr.t.iter()
            .zip(&tr.position)
            .map(|(t, p)| (*t, p[2]))
            .collect();
    h.push_str("<h2>The trajectory</h2>\n");
    if tr.gnss_height.is_empty() {
        h.push_str("<p>The GNSS log holds no height: only the smoothed height and the barometer's are drawn.</p>\n");
    }
    let gnss_height = &tr.gnss_height;
    let mut series = vec![Series::curve("smoothed", &height, 0)];
    // The barometer's heights above the pad, moved by their mean difference from the smoothed
    // height (where the pad is in the frame), as the table compares them.
    let offset = tr.baro_offset.unwrap_or(0.0);
    let baro: Vec<(f64, f64)> = tr.baro.iter().map(|(t, z)| (*t, z + offset)).collect();
    let baro_name = format!("barometer {offset:+.1} m");
    if !baro.is_empty() {
        series.push(Series::dots(&baro_name, &baro, 1));
    }
    if !gnss_height.is_empty() {
        series.push(Series::dots("GNSS", gnss_height, 2));
    }
    figure(
        &mut h,
        &Figure {
            title: "Height above the level frame's origin (the pad, or the first fix)",
            x: "time, s",
            y: "height, m",
            series,
            bands: Vec::new(),
            band_label: "",
            zero_line: false,
            x_names: None,
        },
    )?;
    let path: Vec<(f64, f64)> = tr.position.iter().map(|p| (p[0], p[1])).collect();
    let fixes: Vec<(f64, f64)> = tr.gnss.iter().map(|(_, p)| (p[0], p[1])).collect();
    figure(
        &mut h,
        &Figure {
            title: "Horizontal track",
            x: "east, m",
            y: "north, m",
            series: vec![
                Series::curve("smoothed", &path, 0),
                Series::dots("GNSS", &fixes, 2),
            ],
            bands: Vec::new(),
            band_label: "",
            zero_line: false,
            x_names: None,
        },
    )?;
    terms_over_time(&mut h, c)?;
    h.push_str("</body>\n</html>\n");
    Ok(crate::report::page::with_contents(&h))
}

/// Each term the flight observes, its estimate after the launch with its 1-sigma band against
/// the calibration's 1-sigma: a figure a term, in the term's own unit (the terms' scales differ
/// by orders of magnitude, and a term unobserved is only its prior).
///
/// # Errors
/// A figure that cannot be drawn.
fn terms_over_time(h: &mut String, c: &Checked) -> Result<(), Error> {
    use crate::report::page::esc;
    use crate::report::plot::{Figure, Series, figure};
    let tr = &c.track;
    let launch = c.pass.launch;
    let v = &c.verdict;
    let observed = |t: &crate::nav::verdict::Term| t.z.is_some() || t.shifted;
    let drawn: Vec<usize> = (0..v.terms.len())
        .filter(|&i| observed(&v.terms[i]))
        .collect();
    let _ = writeln!(
        h,
        "<h2>Sensor errors along the flight</h2>\n<p>Drawn from {}, the pass the table reports: each observed term's shift from the calibration from the launch on, as the flight had told it by each moment (the forward pass, shaded 1-sigma either side: the band narrows as the fixes come) and as the whole flight tells it (the smoothed estimate, green), between the calibration's own 1-sigma of it (red). The table's value is the green curve just after the launch ({launch:.3} s). Before the launch the filter's states are the errors at the pad's rates, another quantity, and are not drawn.</p>",
        esc(c.pass_name)
    );
    let unobserved: Vec<&str> = v
        .terms
        .iter()
        .filter(|t| !observed(t))
        .map(|t| t.name)
        .collect();
    if !unobserved.is_empty() {
        let _ = writeln!(
            h,
            "<p>Not drawn: {}, which the flight does not observe; each keeps the calibration's value and 1-sigma.</p>",
            esc(&unobserved.join(", "))
        );
    }
    let after: Vec<usize> = (0..tr.t.len()).filter(|&k| tr.t[k] >= launch).collect();
    let span = (
        after.first().map_or(launch, |&k| tr.t[k]),
        after.last().map_or(launch, |&k| tr.t[k]),
    );
    for i in drawn {
        let term = &v.terms[i];
        let smoothed: Vec<(f64, f64)> =
            after.iter().map(|&k| (tr.t[k], tr.terms[k].0[i])).collect();
        // Before the first fixes the forward pass may know a term far less than the
        // calibration does (a term opened at launch, the navigation put back on GNSS): its
        // band is clipped so that the calibration's and the flight's stay readable.
        let limit = 3.0 * term.prior_sigma.max(term.estimate.abs() + term.sigma);
        let filtered: Vec<(f64, f64)> = after
            .iter()
            .map(|&k| (tr.t[k], tr.filtered[k].0[i].clamp(-limit, limit)))
            .collect();
        let sigma: Vec<f64> = after
            .iter()
            .map(|&k| tr.filtered[k].1[i].min(limit))
            .collect();
        let clipped = after
            .iter()
            .any(|&k| tr.filtered[k].1[i] > limit || tr.filtered[k].0[i].abs() > limit);
        let name = if clipped {
            format!("by then (forward pass), 1-sigma shaded, clipped at {limit:.2e}")
        } else {
            "by then (forward pass), 1-sigma shaded".to_string()
        };
        let upper = [(span.0, term.prior_sigma), (span.1, term.prior_sigma)];
        let lower = [(span.0, -term.prior_sigma), (span.1, -term.prior_sigma)];
        let mut line = Series::curve(&name, &filtered, 0);
        line.band = Some(&sigma);
        let title = format!(
            "{}: its shift from the calibration after the launch{}",
            term.name,
            if term.shifted { " (SHIFTED)" } else { "" }
        );
        let y = if term.unit.is_empty() {
            "shift, relative".to_string()
        } else {
            format!("shift, {}", term.unit)
        };
        figure(
            h,
            &Figure {
                title: &title,
                x: "time, s",
                y: &y,
                series: vec![
                    line,
                    Series::curve("the whole flight (smoothed, the table's)", &smoothed, 2),
                    Series::curve("the calibration's 1-sigma", &upper, 3),
                    Series::curve("", &lower, 3),
                ],
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: None,
            },
        )?;
    }
    Ok(())
}

/// The check's facts as a table: the filter's fit, the inputs, the prior, the track.
/// Each kind of measurement's fit on its own (the share inside its 95 % bounds, its NIS, its
/// refusals and where they ran), and the held-out fixes against the smoothed track.
fn kinds_table(c: &Checked, held_out: Option<&crate::nav::consistency::HeldOut>) -> String {
    use crate::report::page::esc;
    let mut h = String::from(
        "<h2>The fit, kind by kind</h2>\n<table>\n<tr><th>measurement</th><th>innovations</th><th>inside 95 %</th><th>mean NIS</th><th>refused</th><th>refused runs</th><th>fit</th></tr>\n",
    );
    for k in &c.verdict.consistency.kinds {
        let runs: Vec<String> = k.refused_runs.iter().map(ToString::to_string).collect();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.1} %</td><td>{:.2}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td></tr>",
            esc(k.kind),
            k.innovations,
            100.0 * k.inside_95 as f64 / k.innovations.max(1) as f64,
            k.mean_nis,
            k.refused,
            esc(&runs.join("; ")),
            if k.fits { "accept" } else { "reject" },
            if k.fits { "fits" } else { "DOES NOT FIT" }
        );
    }
    h.push_str("</table>\n");
    if let Some(o) = held_out {
        let _ = writeln!(
            h,
            "<p class=\"{}\">Held out: every {}th fix after the launch ({} fixes) was kept from the filter and the smoother: {} within 3 sigma of the smoothed track (each fix's east, north and up together, over the track's and the fix's 1-sigma: {:.1} %; about 97 % where the stated sigmas are true, at least {:.0} % where a track can be believed), {:.1} % inside their 95 % bounds, RMS {:.2} m horizontally, the worst {:.1} sigma at {:.1} s: <b>{}</b>.</p>",
            if o.believed { "accept" } else { "reject" },
            o.every,
            o.fixes,
            o.within_3_sigma,
            100.0 * o.share(),
            100.0 * crate::nav::consistency::HELD_OUT_AT_LEAST,
            100.0 * o.share_95(),
            o.rms_m,
            o.worst.0,
            o.worst.1,
            if o.believed {
                "the track can be believed"
            } else {
                "the track cannot be believed"
            }
        );
    }
    h
}

fn facts_table(c: &Checked, counts: &FixCounts) -> String {
    use crate::report::page::esc;
    let k = &c.verdict.consistency;
    let mut rows: Vec<(String, String)> = vec![
        (
            "GNSS and barometer innovations inside their 95 % bounds".into(),
            format!(
                "{} of {} ({:.1} %)",
                k.inside_95,
                k.innovations,
                100.0 * k.inside_95 as f64 / k.innovations.max(1) as f64
            ),
        ),
        (
            "mean NIS of those taken (1 when the covariance is right)".into(),
            format!("{:.2}", k.mean_nis),
        ),
        ("refused beyond 5 sigma".into(), k.refused.to_string()),
        (
            "GNSS rows read".into(),
            format!(
                "{}: {} without a fix, {} repeating the last fix (left out)",
                counts.rows, counts.no_fix, counts.repeated
            ),
        ),
        (
            "heading at rest, from the track".into(),
            format!("{:.1} &plusmn; {:.1} deg", c.heading_deg.0, c.heading_deg.1),
        ),
        (
            "at rest before launch".into(),
            format!("{:.2} s", c.rest_seconds),
        ),
        (
            "noise densities at rest: accelerometer, gyro".into(),
            format!(
                "{:.3e} m/s<sup>2</sup>/&radic;Hz, {:.3e} rad/s/&radic;Hz",
                c.noise.0, c.noise.1
            ),
        ),
        (
            "flagged samples navigated on doubt".into(),
            format!("{:.3} s", c.pass.flagged_seconds),
        ),
        (
            "barometer left out near and beyond Mach 1".into(),
            format!("{:.1} s", c.pass.baro_skipped_seconds),
        ),
    ];
    if !c.pass.resets.is_empty() {
        rows.push((
            "navigation put back on GNSS after losing track".into(),
            format!(
                "{} time(s), first at {:.2} s",
                c.pass.resets.len(),
                c.pass.resets[0]
            ),
        ));
    }
    let prior = match &c.prior {
        PriorSource::Record(at) => format!("the calibration's record ({})", esc(at)),
        PriorSource::Factors => "the blob's covariance factors".into(),
        PriorSource::Stated(_) => "a stated prior (--prior)".into(),
    };
    rows.push(("prior".into(), prior));
    if let Some((rms, n)) = c.track.track_rms {
        rows.push((
            format!("smoothed horizontal track against {n} GNSS fixes, RMS"),
            format!("{rms:.2} m"),
        ));
    }
    if let Some((rms, n)) = c.track.height_rms {
        rows.push((
            format!(
                "smoothed height against {n} barometer readings, RMS after their mean difference"
            ),
            format!(
                "{rms:.2} m (difference {:+.2} m)",
                c.track.baro_offset.unwrap_or(0.0)
            ),
        ));
    }
    let mut t = String::from("<h2>The filter's fit and its inputs</h2>\n<table>\n");
    for (what, value) in rows {
        let _ = writeln!(t, "<tr><td>{what}</td><td>{value}</td></tr>");
    }
    t.push_str("</table>\n");
    t
}

/// Each sensor error against the calibration, as a table.
fn terms_table(c: &Checked) -> String {
    use crate::report::page::esc;
    let v = &c.verdict;
    let mut t = format!(
        "<h2>Sensor errors at launch</h2>\n<p>From {}: each term's smoothed estimate just after the launch, tested against the calibration's 1-sigma of it over the flight. The flight alone: {}.</p>\n<table class=\"terms\">\n<tr><th>term</th><th>unit</th><th>calibration 1-sigma</th><th>in flight</th><th>1-sigma</th><th>the flight alone, 1-sigma</th><th>z</th><th>p</th><th></th></tr>\n",
        esc(c.pass_name),
        esc(c.alone_from)
    );
    for term in &v.terms {
        let (z, p) = match (term.z, term.p) {
            (Some(z), Some(p)) => (format!("{z:+.2}"), format!("{p:.3}")),
            _ => ("&ndash;".into(), "&ndash;".into()),
        };
        let mark = if term.shifted {
            "<b>SHIFTED</b>"
        } else if term.z.is_none() {
            "not observed"
        } else {
            ""
        };
        let alone = term
            .flight_sigma
            .map_or_else(|| "nothing".to_string(), |f| format!("{f:.3e}"));
        let _ = writeln!(
            t,
            "<tr><td>{}</td><td>{}</td><td>{:.3e}</td><td>{:+.3e}</td><td>{:.3e}</td><td>{alone}</td><td>{z}</td><td>{p}</td><td>{mark}</td></tr>",
            esc(term.name),
            esc(term.unit),
            term.prior_sigma,
            term.estimate,
            term.sigma
        );
    }
    t.push_str("</table>\n");
    if let Some((chi2, dof, p)) = v.overall {
        let _ = writeln!(
            t,
            "<p>Over the observed terms: chi-square {chi2:.2} on {dof} degrees of freedom, p = {p:.3}. z and p test each term on its own; SHIFTED marks the terms a step-down test names, each tested given the shifts already named.</p>"
        );
    }
    if let Some(line) = undecided(c) {
        let _ = writeln!(t, "<p>{}.</p>", esc(&line));
    }
    if !c.unseen.is_empty() {
        let _ = writeln!(
            t,
            "<p>Terms not named, {}.</p>\n<table><tr><th>term</th><th>named from</th><th>the flight's own 1-sigma</th><th>the calibration's 1-sigma in flight</th></tr>",
            esc(UNSEEN_HEAD)
        );
        for u in &c.unseen {
            let [from, sd, cal] = unseen_cells(c, u);
            let _ = writeln!(
                t,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(u.term),
                esc(&from),
                esc(&sd),
                esc(&cal)
            );
        }
        t.push_str("</table>\n");
    }
    t
}
