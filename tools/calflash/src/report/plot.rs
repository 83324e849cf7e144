//! SVG figures for the HTML report, drawn with plotters' SVG backend (text is laid out by the
//! browser, so no font files are needed).

use super::Error;
use super::axis::Ticks;
use plotters::coord::combinators::LogCoord;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// A named set of points and how to draw it.
pub struct Series<'a> {
    /// Legend name.
    pub name: &'a str,
    /// Points.
    pub points: &'a [(f64, f64)],
    /// Colour.
    pub color: RGBColor,
    /// Join the points with a line.
    pub line: bool,
    /// Vertical error bars (half-widths, one per point).
    pub errors: Option<&'a [f64]>,
    /// A shaded band about the line (half-widths, one per point): a 1-sigma that changes
    /// smoothly along a curve, where error bars would hide each other.
    pub band: Option<&'a [f64]>,
}

/// Blue, orange, green, red, purple, brown: distinguishable series colours.
pub const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

impl<'a> Series<'a> {
    /// Unjoined points in the `k`-th colour.
    #[must_use]
    pub fn dots(name: &'a str, points: &'a [(f64, f64)], k: usize) -> Self {
        Self {
            name,
            points,
            color: COLORS[k % COLORS.len()],
            line: false,
            errors: None,
            band: None,
        }
    }

    /// A line through the points in the `k`-th colour.
    #[must_use]
    pub fn curve(name: &'a str, points: &'a [(f64, f64)], k: usize) -> Self {
        Self {
            line: true,
            ..Self::dots(name, points, k)
        }
    }
}

/// What a figure shows.
pub struct Figure<'a> {
    /// Title.
    pub title: &'a str,
    /// x label.
    pub x: &'a str,
    /// y label.
    pub y: &'a str,
    /// The series.
    pub series: Vec<Series<'a>>,
    /// x intervals to shade (the calibrated range, the still poses).
    pub bands: Vec<(f64, f64)>,
    /// The legend of the shaded intervals.
    pub band_label: &'a str,
    /// Draw y = 0.
    pub zero_line: bool,
    /// Names for the whole numbers on the x axis (1 names the first), instead of the numbers:
    /// a figure over named things (the outputs), not over a quantity.
    pub x_names: Option<&'a [&'a str]>,
}

fn bounds(fig: &Figure<'_>) -> ((f64, f64), (f64, f64)) {
    let mut x = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y = (f64::INFINITY, f64::NEG_INFINITY);
    for s in &fig.series {
        for (i, (px, py)) in s.points.iter().enumerate() {
            if !(px.is_finite() && py.is_finite()) {
                continue;
            }
            let bar = s.errors.and_then(|e| e.get(i)).copied().unwrap_or(0.0);
            let band = s.band.and_then(|e| e.get(i)).copied().unwrap_or(0.0);
            let e = bar.max(band);
            x = (x.0.min(*px), x.1.max(*px));
            y = (y.0.min(py - e), y.1.max(py + e));
        }
    }
    for (a, b) in &fig.bands {
        x = (x.0.min(*a), x.1.max(*b));
    }
    if fig.zero_line {
        y = (y.0.min(0.0), y.1.max(0.0));
    }
    let pad = |(lo, hi): (f64, f64)| {
        if !lo.is_finite() {
            return (-1.0, 1.0);
        }
        let w = if hi > lo { hi - lo } else { lo.abs().max(1.0) };
        (lo - 0.05 * w, hi + 0.05 * w)
    };
    (pad(x), pad(y))
}

/// A figure's size in pixels: the report's column (1000 px), scaled down with the window.
const SIZE: (u32, u32) = (1000, 440);

/// The log-log figure's size.
const LOGLOG_SIZE: (u32, u32) = (1000, 540);

/// The plotting area of the log-log figure.
const LOGLOG_PX: (f64, f64) = (LOGLOG_SIZE.0 as f64 - 110.0, LOGLOG_SIZE.1 as f64 - 100.0);

/// Text sizes as given to plotters: the title, the axes' names, the tick labels and the
/// legend. Its SVG backend writes them at 1/1.24 of that (a point size), so 14 is the smallest
/// that a browser draws at 11 px or more.
const TITLE_PX: u32 = 20;
const NAME_PX: u32 = 15;
const TICK_PX: u32 = 14;
const LEGEND_PX: u32 = 14;
/// The smallest text size given to plotters (drawn at 11.3 px).
const MIN_PX: u32 = 14;

/// How a figure is laid out: its size, its title's largest text, its ticks and label areas,
/// and whether it carries its own legend.
struct Frame {
    size: (u32, u32),
    title_px: u32,
    ticks: (usize, usize),
    label_areas: (u32, u32),
    margin: u32,
    legend: bool,
}

/// A figure across the report's column.
const FULL: Frame = Frame {
    size: SIZE,
    title_px: TITLE_PX,
    ticks: (10, 8),
    label_areas: (48, 86),
    margin: 12,
    legend: true,
};

/// One of three small multiples across the column; the key is written once beside the row.
const PANEL: Frame = Frame {
    size: (325, 250),
    title_px: 15,
    ticks: (5, 5),
    label_areas: (44, 78),
    margin: 8,
    legend: false,
};

impl Frame {
    /// The plotting area in pixels (less the caption, margins and the axes' label areas).
    fn plot_px(&self) -> (f64, f64) {
        (
            f64::from(self.size.0) - f64::from(self.label_areas.1) - 24.0,
            f64::from(self.size.1) - f64::from(self.label_areas.0) - 52.0,
        )
    }
}

/// Figures one under another across the column, or as small multiples three to a row with one
/// key for the row (a triad's or an IMU's outputs side by side): [`Sheet::add`] each, then
/// [`Sheet::finish`].
pub struct Sheet {
    small: bool,
    panels: Vec<String>,
    key: Vec<(String, RGBColor, bool)>,
}

impl Sheet {
    /// Full-size figures (`small` false) or small multiples.
    #[must_use]
    pub fn new(small: bool) -> Self {
        Self {
            small,
            panels: Vec::new(),
            key: Vec::new(),
        }
    }

    /// Whether the figures are small multiples.
    #[must_use]
    pub fn small(&self) -> bool {
        self.small
    }

    /// Draws `fig`: at once into `h` at full size, or kept for the row of small multiples.
    ///
    /// # Errors
    /// As [`svg`].
    pub fn add(&mut self, h: &mut String, fig: &Figure<'_>) -> Result<(), Error> {
        if !self.small {
            return figure(h, fig);
        }
        self.panels.push(draw(fig, &PANEL)?);
        let mut entries: Vec<(String, RGBColor, bool)> = fig
            .series
            .iter()
            .filter(|s| !s.name.is_empty())
            .map(|s| (s.name.to_string(), s.color, s.line))
            .collect();
        if !fig.bands.is_empty() && !fig.band_label.is_empty() {
            entries.push((fig.band_label.to_string(), BAND, false));
        }
        for e in entries {
            if !self.key.iter().any(|k| k.0 == e.0) {
                self.key.push(e);
            }
        }
        Ok(())
    }

    /// Writes the small multiples kept (nothing for full-size figures): the key, then the
    /// panels three to a row.
    pub fn finish(self, h: &mut String) {
        if self.panels.is_empty() {
            return;
        }
        h.push_str("<p class=\"key\">");
        for (name, RGBColor(r, g, b), line) in &self.key {
            let mark = if *line { "&#9644;" } else { "&#9679;" };
            h.push_str(&format!(
                "<span style=\"color:rgb({r},{g},{b})\">{mark}</span> {} &#160; ",
                super::page::esc(name)
            ));
        }
        h.push_str("</p>\n<div class=\"panels\">");
        for p in &self.panels {
            h.push_str("<div class=\"fig\">");
            h.push_str(p);
            h.push_str("</div>");
        }
        h.push_str("</div>\n");
    }
}

/// The shade of a figure's marked intervals (the calibrated range, the still poses).
const BAND: RGBColor = RGBColor(230, 240, 255);

/// The title's font size: the standard size, or smaller so that a long title fits the figure's
/// width (sans-serif glyphs average about 0.55 of the size).
fn title_px(title: &str, width: u32) -> u32 {
    let room = f64::from(width) - 40.0;
    let chars = title.chars().count().max(1) as f64;
    let fits = (room / (0.58 * chars)).floor() as u32;
    fits.clamp(MIN_PX, TITLE_PX)
}

/// How a figure's axes map values to distance: the legend's place is chosen in that space.
#[derive(Debug, Clone, Copy)]
enum Axes {
    /// Linear on both axes.
    Linear,
    /// Logarithmic on both axes.
    Log,
}

impl Axes {
    fn to(self, v: f64) -> f64 {
        match self {
            Self::Linear => v,
            Self::Log => v.ln(),
        }
    }

    fn from(self, v: f64) -> f64 {
        match self {
            Self::Linear => v,
            Self::Log => v.exp(),
        }
    }
}

/// The legend's size in pixels: plotters' entries are about 22 px high, their text about 7.8
/// px a character beside a 12 px mark.
fn legend_px(fig: &Figure<'_>) -> Option<(f64, f64)> {
    let mut names: Vec<&str> = fig
        .series
        .iter()
        .map(|s| s.name)
        .filter(|n| !n.is_empty())
        .collect();
    if !fig.bands.is_empty() {
        names.push(fig.band_label);
    }
    let longest = names.iter().map(|n| n.chars().count()).max()?;
    Some((
        40.0 + 7.8 * longest as f64,
        12.0 + 22.0 * names.len() as f64,
    ))
}

/// Where the legend covers no point: the corner of the plot with none under it, else the
/// upper right with the y range raised so that the data stay below it. The position and the
/// (possibly raised) top of the y range.
fn legend_spot(
    fig: &Figure<'_>,
    x: (f64, f64),
    y: (f64, f64),
    (axes, plot_px): (Axes, (f64, f64)),
) -> (SeriesLabelPosition, f64) {
    let Some((w, h)) = legend_px(fig) else {
        return (SeriesLabelPosition::UpperRight, y.1);
    };
    let (x0, x1, y0, y1) = (axes.to(x.0), axes.to(x.1), axes.to(y.0), axes.to(y.1));
    // The legend's share of the plot, with its 10 px from the edges.
    let (fw, fh) = ((w + 10.0) / plot_px.0, (h + 10.0) / plot_px.1);
    let under = |left: bool, top: bool| {
        let (xa, xb) = if left {
            (x0, x0 + fw * (x1 - x0))
        } else {
            (x1 - fw * (x1 - x0), x1)
        };
        let (ya, yb) = if top {
            (y1 - fh * (y1 - y0), y1)
        } else {
            (y0, y0 + fh * (y1 - y0))
        };
        fig.series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|(x, y)| (xa..=xb).contains(&axes.to(*x)) && (ya..=yb).contains(&axes.to(*y)))
            .count()
    };
    for (position, left, top) in [
        (SeriesLabelPosition::UpperRight, false, true),
        (SeriesLabelPosition::UpperLeft, true, true),
        (SeriesLabelPosition::LowerRight, false, false),
        (SeriesLabelPosition::LowerLeft, true, false),
    ] {
        if under(left, top) == 0 {
            return (position, y.1);
        }
    }
    // Room above the data: the legend takes the top fh of the raised range.
    let fh = fh.min(0.6);
    (
        SeriesLabelPosition::UpperRight,
        axes.from(y1 + (y1 - y0) * fh / (1.0 - fh)),
    )
}

/// An axis' coordinate with the ticks of [`Ticks`] (plotters' own choice of ticks formats each
/// label on its own).
struct Ticked<R> {
    inner: R,
    bold: Vec<f64>,
    light: Vec<f64>,
}

impl<R: Ranged<ValueType = f64>> Ticked<R> {
    fn new(inner: R, ticks: &Ticks) -> Self {
        Self {
            inner,
            bold: ticks.bold.clone(),
            light: ticks.light.clone(),
        }
    }
}

impl<R: Ranged<ValueType = f64>> Ranged for Ticked<R> {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.bold.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }

    fn axis_pixel_range(&self, limit: (i32, i32)) -> std::ops::Range<i32> {
        self.inner.axis_pixel_range(limit)
    }
}

/// The distinct units of a report's outputs, in the order they first come: one figure each, so
/// that no axis holds two units (an IMU's m/s^2 and rad/s).
pub(crate) fn units_in_order<'a>(units: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for u in units {
        if !out.contains(&u) {
            out.push(u);
        }
    }
    out
}

/// Appends `fig` to an HTML page `h`, as an inline SVG in a `fig` block.
///
/// # Errors
/// As [`svg`].
pub fn figure(h: &mut String, fig: &Figure<'_>) -> Result<(), Error> {
    h.push_str("<div class=\"fig\">");
    h.push_str(&svg(fig)?);
    h.push_str("</div>\n");
    Ok(())
}

/// The name of whole number `v` (1 names the first), empty between them.
fn named_tick(names: &[&str], v: f64) -> String {
    let k = v.round();
    if (v - k).abs() > 1e-6 || k < 1.0 {
        return String::new();
    }
    names
        .get(k as usize - 1)
        .map_or(String::new(), |n| (*n).to_string())
}

/// Draws a figure as an SVG document (a string).
///
/// # Errors
/// plotters' drawing error.
pub fn svg(fig: &Figure<'_>) -> Result<String, Error> {
    draw(fig, &FULL)
}

/// Draws a figure in `frame` as an SVG document.
fn draw(fig: &Figure<'_>, frame: &Frame) -> Result<String, Error> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, frame.size).into_drawing_area();
        root.fill(&WHITE)?;
        let ((x0, x1), (y0, y1)) = bounds(fig);
        let (spot, y1) = if frame.legend {
            legend_spot(fig, (x0, x1), (y0, y1), (Axes::Linear, frame.plot_px()))
        } else {
            (SeriesLabelPosition::UpperRight, y1)
        };
        // Error bars too short to see are said under the axis, not left to look like no
        // uncertainty.
        let largest = fig
            .series
            .iter()
            .filter_map(|s| s.errors)
            .flatten()
            .fold(0.0_f64, |m, e| m.max(*e));
        let x_desc =
            if fig.series.iter().any(|s| s.errors.is_some()) && 2.0 * largest < 0.02 * (y1 - y0) {
                format!(
                    "{}   (1-sigma error bars, at most +-{}, are within the marks)",
                    fig.x,
                    super::terminal::num(largest)
                )
            } else {
                fig.x.to_string()
            };
        let (xt, yt) = (
            Ticks::linear(x0, x1, frame.ticks.0),
            Ticks::linear(y0, y1, frame.ticks.1),
        );
        let title = title_px(fig.title, frame.size.0).min(frame.title_px);
        let mut chart = ChartBuilder::on(&root)
            .caption(fig.title, (super::page::FONT, title))
            .margin(frame.margin)
            .x_label_area_size(frame.label_areas.0)
            .y_label_area_size(frame.label_areas.1)
            .build_cartesian_2d(
                Ticked::new(RangedCoordf64::from(x0..x1), &xt),
                Ticked::new(RangedCoordf64::from(y0..y1), &yt),
            )?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(fig.y)
            .x_label_formatter(&|v| match fig.x_names {
                Some(names) => named_tick(names, *v),
                None => xt.label(*v),
            })
            .y_label_formatter(&|v| yt.label(*v))
            .label_style((super::page::FONT, TICK_PX))
            .axis_desc_style((super::page::FONT, NAME_PX))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        if !fig.bands.is_empty() {
            chart
                .draw_series(
                    fig.bands
                        .iter()
                        .map(|(a, b)| Rectangle::new([(*a, y0), (*b, y1)], BAND.filled())),
                )?
                .label(fig.band_label)
                .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], BAND.filled()));
        }
        if fig.zero_line {
            chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], BLACK.mix(0.4)))?;
        }
        for s in &fig.series {
            let color = s.color;
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .collect();
            if let Some(half) = s.band {
                // The band's outline: up along the upper edge, back along the lower.
                let kept: Vec<(f64, f64, f64)> = s
                    .points
                    .iter()
                    .zip(half)
                    .map(|((x, y), e)| (*x, *y, *e))
                    .filter(|(x, y, e)| x.is_finite() && y.is_finite() && e.is_finite())
                    .collect();
                let edge: Vec<(f64, f64)> = kept
                    .iter()
                    .map(|(x, y, e)| (*x, y + e))
                    .chain(kept.iter().rev().map(|(x, y, e)| (*x, y - e)))
                    .collect();
                chart.draw_series(std::iter::once(Polygon::new(edge, color.mix(0.2).filled())))?;
            }
            if let Some(errors) = s.errors {
                chart.draw_series(pts.iter().zip(errors).map(|((x, y), e)| {
                    ErrorBar::new_vertical(*x, y - e, *y, y + e, color.filled(), 6)
                }))?;
            }
            line_or_marks(&mut chart, s, &pts, 2)?;
        }
        if frame.legend {
            legend(&mut chart, spot)?;
        }
        root.present()?;
    }
    Ok(out)
}

/// Draws a series as a line or as dots, with its legend entry.
fn line_or_marks<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    s: &Series<'_>,
    pts: &[(f64, f64)],
    radius: i32,
) -> Result<(), Error>
where
    DB: DrawingBackend<ErrorType = std::io::Error> + 'a,
    CT: CoordTranslate<From = (f64, f64)>,
{
    let color = s.color;
    let anno = if s.line {
        chart.draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
    } else {
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, radius, color.filled())))
    }?;
    // A series without a name (the second edge of a band) has no legend entry.
    if !s.name.is_empty() {
        anno.label(s.name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 3), (x + 12, y + 3)], color.filled()));
    }
    Ok(())
}

/// The legend box, at `position`.
fn legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), Error>
where
    DB: DrawingBackend<ErrorType = std::io::Error> + 'a,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .label_font((super::page::FONT, LEGEND_PX))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()?;
    Ok(())
}

/// Draws series on logarithmic axes (the Allan deviation), as an SVG document. Points with a
/// coordinate at or below zero are left out.
///
/// # Errors
/// plotters' drawing error.
pub fn svg_loglog(fig: &Figure<'_>) -> Result<String, Error> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, LOGLOG_SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        // The points and the ends of their error bars.
        let pos: Vec<(f64, f64)> = fig
            .series
            .iter()
            .flat_map(|s| {
                s.points.iter().enumerate().flat_map(move |(i, (x, y))| {
                    let e = s.errors.and_then(|e| e.get(i)).copied().unwrap_or(0.0);
                    [(*x, *y), (*x, y - e), (*x, y + e)]
                })
            })
            .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
            .collect();
        let fold = |f: fn(&(f64, f64)) -> f64| {
            pos.iter()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let ((x0, x1), (y0, y1)) = (fold(|p| p.0), fold(|p| p.1));
        if !x0.is_finite() {
            return Err(Error::Empty(fig.title.to_string()));
        }
        let (x0, x1, y0) = (x0 / 1.5, x1 * 1.5, y0 / 1.5);
        let (spot, y1) = legend_spot(fig, (x0, x1), (y0, y1 * 1.5), (Axes::Log, LOGLOG_PX));
        let (xt, yt) = (Ticks::log(x0, x1), Ticks::log(y0, y1));
        let mut chart = ChartBuilder::on(&root)
            .caption(
                fig.title,
                (super::page::FONT, title_px(fig.title, LOGLOG_SIZE.0)),
            )
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(86)
            .build_cartesian_2d(
                Ticked::new(LogCoord::from((x0..x1).log_scale()), &xt),
                Ticked::new(LogCoord::from((y0..y1).log_scale()), &yt),
            )?;
        chart
            .configure_mesh()
            .x_desc(fig.x)
            .y_desc(fig.y)
            .x_label_formatter(&|v| xt.label(*v))
            .y_label_formatter(&|v| yt.label(*v))
            .label_style((super::page::FONT, TICK_PX))
            .axis_desc_style((super::page::FONT, NAME_PX))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for s in &fig.series {
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| *x > 0.0 && *y > 0.0)
                .collect();
            if let Some(errors) = s.errors {
                let color = s.color;
                chart.draw_series(
                    s.points
                        .iter()
                        .zip(errors)
                        .filter(|((x, y), e)| *x > 0.0 && y - *e > 0.0)
                        .map(|((x, y), e)| {
                            ErrorBar::new_vertical(*x, y - e, *y, y + e, color.filled(), 6)
                        }),
                )?;
            }
            line_or_marks(&mut chart, s, &pts, 3)?;
        }
        legend(&mut chart, spot)?;
        root.present()?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
