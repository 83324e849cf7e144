//! From a continuous temperature model of a single axis to what the device applies: either a
//! table of sets at breakpoints (blended linearly between them) or a Chebyshev series of sets
//! over the calibrated span (`spincal::model::TemperatureModel`). Either is held to the same
//! standard: on a dense grid of temperatures and inputs, the device's correction departs from
//! the model's own by at most a tenth of the model's 1-sigma (of the corrected input, from the
//! bias and scale-factor covariance).

use nalgebra::DMatrix;
use spincal::model::{AxisNonlinearity, MAX_SETS, MAX_TEMPERATURES, SingleSet};

use super::{Scale, ThermalFit};
use crate::sensor::covariance;
use crate::sensor::invert::{Own, linearization, linearize};
use crate::sensor::single::coefficients::{bias_slope_cov, own_at};
use crate::sensor::{Finding, Verdict};

/// What the device applies for one forward model, in f64: the linearisation `n`, then
/// `x = offset + scale u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceSet {
    /// The linearisation.
    pub n: [f64; 5],
    /// Scale of the affine map.
    pub scale: f64,
    /// Offset of the affine map.
    pub offset: f64,
    /// Worst inversion error over the calibrated range, SI.
    pub error: f64,
}

impl DeviceSet {
    /// The device's set for a forward model over inputs `lo..hi`.
    #[must_use]
    pub fn of(o: &Own, center: f64, lo: f64, hi: f64) -> Self {
        let lin = linearization(o, center, lo, hi);
        // x = (L - (bias - center)) / slope with L = alpha + gamma u.
        Self {
            n: lin.n,
            scale: lin.gamma / o.slope,
            offset: (lin.alpha - (o.bias - center)) / o.slope,
            error: lin.error,
        }
    }

    /// The correction of `v = code - center`.
    #[must_use]
    pub fn correct(&self, v: f64) -> f64 {
        self.offset + self.scale * linearize(&self.n, v)
    }

    /// The device's coefficients in f64.
    #[must_use]
    pub fn from_set(s: &SingleSet) -> Self {
        let n = s.axis.to_array().map(f64::from);
        Self {
            n,
            scale: f64::from(s.scale),
            offset: f64::from(s.offset),
            error: 0.0,
        }
    }

    pub(crate) fn to_array(self) -> [f64; 7] {
        let n = self.n;
        [n[0], n[1], n[2], n[3], n[4], self.scale, self.offset]
    }

    pub(crate) fn from_array(a: [f64; 7], error: f64) -> Self {
        Self {
            n: [a[0], a[1], a[2], a[3], a[4]],
            scale: a[5],
            offset: a[6],
            error,
        }
    }

    /// The device's blend: each coefficient linearly.
    fn blend(&self, other: &Self, t: f64) -> Self {
        let (a, b) = (self.to_array(), other.to_array());
        Self::from_array(
            std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t),
            self.error.max(other.error),
        )
    }

    /// The device's coefficients.
    #[must_use]
    pub fn set(&self) -> SingleSet {
        let n = self.n;
        SingleSet {
            axis: AxisNonlinearity {
                quadratic: n[0] as f32,
                cubic: n[1] as f32,
                odd_quadratic: n[2] as f32,
                asymmetry: n[3] as f32,
                asymmetry_break: n[4] as f32,
            },
            scale: self.scale as f32,
            offset: self.offset as f32,
        }
    }
}

/// Temperatures of the grid the device's temperature dependence is checked on.
const GRID: usize = 221;
/// Inputs per temperature of that grid.
const INPUTS: usize = 41;

/// The model on a dense grid: what the device's temperature dependence is checked against.
struct Grid {
    points: Vec<(f64, DeviceSet, Own, f64, f64, f64)>,
    inputs: Vec<f64>,
    center: f64,
}

impl Grid {
    fn new(tf: &ThermalFit, center: f64, (lo, hi): (f64, f64), bp: f64, y: f64) -> Self {
        let scale = tf.scale;
        let points = (0..GRID)
            .map(|i| {
                let t = scale.lo + (scale.hi - scale.lo) * i as f64 / (GRID - 1) as f64;
                let (d, o, c) = model_at(tf, (t, y), center, (lo, hi), bp);
                (t, d, o, c[0], c[1], c[2])
            })
            .collect();
        Self {
            points,
            inputs: (0..INPUTS)
                .map(|k| lo + (hi - lo) * k as f64 / (INPUTS - 1) as f64)
                .collect(),
            center,
        }
    }

    /// The worst departure of `device(t)` from the model, in tenths of the model's 1-sigma,
    /// and the temperature where it is.
    fn ratio(&self, device: impl Fn(f64) -> DeviceSet) -> (f64, f64) {
        let mut worst = (0.0f64, self.points.first().map_or(0.0, |p| p.0));
        for (t, exact, o, c00, c01, c11) in &self.points {
            let d = device(*t);
            for x in &self.inputs {
                let v = o.output(*x) - self.center;
                let sd = (c00 + 2.0 * x * c01 + x * x * c11).max(0.0).sqrt() / o.slope.abs();
                let r = (d.correct(v) - exact.correct(v)).abs() / (0.1 * sd);
                if r > worst.0 {
                    worst = (r, *t);
                }
            }
        }
        worst
    }
}

/// The device set at temperature `t` and scaled supply voltage `y`, and the covariance of the
/// bias and scale factor there (`[var b, cov, var s]`).
fn model_at(
    tf: &ThermalFit,
    (t, y): (f64, f64),
    center: f64,
    (lo, hi): (f64, f64),
    bp: f64,
) -> (DeviceSet, Own, [f64; 3]) {
    let names = tf.base.term_names();
    let (c, cov) = tf.coefficients_at(t);
    let o = own_at(&names, &c, bp, y);
    (
        DeviceSet::of(&o, center, lo, hi),
        o,
        bias_slope_cov(&names, &cov, y),
    )
}

/// What the device gets.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceTemperature {
    /// Table breakpoints, or the series' nodes (where the model is evaluated for the report
    /// and the checks).
    pub temps: Vec<f64>,
    /// `Some(n)`: the sets are an n-term Chebyshev series; `None`: a table at `temps`.
    pub series: Option<usize>,
    /// The sets: one per breakpoint, or one per series term, each at every voltage point
    /// (temperature-major).
    pub sets: Vec<SingleSet>,
    /// Their covariance factors, alike.
    pub covariances: Vec<[f32; 3]>,
    /// The worst departure from the model in tenths of its 1-sigma, and where.
    pub ratio: (f64, f64),
    /// The worst relative error of the device's stated 1-sigma against the model's, where it
    /// is checked (a triad's or an IMU's form).
    pub sigma_error: Option<f64>,
    /// The other form's figures, for the note: (sets, ratio); `None` where the device holds
    /// only tables (an IMU with lever arms).
    pub other: Option<(usize, f64)>,
}

/// The `n` Chebyshev nodes over `scale`.
pub(crate) fn nodes(scale: &Scale, n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let x = (std::f64::consts::PI * (j as f64 + 0.5) / n as f64).cos();
            scale.center() + scale.half() * x
        })
        .collect()
}

/// Chebyshev coefficients of values at the `n` nodes (interpolation at the nodes), each value
/// a row of numbers.
pub(crate) fn chebyshev_rows(values: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = values.len();
    let width = values.first().map_or(0, Vec::len);
    (0..n)
        .map(|k| {
            let w = if k == 0 { 1.0 } else { 2.0 } / n as f64;
            (0..width)
                .map(|i| {
                    w * values
                        .iter()
                        .enumerate()
                        .map(|(j, v)| {
                            v[i] * (std::f64::consts::PI * k as f64 * (j as f64 + 0.5) / n as f64)
                                .cos()
                        })
                        .sum::<f64>()
                })
                .collect()
        })
        .collect()
}

/// [`chebyshev_rows`] of fixed-width values.
fn chebyshev<const K: usize>(values: &[[f64; K]]) -> Vec<[f64; K]> {
    let rows: Vec<Vec<f64>> = values.iter().map(|v| v.to_vec()).collect();
    chebyshev_rows(&rows)
        .into_iter()
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect()
}

/// `sum c_k T_k(x)`, as the device sums it.
pub(crate) fn clenshaw<const K: usize>(c: &[[f64; K]], x: f64) -> [f64; K] {
    let rows: Vec<&[f64]> = c.iter().map(|r| &r[..]).collect();
    let v = clenshaw_rows(&rows, x);
    std::array::from_fn(|i| v[i])
}

/// [`clenshaw`] of rows of numbers.
pub(crate) fn clenshaw_rows(c: &[&[f64]], x: f64) -> Vec<f64> {
    let width = c.first().map_or(0, |r| r.len());
    (0..width)
        .map(|i| {
            let (mut b1, mut b2) = (0.0, 0.0);
            for ck in c.iter().skip(1).rev() {
                let b = ck[i] + 2.0 * x * b1 - b2;
                b2 = b1;
                b1 = b;
            }
            c.first().map_or(0.0, |c0| c0[i]) + x * b1 - b2
        })
        .collect()
}
/// Why the device's temperature form cannot be chosen.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChooseError {
    /// No series was tried (no breakpoints to fit one through).
    #[error("no series")]
    NoSeries,
    /// A covariance factor that cannot be formed at a temperature.
    #[error("output at {temp:.1} C: {source}")]
    Covariance {
        /// The temperature, C.
        temp: f64,
        /// Why.
        source: covariance::CovarianceError,
    },
}

/// The device's temperature dependence for a continuous model of one axis (inputs `lo..hi`,
/// codes about `center`), over `scale` (the calibrated span as the device holds it, in f32),
/// at each of the device's voltage points `ys` (scaled supply voltages; `[0.0]` without a
/// voltage axis): the smallest Chebyshev series that meets the standard at every voltage
/// point, or the table if it meets it with fewer sets; when neither does, the one that comes
/// closer. The sets are temperature-major, as the blob stores them.
///
/// # Errors
/// A covariance factor that cannot be formed, in words.
pub fn choose(
    tf: &ThermalFit,
    scale: &Scale,
    center: f64,
    (lo, hi): (f64, f64),
    bp: f64,
    ys: &[f64],
) -> Result<DeviceTemperature, ChooseError> {
    let grids: Vec<Grid> = ys
        .iter()
        .map(|y| Grid::new(tf, center, (lo, hi), bp, *y))
        .collect();
    let at = |t: f64, y: f64| model_at(tf, (t, y), center, (lo, hi), bp);
    let worst = |r: Vec<(f64, f64)>| {
        r.into_iter()
            .fold((0.0f64, scale.lo), |m, x| if x.0 > m.0 { x } else { m })
    };
    // The table: breakpoints where it departs most, until it meets the standard or is full.
    let (breaks, table_ratio) = breakpoints(scale, MAX_TEMPERATURES, |points| {
        worst(
            ys.iter()
                .zip(&grids)
                .map(|(y, grid)| {
                    let sets: Vec<DeviceSet> = points.iter().map(|t| at(*t, *y).0).collect();
                    grid.ratio(|t| {
                        let k = points
                            .partition_point(|p| *p <= t)
                            .clamp(1, points.len() - 1);
                        let (a, b) = (points[k - 1], points[k]);
                        sets[k - 1].blend(&sets[k], ((t - a) / (b - a)).clamp(0.0, 1.0))
                    })
                })
                .collect(),
        )
    });
    // The series: terms until it meets the standard.
    type Series = (
        Vec<f64>,
        Vec<Vec<(DeviceSet, Own, [f64; 3])>>,
        Vec<Vec<[f64; 7]>>,
        (f64, f64),
    );
    let mut series: Option<Series> = None;
    for n in 1..=MAX_SETS / ys.len().max(1) {
        let temps = nodes(scale, n);
        let models: Vec<Vec<_>> = ys
            .iter()
            .map(|y| temps.iter().map(|t| at(*t, *y)).collect())
            .collect();
        let coefficients: Vec<Vec<[f64; 7]>> = models
            .iter()
            .map(|m| chebyshev(&m.iter().map(|m| m.0.to_array()).collect::<Vec<_>>()))
            .collect();
        let ratio = worst(
            grids
                .iter()
                .zip(&coefficients)
                .zip(&models)
                .map(|((grid, c), m)| {
                    let error = m.iter().map(|m| m.0.error).fold(0.0, f64::max);
                    grid.ratio(|t| {
                        DeviceSet::from_array(clenshaw(c, scale.x(t).clamp(-1.0, 1.0)), error)
                    })
                })
                .collect(),
        );
        if series.as_ref().is_none_or(|s| ratio.0 < s.3.0) {
            series = Some((temps, models, coefficients, ratio));
        }
        if ratio.0 <= 1.0 {
            break;
        }
    }
    let Some((temps, models, coefficients, series_ratio)) = series else {
        return Err(ChooseError::NoSeries);
    };
    let factor = |t: f64, d: &DeviceSet, o: &Own, c: &[f64; 3]| {
        let m = DMatrix::from_row_slice(2, 2, &[c[0], c[1], c[1], c[2]]);
        covariance::single(&m, o.slope, d.offset, d.scale)
            .map(|f| [f[0], f[1], f[2]])
            .map_err(|source| ChooseError::Covariance { temp: t, source })
    };
    let n = temps.len();
    let table_wins = table_ratio.0 <= 1.0 && breaks.len() < n
        || table_ratio.0 > 1.0 && series_ratio.0 > 1.0 && table_ratio.0 < series_ratio.0;
    if table_wins {
        let mut sets = Vec::new();
        let mut covariances = Vec::new();
        for t in &breaks {
            for y in ys {
                let (d, o, c) = at(*t, *y);
                sets.push(d.set());
                covariances.push(factor(*t, &d, &o, &c)?.map(|v| v as f32));
            }
        }
        return Ok(DeviceTemperature {
            temps: breaks,
            series: None,
            sets,
            covariances,
            ratio: table_ratio,
            sigma_error: None,
            other: Some((n, series_ratio.0)),
        });
    }
    let mut factors = Vec::new();
    for m in &models {
        let f = m
            .iter()
            .zip(&temps)
            .map(|((d, o, c), t)| factor(*t, d, o, c))
            .collect::<Result<Vec<_>, _>>()?;
        factors.push(chebyshev(&f));
    }
    let mut sets = Vec::new();
    let mut covariances = Vec::new();
    for k in 0..n {
        for (c, f) in coefficients.iter().zip(&factors) {
            sets.push(DeviceSet::from_array(c[k], 0.0).set());
            covariances.push(f[k].map(|v| v as f32));
        }
    }
    Ok(DeviceTemperature {
        temps,
        series: Some(n),
        sets,
        covariances,
        ratio: series_ratio,
        sigma_error: None,
        other: Some((breaks.len(), table_ratio.0)),
    })
}

/// The finding on how closely the device follows the model.
#[must_use]
pub fn finding(d: &DeviceTemperature, scale: &Scale) -> Finding {
    let range = format!("{:.1} to {:.1} C", scale.lo, scale.hi);
    let (ratio, at) = d.ratio;
    let what = match d.series {
        Some(n) => format!("Chebyshev series of {n} terms"),
        None => format!("table of {} temperatures", d.temps.len()),
    };
    let other = match (d.series, d.other) {
        (Some(_), Some((n, r))) => format!(
            "a table of {n} temperatures would depart by up to {:.2} of it",
            0.1 * r
        ),
        (None, Some((n, r))) => format!(
            "a series of {n} terms would depart by up to {:.2} of it",
            0.1 * r
        ),
        (_, None) => "an IMU with lever arms gets a table".to_string(),
    };
    let stated = d.sigma_error.map_or(String::new(), |e| {
        format!(
            ", and states its 1-sigma within {:.1} % of the model's",
            100.0 * e
        )
    });
    let sigma_ok = d.sigma_error.is_none_or(|e| e <= 0.1);
    if ratio <= 1.0 && sigma_ok {
        Finding {
            verdict: Verdict::Accept,
            text: format!(
                "the device's {what} follows the continuous temperature model within {:.3} of its 1-sigma over {range}{stated} ({other})",
                0.1 * ratio
            ),
        }
    } else {
        Finding {
            verdict: Verdict::Review,
            text: format!(
                "the device's {what} (the most it holds) departs from the continuous temperature model by up to {:.2} of its 1-sigma (at {at:.1} C) over {range}{stated} ({other}): the temperature curve bends more than the device can follow",
                0.1 * ratio
            ),
        }
    }
}

/// Breakpoints for the device's table over `scale`: from the two ends, the temperature where
/// `ratio` is worst is added until `ratio(points)` is at most 1 or `max` points are used.
/// `ratio(points)` gives the worst departure of the interpolated table from the continuous
/// model (against what is allowed) and the temperature where it is; the last is returned.
pub fn breakpoints(
    scale: &Scale,
    max: usize,
    mut ratio: impl FnMut(&[f64]) -> (f64, f64),
) -> (Vec<f64>, (f64, f64)) {
    let mut points = vec![scale.lo, scale.hi];
    loop {
        let (r, at) = ratio(&points);
        if r <= 1.0 || points.len() >= max || points.iter().any(|p| (p - at).abs() < 1e-9) {
            return (points, (r, at));
        }
        let i = points.partition_point(|p| *p < at);
        points.insert(i, at);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chebyshev_interpolation_is_exact_for_polynomials_below_its_order() {
        let scale = Scale {
            lo: -40.0,
            hi: 70.0,
        };
        let f = |t: f64| {
            let x = scale.x(t);
            [1.0 + 2.0 * x - 0.5 * x * x * x]
        };
        let values: Vec<[f64; 1]> = nodes(&scale, 4).iter().map(|t| f(*t)).collect();
        let c = chebyshev(&values);
        for t in [-40.0, -3.3, 12.0, 70.0] {
            assert!((clenshaw(&c, scale.x(t))[0] - f(t)[0]).abs() < 1e-12);
        }
    }

    #[test]
    fn breakpoints_are_added_where_the_table_is_worst() {
        // A kink at 10 C: the table needs a point there and nowhere else.
        let scale = Scale {
            lo: -40.0,
            hi: 70.0,
        };
        let curve = |t: f64| (t - 10.0).abs();
        let (p, r) = breakpoints(&scale, 16, |pts: &[f64]| {
            (0..=110)
                .map(|i| {
                    let t = -40.0 + f64::from(i);
                    let k = pts.partition_point(|p| *p <= t).clamp(1, pts.len() - 1);
                    let (a, b) = (pts[k - 1], pts[k]);
                    let lin = curve(a) + (curve(b) - curve(a)) * (t - a) / (b - a);
                    ((lin - curve(t)).abs() / 0.01, t)
                })
                .fold((0.0, 0.0), |m, x| if x.0 > m.0 { x } else { m })
        });
        assert_eq!(p, [-40.0, 10.0, 70.0]);
        assert!(r.0 <= 1.0);
    }
}
