//! The Allan deviation figure: each axis' curve and the curve of its noise terms, on log axes.

use super::Error;
use super::plot::{COLORS, Figure, Series, svg_loglog};
use crate::noise::allan::{NoiseTerms, Point};

/// The SVG figure of the curves of the axes x, y, z (`unit` the values') with their noise
/// terms' curves.
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
        series.push(Series {
            name: axes[j],
            points: &pts[j],
            color: COLORS[j],
            line: false,
            errors: None,
        });
        series.push(Series {
            name: &fit_names[j],
            points: &fits[j],
            color: COLORS[j],
            line: true,
            errors: None,
        });
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
    })
}
