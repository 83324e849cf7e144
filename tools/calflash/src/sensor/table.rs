//! Temperature and voltage setpoints: grouping the observations into the table points the
//! device interpolates between.

use crate::obs::Table;

/// The observations at one temperature and voltage setpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Temperature setpoint (mean of the group), if the table has a temperature axis.
    pub temp: Option<f64>,
    /// Voltage setpoint, if the table has a voltage axis.
    pub volt: Option<f64>,
    /// Indices of the observations.
    pub rows: Vec<usize>,
}

/// How far apart two readings may be and still belong to one setpoint.
const TEMP_TOLERANCE: f64 = 1.0;
const VOLT_TOLERANCE: f64 = 0.02;

/// The distinct setpoints of a column: sorted means of clusters of readings within `tol`.
fn setpoints(values: &[f64], tol: f64) -> Vec<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut groups: Vec<Vec<f64>> = Vec::new();
    for v in sorted {
        match groups.last_mut() {
            Some(g) if v - g[0] <= tol => g.push(v),
            _ => groups.push(vec![v]),
        }
    }
    groups
        .iter()
        .map(|g| g.iter().sum::<f64>() / g.len() as f64)
        .collect()
}

fn nearest(points: &[f64], v: f64) -> usize {
    points
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - v).abs().total_cmp(&(b.1 - v).abs()))
        .map_or(0, |(i, _)| i)
}

/// A table layout: its temperature and voltage breakpoints and the observations at each
/// (temperature-major, as the blob stores them).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Temperature breakpoints (empty: no temperature axis).
    pub temps: Vec<f64>,
    /// Voltage breakpoints (empty: no voltage axis).
    pub volts: Vec<f64>,
    /// The points, `temps.len().max(1) * volts.len().max(1)` of them.
    pub points: Vec<Point>,
}

/// Setpoints that do not form a full grid of temperature by voltage.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the temperature and voltage setpoints do not form a full grid: no observations at {at}; \
     the device interpolates over a grid, so every temperature needs every voltage"
)]
pub struct GridError {
    /// The setpoint without observations ("-40.0 C, 3.60 V").
    pub at: String,
}

/// Groups the observations by the setpoints of the `temp` and `volt` columns (each axis only
/// when the column is there and takes more than one setpoint).
///
/// # Errors
/// When the setpoints do not form a full grid (a temperature without every voltage).
pub fn layout(table: &Table, temp: Option<&str>, volt: Option<&str>) -> Result<Layout, GridError> {
    let axis = |name: Option<&str>, tol: f64| -> (Vec<f64>, Option<&[f64]>) {
        match name.and_then(|n| table.column(n)) {
            Some(c) => {
                let s = setpoints(c, tol);
                if s.len() > 1 {
                    (s, Some(c))
                } else {
                    (Vec::new(), None)
                }
            }
            None => (Vec::new(), None),
        }
    };
    let (temps, tcol) = axis(temp, TEMP_TOLERANCE);
    let (volts, vcol) = axis(volt, VOLT_TOLERANCE);
    let nv = volts.len().max(1);
    let mut points: Vec<Point> = (0..temps.len().max(1) * nv)
        .map(|k| Point {
            temp: temps.get(k / nv).copied(),
            volt: volts.get(k % nv).copied(),
            rows: Vec::new(),
        })
        .collect();
    for i in 0..table.len() {
        let t = tcol.map_or(0, |c| nearest(&temps, c[i]));
        let v = vcol.map_or(0, |c| nearest(&volts, c[i]));
        points[t * nv + v].rows.push(i);
    }
    if let Some(p) = points.iter().find(|p| p.rows.is_empty()) {
        return Err(GridError { at: describe(p) });
    }
    Ok(Layout {
        temps,
        volts,
        points,
    })
}

/// Whether the readings of `column` sit at exact setpoints, as a chamber held at a few
/// temperatures gives them (each reading within 1 C of its setpoint, the setpoints at least
/// 3 C apart), rather than spread along a ramp.
#[must_use]
pub fn exact_setpoints(table: &Table, column: &str, layout: &Layout) -> bool {
    let Some(values) = table.column(column) else {
        return true;
    };
    let near = layout.points.iter().all(|p| {
        p.temp.is_none_or(|t| {
            p.rows
                .iter()
                .all(|r| (values[*r] - t).abs() <= TEMP_TOLERANCE)
        })
    });
    near && layout
        .temps
        .windows(2)
        .all(|w| w[1] - w[0] >= 3.0 * TEMP_TOLERANCE)
}

/// "25 C, 3.3 V" for messages.
#[must_use]
pub fn describe(p: &Point) -> String {
    match (p.temp, p.volt) {
        (Some(t), Some(v)) => format!("{t:.1} C, {v:.2} V"),
        (Some(t), None) => format!("{t:.1} C"),
        (None, Some(v)) => format!("{v:.2} V"),
        (None, None) => "the single table point".into(),
    }
}

impl Layout {
    /// The point nearest the middle of the table (the reference for the axis centers).
    #[must_use]
    pub fn reference(&self) -> usize {
        let mid = |v: &[f64]| if v.is_empty() { 0 } else { (v.len() - 1) / 2 };
        mid(&self.temps) * self.volts.len().max(1) + mid(&self.volts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_of_setpoints() {
        let t = Table {
            path: "x".into(),
            names: vec!["temp".into(), "volt".into()],
            columns: vec![
                vec![
                    -40.2, -39.9, 25.0, 25.3, 85.1, 84.8, -40.0, 25.0, 85.0, -40.0, 25.0, 85.0,
                ],
                vec![3.0, 3.6, 3.0, 3.6, 3.0, 3.6, 3.0, 3.0, 3.0, 3.6, 3.6, 3.6],
            ],
            lines: (0..12).collect(),
        };
        let l = layout(&t, Some("temp"), Some("volt")).unwrap();
        assert_eq!(l.volts, [3.0, 3.6]);
        assert_eq!(l.temps.len(), 3);
        assert!((l.temps[0] + 40.025).abs() < 1e-9);
        assert_eq!(l.points.len(), 6);
        assert_eq!(l.points[1].rows, [1, 9]);
        assert_eq!(l.reference(), 2);
        let missing = Table {
            columns: vec![vec![-40.0, 25.0, 25.0], vec![3.0, 3.0, 3.6]],
            lines: vec![1, 2, 3],
            ..t
        };
        let e = layout(&missing, Some("temp"), Some("volt")).unwrap_err();
        assert_eq!(e.at, "-40.0 C, 3.60 V");
        assert!(
            e.to_string().contains("no observations at -40.0 C, 3.60 V"),
            "{e}"
        );
    }
}
