//! Stage two of a two-stage calibration (`sensor::stages`): the assembled IMU's observations
//! read through each sensor's stage-one polynomial, the linear triad fits of what assembly
//! adds, and the device's sets at stage one's temperatures with both stages' covariance.

use spincal::model::Span;

mod compose;

use self::compose::{Output, composed, derivative_of_fit, hold};
use super::fit::{fit_axis, fit_triad};
use super::sets::device_sets;
use super::{Kind, NO_SPIN, Spec, Temperature, TriadModel, add_references, finish, read, spins};
use crate::columns as col;
use crate::sensor::stages::StageTwoError;
use crate::sensor::stages::check::{self, Check, Moved};
use crate::sensor::stages::one::{self, OUTPUTS, Sensor1};
use crate::sensor::table::{self, Layout};
use crate::sensor::{AxisFit, Calibrated, Options, WorkflowError, lever};

/// Temperatures closer than this are one point of the blob's table, C.
const SAME_TEMPERATURE: f64 = 0.01;
/// How far beyond stage one's calibrated range stage two may drive an axis, as a share of that
/// range (the lever arms' centripetal terms, a tumble's `g` against a dividing head's).
const RANGE_MARGIN: f64 = 0.05;

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

/// The temperature of every observation of `table` (`None` without a `temp` column, when the
/// records hold no temperature points), each inside every record's span.
fn row_temperatures(
    table: &crate::obs::Table,
    sensors: &[Sensor1],
    temps: &[f64],
) -> Result<Vec<Option<f64>>, StageTwoError> {
    let row_temps: Vec<Option<f64>> = match table.column(col::TEMP) {
        Some(c) => c.iter().map(|t| Some(*t)).collect(),
        None if temps.is_empty() => vec![None; table.len()],
        None => {
            return Err(StageTwoError::NoTemperature {
                temps: temps
                    .iter()
                    .map(|t| format!("{t} C"))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    };
    // A chamber's setpoint may read half a degree off the record's.
    let tol = 0.5;
    for (s, output) in sensors.iter().zip(OUTPUTS) {
        if let Some((line, t)) = table.lines.iter().zip(&row_temps).find_map(|(l, t)| {
            t.filter(|t| *t < f64::from(s.temps.lo) - tol || *t > f64::from(s.temps.hi) + tol)
                .map(|t| (*l, t))
        }) {
            return Err(StageTwoError::TemperatureSpan {
                line,
                temp: t,
                output,
                lo: s.temps.lo,
                hi: s.temps.hi,
                record: s.file.clone(),
            });
        }
    }
    Ok(row_temps)
}

/// Each axis' calibrated range in the unit (`ranges`, a_x to g_z) inside what its sensor's
/// stage one calibrated, give or take [`RANGE_MARGIN`].
fn within_stage_one(sensors: &[Sensor1], ranges: &[Span]) -> Result<(), StageTwoError> {
    for (k, (s, r)) in sensors.iter().zip(ranges).enumerate() {
        let margin = RANGE_MARGIN * f64::from(s.range.hi - s.range.lo);
        if f64::from(r.lo) < f64::from(s.range.lo) - margin
            || f64::from(r.hi) > f64::from(s.range.hi) + margin
        {
            return Err(StageTwoError::Range {
                output: OUTPUTS[k],
                lo: f64::from(r.lo),
                hi: f64::from(r.hi),
                rlo: s.range.lo,
                rhi: s.range.hi,
                unit: crate::sensor::blob::unit(s.quantity),
                record: s.file.clone(),
            });
        }
    }
    Ok(())
}

/// The blob's layout: a point at each of stage one's temperatures (one point without any).
fn device_layout(temps: &[f64]) -> Layout {
    let point = |temp| table::Point {
        temp,
        volt: None,
        rows: Vec::new(),
    };
    Layout {
        points: if temps.is_empty() {
            vec![point(None)]
        } else {
            temps.iter().map(|t| point(Some(*t))).collect()
        },
        temps: temps.to_vec(),
        volts: Vec::new(),
    }
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
    let (mut table, beyond, _) = read(opts, Kind::Imu)?;
    if table.varies(col::VOLT) {
        return Err(WorkflowError::triad(path, super::TriadError::VoltageVaries));
    }
    let mut notes = Vec::new();
    add_references(&mut table, opts, Kind::Imu, &mut notes)?;
    let (temps, span) = grid(sensors).map_err(located)?;
    let row_temps = row_temperatures(&table, sensors, &temps).map_err(located)?;
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
    let spin = spins(&table);
    if !spin {
        notes.push(NO_SPIN.into());
    }
    let f_varies = col::F.iter().all(|c| table.varies(c));
    let layout = table::layout(&table, None, None).map_err(|source| WorkflowError::Grid {
        path: path.clone(),
        source,
    })?;
    let temperature = Temperature::Points(layout);
    let accel_spec = Spec::accel(spin, false);
    let gyro_spec = Spec::gyro(f_varies, false);
    let accel = fit_triad(&accel_spec, &table, &temperature, opts, &mut notes)?;
    let gyro = fit_triad(&gyro_spec, &table, &temperature, opts, &mut notes)?;
    let ranges: Vec<Span> = accel.ranges.iter().chain(&gyro.ranges).copied().collect();
    within_stage_one(sensors, &ranges).map_err(located)?;
    // Each output's fit, refitted with each stage-one coefficient moved.
    let mut outputs: Vec<Output> = Vec::new();
    for (k, sensor) in sensors.iter().enumerate() {
        let (spec, model, i) = if k < 3 {
            (&accel_spec, &accel, k)
        } else {
            (&gyro_spec, &gyro, k - 3)
        };
        let fit = model.fits[0][i].clone();
        let (names, formula) = (fit.fit.names.clone(), fit.formula.clone());
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
                &formula,
                &t,
                i,
                spec.lever.then_some(&lever_use),
                opts,
                ("stage two", None),
            )?;
            Ok(names.iter().map(|n| f.coef(n)).collect())
        };
        outputs.push(Output::refitted(fit, sensor, &used, refit)?);
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
    let final_layout = device_layout(&temps);
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
