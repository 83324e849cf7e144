//! `apply --reference --report`: a verdict, each output's figures in a table (units in their
//! column, not in every cell), and each output's error against its reference along the
//! recording in a figure of its own.

use std::fmt::Write as _;

use super::Error;
use super::page::{STYLE, esc};
use super::plot::{Figure, Series, figure};
use super::terminal::num;
use crate::sensor::accuracy::{Accuracy, Row, Statement};

/// Points a figure's series keeps: the largest error of each stretch of samples, so that no
/// spike is lost.
const SHOWN: usize = 3_000;

/// The page: `x` is each sample's time (or number) and `x_label` says which; `units` the SI
/// unit of each output.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(
    (title, calibration): (&str, &str),
    acc: &Accuracy,
    (x, x_label): (&[f64], &str),
    units: &[&'static str],
) -> Result<String, Error> {
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>{0}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{0}</h1>",
        esc(title)
    );
    let rows = acc.rows();
    let (class, verdict) = verdict(&rows, acc.count());
    let _ = writeln!(h, "<p class=\"verdict {class}\">{}</p>", esc(&verdict));
    let _ = writeln!(h, "<p><b>The calibration:</b> {}</p>", esc(calibration));
    let _ = writeln!(
        h,
        "<p>Each output's error (corrected minus reference) over the {} samples the device did not flag, one figure per output so that none hides another; each point drawn is the largest error of its stretch of samples, and the shade about zero is the 1-sigma the blob stated for those samples (the largest of the stretch): the calibration's error alone, which each sample's noise adds to, so a noisy record's errors go well beyond it while their mean (in the table) stays within a few of it.</p>",
        acc.count()
    );
    h.push_str("<table class=\"terms\">\n<tr><th>output</th><th>unit</th><th>mean</th><th>mean z</th><th>RMS</th><th>stated 1-sigma (median)</th><th>the statement</th><th>robust spread</th><th>99 % below</th><th>worst</th><th>far out</th></tr>\n");
    for (r, unit) in rows.iter().zip(units) {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.name),
            unit,
            num(r.mean),
            r.mean_z(acc.count())
                .map_or("-".to_string(), |z| format!("{z:+.2}")),
            num(r.rms),
            r.typical.map_or("-".to_string(), num),
            statement_word(r.statement(acc.count())),
            num(r.spread),
            num(r.p99),
            num(r.worst.0),
            r.far_out,
        );
    }
    h.push_str("</table>\n<p>The stated 1-sigma is the calibration's error alone (the median of what the blob states at each sample); the statement is overstated when it is over three times the RMS error (a check against it cannot fail), understated when the mean error is beyond 3 of its sigma; the robust spread (1.4826 times the median absolute deviation) includes each sample's noise; mean z: the mean over its sigma, the stated 1-sigma and the spread over the square root of the samples together; 99 % below: of the absolute errors; far out: samples more than five robust spreads from the median.</p>\n");
    for (k, name) in acc.names().iter().enumerate() {
        let unit = units.get(k).copied().unwrap_or("");
        let title = format!("{name}: error along the recording, {unit}");
        let y = format!("{name} error, {unit}");
        let (errors, band) = peaks(acc.errors(k), acc.stated(k), x);
        let zero: Vec<(f64, f64)> = band.iter().map(|(x, _)| (*x, 0.0)).collect();
        let half: Vec<f64> = band.iter().map(|(_, s)| *s).collect();
        // The band over the errors, so that a noisy record does not hide it.
        let mut series = vec![Series::curve(name, &errors, k)];
        if !half.is_empty() {
            series.push(Series {
                band: Some(&half),
                ..Series::curve("stated 1-sigma", &zero, (k + 1) % 6)
            });
        }
        figure(
            &mut h,
            &Figure {
                title: &title,
                x: x_label,
                y: &y,
                series,
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: None,
            },
        )?;
    }
    h.push_str("</body>\n</html>\n");
    Ok(h)
}

/// The statement's word in the table.
fn statement_word(s: Statement) -> &'static str {
    match s {
        Statement::Holds => "holds",
        Statement::Overstated => "OVERSTATED",
        Statement::Understated => "UNDERSTATED",
        Statement::None => "-",
    }
}

/// The page's verdict: it holds when every output's stated 1-sigma holds ([`Statement`]),
/// naming those overstated and understated otherwise; its style class.
fn verdict(rows: &[Row], n: usize) -> (&'static str, String) {
    if n == 0 {
        return (
            "review",
            "No sample the device did not flag: nothing to hold against the reference.".to_string(),
        );
    }
    if rows.iter().any(|r| r.typical.is_none()) {
        return (
            "review",
            "The calibration states no 1-sigma: the errors below are not held against one."
                .to_string(),
        );
    }
    let named = |which: Statement| -> Vec<String> {
        rows.iter()
            .filter(|r| r.statement(n) == which)
            .map(|r| match which {
                Statement::Understated => format!(
                    "{} (mean z {:+.1})",
                    r.name,
                    r.mean_z(n).unwrap_or(f64::NAN)
                ),
                _ => format!(
                    "{} ({} stated against an RMS error of {})",
                    r.name,
                    num(r.typical.unwrap_or(f64::NAN)),
                    num(r.rms)
                ),
            })
            .collect()
    };
    let (under, over) = (named(Statement::Understated), named(Statement::Overstated));
    if under.is_empty() && over.is_empty() {
        return (
            "accept",
            format!(
                "Holds: every output's mean error is within 3 sigma of what its stated 1-sigma and its noise allow, and no stated 1-sigma is over three times its RMS error, over {n} samples."
            ),
        );
    }
    let mut why = Vec::new();
    if !under.is_empty() {
        why.push(format!(
            "understated (the mean error beyond 3 sigma of the stated 1-sigma and noise): {}",
            under.join(", ")
        ));
    }
    if !over.is_empty() {
        why.push(format!(
            "overstated (over three times the RMS error, so no check against it can fail): {}",
            over.join(", ")
        ));
    }
    (
        "review",
        format!(
            "Does not hold over {n} samples: the stated 1-sigma is {}.",
            why.join("; ")
        ),
    )
}

/// A series' points, `(x, y)`.
type Points = Vec<(f64, f64)>;

/// At most [`SHOWN`] points: the largest absolute error of each stretch, at its sample's `x`;
/// and, when `stated` is given (one per error), the largest stated 1-sigma of each stretch.
fn peaks(errors: &[(usize, f64)], stated: Option<&[f64]>, x: &[f64]) -> (Points, Points) {
    let every = errors.len().div_ceil(SHOWN).max(1);
    let at = |i: usize| x.get(i).copied().unwrap_or(i as f64);
    let peaks = errors
        .chunks(every)
        .filter_map(|c| c.iter().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())))
        .map(|(i, e)| (at(*i), *e))
        .collect();
    let band = match stated {
        Some(s) if s.len() == errors.len() => errors
            .chunks(every)
            .zip(s.chunks(every))
            .filter_map(|(c, s)| {
                let first = c.first()?;
                Some((at(first.0), s.iter().copied().fold(0.0, f64::max)))
            })
            .collect(),
        _ => Vec::new(),
    };
    (peaks, band)
}
