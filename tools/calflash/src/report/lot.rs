//! The lot's report: one HTML file with the lot's spread, each unit's distance from the lot
//! with the limit, the units outside, and the control charts with their limits and the points
//! out of control.

use super::Error;
use std::fmt::Write as _;

use super::page::{STYLE, esc};
use super::plot::{Figure, Series, svg};
use super::terminal::{num, signed};
use crate::lot::{Judge, Lot, UnitChart};

/// Units a figure names by serial on its axis; beyond, they are numbered in calibration order.
const NAMED_UNITS: usize = 12;

fn figure(
    title: &str,
    y: &str,
    serials: &[&str],
    series: Vec<Series<'_>>,
) -> Result<String, Error> {
    let named = serials.len() <= NAMED_UNITS;
    svg(&Figure {
        title,
        x: if named {
            "unit, in calibration order"
        } else {
            "unit, numbered in calibration order"
        },
        y,
        series,
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: named.then_some(serials),
    })
}

/// Values as points against their position (the units' calibration order, the first at 1).
fn indexed(values: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    values
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64, v))
        .collect()
}

/// Serials in a sentence: the first six, then how many more.
fn shortened(serials: &[&str]) -> String {
    let mut unique: Vec<&str> = Vec::new();
    for s in serials {
        if !unique.contains(s) {
            unique.push(s);
        }
    }
    if unique.len() <= 6 {
        unique.join(", ")
    } else {
        format!("{}, and {} more", unique[..6].join(", "), unique.len() - 6)
    }
}

/// The unit of a lot's coefficient `output:term` (`a_x:1`, `g_y:w_x`, `a_x:f_x^2`): counts
/// per unit of the term (the fit's coefficients are in the converter's counts).
fn coefficient_unit(name: &str) -> String {
    name.split_once(':').map_or_else(String::new, |(_, term)| {
        super::page::term_unit(term, "unit of input")
    })
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
         <h1>{}: {n} units, {} outside</h1>",
        esc(&name),
        esc(&name),
        lot.outliers.len()
    );
    // The lot's verdict: the units outside it and the control charts' points out of control.
    let out_of_control: Vec<&str> = charts
        .iter()
        .flat_map(|(_, c)| c.out_of_control.iter().filter_map(|&i| c.serials.get(i)))
        .map(String::as_str)
        .collect();
    let outside: Vec<&str> = lot.outliers.iter().map(|o| o.serial.as_str()).collect();
    let (class, verdict) = if outside.is_empty() && out_of_control.is_empty() {
        (
            "accept",
            format!("All {n} units within the lot and in control"),
        )
    } else {
        let mut said = Vec::new();
        if !outside.is_empty() {
            said.push(format!(
                "{} outside the lot ({})",
                outside.len(),
                shortened(&outside)
            ));
        }
        if !out_of_control.is_empty() {
            said.push(format!(
                "{} point(s) out of control ({})",
                out_of_control.len(),
                shortened(&out_of_control)
            ));
        }
        ("review", format!("{n} units: {}", said.join("; ")))
    };
    let _ = write!(h, "<p class=\"verdict {class}\">{}</p><p>", esc(&verdict));
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
    h.push_str("</p><h2>Coefficients</h2><p>Each output's fitted coefficients (<code>output:term</code>). The spread first in a datasheet's unit: the MAD (scaled to a standard deviation) and the lowest and highest unit about the lot's median, each coefficient divided by the lot's median scale factor of its output (a bias in mg or deg/h, a scale factor in ppm, a cross-axis term in mrad, a gyro's g-sensitivity in deg/h/g); then the median and MAD as fitted, in the converter's counts per unit of the term (where a term has no datasheet unit, its range is in those too).</p><table class=\"terms\"><tr><th>coefficient</th><th>spread (MAD)</th><th>lowest, highest about the median</th><th>median as fitted</th><th>MAD as fitted</th><th>unit as fitted</th></tr>");
    for s in &lot.spread {
        let (mad, range) = s.engineering.as_ref().map_or_else(
            || {
                (
                    "no datasheet unit".to_string(),
                    format!("{:.4e} .. {:.4e}", s.min, s.max),
                )
            },
            |e| {
                (
                    format!("{} {}", num(e.mad), e.unit),
                    format!("{} .. {} {}", signed(e.range.0), signed(e.range.1), e.unit),
                )
            },
        );
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.6e}</td><td>{:.3e}</td><td>{}</td></tr>",
            esc(&s.name),
            esc(&mad),
            esc(&range),
            s.median,
            s.mad,
            esc(&coefficient_unit(&s.name)),
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
        (1.0, lot.distance_limit()),
        (n as f64, lot.distance_limit()),
    ];
    let serials: Vec<&str> = lot.units.iter().map(|u| u.serial.as_str()).collect();
    let (what, axis) = match &lot.judge {
        Judge::Scatter { .. } => (
            "A unit's distance is its robust Mahalanobis distance from the lot: how many of the lot's own (robust) standard deviations its coefficients lie from the lot's robust centre, counting the coefficients' correlations; a unit of the lot is beyond the limit with the probability stated above.",
            "robust Mahalanobis distance",
        ),
        Judge::Columns { .. } => (
            "A unit's distance is its largest robust z over the coefficients: how many MADs (scaled to a standard deviation) its furthest coefficient lies from the lot's median.",
            "largest robust z (MADs)",
        ),
    };
    let _ = write!(h, "<p>{what}</p>");
    h.push_str("<div class=\"fig\">");
    h.push_str(&figure(
        "Each unit's distance from the lot, in calibration order",
        axis,
        &serials,
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
            "<h2>{:?} chart of {}</h2><p>Centre {:.6e}, sigma {:.3e} (the baseline's median and median moving range / 0.954, robust to units far out); {}; {} point(s) out of control{}.</p><div class=\"fig\">",
            c.kind,
            esc(name),
            c.centre,
            c.sigma,
            chart_parameters(c),
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
        let centre = [(1.0, c.centre), (c.plotted.len().max(1) as f64, c.centre)];
        let out: Vec<(f64, f64)> = c.out_of_control.iter().map(|&i| plotted[i]).collect();
        let serials: Vec<&str> = c.serials.iter().map(String::as_str).collect();
        let title = format!("{name} ({})", coefficient_unit(name));
        h.push_str(&figure(
            &title,
            name,
            &serials,
            vec![
                Series::curve(statistic, &plotted, 0),
                Series::dots("", &plotted, 0),
                Series::curve("centre", &centre, 2),
                Series::curve("lower limit", &lo, 1),
                Series::curve("upper limit", &hi, 4),
                Series::dots("out of control", &out, 3),
            ],
        )?);
        h.push_str("</div>");
    }
    h.push_str("</body></html>\n");
    Ok(super::page::with_contents(&h))
}

/// What a chart is judged with, in words (issue 68: the EWMA's baseline, lambda and L were not
/// stated): the baseline, the limits, and a warning when the baseline is short.
fn chart_parameters(c: &crate::stats::chart::Chart) -> String {
    use crate::stats::chart::{EWMA_LAMBDA, Kind, SIGMAS};
    let limits = match c.kind {
        Kind::Individuals => format!("limits at {SIGMAS} sigma"),
        Kind::Ewma => format!(
            "EWMA with lambda {EWMA_LAMBDA}, limits at L = {SIGMAS} times the EWMA's own sigma (widening to their steady value)"
        ),
    };
    let short = if c.baseline < 20 {
        format!(
            "; <b>a baseline of {} units, fewer than 20: its centre and sigma, and so its limits, are rough</b>",
            c.baseline
        )
    } else {
        String::new()
    };
    format!(
        "baseline the first {} units in time order; {limits}{short}",
        c.baseline
    )
}

#[cfg(test)]
mod tests {
    use super::coefficient_unit;

    #[test]
    fn a_coefficient_says_its_unit() {
        assert_eq!(coefficient_unit("a_x:1"), "counts");
        assert_eq!(coefficient_unit("a_x:f_y"), "counts per m/s^2");
        assert_eq!(coefficient_unit("g_z:w_x"), "counts per rad/s");
        assert_eq!(coefficient_unit("a_x:f_x^2"), "counts per (m/s^2)^2");
        assert_eq!(coefficient_unit("g_x:w_x:temp"), "counts per rad/s C");
        assert_eq!(
            coefficient_unit("a_y:f_y:abs(f_y)"),
            "counts per m/s^2 m/s^2"
        );
        assert_eq!(coefficient_unit("a_x:dw_z"), "counts per rad/s^2");
        assert_eq!(coefficient_unit("ax:input"), "counts per unit of input");
    }
}
