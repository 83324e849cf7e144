//! A calibration judged for a mission (`calibrate --mission`): each output's predicted 1-sigma
//! error along the flight from the fit's covariance (when the data chose the terms, the
//! model's before the choice, which the unit's stated error carries too), where the flight leaves the calibrated
//! range, and the terms the model leaves out (dropped on the bench, or not in its preset) that
//! would cost most over the flight. For each such
//! term (the nonlinear preset's own-axis terms, and a gyro's g-sensitivity), the kept model
//! with the term added is fitted at the reference point; the term's bench bound is
//! `|b| + t(1 - alpha/2, dof) se(b)`, and its worst contribution over the flight's moments the
//! bench reached is that bound times the largest `|term(x_t)|`, in the output's SI unit.
//!
//! Verdicts: an output whose predicted RMS error over the flight exceeds its requirement, a
//! dropped term whose worst contribution exceeds the requirement (or, without one, three
//! times the output's predicted RMS error), or a flight more than 1 % of whose time is beyond
//! the calibrated range, each make the calibration REVIEW, naming what.

use nalgebra::DMatrix;

use super::Profile;
pub use super::judged::{Judged, Output, TermCost};
use super::weight::{self, Lookup, Reach};
use crate::columns as col;
use crate::design::models;
use crate::design::points::{Points, Unit};
use crate::formula::Formula;
use crate::sensor::{AxisFit, Calibrated, Finding, Verdict, lever};

/// Samples of the flight the timeline shows.
const TIMELINE: usize = 600;
/// The share of the flight beyond the calibrated range a calibration may leave without review.
pub const BEYOND_ALLOWED: f64 = 0.01;

/// Why a calibration cannot be judged over a mission.
#[derive(Debug, thiserror::Error)]
pub enum JudgeError {
    /// The profile lacks a variable the model reads.
    #[error("--mission: {0}")]
    Missing(#[from] weight::Missing),
    /// A requirement for no output.
    #[error(
        "--requirement `{0}`: expected a=SI,g=SI (accelerometer in m/s^2, gyro in rad/s) or OUTPUT=SI, a positive number each"
    )]
    Requirement(String),
    /// A requirement given twice.
    #[error("--requirement: `{0}` is given twice; give each output or family once")]
    RepeatedRequirement(String),
    /// A requirement for an output or family the calibration does not have.
    #[error(
        "--requirement `{key}`: this calibration has no such output or family; the keys that apply are {}",
        .applicable.join(", ")
    )]
    UnknownRequirement {
        /// The key given.
        key: String,
        /// The keys that apply: each output, and `a` or `g` for its family.
        applicable: Vec<String>,
    },
}

/// Reads `--requirement`: `a=0.05,g=0.002` (SI) or per output (`a_x=0.05`). Which keys apply
/// is the calibration's to say ([`judge`]).
///
/// # Errors
/// An item that is not `NAME=positive number`, or a name given twice.
pub fn requirements(text: &str) -> Result<Vec<(String, f64)>, JudgeError> {
    let items: Vec<(String, f64)> = text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|item| {
            let (k, v) = item
                .split_once('=')
                .ok_or_else(|| JudgeError::Requirement(item.to_string()))?;
            let v: f64 = v
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v > 0.0)
                .ok_or_else(|| JudgeError::Requirement(item.to_string()))?;
            Ok((k.trim().to_string(), v))
        })
        .collect::<Result<_, JudgeError>>()?;
    for (i, (key, _)) in items.iter().enumerate() {
        if items[..i].iter().any(|(k, _)| k == key) {
            return Err(JudgeError::RepeatedRequirement(key.clone()));
        }
    }
    Ok(items)
}

/// Refuses a requirement whose key is neither an output of `c` nor the family (`a`, `g`) of
/// one (`single_gyro` says a single axis' family).
fn check_requirements(
    c: &Calibrated,
    single_gyro: bool,
    requirement: &[(String, f64)],
) -> Result<(), JudgeError> {
    let mut applicable: Vec<String> = Vec::new();
    for axis in &c.points[c.reference].axes {
        let gyro = is_gyro(axis, single_gyro);
        for key in [
            axis.output.clone(),
            (if gyro { "g" } else { "a" }).to_string(),
        ] {
            if !applicable.contains(&key) {
                applicable.push(key);
            }
        }
    }
    match requirement.iter().find(|(k, _)| !applicable.contains(k)) {
        Some((key, _)) => Err(JudgeError::UnknownRequirement {
            key: key.clone(),
            applicable,
        }),
        None => Ok(()),
    }
}

/// A term kept by the fit's selection whose t statistic is below this may be there only
/// because it was selected: a term that is not there passes the 5 % test by chance with an
/// estimate of 2 to 3 standard errors, but reaches 4 only once in 16,000.
const SELECTION_T: f64 = 4.0;

/// The covariance the mission is predicted with when the fit chose its terms and dropped none
/// of them (with some dropped, [`stated_variance`]'s is the prediction): each term the
/// selection could have dropped and kept with `|t| <` [`SELECTION_T`] has its estimate's
/// square added to its variance, so that the prediction covers the chance that the term is
/// not there at all and its estimate is the selection's (kept by chance, such a term's
/// estimate is 2.4 standard errors on average: the prediction of its own covariance was 2.1
/// to 2.3 times too small). Terms the fit keeps by construction (the bias, the inputs, the
/// temperature terms) and terms far beyond chance are left as they are.
fn selection_covariance(axis: &AxisFit) -> nalgebra::DMatrix<f64> {
    let mut cov = axis.fit.covariance.clone();
    for (j, name) in axis.fit.names.iter().enumerate() {
        let forced = name == "1"
            || name == &axis.own
            || crate::columns::W.contains(&name.as_str()) && axis.own.starts_with("w_")
            || crate::columns::F.contains(&name.as_str()) && axis.own.starts_with("f_")
            || crate::sensor::thermal::is_thermal(name);
        let t = axis.fit.t.get(j).copied().unwrap_or(f64::INFINITY);
        if !forced && t.abs() < SELECTION_T {
            cov[(j, j)] += axis.fit.coefficients[j].powi(2);
        }
    }
    cov
}

/// What a triad axis of a nonlinear model senses, from its fit: its sensitivity row over its
/// own, its lever arm (an accelerometer) or its g-sensitivity row (a gyro); `None` for a single
/// axis or a model that does not read it.
fn sensed_axis(axis: &AxisFit, gyro: bool, k: usize) -> Option<weight::SensedAxis> {
    use crate::columns as col;
    if !axis
        .formula
        .columns()
        .iter()
        .any(|c| c == crate::sensor::lever::SENSED)
    {
        return None;
    }
    let inputs = if gyro { col::W } else { col::F };
    let own = axis.coef(inputs[k]);
    if own == 0.0 {
        return None;
    }
    Some(weight::SensedAxis {
        gyro,
        direction: inputs.map(|n| axis.coef(n) / own),
        lever: std::array::from_fn(|j| axis.coef(&crate::sensor::lever::column(k, j))),
        g: if gyro {
            col::F.map(|n| axis.coef(n) / own)
        } else {
            [0.0; 3]
        },
    })
}

/// Whether an axis reads a rate: a gyro triad's, or a single axis calibrated as a gyro.
fn is_gyro(axis: &AxisFit, single_gyro: bool) -> bool {
    match kind(axis) {
        (Unit::Triad, gyro, _) => gyro,
        _ => single_gyro,
    }
}

/// What kind of input an axis reads: the unit kind for the profile, whether it is a gyro, and
/// its triad index.
fn kind(axis: &AxisFit) -> (Unit, bool, usize) {
    let own = axis.own.as_str();
    let k = own.chars().last().map_or(0, |c| match c {
        'y' => 1,
        'z' => 2,
        _ => 0,
    });
    if own.starts_with("w_") {
        (Unit::Triad, true, k)
    } else if own.starts_with("f_") {
        (Unit::Triad, false, k)
    } else if axis.output.contains('g') && !axis.output.contains("output") {
        (Unit::SingleGyro, true, 0)
    } else {
        (Unit::SingleAccel, false, 0)
    }
}

/// The terms the bench could have kept for an axis: the nonlinear preset's, and a gyro's
/// g-sensitivity.
fn candidates(unit: Unit, gyro: bool, k: usize) -> Vec<String> {
    let preset = match unit {
        Unit::Triad => "triad-nonlinear",
        _ => "single",
    };
    let mut names: Vec<String> = models::blocks(preset, gyro)
        .map(|b| b[k.min(b.len() - 1)].formula.term_names())
        .unwrap_or_default();
    if gyro && unit == Unit::Triad {
        names.extend(crate::columns::F.iter().map(|s| (*s).to_string()));
    }
    names
}

/// Judges `c` (whose unit kind is `single_gyro` for a single axis) over `profile`.
///
/// # Errors
/// A profile without a variable the model reads, or a requirement that cannot be read.
pub fn judge(
    c: &Calibrated,
    profile: &Profile,
    single_gyro: bool,
    requirement: &[(String, f64)],
    (alpha, selected): (f64, bool),
) -> Result<Judged, JudgeError> {
    check_requirements(c, single_gyro, requirement)?;
    let point = &c.points[c.reference];
    let mut out = Judged {
        profile: profile.source.display().to_string(),
        outputs: Vec::new(),
        terms: Vec::new(),
        assumed: Vec::new(),
        findings: Vec::new(),
    };
    for (a, axis) in point.axes.iter().enumerate() {
        let (mut unit, _, k) = kind(axis);
        let gyro = is_gyro(axis, single_gyro);
        if unit != Unit::Triad {
            unit = if single_gyro {
                Unit::SingleGyro
            } else {
                Unit::SingleAccel
            };
        }
        let lookup = Lookup::of_axis(profile, &axis.formula, unit, sensed_axis(axis, gyro, k))?;
        for v in lookup.assumed(profile) {
            if !out.assumed.contains(&v) {
                out.assumed.push(v);
            }
        }
        let rows = reference_rows(&c.table, axis);
        let bench = as_fitted(&c.table.select(&rows), axis, k, gyro);
        let vars: Vec<String> = axis.formula.columns().into_iter().skip(1).collect();
        let reach = Reach::of(&points(&bench, &vars), &vars, &[]);
        let scale = axis
            .fit
            .names
            .iter()
            .position(|n| *n == axis.own)
            .map_or(1.0, |j| axis.fit.coefficients[j].abs());
        let w = weight::weight(profile, &axis.formula, &lookup, &reach);
        let stated = if selected {
            stated_variance(profile, axis, &bench, (unit, sensed_axis(axis, gyro, k)))
        } else {
            None
        };
        let (rms, worst_in, timeline) = if let Some(v) = &stated {
            let inside = |i: &usize| lookup.inside(profile, *i, &reach);
            (
                inside_mean(profile, &lookup, &reach, v).max(0.0).sqrt() / scale,
                (0..profile.len())
                    .filter(inside)
                    .map(|i| v[i])
                    .fold(0.0, f64::max),
                timeline(profile, (&lookup, &reach), |i| v[i], scale),
            )
        } else {
            let cov = if selected {
                selection_covariance(axis)
            } else {
                axis.fit.covariance.clone()
            };
            let (worst_in, _) =
                weight::worst_variance(profile, &axis.formula, &lookup, &reach, &cov, 1);
            (
                weight::mean_variance(&cov, 1, &w.inside).max(0.0).sqrt() / scale,
                worst_in,
                timeline(
                    profile,
                    (&lookup, &reach),
                    |i| moment_variance(profile, (&axis.formula, &lookup), &cov, i),
                    scale,
                ),
            )
        };
        let name = axis.output.clone();
        let required = requirement
            .iter()
            .find(|(key, _)| *key == name)
            .or_else(|| {
                let family = if gyro { "g" } else { "a" };
                requirement.iter().find(|(key, _)| key == family)
            })
            .map(|r| r.1);
        let beyond = crate::design::space::describe_beyond(&w, &reach);
        if 1.0 - w.share_inside > BEYOND_ALLOWED {
            out.findings.push(Finding {
                verdict: Verdict::Review,
                text: format!(
                    "{name}: {} % of the flight is beyond the calibrated range ({beyond}); the calibration extrapolates there",
                    crate::design::space::percent(1.0 - w.share_inside)
                ),
            });
        }
        let worst = worst_in.max(0.0).sqrt() / scale;
        if let Some(req) = required {
            let num = crate::report::terminal::num;
            let unit = c.units[a];
            if rms > req {
                out.findings.push(Finding {
                    verdict: Verdict::Review,
                    text: format!(
                        "{name}: predicted 1-sigma error over the flight {} {unit} rms exceeds the requirement {req} (the verdict's statistic: the RMS over the flight's moments within range; at its worst moment {} {unit})",
                        num(rms),
                        num(worst)
                    ),
                });
            } else if worst > req {
                // Every output over its requirement is named, at the statistic that puts it
                // there (issue 68: a worst case over the requirement went unsaid).
                out.findings.push(Finding {
                    verdict: Verdict::Accept,
                    text: format!(
                        "{name}: within the requirement {req} by the verdict's statistic (the RMS over the flight, {} {unit}), but over it at the flight's worst moment ({} {unit})",
                        num(rms),
                        num(worst)
                    ),
                });
            }
        }
        // The terms the bench dropped, priced over the flight's moments it reached.
        let reached: Vec<usize> = (0..profile.len())
            .filter(|i| lookup.inside(profile, *i, &reach))
            .collect();
        let mut row = Vec::with_capacity(1);
        for term in candidates(unit, gyro, k) {
            if axis.formula.term_names().contains(&term) || !vars_in_table(&term, &c.table) {
                continue;
            }
            let Ok(with) = crate::formula::parse(&format!("{} + {term}", axis.formula)) else {
                continue;
            };
            if with.columns().iter().any(|v| bench.column(v).is_none()) {
                continue;
            }
            let Ok(fit) = AxisFit::fit(
                &with,
                &bench,
                &axis.own,
                alpha,
                (&c.table.path, "mission"),
                false,
            ) else {
                continue;
            };
            let j = fit.fit.names.len() - 1;
            let (b, se) = (fit.fit.coefficients[j], fit.fit.std_errors[j]);
            let t = crate::stats::dist::t_upper_quantile(alpha / 2.0, fit.fit.dof as f64);
            let bound = b.abs() + t * se;
            let Ok(only) = crate::formula::parse(&format!("{} ~ 0 + {term}", with.response)) else {
                continue;
            };
            let Ok(term_lookup) = Lookup::new(profile, &only, unit) else {
                continue;
            };
            let largest = reached
                .iter()
                .map(|&i| {
                    only.row(|v| term_lookup.value(profile, i, v), &mut row);
                    row.first().copied().unwrap_or(0.0).abs()
                })
                .fold(0.0, f64::max);
            out.terms.push(TermCost {
                output: name.clone(),
                term,
                estimate: b,
                bound,
                worst: bound * largest / scale,
            });
        }
        let limit = required.unwrap_or(3.0 * rms);
        for cost in out
            .terms
            .iter()
            .filter(|t| t.output == name && t.worst > limit)
        {
            out.findings.push(Finding {
                verdict: Verdict::Review,
                text: format!(
                    "{name}: the term {}, left out of the model, may cost up to {} {} over the flight (its bench bound {} times its largest value in flight), more than {}",
                    cost.term,
                    crate::report::terminal::num(cost.worst),
                    c.units[a],
                    crate::report::terminal::num(cost.bound),
                    match required {
                        Some(r) => format!("the requirement {r}"),
                        None => "three times the predicted error; keep it (--nonlinear, or the model) or calibrate where the flight goes".to_string(),
                    }
                ),
            });
        }
        out.outputs.push(Output {
            output: name,
            unit: c.units[a],
            rms,
            worst,
            share_inside: w.share_inside,
            beyond,
            timeline,
            requirement: required,
        });
    }
    out.terms.sort_by(|a, b| b.worst.total_cmp(&a.worst));
    Ok(out)
}

/// The rows of the reference point's fit of `axis` in `table` (by file line).
fn reference_rows(table: &crate::obs::Table, axis: &AxisFit) -> Vec<usize> {
    let lines: std::collections::HashSet<u64> = axis.lines.iter().copied().collect();
    (0..table.len())
        .filter(|i| lines.contains(&table.lines[*i]))
        .collect()
}

/// The bench rows as the axis' own fit read them: under rotation an accelerometer's lever-arm
/// regressors, its force at the lever arm and its pseudo-response, and what an axis senses (for
/// its nonlinear terms), rebuilt by [`lever::axis_table`] at the fitted estimate. A term added
/// to that table is then tested as the fit's last Gauss-Newton step would test it.
fn as_fitted(table: &crate::obs::Table, axis: &AxisFit, i: usize, gyro: bool) -> crate::obs::Table {
    let cols = axis.formula.columns();
    if cols.iter().all(|v| table.column(v).is_some()) {
        return table.clone();
    }
    let coef = |name: &str| {
        axis.fit
            .names
            .iter()
            .position(|n| n == name)
            .map_or(0.0, |j| axis.fit.coefficients[j])
    };
    let own = if gyro { col::W } else { col::F };
    let est = lever::Estimate {
        s: std::array::from_fn(|k| coef(own[k])),
        r: std::array::from_fn(|k| coef(&lever::column(i, k))),
        g: if gyro {
            std::array::from_fn(|k| coef(col::F[k]))
        } else {
            [0.0; 3]
        },
    };
    if est.s[i] == 0.0 {
        return table.clone();
    }
    let which: [bool; 3] = std::array::from_fn(|k| cols.contains(&lever::column(i, k)));
    let lever = (!gyro && which.contains(&true)).then_some(&which);
    let nonlinear = cols.iter().any(|v| v == lever::SENSED);
    lever::axis_table(table, gyro, i, &axis.output, &est, lever, nonlinear)
}

/// True when every variable of `term` is a column of `table`.
fn vars_in_table(term: &str, table: &crate::obs::Table) -> bool {
    crate::formula::parse(&format!("y ~ {term}")).is_ok_and(|f| {
        f.columns()
            .iter()
            .skip(1)
            .all(|v| table.column(v).is_some())
    })
}

/// The table's `vars` as points.
fn points(table: &crate::obs::Table, vars: &[String]) -> Points {
    let cols: Vec<Option<&[f64]>> = vars.iter().map(|v| table.column(v)).collect();
    Points {
        names: vars.to_vec(),
        rows: (0..table.len())
            .map(|i| {
                cols.iter()
                    .zip(vars)
                    .map(|(c, v)| {
                        c.map_or_else(|| crate::design::points::default_value(v), |c| c[i])
                    })
                    .collect()
            })
            .collect(),
    }
}

/// The predicted 1-sigma error at [`TIMELINE`] moments spread over the flight, SI.
fn timeline(
    p: &Profile,
    (lookup, reach): (&Lookup, &Reach),
    variance: impl Fn(usize) -> f64,
    scale: f64,
) -> Vec<(f64, f64, bool)> {
    let every = p.len().div_ceil(TIMELINE).max(1);
    (0..p.len())
        .step_by(every)
        .map(|i| {
            (
                p.t[i],
                variance(i).max(0.0).sqrt() / scale,
                lookup.inside(p, i, reach),
            )
        })
        .collect()
}

/// The chosen model's prediction variance `x' C x` at the flight's moment `i`.
fn moment_variance(
    p: &Profile,
    (formula, lookup): (&Formula, &Lookup),
    cov: &DMatrix<f64>,
    i: usize,
) -> f64 {
    let mut row = Vec::with_capacity(formula.width());
    formula.row(|v| lookup.value(p, i, v), &mut row);
    let x = nalgebra::DVector::from_vec(row);
    (x.transpose() * cov * &x)[(0, 0)]
}

/// The dwell-weighted mean of `per_moment` over the flight's moments inside `reach`.
fn inside_mean(p: &Profile, lookup: &Lookup, reach: &Reach, per_moment: &[f64]) -> f64 {
    let dwell = p.dwell();
    let (sum, time) = (0..p.len())
        .filter(|&i| lookup.inside(p, i, reach))
        .fold((0.0, 0.0), |(s, t), i| {
            (s + dwell[i] * per_moment[i], t + dwell[i])
        });
    if time > 0.0 { sum / time } else { 0.0 }
}

/// Per moment of the flight, the variance of the chosen model's error when the data chose its
/// terms (in the fit's unit, squared): the model before the choice's (`AxisFit::stated_fit`,
/// whose covariance the unit's stated 1-sigma carries) at the moment's values of all its
/// terms. A dropped term is not known to be zero: it counts where the bench reached it in its
/// own variables, and elsewhere is priced as a left-out term's cost ([`TermCost`]); a term
/// kept because it passed its test by chance is stated with the spread it has over every
/// unit. `None` when the data dropped nothing (then [`selection_covariance`] widens the terms
/// kept near the test's edge) or the model before the choice cannot be read over the flight.
/// With the chosen model's covariance widened by [`selection_covariance`] alone, on 240 gyro
/// triads of a model not ours flown on the three reference flights (a third without
/// g-sensitivity, a third a MEMS gyro's, a third near the bench's detection limit), each
/// unit's realised error was about twice the predicted (RMS 2.08, 1.99, 1.97 on the three
/// axes; now 0.95, 0.86, 0.81): the g-sensitivity the selection dropped went unpredicted.
fn stated_variance(
    profile: &Profile,
    axis: &AxisFit,
    bench: &crate::obs::Table,
    (unit, sensed): (Unit, Option<weight::SensedAxis>),
) -> Option<Vec<f64>> {
    let full = axis.full.as_deref()?;
    let formula = crate::formula::parse(&format!(
        "{} ~ {}",
        axis.formula.response,
        full.names.join(" + ")
    ))
    .ok()?;
    if formula.term_names() != full.names {
        return None;
    }
    let lookup = Lookup::of_axis(profile, &formula, unit, sensed).ok()?;
    let kept = axis.formula.term_names();
    // Per dropped term, its position and the bench's reach in its own variables.
    let mut dropped = Vec::new();
    for (j, term) in full.names.iter().enumerate() {
        if kept.contains(term) {
            continue;
        }
        let only =
            crate::formula::parse(&format!("{} ~ 0 + {term}", axis.formula.response)).ok()?;
        let vars: Vec<String> = only.columns().into_iter().skip(1).collect();
        if vars.iter().any(|v| bench.column(v).is_none()) {
            return None;
        }
        dropped.push((j, Reach::of(&points(bench, &vars), &vars, &[])));
    }
    use rayon::prelude::*;
    Some(
        (0..profile.len())
            .into_par_iter()
            .map(|i| {
                let mut row = Vec::with_capacity(formula.width());
                formula.row(|v| lookup.value(profile, i, v), &mut row);
                for (j, reach) in &dropped {
                    if !lookup.inside(profile, i, reach) {
                        row[*j] = 0.0;
                    }
                }
                let x = nalgebra::DVector::from_vec(row);
                (x.transpose() * &full.covariance * &x)[(0, 0)]
            })
            .collect(),
    )
}
