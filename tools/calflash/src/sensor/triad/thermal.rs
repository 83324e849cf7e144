//! A triad's or an IMU's continuous temperature model on the device: a Chebyshev series of
//! sets, or a table at temperatures chosen so that the device's interpolation between them
//! departs from the model by at most a tenth of the model's 1-sigma anywhere in the calibrated
//! range; the form that meets the standard with fewer sets (or comes closer), as
//! `sensor::thermal::device` chooses for a single axis. An IMU with lever arms gets a table
//! (the device proves its sensing directions per set of one).
//!
//! The check: on a grid of temperatures, at the corners and the centre of the calibrated box,
//! the codes the model gives are corrected by the interpolated table and by the model's own set
//! at that temperature; the difference is held against the 1-sigma of each axis' corrected
//! input from the covariance of its bias and sensitivity row there.

use spincal::model::{MAX_SETS, MAX_TEMPERATURES};

use super::sets::{Applied, box_corners, linear_cov, point_device};
use super::{Spec, TriadModel};
use crate::sensor::WorkflowError;
use crate::sensor::thermal::Scale;
use crate::sensor::thermal::device::{breakpoints, chebyshev_rows, clenshaw_rows, nodes};

/// Temperatures of the grid the table is checked on.
const GRID: usize = 111;

/// A temperature, the device's own set there, and per checked input the codes and each
/// axis' 1-sigma.
type GridRow = (f64, Applied, Vec<([f64; 3], [f64; 3])>);

/// One triad's model on the grid: at each temperature the device's own set there, and at each
/// checked input the codes and each axis' 1-sigma.
struct Grid {
    rows: Vec<GridRow>,
    centers: [f64; 3],
}

impl Grid {
    fn new(
        spec: &Spec<'_>,
        model: &TriadModel,
        scale: &Scale,
        path: &std::path::Path,
    ) -> Result<Self, WorkflowError> {
        let Some(tfs) = &model.thermal else {
            return Ok(Self {
                rows: Vec::new(),
                centers: model.centers,
            });
        };
        let mut inputs = box_corners(&model.ranges);
        inputs.push(
            model
                .ranges
                .map(|r| 0.5 * (f64::from(r.lo) + f64::from(r.hi))),
        );
        let mut rows = Vec::with_capacity(GRID);
        for k in 0..GRID {
            let t = scale.lo + (scale.hi - scale.lo) * k as f64 / (GRID - 1) as f64;
            let f = [tfs[0].at(t), tfs[1].at(t), tfs[2].at(t)];
            let at = format!("{t:.1} C");
            let d = point_device(spec, &f, (&model.centers, &model.ranges), None, (path, &at))?;
            let covs = [
                linear_cov(spec, &f[0]),
                linear_cov(spec, &f[1]),
                linear_cov(spec, &f[2]),
            ];
            let checks = inputs
                .iter()
                .map(|x| {
                    let u: [f64; 3] = std::array::from_fn(|i| {
                        let z = (0..3).map(|j| d.s[(i, j)] * x[j]).sum::<f64>() / d.s[(i, i)];
                        d.own[i].output(z)
                    });
                    let sigma: [f64; 3] = std::array::from_fn(|i| {
                        let g = [1.0, x[0], x[1], x[2]];
                        let v: f64 = (0..4)
                            .flat_map(|r| (0..4).map(move |c| (r, c)))
                            .map(|(r, c)| g[r] * covs[i][(r, c)] * g[c])
                            .sum();
                        v.max(0.0).sqrt() / d.s[(i, i)].abs()
                    });
                    (u, sigma)
                })
                .collect();
            rows.push((t, d.applied, checks));
        }
        Ok(Self {
            rows,
            centers: model.centers,
        })
    }

    /// How far the table of `sets` at `points` is from the model.
    fn ratio(&self, points: &[f64], sets: &[Applied]) -> Worst {
        self.departure(|t| {
            let k = points
                .partition_point(|p| *p <= t)
                .clamp(1, points.len() - 1);
            let (a, b) = (points[k - 1], points[k]);
            sets[k - 1].blend(&sets[k], ((t - a) / (b - a)).clamp(0.0, 1.0))
        })
    }

    /// How far the series of coefficients `c` over `scale` is from the model.
    fn series_ratio(&self, c: &[Vec<f64>], scale: &Scale) -> Worst {
        let rows: Vec<&[f64]> = c.iter().map(|r| &r[..]).collect();
        self.departure(|t| Applied::from_flat(&clenshaw_rows(&rows, scale.x(t).clamp(-1.0, 1.0))))
    }

    /// How far `device(t)` is from the model on the grid.
    fn departure(&self, device: impl Fn(f64) -> Applied) -> Worst {
        let mut worst = Worst {
            ratio: 0.0,
            at: self.rows.first().map_or(0.0, |r| r.0),
            departure: 0.0,
            sigma: 0.0,
        };
        for (t, exact, checks) in &self.rows {
            let table = device(*t);
            for (u, sigma) in checks {
                let (want, got) = (
                    exact.correct(u, &self.centers),
                    table.correct(u, &self.centers),
                );
                let (stated, own) = (table.sigma(u, &self.centers), exact.sigma(u, &self.centers));
                for i in 0..3 {
                    let d = (got[i] - want[i]).abs() / (0.1 * sigma[i]).max(f64::MIN_POSITIVE);
                    let e = (stated[i] / own[i].max(f64::MIN_POSITIVE) - 1.0).abs();
                    worst.departure = worst.departure.max(d);
                    worst.sigma = worst.sigma.max(e);
                    let r = d.max(e / SIGMA_STANDARD);
                    if r > worst.ratio {
                        (worst.ratio, worst.at) = (r, *t);
                    }
                }
            }
        }
        worst
    }
}

/// The device's stated 1-sigma is held within this fraction of the model's.
const SIGMA_STANDARD: f64 = 0.1;

/// How far the device's form is from the model: its correction's departure in tenths of the
/// model's 1-sigma, its stated 1-sigma's relative error, and the larger of the two against
/// its standard (1: at the standard) with the temperature where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Worst {
    pub ratio: f64,
    pub at: f64,
    pub departure: f64,
    pub sigma: f64,
}

impl Worst {
    fn max(self, other: Self) -> Self {
        Self {
            departure: self.departure.max(other.departure),
            sigma: self.sigma.max(other.sigma),
            ..if other.ratio > self.ratio {
                other
            } else {
                self
            }
        }
    }
}

/// What the device gets for a unit's continuous model.
pub(super) struct Choice {
    /// Table breakpoints, or the series' nodes (where the sets are evaluated).
    pub temps: Vec<f64>,
    /// `Some(n)`: the sets are an n-term Chebyshev series; `None`: a table at `temps`.
    pub series: Option<usize>,
    /// How far it is from the model.
    pub worst: Worst,
    /// The other form's (sets, ratio); `None` when a series is not allowed.
    pub other: Option<(usize, f64)>,
}

/// The device's form for the triads of one unit (an IMU's two share it) over `scale` (the
/// calibrated span as the device holds it): the smallest Chebyshev series that meets the
/// standard, or the table if it meets it with fewer sets (`series` false: the table); when
/// neither does, the one that comes closer.
///
/// # Errors
/// A point whose sensitivity matrix is singular.
pub(super) fn choose(
    parts: &[(&Spec<'_>, &TriadModel)],
    scale: &Scale,
    series: bool,
    path: &std::path::Path,
) -> Result<Choice, WorkflowError> {
    let grids = parts
        .iter()
        .map(|(spec, model)| Grid::new(spec, model, scale, path))
        .collect::<Result<Vec<_>, _>>()?;
    let sets_at = |t: f64| -> Result<Vec<Applied>, WorkflowError> {
        parts
            .iter()
            .map(|(spec, model)| {
                let tfs = model
                    .thermal
                    .as_ref()
                    .expect("a continuous temperature model's triads have thermal fits");
                let f = [tfs[0].at(t), tfs[1].at(t), tfs[2].at(t)];
                let at = format!("{t:.1} C");
                point_device(spec, &f, (&model.centers, &model.ranges), None, (path, &at))
                    .map(|d| d.applied)
            })
            .collect()
    };
    let worst = |r: Vec<Worst>| {
        r.into_iter().fold(
            Worst {
                ratio: 0.0,
                at: scale.lo,
                departure: 0.0,
                sigma: 0.0,
            },
            Worst::max,
        )
    };
    // The table: every temperature's sets are computed once (the search asks again).
    let mut failure = None;
    let mut cache: Vec<(f64, Vec<Applied>)> = Vec::new();
    let mut table_worst = None;
    let (breaks, _) = breakpoints(scale, MAX_TEMPERATURES, |points| {
        let mut per_point = Vec::with_capacity(points.len());
        for p in points {
            let found = cache.iter().find(|(t, _)| t == p).map(|(_, s)| s.clone());
            let sets = match found {
                Some(s) => s,
                None => match sets_at(*p) {
                    Ok(s) => {
                        cache.push((*p, s.clone()));
                        s
                    }
                    Err(e) => {
                        failure = Some(e);
                        return (0.0, *p);
                    }
                },
            };
            per_point.push(sets);
        }
        let w = worst(
            grids
                .iter()
                .enumerate()
                .map(|(k, g)| {
                    let sets: Vec<Applied> = per_point.iter().map(|s| s[k].clone()).collect();
                    g.ratio(points, &sets)
                })
                .collect(),
        );
        table_worst = Some(w);
        (w.ratio, w.at)
    });
    if let Some(e) = failure {
        return Err(e);
    }
    let table_worst = table_worst.expect("breakpoints measures the table at least once");
    let table_ratio = table_worst.ratio;
    let table = Choice {
        temps: breaks.clone(),
        series: None,
        worst: table_worst,
        other: None,
    };
    if !series {
        return Ok(table);
    }
    // The series: terms until it meets the standard.
    let mut best: Option<(Vec<f64>, Worst)> = None;
    for n in 1..=MAX_SETS {
        let temps = nodes(scale, n);
        let values = temps
            .iter()
            .map(|t| sets_at(*t))
            .collect::<Result<Vec<_>, _>>()?;
        let ratio = worst(
            grids
                .iter()
                .enumerate()
                .map(|(k, g)| {
                    let rows: Vec<Vec<f64>> = values.iter().map(|v| v[k].to_flat()).collect();
                    g.series_ratio(&chebyshev_rows(&rows), scale)
                })
                .collect(),
        );
        if best.as_ref().is_none_or(|b| ratio.ratio < b.1.ratio) {
            best = Some((temps, ratio));
        }
        if ratio.ratio <= 1.0 {
            break;
        }
    }
    let Some((temps, series_ratio)) = best else {
        return Ok(table);
    };
    let n = temps.len();
    let table_wins = table_ratio <= 1.0 && breaks.len() < n
        || table_ratio > 1.0 && series_ratio.ratio > 1.0 && table_ratio < series_ratio.ratio;
    Ok(if table_wins {
        Choice {
            other: Some((n, series_ratio.departure)),
            ..table
        }
    } else {
        Choice {
            temps,
            series: Some(n),
            worst: series_ratio,
            other: Some((breaks.len(), table_worst.departure)),
        }
    })
}
