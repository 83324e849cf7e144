//! The lot's report: one HTML file with the lot's spread, each unit's distance from the lot
//! with the limit, the units outside, and the control charts with their limits and the points
//! out of control.

use super::Error;
use std::fmt::Write as _;

use super::page::{STYLE, esc};
use super::plot::{Figure, Series, svg};
use crate::lot::{Judge, Lot, UnitChart};

fn figure(title: &str, x: &str, y: &str, series: Vec<Series<'_>>) -> Result<String, Error> {
    svg(&Figure {
        title,
        x,
        y,
        series,
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: None,
    })
}

/// Values as points against their position (the units' calibration order).
fn indexed(values: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    values.enumerate().map(|(i, v)| (i as f64, v)).collect()
}

/// Renders the report of `lot` (described by `name`, as [`crate::db::Selection`] says it)
/// with `charts` (coefficient, chart).
///
/// # Errors
/// A figure that cannot be drawn.
pub fn render(lot: &Lot, name: &str, charts: &[(String, UnitChart)]) -> Result<String, Error> {
    let name = name.replace('`', "");
    let mut h = String::new();
    let n = lot.units.len();
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head><body>\
         <h1>{}: {n} units, {} outside</h1><p>",
        esc(&name),
        esc(&name),
        lot.outliers.len()
    );
    match &lot.judge {
        Judge::Scatter { robust, .. } => {
            let _ = write!(
                h,
                "Judged on the robust centre and covariance of {} coefficients (reweighted OGK; {} units kept after reweighting): a unit is outside when its distance exceeds {:.2}, which a unit of the lot's own distribution does with probability {}.",
                lot.names.len(),
                robust.kept,
                lot.distance_limit(),
                lot.alpha
            );
        }
        Judge::Columns { why } => {
            let _ = write!(
                h,
                "Judged coefficient by coefficient ({}): a unit is outside when a coefficient is more than {:.2} MADs from the lot's median.",
                esc(&why.to_string()),
                lot.distance_limit()
            );
        }
    }
    if !lot.left_out.is_empty() {
        let _ = write!(
            h,
            " Left out (not in every unit, or the same in all): {}.",
            esc(&lot.left_out.join(", "))
        );
    }
    h.push_str("</p><h2>Coefficients</h2><table><tr><th>coefficient</th><th>median</th><th>MAD</th><th>min</th><th>max</th></tr>");
    for s in &lot.spread {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.6e}</td><td>{:.3e}</td><td>{:.6e}</td><td>{:.6e}</td></tr>",
            esc(&s.name),
            s.median,
            s.mad,
            s.min,
            s.max
        );
    }
    h.push_str("</table><h2>Distance from the lot</h2>");
    let all = indexed(lot.distances.iter().copied());
    let outside: Vec<(f64, f64)> = all
        .iter()
        .copied()
        .filter(|(_, d)| *d > lot.distance_limit())
        .collect();
    let limit = [
        (0.0, lot.distance_limit()),
        ((n - 1) as f64, lot.distance_limit()),
    ];
    h.push_str("<div class=\"fig\">");
    h.push_str(&figure(
        "each unit's distance, in calibration order",
        "unit (calibration order)",
        "distance",
        vec![
            Series::dots("units", &all, 0),
            Series::dots("outside", &outside, 3),
            Series::curve("limit", &limit, 1),
        ],
    )?);
    h.push_str("</div>");
    if !lot.outliers.is_empty() {
        h.push_str("<table><tr><th>unit</th><th>distance</th><th>furthest coefficients (robust z)</th></tr>");
        for o in &lot.outliers {
            let why: Vec<String> = o
                .coefficients
                .iter()
                .map(|(k, z)| format!("{} {z:+.1}", esc(k)))
                .collect();
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{:.2}</td><td>{}</td></tr>",
                esc(&o.serial),
                o.distance,
                why.join(", ")
            );
        }
        h.push_str("</table>");
    }
    for (name, c) in charts {
        let _ = write!(
            h,
            "<h2>{:?} chart of {}</h2><p>Centre {:.6e}, sigma {:.3e} (the baseline's median and median moving range / 0.954, robust to units far out); {} point(s) out of control{}.</p><div class=\"fig\">",
            c.kind,
            esc(name),
            c.centre,
            c.sigma,
            c.out_of_control.len(),
            if c.out_of_control.is_empty() {
                String::new()
            } else {
                let units: Vec<String> = c
                    .out_of_control
                    .iter()
                    .filter_map(|&i| c.serials.get(i))
                    .map(|s| esc(s))
                    .collect();
                format!(": {}", units.join(", "))
            }
        );
        let plotted = indexed(c.plotted.iter().copied());
        let statistic = match c.kind {
            crate::stats::chart::Kind::Individuals => "each unit's value",
            crate::stats::chart::Kind::Ewma => "EWMA of the units' values",
        };
        let lo = indexed(c.limits.iter().map(|l| l.0));
        let hi = indexed(c.limits.iter().map(|l| l.1));
        let out: Vec<(f64, f64)> = c.out_of_control.iter().map(|&i| plotted[i]).collect();
        h.push_str(&figure(
            name,
            "unit (calibration order)",
            name,
            vec![
                Series::curve(statistic, &plotted, 0),
                Series::dots("", &plotted, 0),
                Series::curve("lower limit", &lo, 1),
                Series::curve("upper limit", &hi, 1),
                Series::dots("out of control", &out, 3),
            ],
        )?);
        h.push_str("</div>");
    }
    h.push_str("</body></html>\n");
    Ok(super::page::with_contents(&h))
}
