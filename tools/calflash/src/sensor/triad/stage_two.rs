//! Stage two of a two-stage calibration (`sensor::stages`): the assembled IMU's observations
//! read through each sensor's stage-one polynomial, the linear triad fits of what assembly
//! adds, and the device's sets at stage one's temperatures with both stages' covariance.

use nalgebra::DMatrix;
use spincal::model::Span;

use super::fit::{fit_axis, fit_triad};
use super::sets::device_sets;
use super::{Kind, Spec, Temperature, TriadModel, add_references, finish, read};
use crate::columns as col;
use crate::formula;
use crate::sensor::stages::StageTwoError;
use crate::sensor::stages::check::{self, Check, Moved};
use crate::sensor::stages::one::{self, OUTPUTS, Sensor1};
use crate::sensor::table::{self, Layout};
use crate::sensor::{AxisFit, Calibrated, Options, WorkflowError, lever};

/// Temperatures closer than this are one point of the blob's table, C.
const SAME_TEMPERATURE: f64 = 0.01;
/// A derivative's step, in standard errors of the coefficient it moves.
const STEP: f64 = 0.1;
/// How far beyond stage one's calibrated range stage two may drive an axis, as a share of that
/// range (the lever arms' centripetal terms, a tumble's `g` against a dividing head's).
const RANGE_MARGIN: f64 = 0.05;

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

/// The temperatures the blob holds: every record's points inside the span all six share.
fn grid(sensors: &[Sensor1]) -> Result<(Vec<f64>, Span), StageTwoError> {
    let lo = sensors.iter().map(|s| s.temps.lo).fold(f32::MIN, f32::max);
    let hi = sensors.iter().map(|s| s.temps.hi).fold(f32::MAX, f32::min);
    if lo > hi {
        return Err(StageTwoError::Spans {
            spans: sensors
                .iter()
                .zip(OUTPUTS)
                .map(|(s, o)| format!("{o} {} to {} C", s.temps.lo, s.temps.hi))
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    let mut temps: Vec<f64> = sensors
        .iter()
        .flat_map(|s| s.points.iter().filter_map(|p| p.temp))
        .filter(|t| {
            (f64::from(lo) - SAME_TEMPERATURE..=f64::from(hi) + SAME_TEMPERATURE).contains(t)
        })
        .collect();
    temps.sort_by(f64::total_cmp);
    temps.dedup_by(|a, b| (*a - *b).abs() < SAME_TEMPERATURE);
    Ok((temps, Span::new(lo, hi)))
}

/// Stage one's reading of output `k` (SI) at every observation: its polynomial inverted at
/// the observation's temperature, with `delta` added to one of its coefficients.
fn linearised(
    sensor: &Sensor1,
    k: usize,
    (raw, temps, lines): (&[f64], &[Option<f64>], &[u64]),
    delta: Option<(usize, usize, f64)>,
) -> Result<Vec<f64>, StageTwoError> {
    raw.iter()
        .zip(temps)
        .zip(lines)
        .map(|((out, t), line)| {
            let own = one::own(&sensor.at(*t, delta));
            let x = own.input_for(*out, (out - own.bias) / own.slope);
            let close = (own.output(x) - out).abs() <= 1e-6 * (1.0 + out.abs());
            if x.is_finite() && close {
                Ok(x)
            } else {
                Err(StageTwoError::NotInvertible {
                    line: *line,
                    output: OUTPUTS[k],
                    code: *out,
                    record: sensor.file.clone(),
                })
            }
        })
        .collect()
}

/// One output's stage two: its fit (SI), and per stage-one coefficient with a variance the
/// step and stage two's coefficients refitted with it moved up and down.
struct Output {
    fit: AxisFit,
    steps: Vec<Step>,
}

struct Step {
    /// Flat index into the sensor's coefficients (point-major).
    at: usize,
    h: f64,
    plus: Vec<f64>,
    minus: Vec<f64>,
}

/// Calibrates the assembled IMU in `opts.file` on the six stage-one `sensors` (in the order
/// of [`OUTPUTS`]); returns the calibration and the check between the stages.
///
/// # Errors
/// A [`WorkflowError`] naming the file, the record, the line or the output.
pub fn calibrate(
    opts: &Options,
    sensors: &[Sensor1],
) -> Result<(Calibrated, Check), WorkflowError> {
    let path = &opts.file;
    let located = |source| WorkflowError::StageTwo {
        path: path.clone(),
        source,
    };
    let (mut table, beyond) = read(opts, Kind::Imu)?;
    if table.varies(col::VOLT) {
        return Err(WorkflowError::triad(path, super::TriadError::VoltageVaries));
    }
    let mut notes = Vec::new();
    add_references(&mut table, opts, Kind::Imu, &mut notes)?;
    let (temps, span) = grid(sensors).map_err(located)?;
    let row_temps: Vec<Option<f64>> = match table.column(col::TEMP) {
        Some(c) => c.iter().map(|t| Some(*t)).collect(),
        None if temps.is_empty() => vec![None; table.len()],
        None => {
            return Err(located(StageTwoError::NoTemperature {
                temps: temps
                    .iter()
                    .map(|t| format!("{t} C"))
                    .collect::<Vec<_>>()
                    .join(", "),
            }));
        }
    };
    for (s, output) in sensors.iter().zip(OUTPUTS) {
        let tol = 0.5;
        if let Some((line, t)) = table.lines.iter().zip(&row_temps).find_map(|(l, t)| {
            t.filter(|t| *t < f64::from(s.temps.lo) - tol || *t > f64::from(s.temps.hi) + tol)
                .map(|t| (*l, t))
        }) {
            return Err(located(StageTwoError::TemperatureSpan {
                line,
                temp: t,
                output,
                lo: s.temps.lo,
                hi: s.temps.hi,
                record: s.file.clone(),
            }));
        }
    }
    let raw_table = table.clone();
    let raw: Vec<Vec<f64>> = OUTPUTS
        .iter()
        .map(|o| table.column(o).unwrap_or_default().to_vec())
        .collect();
    let lines = table.lines.clone();
    let reading = |k: usize, delta| {
        linearised(&sensors[k], k, (&raw[k], &row_temps, &lines), delta).map_err(located)
    };
    for (k, output) in OUTPUTS.iter().enumerate() {
        table.set_column(output, reading(k, None)?);
    }
    notes.push("two stages: each output read through its sensor's stage-one polynomial (bias, scale factor and nonlinear terms at the observation's temperature); stage two fits the sensing directions, bias and scale changes, lever arms and g-sensitivity".into());
    let spin = col::W
        .iter()
        .any(|w| table.column(w).is_some_and(|c| c.iter().any(|v| *v != 0.0)));
    if !spin {
        notes.push(
            "the plan does not spin the unit: no lever arms (size effect) are estimated".into(),
        );
    }
    let f_varies = col::F.iter().all(|c| table.varies(c));
    let layout = table::layout(&table, None, None).map_err(|source| WorkflowError::Grid {
        path: path.clone(),
        source,
    })?;
    let temperature = Temperature::Points(layout);
    let accel_spec = Spec {
        outputs: col::A,
        inputs: col::F,
        gyro: false,
        g_sens: false,
        lever: spin,
        nonlinear: false,
    };
    let gyro_spec = Spec {
        outputs: col::GYRO,
        inputs: col::W,
        gyro: true,
        g_sens: f_varies,
        lever: false,
        nonlinear: false,
    };
    let accel = fit_triad(&accel_spec, &table, &temperature, opts, &mut notes)?;
    let gyro = fit_triad(&gyro_spec, &table, &temperature, opts, &mut notes)?;
    for (k, s) in sensors.iter().enumerate() {
        let r = if k < 3 {
            accel.ranges[k]
        } else {
            gyro.ranges[k - 3]
        };
        let margin = RANGE_MARGIN * f64::from(s.range.hi - s.range.lo);
        if f64::from(r.lo) < f64::from(s.range.lo) - margin
            || f64::from(r.hi) > f64::from(s.range.hi) + margin
        {
            return Err(located(StageTwoError::Range {
                output: OUTPUTS[k],
                lo: f64::from(r.lo),
                hi: f64::from(r.hi),
                rlo: s.range.lo,
                rhi: s.range.hi,
                unit: crate::sensor::blob::unit(s.quantity),
                record: s.file.clone(),
            }));
        }
    }
    // Each output's fit, refitted with each stage-one coefficient moved.
    let mut outputs: Vec<Output> = Vec::new();
    for (k, sensor) in sensors.iter().enumerate() {
        let (spec, model, i) = if k < 3 {
            (&accel_spec, &accel, k)
        } else {
            (&gyro_spec, &gyro, k - 3)
        };
        let fit = model.fits[0][i].clone();
        let names = fit.fit.names.clone();
        let lever_use: [bool; 3] =
            std::array::from_fn(|a| names.iter().any(|n| *n == lever::column(i, a)));
        let used: Vec<bool> = (0..sensor.points.len())
            .map(|p| {
                row_temps
                    .iter()
                    .any(|t| sensor.weights(*t).iter().any(|(q, w)| *q == p && *w > 0.0))
            })
            .collect();
        let refit = |delta: (usize, usize, f64)| -> Result<Vec<f64>, WorkflowError> {
            let mut t = table.clone();
            t.set_column(OUTPUTS[k], reading(k, Some(delta))?);
            let f = fit_axis(
                spec,
                &fit.formula,
                &t,
                i,
                spec.lever.then_some(&lever_use),
                opts,
                ("stage two", None),
            )?;
            Ok(names.iter().map(|n| f.coef(n)).collect())
        };
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
        outputs.push(Output { fit, steps });
    }
    // The check: beta and the sensing row under "stage one holds", both stages' covariance.
    let mut moved = Vec::new();
    for (k, (o, sensor)) in outputs.iter().zip(sensors).enumerate() {
        let names = &o.fit.fit.names;
        let inputs = if k < 3 { col::F } else { col::W };
        let idx: Vec<usize> = std::iter::once("1")
            .chain(inputs)
            .map(|n| names.iter().position(|m| m == n).unwrap_or(0))
            .collect();
        let sigma1 = sensor.covariance();
        let d = derivative_of_fit(o, sigma1.nrows());
        let v = &o.fit.fit.covariance + &d * &sigma1 * d.transpose();
        moved.push(Moved {
            beta: o.fit.fit.coefficients[idx[0]],
            m: std::array::from_fn(|a| o.fit.fit.coefficients[idx[1 + a]]),
            cov: std::array::from_fn(|r| std::array::from_fn(|s| v[(idx[r], idx[s])])),
        });
    }
    let who: Vec<(String, String)> = sensors
        .iter()
        .map(|s| (s.serial.clone(), s.file.display().to_string()))
        .collect();
    let check = check::check(&moved, &who, opts.alpha);
    // What held is stage one's: the bias change and the own scale factor held at 0 and 1.
    for (k, o) in outputs.iter_mut().enumerate() {
        let s = &check.sensors[k];
        let own = if k < 3 { col::F[k] } else { col::W[k - 3] };
        let mut fixed = Vec::new();
        if !s.bias_moved {
            fixed.push(("1", 0.0));
        }
        if !s.scale_moved {
            fixed.push((own, 1.0));
        }
        hold(o, &fixed);
    }
    notes.extend(
        check
            .lines()
            .into_iter()
            .map(|l| format!("between the stages: {l}")),
    );
    for (s, o) in sensors.iter().zip(OUTPUTS) {
        if !s.left.is_empty() {
            notes.push(format!(
                "{o}: stage one's {} (of {}) not carried: in the unit its misalignment takes their place",
                s.left.join(", "),
                s.file.display()
            ));
        }
    }
    // The device's sets at stage one's temperatures.
    let final_layout = Layout {
        points: if temps.is_empty() {
            vec![table::Point {
                temp: None,
                volt: None,
                rows: Vec::new(),
            }]
        } else {
            temps
                .iter()
                .map(|t| table::Point {
                    temp: Some(*t),
                    volt: None,
                    rows: Vec::new(),
                })
                .collect()
        },
        temps: temps.clone(),
        volts: Vec::new(),
    };
    let reference = final_layout.reference();
    let mut per_point: Vec<Vec<AxisFit>> = vec![Vec::new(); final_layout.points.len()];
    for (k, (o, sensor)) in outputs.iter().zip(sensors).enumerate() {
        for (p, point) in final_layout.points.iter().enumerate() {
            per_point[p].push(composed(o, sensor, k, point.temp, path)?);
        }
    }
    let sets = |spec: &Spec<'_>, model: &TriadModel, range: std::ops::Range<usize>| {
        let fits_at = |p: usize| -> [AxisFit; 3] {
            std::array::from_fn(|a| per_point[p][range.start + a].clone())
        };
        let centers: [f64; 3] = fits_at(reference).map(|f| f.coef("1"));
        let points = (0..final_layout.points.len())
            .map(|p| {
                (
                    fits_at(p),
                    table::describe(&final_layout.points[p]),
                    raw_table.clone(),
                )
            })
            .collect();
        device_sets(
            spec,
            TriadModel {
                fits: Vec::new(),
                thermal: None,
                lever: model.lever,
                centers,
                ranges: model.ranges,
            },
            points,
            path,
        )
    };
    let accel_sets = sets(&accel_spec, &accel, 0..3)?;
    let gyro_sets = sets(&gyro_spec, &gyro, 3..6)?;
    let mut findings: Vec<_> = beyond.into_iter().collect();
    findings.extend(check.findings());
    let mut c = finish(
        opts,
        raw_table,
        &final_layout,
        (Some(accel_sets), Some(gyro_sets)),
        (None, Some(span)),
        notes,
        findings,
    )?;
    c.stages = Some(check.clone());
    Ok((c, check))
}

/// Stage two's fit of `o` with the coefficients `fixed` held at their values: the least-squares
/// estimate under those constraints, `theta - K (A theta - b)` with `K = C A' (A C A')^-1`
/// (`C` the fit's covariance), and its covariance `C - K A C`; the refits of the derivatives
/// constrained the same way.
fn hold(o: &mut Output, fixed: &[(&str, f64)]) {
    if fixed.is_empty() {
        return;
    }
    let names = &o.fit.fit.names;
    let idx: Vec<usize> = fixed
        .iter()
        .filter_map(|(n, _)| names.iter().position(|m| m == n))
        .collect();
    let b: Vec<f64> = fixed
        .iter()
        .filter(|(n, _)| names.iter().any(|m| m == n))
        .map(|(_, v)| *v)
        .collect();
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
fn derivative_of_fit(o: &Output, n1: usize) -> DMatrix<f64> {
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
fn composed(
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
    Ok(AxisFit {
        formula,
        fit,
        ..o.fit.clone()
    })
}
