//! Before/after comparison of two calibrations of one unit (before and after shock, before
//! and after flight, months apart): per term a Wald test of the change against both
//! calibrations' uncertainties, and per output axis and table point a chi-square test of all
//! terms together.

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use super::record::Record;
use crate::stats::dist;

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
    /// Moved beyond its uncertainty at the level.
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
}

/// Compares two records of the same unit at significance level `alpha`.
///
/// # Errors
/// When the records are of different units or sensors, or share no table point.
pub fn compare(before: &Record, after: &Record, alpha: f64) -> Result<Vec<AxisChange>, String> {
    if before.serial != after.serial {
        return Err(format!(
            "the records are of different units: {} and {} (compare calibrations of one unit)",
            before.serial, after.serial
        ));
    }
    if before.sensor != after.sensor {
        return Err(format!(
            "the records are of different sensors: {} and {}",
            before.sensor, after.sensor
        ));
    }
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
        for ab in &pb.axes {
            let Some(aa) = pa.axes.iter().find(|a| a.output == ab.output) else {
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
                    let d = aa.coefficients[j] - ab.coefficients[i];
                    let z = d / (ab.std_errors[i].powi(2) + aa.std_errors[j].powi(2)).sqrt();
                    let p = dist::normal_two_sided(z);
                    TermChange {
                        term: ab.terms[i].clone(),
                        before: ab.coefficients[i],
                        after: aa.coefficients[j],
                        z,
                        p,
                        moved: p < alpha,
                    }
                })
                .collect();
            let k = common.len();
            let d = DVector::from_iterator(
                k,
                common
                    .iter()
                    .map(|&(i, j)| aa.coefficients[j] - ab.coefficients[i]),
            );
            let c = DMatrix::from_fn(k, k, |r, s| {
                let (i1, j1) = common[r];
                let (i2, j2) = common[s];
                ab.covariance[i1][i2] + aa.covariance[j1][j2]
            });
            let chi2 = c.cholesky().map_or(f64::NAN, |ch| d.dot(&ch.solve(&d)));
            let p = ChiSquared::new(k as f64).map_or(f64::NAN, |dist| dist.sf(chi2));
            out.push(AxisChange {
                output: ab.output.clone(),
                temp: pb.temp,
                volt: pb.volt,
                terms,
                chi2,
                df: k,
                p,
            });
        }
    }
    if out.is_empty() {
        return Err("the records share no table point and output axis".into());
    }
    Ok(out)
}
