//! Before/after comparison of two calibrations of one unit (before and after shock, before
//! and after flight, months apart): per term a Wald test of the change against both
//! calibrations' uncertainties, and per output (axis, or triad for a calibration without
//! equipment) and table point a chi-square test of all terms together.
//!
//! Two kinds of record compare: those of `calflash calibrate` (`calflash.calibration/1`: per
//! table point and output axis, the forward fit's terms) and those of `calflash selfcal`
//! (`calflash.selfcal/1`: one point, the accelerometer's parameters and the gyro matrix, each
//! with its covariance). A record is compared only with one of its kind.

use nalgebra::{DMatrix, DVector};
use serde_json::Value;
use statrs::distribution::{ChiSquared, ContinuousCDF};

use super::record::{self, Record};
use crate::nonlinear::gravity;
use crate::stats::dist;

/// Why two records cannot be read or compared.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Not JSON.
    #[error("{file}:{line}:{column}: not a calibration record: {source}")]
    NotJson {
        /// The record's name.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The parser's error.
        source: serde_json::Error,
    },
    /// JSON of the calibration schema that is not a calibration record.
    #[error("{file}: not a calibration record: {source}")]
    NotRecord {
        /// The record's name.
        file: String,
        /// What serde found wrong.
        source: serde_json::Error,
    },
    /// A schema of neither kind.
    #[error("{file}: schema `{found}`, expected `{calibration}` or `{selfcal}`")]
    Schema {
        /// The record's name.
        file: String,
        /// Its schema.
        found: String,
        /// `calflash calibrate`'s.
        calibration: &'static str,
        /// `calflash selfcal`'s.
        selfcal: &'static str,
    },
    /// A record changed after it was written.
    #[error("{file}: {why}")]
    Edited {
        /// The record.
        file: String,
        /// What does not match.
        why: crate::sensor::record::Unsealed,
    },
    /// No schema at all.
    #[error("{file}: no `schema`: not a record of `calflash calibrate` or `calflash selfcal`")]
    NoSchema {
        /// The record's name.
        file: String,
    },
    /// A selfcal record without a field the comparison needs.
    #[error("{file}: selfcal record without `{field}`")]
    Missing {
        /// The record's name.
        file: String,
        /// The field's path, dotted.
        field: String,
    },
    /// A selfcal field of the wrong type.
    #[error("{file}: `{field}` is not {expected}")]
    NotA {
        /// The record's name.
        file: String,
        /// The field's path, dotted.
        field: &'static str,
        /// What it should be ("a list of numbers").
        expected: &'static str,
    },
    /// A covariance whose size does not match the terms.
    #[error("{file}: `{field}` is not {k} x {k} for the {k} terms of the {output}")]
    CovarianceSize {
        /// The record's name.
        file: String,
        /// The field's path, dotted.
        field: &'static str,
        /// Terms.
        k: usize,
        /// The output ("gyro").
        output: &'static str,
    },
    /// Records of two units.
    #[error(
        "the records are of different units: {before} and {after} (compare calibrations of one unit)"
    )]
    DifferentUnits {
        /// The first record's serial.
        before: String,
        /// The second's.
        after: String,
    },
    /// Records of two kinds.
    #[error(
        "the records are of different kinds: {before} and {after} (compare two records of one kind)"
    )]
    DifferentKinds {
        /// The first record's kind.
        before: String,
        /// The second's.
        after: String,
    },
    /// Nothing in common with a covariance.
    #[error("the records share no table point and output with a covariance to compare")]
    NothingShared,
}

/// One output's estimated terms and their covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Output (axis, or triad).
    pub output: String,
    /// Term names.
    pub terms: Vec<String>,
    /// Estimates.
    pub values: Vec<f64>,
    /// Standard errors.
    pub std_errors: Vec<f64>,
    /// Covariance, rows in the order of `terms`.
    pub covariance: Vec<Vec<f64>>,
    /// The residual degrees of freedom its noise was estimated with (`None`: known, or not
    /// recorded: the tests take the normal and chi-square references).
    pub dof: Option<f64>,
}

/// The estimates of one table point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointEstimates {
    /// Temperature setpoint.
    pub temp: Option<f64>,
    /// Voltage setpoint.
    pub volt: Option<f64>,
    /// Per output.
    pub outputs: Vec<Estimate>,
}

/// What a comparison needs of a calibration record.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimates {
    /// Unit serial.
    pub serial: String,
    /// The kind of record: `single`, `triad`, `imu` (`calflash calibrate`) or
    /// `imu without equipment` (`calflash selfcal`).
    pub kind: String,
    /// Per table point.
    pub points: Vec<PointEstimates>,
    /// A selfcal record's accelerometer center (counts): its parameters are relative to it, so
    /// a comparison refers the later record's accelerometer to the earlier one's center.
    pub accel_center: Option<[f64; 3]>,
}

/// The schema of a `calflash selfcal` record.
pub const SELFCAL_SCHEMA: &str = "calflash.selfcal/1";

impl Estimates {
    /// The estimates of a `calflash calibrate` record.
    #[must_use]
    pub fn of_record(r: &Record) -> Self {
        Self {
            serial: r.serial.clone(),
            kind: r.sensor.clone(),
            points: r
                .points
                .iter()
                .map(|p| PointEstimates {
                    temp: p.temp,
                    volt: p.volt,
                    outputs: p
                        .axes
                        .iter()
                        .map(|a| Estimate {
                            output: a.output.clone(),
                            terms: a.terms.clone(),
                            values: a.coefficients.clone(),
                            std_errors: a.std_errors.clone(),
                            covariance: a.covariance.clone(),
                            dof: (a.dof > 0).then_some(a.dof as f64),
                        })
                        .collect(),
                })
                .collect(),
            accel_center: None,
        }
    }

    /// The estimates of a `calflash selfcal` record: the accelerometer's parameters and the
    /// gyro matrix (row by row), each with its covariance. An output whose covariance the
    /// record lacks (terms not all observable) is left out.
    ///
    /// # Errors
    /// A field missing or of the wrong type, named with `source`.
    pub fn of_selfcal(v: &Value, source: &str) -> Result<Self, Error> {
        let file = || source.to_string();
        let field = |path: &[&str]| -> Result<&Value, Error> {
            path.iter()
                .try_fold(v, |at, key| at.get(key))
                .ok_or_else(|| Error::Missing {
                    file: file(),
                    field: path.join("."),
                })
        };
        let not_a = |field: &'static str, expected: &'static str| Error::NotA {
            file: file(),
            field,
            expected,
        };
        let numbers = |x: &Value, what: &'static str| -> Result<Vec<f64>, Error> {
            let flat: Vec<&Value> = match x.as_array() {
                Some(items) if items.iter().all(Value::is_array) => items
                    .iter()
                    .flat_map(|r| r.as_array().into_iter().flatten())
                    .collect(),
                Some(items) => items.iter().collect(),
                None => Vec::new(),
            };
            flat.iter()
                .map(|n| n.as_f64())
                .collect::<Option<Vec<f64>>>()
                .filter(|n| !n.is_empty())
                .ok_or_else(|| not_a(what, "a list of numbers"))
        };
        let names = |x: &Value, what: &'static str| -> Result<Vec<String>, Error> {
            x.as_array()
                .and_then(|a| a.iter().map(|t| t.as_str().map(String::from)).collect())
                .ok_or_else(|| not_a(what, "a list of names"))
        };
        let estimate = |output: &'static str,
                        terms: Vec<String>,
                        values: Vec<f64>,
                        cov: &Value,
                        what: &'static str|
         -> Result<Option<Estimate>, Error> {
            if cov.is_null() {
                return Ok(None);
            }
            let k = terms.len();
            let flat = numbers(cov, what)?;
            if values.len() != k || flat.len() != k * k {
                return Err(Error::CovarianceSize {
                    file: file(),
                    field: what,
                    k,
                    output,
                });
            }
            let covariance: Vec<Vec<f64>> = flat.chunks(k).map(<[f64]>::to_vec).collect();
            let std_errors = (0..k).map(|i| covariance[i][i].max(0.0).sqrt()).collect();
            Ok(Some(Estimate {
                output: output.into(),
                terms,
                values,
                std_errors,
                covariance,
                dof: None,
            }))
        };
        let serial = field(&["serial"])?
            .as_str()
            .ok_or_else(|| not_a("serial", "a string"))?
            .to_string();
        let accel = estimate(
            "accelerometer",
            names(field(&["accel", "terms"])?, "accel.terms")?,
            numbers(field(&["accel", "parameters"])?, "accel.parameters")?,
            field(&["accel", "covariance"])?,
            "accel.covariance",
        )?;
        let gyro = estimate(
            "gyro",
            names(field(&["gyro", "terms"])?, "gyro.terms")?,
            numbers(
                field(&["gyro", "matrix_rad_s_per_count"])?,
                "gyro.matrix_rad_s_per_count",
            )?,
            field(&["gyro", "covariance"])?,
            "gyro.covariance",
        )?;
        let center = numbers(field(&["accel", "center_counts"])?, "accel.center_counts")?;
        let accel_center = <[f64; 3]>::try_from(center.as_slice())
            .map_err(|_| not_a("accel.center_counts", "3 numbers"))?;
        Ok(Self {
            accel_center: Some(accel_center),
            serial,
            kind: "imu without equipment".into(),
            points: vec![PointEstimates {
                temp: None,
                volt: None,
                outputs: accel.into_iter().chain(gyro).collect(),
            }],
        })
    }

    /// These estimates with the selfcal accelerometer referred to the center `to`
    /// ([`gravity::recentered`]); the covariance goes through the map's Jacobian (central
    /// differences, steps of a thousandth of each standard error).
    #[must_use]
    pub fn recentered(&self, to: [f64; 3]) -> Self {
        let Some(from) = self.accel_center else {
            return self.clone();
        };
        let mut out = self.clone();
        out.accel_center = Some(to);
        for e in out
            .points
            .iter_mut()
            .flat_map(|p| &mut p.outputs)
            .filter(|e| e.output == "accelerometer")
        {
            let k = e.values.len();
            let map = |p: &[f64]| DVector::from_vec(gravity::recentered(p, from, to));
            let mut jac = DMatrix::zeros(k, k);
            for c in 0..k {
                let h = (e.std_errors[c] * 1e-3)
                    .max(e.values[c].abs() * 1e-9)
                    .max(1e-300);
                let mut up = e.values.clone();
                let mut down = e.values.clone();
                up[c] += h;
                down[c] -= h;
                jac.set_column(c, &((map(&up) - map(&down)) / (2.0 * h)));
            }
            let cov = DMatrix::from_fn(k, k, |i, j| e.covariance[i][j]);
            let moved = &jac * cov * jac.transpose();
            e.values = map(&e.values).iter().copied().collect();
            e.covariance = moved
                .row_iter()
                .map(|r| r.iter().copied().collect())
                .collect();
            e.std_errors = (0..k).map(|i| moved[(i, i)].max(0.0).sqrt()).collect();
        }
        out
    }

    /// Reads either kind of record from its JSON text; `source` names it in errors.
    ///
    /// # Errors
    /// Not JSON, an unknown schema, or a record missing what the comparison needs.
    pub fn parse(text: &str, source: &str) -> Result<Self, Error> {
        let v: Value = serde_json::from_str(text).map_err(|e| Error::NotJson {
            file: source.to_string(),
            line: e.line(),
            column: e.column(),
            source: e,
        })?;
        match v.get("schema").and_then(Value::as_str) {
            Some(record::SCHEMA) => {
                let r: Record = serde_json::from_value(v).map_err(|e| Error::NotRecord {
                    file: source.to_string(),
                    source: e,
                })?;
                r.check_seal().map_err(|why| Error::Edited {
                    file: source.to_string(),
                    why,
                })?;
                Ok(Self::of_record(&r))
            }
            Some(SELFCAL_SCHEMA) => Self::of_selfcal(&v, source),
            Some(other) => Err(Error::Schema {
                file: source.to_string(),
                found: other.to_string(),
                calibration: record::SCHEMA,
                selfcal: SELFCAL_SCHEMA,
            }),
            None => Err(Error::NoSchema {
                file: source.to_string(),
            }),
        }
    }
}

/// The change of one term.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TermChange {
    /// Term.
    pub term: String,
    /// Before.
    pub before: f64,
    /// After.
    pub after: f64,
    /// Change in units of its standard error: `(after - before) / sqrt(se1^2 + se2^2)`.
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
    /// Moved beyond its uncertainty: rejected by Holm's procedure over every term of the
    /// comparison at the level.
    pub moved: bool,
}

/// The comparison of one output axis at one table point.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AxisChange {
    /// Output.
    pub output: String,
    /// Table point temperature.
    pub temp: Option<f64>,
    /// Table point voltage.
    pub volt: Option<f64>,
    /// Per term.
    pub terms: Vec<TermChange>,
    /// Chi-square of all common terms together.
    pub chi2: f64,
    /// Its degrees of freedom.
    pub df: usize,
    /// Its p-value.
    pub p: f64,
    /// Changed beyond the uncertainty: rejected by Holm's procedure over every output and
    /// table point of the comparison at the level.
    pub changed: bool,
}

/// Compares two records of the same unit at significance level `alpha`.
///
/// # Errors
/// When the records are of different units or sensors, or share no table point.
pub fn compare(
    before: &Estimates,
    after: &Estimates,
    alpha: f64,
) -> Result<Vec<AxisChange>, Error> {
    if before.serial != after.serial {
        return Err(Error::DifferentUnits {
            before: before.serial.clone(),
            after: after.serial.clone(),
        });
    }
    if before.kind != after.kind {
        return Err(Error::DifferentKinds {
            before: before.kind.clone(),
            after: after.kind.clone(),
        });
    }
    // Parameters relative to a center compare only at one center.
    let after = &match before.accel_center {
        Some(c) if after.accel_center != Some(c) => after.recentered(c),
        _ => after.clone(),
    };
    let near = |a: Option<f64>, b: Option<f64>, tol: f64| match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() <= tol,
        (None, None) => true,
        _ => false,
    };
    let mut out = Vec::new();
    for pb in &before.points {
        let Some(pa) = after
            .points
            .iter()
            .find(|p| near(p.temp, pb.temp, 1.0) && near(p.volt, pb.volt, 0.02))
        else {
            continue;
        };
        for ab in &pb.outputs {
            let Some(aa) = pa.outputs.iter().find(|a| a.output == ab.output) else {
                continue;
            };
            let common: Vec<(usize, usize)> = ab
                .terms
                .iter()
                .enumerate()
                .filter_map(|(i, t)| aa.terms.iter().position(|u| u == t).map(|j| (i, j)))
                .collect();
            let terms: Vec<TermChange> = common
                .iter()
                .map(|&(i, j)| {
                    let d = aa.values[j] - ab.values[i];
                    let (v1, v2) = (ab.std_errors[i].powi(2), aa.std_errors[j].powi(2));
                    let z = d / (v1 + v2).sqrt();
                    // Each variance estimated from its fit's residuals: Welch's t with
                    // Satterthwaite's degrees of freedom, not the normal.
                    let p = match (ab.dof, aa.dof) {
                        (Some(n1), Some(n2)) => {
                            let nu = (v1 + v2).powi(2) / (v1 * v1 / n1 + v2 * v2 / n2);
                            dist::t_two_sided(z, nu)
                        }
                        _ => dist::normal_two_sided(z),
                    };
                    TermChange {
                        term: ab.terms[i].clone(),
                        before: ab.values[i],
                        after: aa.values[j],
                        z,
                        p,
                        moved: false,
                    }
                })
                .collect();
            let k = common.len();
            let d =
                DVector::from_iterator(k, common.iter().map(|&(i, j)| aa.values[j] - ab.values[i]));
            let c = DMatrix::from_fn(k, k, |r, s| {
                let (i1, j1) = common[r];
                let (i2, j2) = common[s];
                ab.covariance[i1][i2] + aa.covariance[j1][j2]
            });
            let chi2 = c.cholesky().map_or(f64::NAN, |ch| d.dot(&ch.solve(&d)));
            // With estimated noise, chi2 / k is F(k, nu) (nu the smaller fit's residual
            // degrees of freedom, which errs towards calling no change).
            let p = match (ab.dof, aa.dof) {
                (Some(n1), Some(n2)) => dist::f_upper(chi2 / k as f64, k as f64, n1.min(n2)),
                _ => ChiSquared::new(k as f64).map_or(f64::NAN, |dist| dist.sf(chi2)),
            };
            out.push(AxisChange {
                output: ab.output.clone(),
                temp: pb.temp,
                volt: pb.volt,
                terms,
                chi2,
                df: k,
                p,
                changed: false,
            });
        }
    }
    if out.is_empty() {
        return Err(Error::NothingShared);
    }
    // One family each: the outputs' joint tests, and every term's test.
    let changed = crate::stats::multiple::holm(&out.iter().map(|c| c.p).collect::<Vec<_>>(), alpha);
    for (c, ch) in out.iter_mut().zip(changed) {
        c.changed = ch;
    }
    let ps: Vec<f64> = out
        .iter()
        .flat_map(|c| c.terms.iter().map(|t| t.p))
        .collect();
    let mut moved = crate::stats::multiple::holm(&ps, alpha).into_iter();
    for t in out.iter_mut().flat_map(|c| c.terms.iter_mut()) {
        t.moved = moved.next().unwrap_or(false);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
