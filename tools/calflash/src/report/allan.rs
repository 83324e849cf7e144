//! The Allan deviation as the field draws it: each axis' curve with its confidence bars, the
//! curve of its noise terms, and the -1/2, 0 and +1/2 slope lines with the points where the
//! random walk `N` (at tau = 1 s), the bias instability `B` (at the flattest point, over
//! sqrt(2 ln 2 / pi) = 0.664) and the rate random walk `K` (at tau = 3 s) are read; and the
//! page that holds them.

use std::fmt::Write as _;

use super::Error;
use super::page::{STYLE, esc};
use super::plot::{Figure, Series, svg_loglog};
use super::terminal::num;
use crate::noise::allan::{NoiseTerms, Point, flattest};

/// `sqrt(2 ln 2 / pi)`: the Allan deviation of flicker noise of bias instability `B` is this
/// times `B`.
const FLICKER: f64 = 0.664_282_507_320_6;

/// One sensor as analysed: its name, the unit of its values, and per axis the curve and terms.
pub struct Sensor<'a> {
    /// `gyro` or `accelerometer`.
    pub name: &'static str,
    /// The unit of the values.
    pub unit: &'a str,
    /// x, y, z.
    pub curves: &'a [Vec<Point>],
    /// Their noise terms.
    pub terms: &'a [NoiseTerms],
}

/// The SVG figure of the curves of the axes x, y, z (`unit` the values') with their noise
/// terms' curves: one sensor at a glance (`calflash allan --plot`).
///
/// # Errors
/// When plotters cannot draw it.
pub fn figure(curves: &[Vec<Point>], terms: &[NoiseTerms], unit: &str) -> Result<String, Error> {
    let axes = ["x", "y", "z"];
    let pts: Vec<Vec<(f64, f64)>> = curves
        .iter()
        .map(|c| c.iter().map(|p| (p.tau, p.adev)).collect())
        .collect();
    let fits: Vec<Vec<(f64, f64)>> = curves
        .iter()
        .zip(terms)
        .map(|(c, t)| c.iter().map(|p| (p.tau, t.adev(p.tau))).collect())
        .collect();
    let fit_names: Vec<String> = axes.iter().map(|a| format!("{a}: noise terms")).collect();
    let mut series = Vec::new();
    for j in 0..curves.len().min(3) {
        series.push(Series::dots(axes[j], &pts[j], j));
        series.push(Series::curve(&fit_names[j], &fits[j], j));
    }
    let y = format!("Allan deviation [{unit}]");
    svg_loglog(&Figure {
        title: "Overlapping Allan deviation",
        x: "tau [s]",
        y: &y,
        series,
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: None,
    })
}

/// A slope line: its legend, its points, its colour.
type SlopeLine = (String, Vec<(f64, f64)>, usize);

/// The figure of one axis: its curve with 1-sigma confidence bars, its noise terms' curve, and
/// the slope lines of the terms this record resolves with their read-off points.
///
/// # Errors
/// When plotters cannot draw it.
pub fn axis_figure(
    title: &str,
    curve: &[Point],
    terms: &NoiseTerms,
    unit: &str,
) -> Result<String, Error> {
    let pts: Vec<(f64, f64)> = curve.iter().map(|p| (p.tau, p.adev)).collect();
    let bars: Vec<f64> = curve.iter().map(|p| p.adev * p.rel_error).collect();
    let fit: Vec<(f64, f64)> = curve.iter().map(|p| (p.tau, terms.adev(p.tau))).collect();
    let (lo, hi) = match (curve.first(), curve.last()) {
        (Some(a), Some(b)) => (a.tau.min(1.0), b.tau.max(3.0)),
        _ => return Err(Error::Empty(title.to_string())),
    };
    let line = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=40)
            .map(|k| lo * (hi / lo).powf(f64::from(k) / 40.0))
            .map(|t| (t, f(t)))
            .collect()
    };
    let (n, b, k) = (
        terms.random_walk,
        terms.bias_instability,
        terms.rate_random_walk,
    );
    let mut read = Vec::new();
    // (legend, points, colour): each slope in its own colour, whichever are resolved.
    let mut lines: Vec<SlopeLine> = Vec::new();
    if n > 0.0 {
        lines.push((
            format!("slope -1/2: N = {} {unit}/sqrt(Hz) at tau = 1 s", num(n)),
            line(&|t| n / t.sqrt()),
            2,
        ));
        read.push((1.0, n));
    }
    if b > 0.0 {
        let at = flattest(terms, curve).unwrap_or(1.0);
        lines.push((
            format!(
                "slope 0: B = {} {unit} (the flattest point / 0.664)",
                num(b)
            ),
            line(&|_| FLICKER * b),
            3,
        ));
        read.push((at, FLICKER * b));
    }
    if k > 0.0 {
        lines.push((
            format!("slope +1/2: K = {} {unit}/sqrt(s) at tau = 3 s", num(k)),
            line(&|t| k * (t / 3.0).sqrt()),
            4,
        ));
        read.push((3.0, k));
    }
    let mut points = Series::dots("Allan deviation (1-sigma bars)", &pts, 0);
    points.errors = Some(&bars);
    let mut series = vec![points, Series::curve("the noise terms' curve", &fit, 1)];
    for (name, p, colour) in &lines {
        series.push(Series::curve(name, p, *colour));
    }
    if !read.is_empty() {
        series.push(Series::dots("where N, B and K are read", &read, 5));
    }
    let y = format!("Allan deviation [{unit}]");
    svg_loglog(&Figure {
        title,
        x: "tau [s]",
        y: &y,
        series,
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: None,
    })
}

/// The Allan report: what was read, each sensor's terms per axis and its figures, and the
/// Kalibr `imu.yaml` when both sensors are in SI units.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(
    source: &str,
    read: &str,
    sensors: &[Sensor<'_>],
    kalibr: Option<&str>,
) -> Result<String, Error> {
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Allan deviation of {0}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>Allan deviation of {0}</h1>\n<p>{1}. Overlapping Allan deviation (IEEE Std 952, annex C); the noise terms are fitted to the whole curve (each point weighted by its confidence), and each is read where its slope line says: N on the -1/2 line at 1 s, B on the flat line over 0.664, K on the +1/2 line at 3 s. The bars are each point's 1-sigma, from its number of independent clusters: the long-tau points rest on few.</p>",
        esc(source),
        esc(read)
    );
    h.push_str(&resolved_box(sensors));
    for s in sensors {
        let u = s.unit;
        let _ = writeln!(
            h,
            "<h2>{}</h2>\n<table><tr><th>axis</th><th>random walk N</th><th>bias instability B</th><th>rate random walk K</th><th>quantization Q</th><th>rate ramp R</th></tr>",
            esc(&capitalised(s.name))
        );
        for (axis, t) in ["x", "y", "z"].iter().zip(s.terms) {
            let _ = write!(h, "<tr><td>{axis}</td>");
            for said in crate::noise::said::terms(t, u) {
                let _ = write!(h, "<td>{}</td>", esc(&said.value));
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</table>\n");
        for ((axis, c), t) in ["x", "y", "z"].iter().zip(s.curves).zip(s.terms) {
            let title = format!("{} {axis}: Allan deviation and its noise terms", s.name);
            h.push_str("<div class=\"fig\">");
            h.push_str(&axis_figure(&title, c, t, u)?);
            h.push_str("</div>\n");
        }
    }
    if let Some(y) = kalibr {
        let _ = writeln!(
            h,
            "<h2>Kalibr imu.yaml</h2>\n<p>The noise terms as Kalibr's camera-IMU calibration takes them (the largest axis of each sensor):</p>\n<pre>{}</pre>",
            esc(y)
        );
    }
    h.push_str("</body>\n</html>\n");
    Ok(super::page::with_contents(&h))
}

/// The report's answer first: which of the noise terms a datasheet states (N, B, K) this
/// record resolves on every axis, and which it is too short or too quiet to read.
fn resolved_box(sensors: &[Sensor<'_>]) -> String {
    let mut missing: Vec<String> = Vec::new();
    let mut axes = 0;
    for s in sensors {
        for (axis, t) in ["x", "y", "z"].iter().zip(s.terms) {
            axes += 1;
            for (name, v) in [
                ("N", t.random_walk),
                ("B", t.bias_instability),
                ("K", t.rate_random_walk),
            ] {
                if v.is_nan() || v <= 0.0 {
                    missing.push(format!("{} {axis} {name}", s.name));
                }
            }
        }
    }
    let (class, said) = if missing.is_empty() {
        ("accept", format!("N, B and K read on all {axes} axes"))
    } else {
        (
            "review",
            format!(
                "{} of the {} terms N, B and K on {axes} axes read; not resolved in this record: {}",
                3 * axes - missing.len(),
                3 * axes,
                missing.join(", ")
            ),
        )
    };
    format!("<p class=\"verdict {class}\">{}</p>\n", esc(&said))
}

/// `gyro` as `Gyro`.
fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
