use super::*;

#[test]
fn a_figure_is_an_svg_with_its_marks() {
    let pts = [(0.0, 1.0), (1.0, -0.5), (2.0, 0.25)];
    let s = svg(&Figure {
        title: "residuals",
        x: "input",
        y: "residual",
        series: vec![Series {
            name: "data",
            points: &pts,
            color: COLORS[0],
            line: false,
            errors: Some(&[0.1, 0.1, 0.1]),
            band: None,
        }],
        bands: vec![(0.5, 1.5)],
        band_label: "calibrated range",
        zero_line: true,
        x_names: None,
    })
    .unwrap();
    assert!(s.starts_with("<svg"));
    assert!(s.matches("<circle").count() >= 3);
    assert!(s.contains("residuals") && s.contains("calibrated range"));
}

#[test]
fn a_log_log_figure_with_no_positive_point_says_so() {
    let pts = [(0.0, 1.0), (1.0, -0.5)];
    let e = svg_loglog(&figure(&pts)).unwrap_err();
    assert!(matches!(&e, Error::Empty(title) if title == "t"));
    assert_eq!(e.to_string(), "t: nothing to draw");
    assert!(svg_loglog(&figure(&[(1.0, 2.0), (10.0, 0.5)])).is_ok());
}

fn figure<'a>(pts: &'a [(f64, f64)]) -> Figure<'a> {
    Figure {
        title: "t",
        x: "x",
        y: "y",
        series: vec![Series::dots("a series", pts, 0)],
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: None,
    }
}

#[test]
fn on_log_axes_the_legend_is_placed_by_decades() {
    // In decades, (700, 700) is in the upper right and (1.5, 700) in the upper left; on
    // linear axes both are far from those corners.
    let pts = [(700.0, 700.0), (1.5, 700.0), (1.5, 1.5)];
    let range = ((1.0, 1000.0), (1.0, 1000.0));
    let (spot, top) = legend_spot(&figure(&pts), range.0, range.1, (Axes::Log, LOGLOG_PX));
    assert!(matches!(spot, SeriesLabelPosition::LowerRight));
    assert_eq!(top, 1000.0);
    let (spot, _) = legend_spot(
        &figure(&pts),
        range.0,
        range.1,
        (Axes::Linear, FULL.plot_px()),
    );
    assert!(matches!(spot, SeriesLabelPosition::UpperRight));
    // Every corner taken: the top is raised by a share of the decades, not of the values.
    let pts = [(1.1, 1.1), (900.0, 1.1), (1.1, 900.0), (900.0, 900.0)];
    let (spot, top) = legend_spot(&figure(&pts), range.0, range.1, (Axes::Log, LOGLOG_PX));
    assert!(matches!(spot, SeriesLabelPosition::UpperRight));
    let (_, h) = legend_px(&figure(&pts)).unwrap();
    let share = (h + 10.0) / LOGLOG_PX.1;
    let want = (1000f64.ln() / (1.0 - share)).exp();
    assert!((top / want - 1.0).abs() < 1e-9, "{top} {want}");
}

#[test]
fn the_legend_goes_where_it_covers_no_point() {
    let range = ((0.0, 10.0), (0.0, 10.0));
    // Points in the upper right: the upper left is free.
    let pts = [(9.5, 9.5), (5.0, 5.0)];
    let (spot, top) = legend_spot(
        &figure(&pts),
        range.0,
        range.1,
        (Axes::Linear, FULL.plot_px()),
    );
    assert!(matches!(spot, SeriesLabelPosition::UpperLeft));
    assert_eq!(top, 10.0);
    // Points in every corner: room is made above them.
    let pts = [(0.2, 0.2), (9.8, 0.2), (0.2, 9.8), (9.8, 9.8)];
    let (spot, top) = legend_spot(
        &figure(&pts),
        range.0,
        range.1,
        (Axes::Linear, FULL.plot_px()),
    );
    assert!(matches!(spot, SeriesLabelPosition::UpperRight));
    let (_, h) = legend_px(&figure(&pts)).unwrap();
    let share = (h + 10.0) / FULL.plot_px().1;
    assert!((top - 10.0 / (1.0 - share)).abs() < 1e-9, "{top}");
}

#[test]
fn error_bars_too_short_to_see_are_said() {
    let pts = [(0.0, 0.0), (1.0, 100.0)];
    let mut f = figure(&pts);
    f.series[0].errors = Some(&[0.01, 0.01]);
    assert!(svg(&f).unwrap().contains("are within the marks"));
    f.series[0].errors = Some(&[20.0, 20.0]);
    assert!(!svg(&f).unwrap().contains("are within the marks"));
}
