//! The single-axis workflow's decisions about the model: which terms the data support, and
//! whether an asymmetry (a kink at the breakpoint) or a hysteresis (an offset by sweep
//! direction) is there, each by a partial F-test.

use super::super::{AxisFit, Decision, Options, WorkflowError, thermal};
use super::{KINK, SingleError, fit_axis};
use crate::columns as col;
use crate::formula::{self, Formula};
use crate::obs::Table;
use crate::stats::{self, select};

/// Terms of `formula` that are not significant, dropped one at a time (never `1` or `input`,
/// never a term another kept term contains), with the reasons.
pub(super) fn select_terms(
    formula: &Formula,
    table: &Table,
    alpha: f64,
    notes: &mut Vec<String>,
) -> Result<Formula, WorkflowError> {
    let d = formula.design(table);
    let opts = stats::Options {
        alpha,
        ..stats::Options::default()
    };
    let e = select::backward(
        &d.x,
        &d.y,
        &d.names,
        d.intercept,
        &opts,
        alpha,
        |names, j| {
            let name = &names[j];
            if name == "1" || name == col::INPUT || thermal::is_thermal(name) {
                return false;
            }
            let Some(t) = formula.terms.iter().find(|t| &t.name() == name) else {
                return false;
            };
            !formula
                .terms
                .iter()
                .filter(|o| names.contains(&o.name()))
                .any(|o| Formula::contains(o, t))
        },
    )
    .map_err(WorkflowError::Selection)?;
    let mut out = formula.clone();
    for s in &e.steps {
        notes.push(format!(
            "dropped {}: not significant (p = {:.3} > {alpha})",
            s.dropped, s.p_value
        ));
        out = out.without(&s.dropped);
    }
    Ok(out)
}

/// The Chow test of separate fits of `model` below and above the breakpoint, in words (empty
/// when a side has too few observations for its own fit).
fn chow(
    model: &Formula,
    t: &Table,
    bp: f64,
    alpha: f64,
    path: &std::path::Path,
    where_: &str,
) -> String {
    let input = t.column(col::INPUT).unwrap_or_default();
    let below: Vec<usize> = (0..t.len()).filter(|&i| input[i] < bp).collect();
    let above: Vec<usize> = (0..t.len()).filter(|&i| input[i] >= bp).collect();
    let k = model.width();
    if below.len() <= k || above.len() <= k {
        return String::new();
    }
    let fits = (
        fit_axis(model, t, alpha, path, where_),
        fit_axis(model, &t.select(&below), alpha, path, where_),
        fit_axis(model, &t.select(&above), alpha, path, where_),
    );
    let (Ok(pooled), Ok(lo), Ok(hi)) = fits else {
        return String::new();
    };
    let separate = lo.fit.rss + hi.fit.rss;
    let dof = t.len() - 2 * k;
    let f = (pooled.fit.rss - separate) / k as f64 / (separate / dof as f64);
    let p = stats::dist::f_upper(f, k as f64, dof as f64);
    format!(
        "; Chow test of separate fits below and above: F = {f:.3} on ({k}, {dof}) dof, p = {p:.3e}; slopes {:.6e} below, {:.6e} above",
        lo.coef(col::INPUT),
        hi.coef(col::INPUT)
    )
}

pub(super) type Decide<'a> = dyn Fn(&Formula) -> Result<AxisFit, WorkflowError> + 'a;

/// Asymmetry: does a kink at the breakpoint improve the model (`decide` fits a model where the
/// decisions are taken)? The decision and the model to go on with; `None` when a side has too
/// few inputs (an error if asymmetry was asked for).
pub(super) fn asymmetry(
    model: &Formula,
    input: &[f64],
    opts: &Options,
    decide: &Decide<'_>,
    (ref_table, ref_where): (&Table, &str),
) -> Result<Option<(Decision, Formula)>, WorkflowError> {
    let path = &opts.file;
    let bp = opts.breakpoint;
    let with_kink = {
        let mut m = model.clone();
        m.terms.push(formula::Term::var(KINK));
        m
    };
    let below = input.iter().filter(|x| **x < bp).count();
    let above = input.len() - below;
    if below < 2 || above < 2 {
        if opts.asymmetry == Some(true) {
            return Err(SingleError::Asymmetry {
                path: path.clone(),
                breakpoint: bp,
                below,
                above,
            }
            .into());
        }
        return Ok(None);
    }
    let reduced = decide(model)?;
    // A kink the plan cannot estimate (one level on a side: the kink is then a constant, or a
    // combination of the model's terms) is not tested, unless it was asked for.
    let full = match decide(&with_kink) {
        Ok(f) => f,
        Err(WorkflowError::Fit { .. }) if opts.asymmetry != Some(true) => return Ok(None),
        Err(e) => return Err(e),
    };
    let test = select::partial_f(&full.fit, &reduced.fit);
    let k1 = full.coef(col::INPUT);
    let ca = full.coef(KINK);
    let kept = opts.asymmetry.unwrap_or(test.p < opts.alpha);
    let scale = reduced.coef(col::INPUT);
    let side = |below: bool| -> Vec<(f64, f64)> {
        reduced
            .input
            .iter()
            .zip(&reduced.fit.residuals)
            .filter(|(x, _)| (**x < bp) == below)
            .map(|(x, e)| (*x, *e / scale))
            .collect()
    };
    let decision = Decision {
        figure: vec![
            (format!("below {bp}"), side(true)),
            (format!("above {bp}"), side(false)),
        ],
        name: format!("asymmetry about {bp}"),
        test,
        detail: format!(
            "scale factor {:.6e} above and {:.6e} below the breakpoint ({:+.3e} relative){}",
            k1 + ca,
            k1 - ca,
            2.0 * ca / k1,
            chow(model, ref_table, bp, opts.alpha, path, ref_where)
        ),
        kept,
    };
    Ok(Some((
        decision,
        if kept { with_kink } else { model.clone() },
    )))
}

/// Hysteresis: an offset by sweep direction (reported; the device cannot know the direction).
pub(super) fn hysteresis(model: &Formula, decide: &Decide<'_>) -> Result<Decision, WorkflowError> {
    let mut m = model.clone();
    m.terms.push(formula::Term::var(col::DIR));
    let full = decide(&m)?;
    let reduced = decide(model)?;
    let test = select::partial_f(&full.fit, &reduced.fit);
    let h = full.coef(col::DIR);
    let se = full.fit.std_errors[full.index(col::DIR).unwrap_or(0)];
    let scale = reduced.coef(col::INPUT);
    let in_input = |v: Vec<(f64, f64)>| v.into_iter().map(|(x, e)| (x, e / scale)).collect();
    let figure = super::super::hysteresis::by_direction(&reduced)
        .map(|(up, down)| {
            vec![
                ("ascending".to_string(), in_input(up)),
                ("descending".to_string(), in_input(down)),
            ]
        })
        .unwrap_or_default();
    Ok(Decision {
        figure,
        name: "hysteresis".into(),
        test,
        detail: format!(
            "output {:+.4} counts ascending, {:+.4} descending (+-{:.2}); {:.3e} input units",
            h,
            -h,
            se,
            h / full.coef(col::INPUT)
        ),
        kept: false,
    })
}
