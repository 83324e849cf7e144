//! Stage two's composition: the device's forward coefficients of an output from stage one's
//! polynomial and stage two's fit, the constraint of what held, and the covariance of both
//! stages by central differences.

use nalgebra::DMatrix;

use crate::columns as col;
use crate::formula;
use crate::sensor::stages::one::{self, OUTPUTS, Sensor1};
use crate::sensor::{AxisFit, WorkflowError, lever};

/// A derivative's step, in standard errors of the coefficient it moves.
const STEP: f64 = 0.1;

/// The stage-one names of the nonlinear terms in the device's form (index into
/// [`one::TERMS`]).
fn nonlinear_name(j: usize) -> String {
    let s = lever::SENSED;
    match j {
        2 => format!("{s}^2"),
        3 => format!("{s}^3"),
        4 => format!("{s}:abs({s})"),
        _ => lever::SENSED_KINK.to_string(),
    }
}

/// The device's forward coefficients (counts) of one output from stage one's coefficients `c`
/// at a temperature and stage two's fit `th` (SI, terms `names`): `out = h(beta + m . F)`
/// expanded, `own` the output's own input, `nl` the nonlinear terms carried. `beta` inside the
/// odd-quadratic and asymmetry terms is left out (`2 coq beta |x|` and `ca beta` counts: a
/// bias change of 0.01 m/s^2 moves them by 1e-5 of the term).
fn compose(c: &[f64; 6], names: &[String], th: &[f64], own: &str, nl: &[usize]) -> Vec<f64> {
    let get = |n: &str| names.iter().position(|x| x == n).map_or(0.0, |i| th[i]);
    let beta = get("1");
    let [c0, c1, c2, c3, coq, ca] = *c;
    let slope = c1 + beta * (2.0 * c2 + 3.0 * c3 * beta);
    let mii = get(own);
    let mut v: Vec<f64> = names
        .iter()
        .zip(th)
        .map(|(n, t)| match n.as_str() {
            "1" => c0 + beta * (c1 + beta * (c2 + beta * c3)),
            n if n.starts_with("lever_") => *t,
            _ => slope * t,
        })
        .collect();
    v.extend(nl.iter().map(|j| match j {
        2 => (c2 + 3.0 * c3 * beta) * mii * mii,
        3 => c3 * mii.powi(3),
        4 => coq * mii * mii.abs(),
        _ => ca * mii.abs(),
    }));
    v
}

/// One output's stage two: its fit (SI), and per stage-one coefficient with a variance the
/// step and stage two's coefficients refitted with it moved up and down.
pub(super) struct Output {
    pub(super) fit: AxisFit,
    steps: Vec<Step>,
}

struct Step {
    /// Flat index into the sensor's coefficients (point-major).
    at: usize,
    h: f64,
    plus: Vec<f64>,
    minus: Vec<f64>,
}

impl Output {
    /// Output's stage-two `fit` with its steps: each stage-one coefficient of `sensor` with a
    /// variance moved by [`STEP`] of its standard error up and down, and stage two refitted
    /// (`refit`) where some observation reads that point (`used`), else left as it is.
    pub(super) fn refitted(
        fit: AxisFit,
        sensor: &Sensor1,
        used: &[bool],
        refit: impl Fn((usize, usize, f64)) -> Result<Vec<f64>, WorkflowError>,
    ) -> Result<Self, WorkflowError> {
        let mut steps = Vec::new();
        for (p, point) in sensor.points.iter().enumerate() {
            for j in 0..6 {
                let var = point.cov[j][j];
                if var <= 0.0 {
                    continue;
                }
                let h = STEP * var.sqrt();
                let (plus, minus) = if used[p] {
                    (refit((p, j, h))?, refit((p, j, -h))?)
                } else {
                    (fit.fit.coefficients.clone(), fit.fit.coefficients.clone())
                };
                steps.push(Step {
                    at: 6 * p + j,
                    h,
                    plus,
                    minus,
                });
            }
        }
        Ok(Self { fit, steps })
    }
}

/// Stage two's fit of `o` with the coefficients `fixed` held at their values: the least-squares
/// estimate under those constraints, `theta - K (A theta - b)` with `K = C A' (A C A')^-1`
/// (`C` the fit's covariance), and its covariance `C - K A C`; the refits of the derivatives
/// constrained the same way.
pub(super) fn hold(o: &mut Output, fixed: &[(&str, f64)]) {
    if fixed.is_empty() {
        return;
    }
    let names = &o.fit.fit.names;
    let (idx, b): (Vec<usize>, Vec<f64>) = fixed
        .iter()
        .filter_map(|(n, v)| names.iter().position(|m| m == n).map(|i| (i, *v)))
        .unzip();
    let c = &o.fit.fit.covariance;
    let p = c.nrows();
    let a = DMatrix::from_fn(idx.len(), p, |r, q| f64::from(u8::from(idx[r] == q)));
    let aca = &a * c * a.transpose();
    let Some(inv) = aca.try_inverse() else {
        return;
    };
    let k = c * a.transpose() * inv;
    let project = |theta: &[f64]| -> Vec<f64> {
        let miss: Vec<f64> = idx.iter().zip(&b).map(|(i, v)| theta[*i] - v).collect();
        (0..p)
            .map(|r| theta[r] - (0..idx.len()).map(|q| k[(r, q)] * miss[q]).sum::<f64>())
            .collect()
    };
    o.fit.fit.coefficients = project(&o.fit.fit.coefficients);
    let held = c - &k * &a * c;
    o.fit.fit.covariance = (&held + held.transpose()) * 0.5;
    for s in &mut o.steps {
        s.plus = project(&s.plus);
        s.minus = project(&s.minus);
    }
}

/// `d theta2 / d theta1`: how stage two's coefficients follow each stage-one coefficient of
/// the sensor (`n1` of them, point-major), by central differences.
pub(super) fn derivative_of_fit(o: &Output, n1: usize) -> DMatrix<f64> {
    let n2 = o.fit.fit.coefficients.len();
    let mut d = DMatrix::zeros(n2, n1);
    for s in &o.steps {
        for r in 0..n2 {
            d[(r, s.at)] = (s.plus[r] - s.minus[r]) / (2.0 * s.h);
        }
    }
    d
}

/// Output `k`'s device-form fit at temperature `t`: stage two's fit composed with stage one's
/// polynomial there, with the covariance of both stages.
pub(super) fn composed(
    o: &Output,
    sensor: &Sensor1,
    k: usize,
    t: Option<f64>,
    path: &std::path::Path,
) -> Result<AxisFit, WorkflowError> {
    let i = k % 3;
    let inputs = if k < 3 { col::F } else { col::W };
    let own = inputs[i];
    let names2 = &o.fit.fit.names;
    let th2 = &o.fit.fit.coefficients;
    let nl: Vec<usize> = (2..6)
        .filter(|j| sensor.points.iter().any(|p| p.cov[*j][*j] > 0.0))
        .collect();
    let c = sensor.at(t, None);
    let value = compose(&c, names2, th2, own, &nl);
    let nf = value.len();
    // Stage one: the total derivative through the refit and the composition.
    let sigma1 = sensor.covariance();
    let mut j1 = DMatrix::zeros(nf, sigma1.nrows());
    for s in &o.steps {
        let (p, j) = (s.at / 6, s.at % 6);
        let up = compose(&sensor.at(t, Some((p, j, s.h))), names2, &s.plus, own, &nl);
        let down = compose(
            &sensor.at(t, Some((p, j, -s.h))),
            names2,
            &s.minus,
            own,
            &nl,
        );
        for r in 0..nf {
            j1[(r, s.at)] = (up[r] - down[r]) / (2.0 * s.h);
        }
    }
    // Stage two's own scatter through the composition.
    let sigma2 = &o.fit.fit.covariance;
    let mut j2 = DMatrix::zeros(nf, th2.len());
    for q in 0..th2.len() {
        let h = STEP * sigma2[(q, q)].max(0.0).sqrt();
        if h == 0.0 {
            continue;
        }
        let moved = |sign: f64| {
            let mut th = th2.clone();
            th[q] += sign * h;
            compose(&c, names2, &th, own, &nl)
        };
        let (up, down) = (moved(1.0), moved(-1.0));
        for r in 0..nf {
            j2[(r, q)] = (up[r] - down[r]) / (2.0 * h);
        }
    }
    let cov = &j1 * &sigma1 * j1.transpose() + &j2 * sigma2 * j2.transpose();
    let mut names: Vec<String> = names2.clone();
    names.extend(nl.iter().map(|j| nonlinear_name(*j)));
    let at = match t {
        Some(t) => format!("{t} C"),
        None => "the single table point".into(),
    };
    let formula = formula::parse(&format!("{} ~ {}", OUTPUTS[k], names.join(" + ")))?;
    let slope = c[1];
    let fit = o
        .fit
        .fit
        .recomposed(names, value, &cov, o.fit.fit.sigma2 * slope * slope)
        .ok_or_else(|| WorkflowError::WeightedCovariance {
            path: path.to_path_buf(),
            at: format!("{} at {at} (both stages' covariance)", OUTPUTS[k]),
        })?;
    let own_poly = one::own(&c);
    let mut fit = fit;
    fit.residuals = o.fit.fit.residuals.iter().map(|r| r * slope).collect();
    fit.fitted = o
        .fit
        .fit
        .fitted
        .iter()
        .map(|x| own_poly.output(*x))
        .collect();
    // The noise without the model, in the output's units as the residuals are.
    let noise_reference = o.fit.noise_reference.map(|mut r| {
        r.noise.variance *= slope * slope;
        r
    });
    Ok(AxisFit {
        formula,
        fit,
        noise_reference,
        full: None,
        ..o.fit.clone()
    })
}
