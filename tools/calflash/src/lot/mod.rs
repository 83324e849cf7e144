//! A production lot judged as a lot (issue 18): every unit's newest coefficients from the unit
//! history, their distribution across the lot, each unit's robust distance from the lot, the
//! units outside the stated limit and the coefficients that put them there, and control charts
//! of chosen coefficients in the order the units were calibrated.

pub mod engineering;
pub mod history;

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use crate::stats::chart::{self, Chart};
use crate::stats::robust::{self, ColumnLimits, Robust, RobustError};

/// Why a lot cannot be judged, or a unit placed or charted in it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A fit's coefficients that are not JSON.
    #[error("{0}")]
    NotJson(#[source] serde_json::Error),
    /// JSON that holds no coefficients calflash wrote.
    #[error("neither a calibration's points nor a selfcal record")]
    NotCoefficients,
    /// A fit whose record fails its seal: its coefficients are not taken.
    #[error("its record is not as calflash wrote it ({0}); the lot is not judged on it")]
    Unsealed(String),
    /// Fewer than two units.
    #[error("a lot of {0} unit(s): at least 2 are needed to compare")]
    TooFewUnits(usize),
    /// No coefficient that every unit has varies across the lot.
    #[error(
        "no coefficient is shared by every unit and varies across the lot{}",
        if .0.is_empty() { String::new() } else { format!("; the units are of more than one kind: {}", .0) }
    )]
    NothingShared(String),
    /// A unit without coefficients the lot is judged on.
    #[error("the unit lacks coefficients its lot is judged on: {}", .0.join(", "))]
    UnitLacks(Vec<String>),
    /// A chart of a coefficient the lot is not judged on.
    #[error("the lot has no coefficient {name}; it has {}", .has.join(", "))]
    NoCoefficient {
        /// The coefficient asked for.
        name: String,
        /// Those the lot has.
        has: Vec<String>,
    },
    /// A chart of fewer than two units.
    #[error(
        "a chart of {name} needs two units{}",
        .station.as_ref().map(|s| format!(" at station {s}")).unwrap_or_default()
    )]
    ChartTooShort {
        /// The coefficient.
        name: String,
        /// The station, when the chart is of one.
        station: Option<String>,
    },
}

/// One unit's coefficients, by name (`OUTPUT:TERM`, with `@T` for each temperature point of a
/// table beyond the first).
#[derive(Debug, Clone)]
pub struct Unit {
    /// Serial.
    pub serial: String,
    /// When it was calibrated (Unix seconds).
    pub time: i64,
    /// The station that recorded the fit.
    pub station: String,
    /// Coefficients by name.
    pub coefficients: BTreeMap<String, f64>,
}

/// The coefficients of a fit record's `coefficients` JSON (`calflash calibrate`'s points of
/// axes, or `calflash selfcal`'s matrices).
///
/// # Errors
/// JSON that is neither.
pub fn coefficients(json: &str) -> Result<BTreeMap<String, f64>, Error> {
    let v: serde_json::Value = serde_json::from_str(json).map_err(Error::NotJson)?;
    let mut out = BTreeMap::new();
    match &v {
        serde_json::Value::Array(points) => {
            for (k, p) in points.iter().enumerate() {
                let at = if k == 0 {
                    String::new()
                } else {
                    format!("@{}", p["temp"].as_f64().unwrap_or(f64::NAN))
                };
                for axis in p["axes"].as_array().into_iter().flatten() {
                    let output = axis["output"].as_str().unwrap_or("?");
                    let terms = axis["terms"].as_array().into_iter().flatten();
                    let values = axis["coefficients"].as_array().into_iter().flatten();
                    for (t, c) in terms.zip(values) {
                        if let (Some(t), Some(c)) = (t.as_str(), c.as_f64()) {
                            out.insert(format!("{output}:{t}{at}"), c);
                        }
                    }
                }
            }
        }
        serde_json::Value::Object(_) => flatten("", &v, &mut out),
        _ => return Err(Error::NotCoefficients),
    }
    Ok(out)
}

/// Numbers of a selfcal record's JSON by path (`gyro[1][2]`, `accel.bias[0]`).
fn flatten(at: &str, v: &serde_json::Value, out: &mut BTreeMap<String, f64>) {
    match v {
        serde_json::Value::Number(n) => {
            if let Some(x) = n.as_f64() {
                out.insert(at.to_string(), x);
            }
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                flatten(&format!("{at}[{i}]"), x, out);
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                // The covariance is the fit's, not a property of the unit.
                if k != "covariance" {
                    let name = if at.is_empty() {
                        k.clone()
                    } else {
                        format!("{at}.{k}")
                    };
                    flatten(&name, x, out);
                }
            }
        }
        _ => {}
    }
}

/// How the lot was judged: on its robust scatter, or coefficient by coefficient when too small.
#[derive(Debug, Clone)]
pub enum Judge {
    /// Robust centre and scatter; the squared-distance limit.
    Scatter {
        /// The estimate.
        robust: Robust,
        /// Squared-distance limit (chi-square, p degrees of freedom, at 1 - alpha).
        limit: f64,
    },
    /// Per-coefficient median and MAD limits (Bonferroni): the lot is too small for a scatter.
    Columns {
        /// Why there is no scatter.
        why: RobustError,
    },
}

/// A unit outside the lot.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outlier {
    /// Serial.
    pub serial: String,
    /// Robust distance from the lot (the square root of the squared Mahalanobis distance; for
    /// a lot judged by coefficients, the largest |z|).
    pub distance: f64,
    /// The coefficients furthest from the lot's medians, with their robust z-scores (largest
    /// first: those beyond 3, at most five; else the two furthest, whose combination is off).
    pub coefficients: Vec<(String, f64)>,
}

/// A coefficient across the lot.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Spread {
    /// Name.
    pub name: String,
    /// Median.
    pub median: f64,
    /// MAD, scaled to a standard deviation.
    pub mad: f64,
    /// Smallest and largest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// The MAD and the range about the median in a datasheet's unit (mg, ppm, mrad, ...),
    /// where the output's scale factor is in the lot ([`engineering`]).
    pub engineering: Option<engineering::Engineering>,
}

/// A lot judged.
#[derive(Debug, Clone)]
pub struct Lot {
    /// The units, in the order they were calibrated.
    pub units: Vec<Unit>,
    /// The coefficients every unit has (and that vary across the lot).
    pub names: Vec<String>,
    /// Coefficients left out: not in every unit, or the same in all.
    pub left_out: Vec<String>,
    /// Each coefficient's distribution.
    pub spread: Vec<Spread>,
    /// How the lot was judged.
    pub judge: Judge,
    /// Per-coefficient limits (always computed: they name the coefficients).
    pub columns: ColumnLimits,
    /// Each unit's distance (as in [`Outlier::distance`]).
    pub distances: Vec<f64>,
    /// The units outside, furthest first.
    pub outliers: Vec<Outlier>,
    /// The family-wise level.
    pub alpha: f64,
}

/// Judges `units` (at least two) at the level `alpha`: a unit of the lot's distribution is
/// called outside with probability `alpha`.
///
/// # Errors
/// Fewer than two units, or no coefficient shared by all that varies.
pub fn judge(units: Vec<Unit>, alpha: f64) -> Result<Lot, Error> {
    if units.len() < 2 {
        return Err(Error::TooFewUnits(units.len()));
    }
    let mut shared: Vec<String> = units[0].coefficients.keys().cloned().collect();
    shared.retain(|k| units.iter().all(|u| u.coefficients.contains_key(k)));
    let mut left_out: Vec<String> = units
        .iter()
        .flat_map(|u| u.coefficients.keys())
        .filter(|k| !shared.contains(k))
        .cloned()
        .collect();
    left_out.sort();
    left_out.dedup();
    let column = |k: &str| -> Vec<f64> { units.iter().map(|u| u.coefficients[k]).collect() };
    let (names, constant): (Vec<String>, Vec<String>) = shared
        .into_iter()
        .partition(|k| robust::median_mad(&column(k)).1 > 0.0);
    left_out.extend(constant);
    if names.is_empty() {
        return Err(Error::NothingShared(kinds(&units).unwrap_or_default()));
    }
    let (n, p) = (units.len(), names.len());
    let cols: Vec<Vec<f64>> = names.iter().map(|k| column(k)).collect();
    let x = DMatrix::from_fn(n, p, |i, j| cols[j][i]);
    let columns = robust::column_limits(&x, alpha);
    let mut spread: Vec<Spread> = names
        .iter()
        .zip(&cols)
        .zip(columns.median.iter().zip(&columns.scale))
        .map(|((name, c), (m, s))| Spread {
            name: name.clone(),
            median: *m,
            mad: *s,
            min: c.iter().copied().fold(f64::INFINITY, f64::min),
            max: c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            engineering: None,
        })
        .collect();
    let said = engineering::spread(&spread);
    for (s, e) in spread.iter_mut().zip(said) {
        s.engineering = e;
    }
    let row = |i: usize| -> Vec<f64> { x.row(i).iter().copied().collect() };
    let (judge, distances, outside): (Judge, Vec<f64>, Vec<bool>) = match robust::estimate(&x) {
        Ok(r) => {
            let limit = r.limit(alpha);
            let d2: Vec<f64> = (0..n)
                .map(|i| r.distance2(&DVector::from_vec(row(i))))
                .collect();
            let outside = d2.iter().map(|d| *d > limit).collect();
            (
                Judge::Scatter { robust: r, limit },
                d2.iter().map(|d| d.sqrt()).collect(),
                outside,
            )
        }
        Err(why) => {
            let worst: Vec<f64> = (0..n)
                .map(|i| {
                    columns
                        .scores(&row(i))
                        .iter()
                        .fold(0.0f64, |a, z| a.max(z.abs()))
                })
                .collect();
            let outside = worst.iter().map(|z| *z > columns.z).collect();
            (Judge::Columns { why }, worst, outside)
        }
    };
    let mut outliers: Vec<Outlier> = (0..n)
        .filter(|&i| outside[i])
        .map(|i| Outlier {
            serial: units[i].serial.clone(),
            distance: distances[i],
            coefficients: furthest(&names, &columns.scores(&row(i))),
        })
        .collect();
    outliers.sort_by(|a, b| b.distance.total_cmp(&a.distance));
    Ok(Lot {
        units,
        names,
        left_out,
        spread,
        judge,
        columns,
        distances,
        outliers,
        alpha,
    })
}

/// When the units hold different sets of coefficients (units of another kind, or calibrated
/// with other models), each set's units, largest group first: how many, up to five serials,
/// and up to four of the coefficients; `None` when all hold the same set.
#[must_use]
pub fn kinds(units: &[Unit]) -> Option<String> {
    let mut groups: Vec<(Vec<&String>, Vec<&str>)> = Vec::new();
    for u in units {
        let keys: Vec<&String> = u.coefficients.keys().collect();
        match groups.iter_mut().find(|(k, _)| *k == keys) {
            Some((_, serials)) => serials.push(&u.serial),
            None => groups.push((keys, vec![&u.serial])),
        }
    }
    if groups.len() < 2 {
        return None;
    }
    groups.sort_by_key(|g| std::cmp::Reverse(g.1.len()));
    let described: Vec<String> = groups
        .iter()
        .map(|(keys, serials)| {
            let more = |n: usize, all: usize| {
                if all > n {
                    format!(", ... ({all} in all)")
                } else {
                    String::new()
                }
            };
            let named: Vec<&str> = serials.iter().take(5).copied().collect();
            let coefs: Vec<&str> = keys.iter().take(4).map(|k| k.as_str()).collect();
            format!(
                "{} unit(s) {}{} with {}{}",
                serials.len(),
                named.join(", "),
                more(5, serials.len()),
                coefs.join(", "),
                more(4, keys.len())
            )
        })
        .collect();
    Some(described.join("; "))
}

/// The coefficients with |z| beyond 3, largest first, at most five; when none is, the two
/// furthest (the unit is outside by their combination, not by one alone).
fn furthest(names: &[String], z: &[f64]) -> Vec<(String, f64)> {
    let mut by: Vec<(String, f64)> = names.iter().cloned().zip(z.iter().copied()).collect();
    by.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let beyond = by.iter().filter(|(_, z)| z.abs() > 3.0).count();
    by.truncate(if beyond == 0 { 2 } else { beyond.min(5) });
    by
}

impl Lot {
    /// Where a new unit with `coefficients` stands against the lot: its distance, whether it is
    /// outside, and the coefficients that put it there. Coefficients the lot lacks are ignored;
    /// ones the unit lacks are named.
    ///
    /// # Errors
    /// The unit lacks coefficients the lot is judged on.
    pub fn place(&self, coefficients: &BTreeMap<String, f64>) -> Result<(Outlier, bool), Error> {
        let missing: Vec<String> = self
            .names
            .iter()
            .filter(|k| !coefficients.contains_key(*k))
            .cloned()
            .collect();
        if !missing.is_empty() {
            return Err(Error::UnitLacks(missing));
        }
        let row: Vec<f64> = self.names.iter().map(|k| coefficients[k]).collect();
        let z = self.columns.scores(&row);
        let (distance, outside) = match &self.judge {
            Judge::Scatter { robust, limit } => {
                let d2 = robust.distance2(&DVector::from_vec(row));
                (d2.sqrt(), d2 > *limit)
            }
            Judge::Columns { .. } => {
                let worst = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                (worst, worst > self.columns.z)
            }
        };
        Ok((
            Outlier {
                serial: String::new(),
                distance,
                coefficients: furthest(&self.names, &z),
            },
            outside,
        ))
    }

    /// The limit on [`Outlier::distance`].
    #[must_use]
    pub fn distance_limit(&self) -> f64 {
        match &self.judge {
            Judge::Scatter { limit, .. } => limit.sqrt(),
            Judge::Columns { .. } => self.columns.z,
        }
    }

    /// The stations that recorded the lot's fits, in name order.
    #[must_use]
    pub fn stations(&self) -> Vec<String> {
        let mut s: Vec<String> = self.units.iter().map(|u| u.station.clone()).collect();
        s.sort();
        s.dedup();
        s
    }

    /// The control chart of coefficient `name` over the units in calibration order (those of
    /// `station` only, when given).
    ///
    /// # Errors
    /// A name the lot does not have (the names it has are listed), or fewer than two units.
    pub fn chart(
        &self,
        name: &str,
        kind: chart::Kind,
        station: Option<&str>,
    ) -> Result<UnitChart, Error> {
        let Some(key) = self.names.iter().find(|k| *k == name) else {
            return Err(Error::NoCoefficient {
                name: name.to_string(),
                has: self.names.clone(),
            });
        };
        let units: Vec<&Unit> = self
            .units
            .iter()
            .filter(|u| station.is_none_or(|s| u.station == s))
            .collect();
        let values: Vec<f64> = units.iter().map(|u| u.coefficients[key]).collect();
        let chart = chart::chart(&values, kind).ok_or_else(|| Error::ChartTooShort {
            name: name.to_string(),
            station: station.map(str::to_string),
        })?;
        Ok(UnitChart {
            chart,
            serials: units.iter().map(|u| u.serial.clone()).collect(),
        })
    }
}

/// A control chart of a lot's units: the chart, and the unit of each point.
#[derive(Debug, Clone, serde::Serialize)]
pub struct UnitChart {
    /// The chart.
    #[serde(flatten)]
    pub chart: Chart,
    /// The serial of each plotted point.
    pub serials: Vec<String>,
}

impl std::ops::Deref for UnitChart {
    type Target = Chart;
    fn deref(&self) -> &Chart {
        &self.chart
    }
}

/// What `calflash lot --json` writes (schema `calflash.lot/1`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Record<'a> {
    /// `calflash.lot/1`.
    pub schema: &'static str,
    /// The serial prefix the lot was selected by (empty: every unit).
    pub prefix: &'a str,
    /// The production lot, when selected by one.
    pub lot: Option<&'a str>,
    /// How many units.
    pub units: usize,
    /// The coefficients judged.
    pub coefficients: &'a [String],
    /// The coefficients left out (not in every unit, or the same in all).
    pub left_out: &'a [String],
    /// `robust covariance`, or `coefficients: ` and why there is no scatter.
    pub judged_by: String,
    /// The family-wise level.
    pub alpha: f64,
    /// The distance beyond which a unit is outside.
    pub distance_limit: f64,
    /// Each coefficient's distribution.
    pub spread: &'a [Spread],
    /// Each unit's distance, in calibration order.
    pub distances: Vec<UnitDistance<'a>>,
    /// The units outside, furthest first.
    pub outliers: &'a [Outlier],
    /// The control charts, by coefficient (and station).
    pub charts: Vec<NamedChart<'a>>,
}

/// A unit's distance from its lot, in a [`Record`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct UnitDistance<'a> {
    /// Serial.
    pub serial: &'a str,
    /// When it was calibrated (Unix seconds).
    pub time: i64,
    /// As in [`Outlier::distance`].
    pub distance: f64,
}

/// A control chart and what it charts, in a [`Record`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct NamedChart<'a> {
    /// The coefficient (and station).
    pub coefficient: &'a str,
    /// The chart.
    pub chart: &'a UnitChart,
}

impl<'a> Record<'a> {
    /// The record of `lot`, selected by `prefix` and `name`, with its `charts`.
    #[must_use]
    pub fn new(
        lot: &'a Lot,
        (prefix, name): (&'a str, Option<&'a str>),
        charts: &'a [(String, UnitChart)],
    ) -> Self {
        Self {
            schema: "calflash.lot/1",
            prefix,
            lot: name,
            units: lot.units.len(),
            coefficients: &lot.names,
            left_out: &lot.left_out,
            judged_by: match &lot.judge {
                Judge::Scatter { .. } => "robust covariance".to_string(),
                Judge::Columns { why } => format!("coefficients: {why}"),
            },
            alpha: lot.alpha,
            distance_limit: lot.distance_limit(),
            spread: &lot.spread,
            distances: lot
                .units
                .iter()
                .zip(&lot.distances)
                .map(|(u, d)| UnitDistance {
                    serial: &u.serial,
                    time: u.time,
                    distance: *d,
                })
                .collect(),
            outliers: &lot.outliers,
            charts: charts
                .iter()
                .map(|(n, c)| NamedChart {
                    coefficient: n,
                    chart: c,
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests;
