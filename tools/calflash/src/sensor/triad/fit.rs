//! Fitting a triad: each output axis' terms, then its regression (Gauss-Newton for the lever
//! arms, refreshed sensed inputs for the nonlinear terms) at each table point or as one
//! continuous temperature model, and the channels from the reference point.

use nalgebra::Matrix3;

use super::super::table;
use super::super::thermal::{self as continuous};
use super::super::{AxisFit, Options, WorkflowError, lever};
use super::{ALL, Spec, Temperature, TriadError, TriadModel, calibrated_ranges};
use crate::columns as col;
use crate::formula::{self, Formula};
use crate::obs::Table;
use crate::stats::{self, select};

/// Most regression steps of one axis' fit (Gauss-Newton for the lever arms, refreshed sensed
/// inputs for the nonlinear terms); it converges in a handful.
const MAX_STEPS: usize = 50;
/// Converged when no estimate moves by more than this, relative to the axis' scale factor (or
/// in metres for the lever arm).
const STEP_TOLERANCE: f64 = 1e-11;

fn fit_one(
    formula: &Formula,
    t: &Table,
    own: &str,
    opts: &Options,
    where_: &str,
    weights: Option<&[f64]>,
) -> Result<AxisFit, WorkflowError> {
    AxisFit::fit_weighted(
        formula,
        t,
        own,
        opts.alpha,
        (&opts.file, where_),
        true,
        weights,
    )
}

/// Fits axis `i` of a triad at one table point: one regression when the model is linear in
/// its coefficients, else regression steps from [`lever::Estimate::start`] until the estimates
/// the regressors are made from stop moving (`sensor::lever`).
#[allow(clippy::too_many_arguments)]
pub(super) fn fit_axis(
    spec: &Spec<'_>,
    formula: &Formula,
    t: &Table,
    i: usize,
    lever_use: Option<&[bool; 3]>,
    opts: &Options,
    (where_, weights): (&str, Option<&[f64]>),
) -> Result<AxisFit, WorkflowError> {
    let iterate = lever_use.is_some() || spec.nonlinear;
    let mut est = lever::Estimate::start(i);
    for step in 0..MAX_STEPS {
        let at = lever::axis_table(
            t,
            spec.gyro,
            i,
            spec.outputs[i],
            &est,
            lever_use,
            spec.nonlinear,
        );
        let fit = fit_one(formula, &at, spec.inputs[i], opts, where_, weights)?;
        if !iterate {
            return Ok(fit);
        }
        let next = estimate_of(spec, &fit, i, step == 0);
        let s = next.s;
        let scale = s[i].abs().max(f64::MIN_POSITIVE);
        let moved = (0..3)
            .map(|k| {
                ((next.s[k] - est.s[k]).abs() / scale)
                    .max((next.r[k] - est.r[k]).abs())
                    .max((next.g[k] - est.g[k]).abs() / scale)
            })
            .fold(0.0, f64::max);
        if step > 0 && moved <= STEP_TOLERANCE {
            return Ok(fit);
        }
        if !next.s.iter().chain(&next.r).all(|x| x.is_finite()) || s[i] == 0.0 {
            break;
        }
        est = next;
    }
    Err(WorkflowError::triad(
        &opts.file,
        TriadError::NotSettled {
            output: spec.outputs[i].into(),
            at: where_.into(),
            steps: MAX_STEPS,
        },
    ))
}

/// Axis `i`'s estimate from its fit: the sensitivity row, the lever arm and the g-sensitivity
/// row. The `first` step's lever coefficients are `S_ii r_ik` (its regressors assume a unit
/// sensitivity); later ones are `r_ik`.
fn estimate_of(spec: &Spec<'_>, fit: &AxisFit, i: usize, first: bool) -> lever::Estimate {
    let s = spec.inputs.map(|n| fit.coef(n));
    let per = if first { s[i] } else { 1.0 };
    lever::Estimate {
        s,
        r: std::array::from_fn(|k| fit.coef(&lever::column(i, k)) / per),
        g: if spec.gyro {
            col::F.map(|n| fit.coef(n))
        } else {
            [0.0; 3]
        },
    }
}

/// Which of axis `i`'s lever-arm components `f` has.
fn lever_terms(f: &Formula, i: usize) -> [bool; 3] {
    std::array::from_fn(|k| f.terms.iter().any(|t| t.name() == lever::column(i, k)))
}

/// Notes on the lever-arm components the plan cannot estimate.
fn lever_notes(estimable: &[[bool; 3]; 3], notes: &mut Vec<String>) {
    let missing: Vec<String> = (0..3)
        .flat_map(|i| (0..3).map(move |k| (i, k)))
        .filter(|(i, k)| !estimable[*i][*k])
        .map(|(i, k)| format!("r_{}{}", lever::AXES[i], lever::AXES[k]))
        .collect();
    let estimated = 9 - missing.len();
    if missing.is_empty() {
        notes.push("the plan spins the unit about axes and diagonals: all nine lever-arm components of the accelerometer are estimated".into());
    } else {
        notes.push(format!(
            "the plan spins the unit: {estimated} of the nine lever-arm components are estimated; {} cannot be (component k of axis i needs a spin with rate along both i and k, or an angular acceleration about the third axis) and are set to 0: add a `diagonal:LO:HI:N` plan item (the rate table's 45-degree fixture) to estimate them",
            missing.join(", ")
        ));
    }
}

/// Axis `i`'s preset formula, its terms chosen on the first step's regressors at the reference
/// (`ref_table`, every observation for a continuous model, whose bias and own scale factor
/// meanwhile follow the temperature at the highest order the observations can estimate); with
/// the formula before the choice when the choice dropped a term.
#[allow(clippy::too_many_arguments)]
fn axis_formula(
    spec: &Spec<'_>,
    i: usize,
    ref_table: &Table,
    (ref_where, weights): (&str, Option<&[f64]>),
    estimable: Option<&[[bool; 3]; 3]>,
    support: Option<&continuous::Support>,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<(Formula, Option<Formula>), WorkflowError> {
    let inputs = format!(
        "{} + {} + {}",
        spec.inputs[0], spec.inputs[1], spec.inputs[2]
    );
    let mut text = format!("{} ~ 1 + {inputs}", spec.outputs[i]);
    if spec.nonlinear {
        let n = lever::SENSED;
        text.push_str(&format!(" + {n}^2 + {n}^3 + {n}:abs({n})"));
    }
    if spec.g_sens {
        text.push_str(&format!(" + {} + {} + {}", col::F[0], col::F[1], col::F[2]));
    }
    if let Some(e) = estimable {
        for k in (0..3).filter(|k| e[i][*k]) {
            text.push_str(&format!(" + {}", lever::column(i, k)));
        }
    }
    notes.push(format!("preset expands {} to: {text}", spec.outputs[i]));
    let base = formula::parse(&text)?;
    let first = lever::axis_table(
        ref_table,
        spec.gyro,
        i,
        spec.outputs[i],
        &lever::Estimate::start(i),
        estimable.map(|e| &e[i]),
        spec.nonlinear,
    );
    let fit = |f: &Formula| fit_one(f, &first, spec.inputs[i], opts, ref_where, weights);
    let mut f = match support {
        Some(s) => {
            let linear = formula::parse(&format!("{} ~ 1 + {inputs}", spec.outputs[i]))?;
            let bias = continuous::estimable(&linear, 0, s.max_order, &[], &fit);
            let own = continuous::estimable(&linear, 1 + i, s.max_order, &[bias], &fit);
            let orders: Vec<u32> = base
                .term_names()
                .iter()
                .map(|n| match n.as_str() {
                    "1" => bias,
                    n if n == spec.inputs[i] => own,
                    _ => 0,
                })
                .collect();
            continuous::expand(&base, &orders)
        }
        None => base,
    };
    if spec.nonlinear && !opts.nonlinear_required {
        f = observable(f, &fit, spec.outputs[i], notes);
    }
    fit(&f)?;
    let before = if spec.stated_nonlinear {
        let n = lever::SENSED;
        let all = formula::parse(&format!("{text} + {n}^2 + {n}^3 + {n}:abs({n})"))?;
        // Fitted on what the axis senses (the correction's own table has no such column).
        let sensed = lever::axis_table(
            ref_table,
            spec.gyro,
            i,
            spec.outputs[i],
            &lever::Estimate::start(i),
            estimable.map(|e| &e[i]),
            true,
        );
        let fit_all = |f: &Formula| fit_one(f, &sensed, spec.inputs[i], opts, ref_where, weights);
        observable(all, &fit_all, spec.outputs[i], notes)
    } else {
        f.clone()
    };
    if !opts.keep_all_terms {
        // With lever arms, the terms are chosen on the regressors at the whole model's converged
        // estimate (elsewhere the first step's are the converged ones but for the small change
        // of what the axis senses, and the choice is left as it was). At
        // the start (a unit sensitivity along the axis, no lever arm) the bilinear term, the
        // axis' misalignment times the centripetal force across it (1.5 m/s^2 for 1 mrad at
        // 1,000 rad/s on a 1.5 mm arm), is not yet in the regressors, and its residual would
        // hide a lever component worth a tenth of that, thirty times the noise.
        let chosen_on = if estimable.is_some() {
            let lever_use = estimable.map(|_| lever_terms(&f, i));
            let whole = fit_axis(
                spec,
                &f,
                ref_table,
                i,
                lever_use.as_ref(),
                opts,
                (ref_where, weights),
            )?;
            lever::axis_table(
                ref_table,
                spec.gyro,
                i,
                spec.outputs[i],
                &estimate_of(spec, &whole, i, false),
                lever_use.as_ref(),
                spec.nonlinear,
            )
        } else {
            first
        };
        let d = f.design(&chosen_on);
        let sopts = stats::Options {
            alpha: opts.alpha,
            ..stats::Options::default()
        };
        let ff = f.clone();
        let e = select::backward(
            &d.x,
            &d.y,
            &d.names,
            true,
            &sopts,
            opts.alpha,
            |names, j| {
                let n = &names[j];
                if n == "1" || spec.inputs.contains(&n.as_str()) || continuous::is_thermal(n) {
                    return false;
                }
                let Some(t) = ff.terms.iter().find(|t| &t.name() == n) else {
                    return false;
                };
                !ff.terms
                    .iter()
                    .filter(|o| names.contains(&o.name()))
                    .any(|o| Formula::contains(o, t))
            },
        )
        .map_err(WorkflowError::Selection)?;
        for s in &e.steps {
            notes.push(format!(
                "{}: dropped {} (p = {:.3} > {})",
                spec.outputs[i], s.dropped, s.p_value, opts.alpha
            ));
            f = f.without(&s.dropped);
        }
    }
    let dropped = spec.stated_nonlinear || before.terms.len() != f.terms.len();
    Ok((
        continuous::base_of(&f),
        dropped.then(|| continuous::base_of(&before)),
    ))
}

/// Fits a triad: its terms, then a fit at each table point or one continuous temperature model
/// per axis, and the channels (centres and calibrated ranges) from the reference.
pub(super) fn fit_triad(
    spec: &Spec<'_>,
    table: &Table,
    temperature: &Temperature,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<TriadModel, WorkflowError> {
    let path = &opts.file;
    let (ref_table, ref_where, weights, support) = match temperature {
        Temperature::Points(layout) => {
            let p = &layout.points[layout.reference()];
            (table.select(&p.rows), table::describe(p), None, None)
        }
        Temperature::Continuous(prep) => (
            table.clone(),
            ALL.to_string(),
            prep.weights.as_deref(),
            Some(&prep.support),
        ),
    };
    let estimable = spec
        .lever
        .then(|| lever::estimable(lever::motion(table).into_iter()));
    if let Some(e) = &estimable {
        lever_notes(e, notes);
    }
    let mut formulas = Vec::new();
    let mut before = Vec::new();
    for i in 0..3 {
        let (chosen, all) = axis_formula(
            spec,
            i,
            &ref_table,
            (&ref_where, weights),
            estimable.as_ref(),
            support,
            opts,
            notes,
        )?;
        formulas.push(chosen);
        before.push(all);
    }
    // The lever components each axis' formula kept.
    let lever_use: Option<[[bool; 3]; 3]> =
        estimable.map(|_| std::array::from_fn(|i| lever_terms(&formulas[i], i)));
    let one = |f: &Formula, t: &Table, i: usize, at: (&str, Option<&[f64]>)| {
        fit_axis(spec, f, t, i, lever_use.as_ref().map(|u| &u[i]), opts, at)
    };
    let mut fits: Vec<[AxisFit; 3]> = Vec::new();
    // The model the channels are taken from: the reference point's, or the continuous model's
    // at the middle of the calibrated temperatures.
    let (thermal_fits, reference) = match temperature {
        Temperature::Points(layout) => {
            for p in &layout.points {
                let t = table.select(&p.rows);
                let w = table::describe(p);
                let at = |i: usize| one(&formulas[i], &t, i, (&w, None));
                let mut point = [at(0)?, at(1)?, at(2)?];
                // The model before the choice, for the stated error (`AxisFit::stated_fit`).
                for (i, axis) in point.iter_mut().enumerate() {
                    if let Some(all) = &before[i] {
                        axis.full =
                            stated_fit(spec, all, &t, i, estimable.as_ref(), opts, &w, axis)
                                .map(Box::new);
                    }
                }
                fits.push(point);
            }
            let reference = fits[layout.reference()].clone();
            if spec.stated_nonlinear {
                shown_but_left_out(spec, &reference, opts.alpha, notes);
            }
            (None, reference)
        }
        Temperature::Continuous(prep) => {
            let temps = table.column(col::TEMP).unwrap_or_default();
            let axis = |i: usize, notes: &mut Vec<String>| {
                let tf = continuous::choose(
                    &formulas[i],
                    (&prep.support, temps),
                    opts.alpha,
                    opts.thermal_order,
                    &|f| one(f, table, i, (ALL, weights)),
                )?;
                notes.extend(
                    tf.reasons
                        .iter()
                        .map(|r| format!("{}: temperature order of {r}", spec.outputs[i])),
                );
                Ok::<_, WorkflowError>(tf)
            };
            let tfs = [axis(0, notes)?, axis(1, notes)?, axis(2, notes)?];
            let mid = prep.support.scale.center();
            let reference = [tfs[0].at(mid), tfs[1].at(mid), tfs[2].at(mid)];
            (Some(tfs), reference)
        }
    };
    // No lever arm when the plan estimates none or every component was dropped.
    let lever_arm = lever_use
        .filter(|u| u.iter().flatten().any(|kept| *kept))
        .map(|_| lever_of(&reference));
    let ranges = calibrated_ranges(spec, table, &s_of(spec, &reference), lever_arm.as_ref());
    for (j, r) in ranges.iter().enumerate() {
        if r.lo >= r.hi {
            return Err(WorkflowError::triad(
                path,
                TriadError::ConstantInput {
                    input: spec.inputs[j].into(),
                },
            ));
        }
    }
    Ok(TriadModel {
        fits,
        thermal: thermal_fits,
        lever: lever_arm,
        centers: b_of(&reference),
        ranges,
    })
}

/// `f` without the nonlinear terms the plan cannot estimate (the cube and the odd square need
/// four and three distinct levels of what the axis senses; a tumble gives three), dropped
/// highest first until `fit` can estimate the rest, each said in a note.
fn observable(
    mut f: Formula,
    fit: &dyn Fn(&Formula) -> Result<AxisFit, WorkflowError>,
    output: &str,
    notes: &mut Vec<String>,
) -> Formula {
    let n = lever::SENSED;
    for term in [format!("{n}^3"), format!("{n}:abs({n})"), format!("{n}^2")] {
        if fit(&f).is_ok() {
            break;
        }
        if f.term_names().contains(&term) {
            notes.push(format!(
                "{output}: {term} left out of the candidates: this plan cannot estimate it"
            ));
            f = f.without(&term);
        }
    }
    f
}

/// Notes the nonlinear terms the data show (significant at `alpha` in the whole model at the
/// reference point) that `--linear` leaves out of the correction.
fn shown_but_left_out(
    spec: &Spec<'_>,
    reference: &[AxisFit; 3],
    alpha: f64,
    notes: &mut Vec<String>,
) {
    for (i, axis) in reference.iter().enumerate() {
        let Some(full) = &axis.full else { continue };
        let shown: Vec<String> = full
            .names
            .iter()
            .zip(&full.p_values)
            .filter(|(n, p)| n.starts_with(lever::SENSED) && **p < alpha)
            .map(|(n, p)| format!("{n} (p = {p:.2e})"))
            .collect();
        if !shown.is_empty() {
            notes.push(format!(
                "{}: --linear leaves out {}, which the data show: the correction does not apply it, and its estimate is in the stated 1-sigma",
                spec.outputs[i],
                shown.join(", ")
            ));
        }
    }
}

/// The fit of axis `i`'s model before its terms were chosen (`all`), at the table point `t`,
/// whose covariance states the error of the chosen fit `chosen` (`AxisFit::stated_fit`);
/// `None` when it cannot be fitted there. When the correction leaves out terms the data may
/// show (`Spec::stated_nonlinear`), the covariance widens by `d d'`, `d` the chosen
/// coefficients (zero for a term left out) less the whole model's: the mean square error of
/// the chosen model's estimate, `C_R + A (C_DD + b b') A'` over the terms kept and
/// `C_DD + b b'` over those left out, `A` their alias and `b` their estimate.
#[allow(clippy::too_many_arguments)]
fn stated_fit(
    spec: &Spec<'_>,
    all: &Formula,
    t: &Table,
    i: usize,
    estimable: Option<&[[bool; 3]; 3]>,
    opts: &Options,
    where_: &str,
    chosen: &AxisFit,
) -> Option<stats::Fit> {
    let whole = Spec {
        nonlinear: spec.nonlinear || spec.stated_nonlinear,
        ..*spec
    };
    let lever = estimable.map(|_| lever_terms(all, i));
    let mut fit = fit_axis(&whole, all, t, i, lever.as_ref(), opts, (where_, None))
        .ok()?
        .fit;
    if spec.stated_nonlinear {
        let d = nalgebra::DVector::from_iterator(
            fit.names.len(),
            fit.names
                .iter()
                .zip(&fit.coefficients)
                .map(|(n, b)| chosen.coef(n) - b),
        );
        fit.covariance += &d * d.transpose();
    }
    Some(fit)
}

pub(super) fn s_of(spec: &Spec<'_>, f: &[AxisFit; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| f[i].coef(spec.inputs[j]))
}

pub(super) fn b_of(f: &[AxisFit; 3]) -> [f64; 3] {
    [f[0].coef("1"), f[1].coef("1"), f[2].coef("1")]
}

pub(super) fn lever_of(f: &[AxisFit; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|k| f[i].coef(&lever::column(i, k))))
}
