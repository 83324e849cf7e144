//! `apply --reference --report`: each output's error against its reference along the
//! recording, one figure per physical unit, with the robust figures in a table.

use std::fmt::Write as _;

use super::Error;
use super::page::{STYLE, esc};
use super::plot::{Figure, Series, figure};
use super::terminal::num;
use crate::sensor::accuracy::Accuracy;

/// Points a figure's series keeps: the largest error of each stretch of samples, so that no
/// spike is lost.
const SHOWN: usize = 3_000;

/// The page: `x` is each sample's time (or number) and `x_label` says which; `units` the SI
/// unit of each output.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(
    title: &str,
    acc: &Accuracy,
    (x, x_label): (&[f64], &str),
    units: &[&'static str],
) -> Result<String, Error> {
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>{0}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{0}</h1>\n<p>Each output's error (corrected minus reference) over the {1} samples the device did not flag; each point drawn is the largest error of its stretch of samples.</p>",
        esc(title),
        acc.count()
    );
    let families = super::plot::units_in_order(units.iter().copied());
    let series: Vec<Vec<(f64, f64)>> = (0..acc.names().len())
        .map(|k| peaks(acc.errors(k), x))
        .collect();
    for unit in families {
        let y = format!("error, {unit}");
        figure(
            &mut h,
            &Figure {
                title: "Error along the recording",
                x: x_label,
                y: &y,
                series: acc
                    .names()
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| units[*k] == unit)
                    .map(|(k, name)| Series::curve(name, &series[k], k))
                    .collect(),
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
            },
        )?;
    }
    h.push_str("<table>\n<tr><th>output</th><th>mean</th><th>RMS</th><th>stated 1-sigma</th><th>median</th><th>robust spread</th><th>99 % of |error| below</th><th>worst</th><th>far out</th></tr>\n");
    for (r, unit) in acc.rows().iter().zip(units) {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{} {u}</td><td>{} {u}</td><td>{}</td><td>{} {u}</td><td>{} {u}</td><td>{} {u}</td><td>{} {u}</td><td>{}</td></tr>",
            esc(&r.name),
            num(r.mean),
            num(r.rms),
            r.sigma
                .map_or("-".to_string(), |s| format!("{} {unit}", num(s))),
            num(r.median),
            num(r.spread),
            num(r.p99),
            num(r.worst.0),
            r.far_out,
            u = unit,
        );
    }
    h.push_str("</table>\n<p>The stated 1-sigma is the calibration's error alone; the robust spread (1.4826 times the median absolute deviation) includes each sample's noise; far out: samples more than five robust spreads from the median.</p>\n</body>\n</html>\n");
    Ok(h)
}

/// At most [`SHOWN`] points: the largest absolute error of each stretch, at its sample's `x`.
fn peaks(errors: &[(usize, f64)], x: &[f64]) -> Vec<(f64, f64)> {
    let every = errors.len().div_ceil(SHOWN).max(1);
    errors
        .chunks(every)
        .filter_map(|c| c.iter().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())))
        .map(|(i, e)| (x.get(*i).copied().unwrap_or(*i as f64), *e))
        .collect()
}
