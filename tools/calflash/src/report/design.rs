//! Reports of `calflash design`: plans side by side, the optimum against the usual plans, and
//! predicted (and simulated) precision.

use super::Error;
use std::fmt::Write as _;
use std::path::Path;

use serde_json::{Value, json};

use super::page::esc;
use super::plot::{Figure, Series, figure};
use super::terminal::num;
use crate::design::criteria::{self, Criteria};
use crate::design::exchange::Criterion;
use crate::design::models::Block;
use crate::design::points::{self, Points};
use crate::design::predict::{Expected, MonteCarlo};

/// One plan's evaluation.
#[derive(Debug, Clone)]
pub struct PlanResult {
    /// Its name (file or items).
    pub name: String,
    /// Its points.
    pub points: Points,
    /// Criteria per block.
    pub criteria: Vec<Criteria>,
    /// Standard errors per block without and with the fixture's orientation error.
    pub fixture: Option<Vec<(Vec<f64>, Vec<f64>)>>,
}

fn d_eff(a: &Criteria, best: f64) -> f64 {
    a.d / best
}

/// One row of the comparison: its label and one cell per plan.
struct Row {
    label: String,
    cells: Vec<String>,
}

/// The comparison's rows for block `b`.
fn rows(block: &Block, b: usize, plans: &[PlanResult]) -> Vec<Row> {
    let p = block.formula.width();
    let best_d = plans
        .iter()
        .map(|pl| pl.criteria[b].d)
        .fold(0.0f64, f64::max);
    let mut out = Vec::new();
    let mut row = |label: &str, f: &dyn Fn(&PlanResult) -> String| {
        out.push(Row {
            label: label.to_string(),
            cells: plans.iter().map(f).collect(),
        });
    };
    row("observations n", &|pl| pl.criteria[b].n.to_string());
    row("distinct points", &|pl| {
        points::tally(&pl.points).len().to_string()
    });
    row("IEEE 4(p+2)", &|_| (4 * (p + 2)).to_string());
    row("residual dof n - p", &|pl| {
        (pl.criteria[b].n as i64 - p as i64).to_string()
    });
    row("D  det(M)^(1/p)", &|pl| num(pl.criteria[b].d));
    row("D-efficiency vs best", &|pl| {
        format!("{:.4}", d_eff(&pl.criteria[b], best_d))
    });
    row("A  trace(M^-1)/p", &|pl| num(pl.criteria[b].a));
    row("E  min eig(M)", &|pl| num(pl.criteria[b].e));
    row("G  max n x'(X'X)^-1 x", &|pl| num(pl.criteria[b].g));
    row("G-efficiency p / G", &|pl| {
        format!("{:.4}", p as f64 / pl.criteria[b].g)
    });
    row("I  mean n x'(X'X)^-1 x", &|pl| num(pl.criteria[b].i));
    row("condition number", &|pl| {
        num(pl.criteria[b].condition_number)
    });
    row("largest VIF", &|pl| {
        num(pl.criteria[b]
            .vif
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(*v)))
    });
    let names = block.formula.term_names();
    for (k, name) in names.iter().enumerate() {
        row(&format!("sd({name}) / sigma"), &|pl| {
            num(pl.criteria[b].unscaled_covariance[(k, k)].sqrt())
        });
    }
    if plans.iter().any(|pl| pl.fixture.is_some()) {
        for (k, name) in names.iter().enumerate() {
            row(&format!("sd({name}) + fixture"), &|pl| {
                pl.fixture.as_ref().map_or("-".into(), |f| {
                    format!("{} ({})", num(f[b].1[k]), num(f[b].0[k]))
                })
            });
        }
    }
    out
}

/// The comparison table, as text.
fn table(blocks: &[Block], plans: &[PlanResult]) -> String {
    let mut s = String::new();
    let w = plans
        .iter()
        .map(|p| p.name.len())
        .max()
        .unwrap_or(8)
        .clamp(10, 28);
    for (b, block) in blocks.iter().enumerate() {
        let p = block.formula.width();
        if blocks.len() > 1 {
            let _ = writeln!(
                s,
                "  axis {}: {} ({p} parameters)",
                block.label,
                block.formula.term_names().join(" + ")
            );
        }
        let _ = write!(s, "  {:<26}", "");
        for pl in plans {
            let _ = write!(s, " {:>w$}", truncate(&pl.name, w));
        }
        s.push('\n');
        for r in rows(block, b, plans) {
            let _ = write!(s, "  {:<26}", r.label);
            for c in &r.cells {
                let _ = write!(s, " {c:>w$}");
            }
            s.push('\n');
        }
        if let Some(advice) = recommend(block, b, plans) {
            let _ = writeln!(s, "  {advice}");
        }
    }
    s
}

/// Which plan to choose for block `b`: the lowest mean prediction variance over the operating
/// region among the plans with at least the IEEE count of observations (`4 (p + 2)`, so that
/// the residuals can test the model), and the most efficient per observation when that is
/// another plan. `None` with a single plan.
fn recommend(block: &Block, b: usize, plans: &[PlanResult]) -> Option<String> {
    if plans.len() < 2 {
        return None;
    }
    let p = block.formula.width();
    let ieee = 4 * (p + 2);
    // Mean prediction variance over the region, in sigma^2: I / n.
    let mean = |pl: &PlanResult| pl.criteria[b].i / pl.criteria[b].n.max(1) as f64;
    let lowest = |it: &mut dyn Iterator<Item = &PlanResult>, f: &dyn Fn(&PlanResult) -> f64| {
        it.filter(|pl| f(pl).is_finite())
            .min_by(|x, y| f(x).total_cmp(&f(y)))
            .map(|pl| pl.name.clone())
    };
    let enough = lowest(
        &mut plans.iter().filter(|pl| pl.criteria[b].n >= ieee),
        &mean,
    );
    let any = lowest(&mut plans.iter(), &mean)?;
    let efficient = lowest(&mut plans.iter(), &|pl: &PlanResult| pl.criteria[b].i)?;
    let under: Vec<&str> = plans
        .iter()
        .filter(|pl| pl.criteria[b].n < ieee)
        .map(|pl| pl.name.as_str())
        .collect();
    let mut s = match &enough {
        Some(best) => format!(
            "recommended: {best} (the lowest mean prediction variance over the operating region, with at least the IEEE {ieee} observations)"
        ),
        None => format!(
            "no plan has the IEEE {ieee} observations this model needs for its residuals to test it; the lowest mean prediction variance is {any}'s"
        ),
    };
    if enough.as_ref().is_some_and(|b| *b != any) {
        let _ = write!(
            s,
            "; {any} predicts better but has fewer than {ieee} observations"
        );
    }
    if efficient != *enough.as_ref().unwrap_or(&any) {
        let _ = write!(
            s,
            "; per observation {efficient} is the most efficient (lowest I): at equal cost, its points repeated"
        );
    }
    if !under.is_empty() {
        let _ = write!(s, "; under the IEEE count: {}", under.join(", "));
    }
    Some(s)
}

fn truncate(s: &str, w: usize) -> String {
    if s.chars().count() <= w {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(w - 1).collect::<String>())
    }
}

/// `design evaluate`'s terminal text.
#[must_use]
pub fn evaluate_text(
    model: &str,
    blocks: &[Block],
    plans: &[PlanResult],
    fixture: Option<f64>,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calflash design evaluate  model {model}: {}",
        blocks
            .iter()
            .map(|b| b.formula.term_names().join(" + "))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    let _ = writeln!(
        s,
        "  M = X'X / n; standard errors are sigma x sd/sigma; G and I over the operating region (n x'(X'X)^-1 x is at least p)"
    );
    if let Some(deg) = fixture {
        let _ = writeln!(
            s,
            "  fixture orientation error {deg} deg (1 sigma per axis): standard errors with it (without it in brackets), in counts"
        );
    }
    s.push_str(&table(blocks, plans));
    s
}

/// What a spin-rig plan tells of the lever arms: which components it estimates (the others
/// need the rate table's 45-degree fixture) and, with the noise (counts) over the scale
/// (counts per m/s^2), each one's standard error and what it leaves at a 300 Hz roll.
#[must_use]
pub fn lever_text(
    plan: &PlanResult,
    blocks: &[Block],
    estimable: &[[bool; 3]; 3],
    noise_over_scale: Option<f64>,
) -> String {
    let axes = ["x", "y", "z"];
    let name = |i: usize, k: usize| format!("r_{}{}", axes[i], axes[k]);
    let (mut yes, mut no) = (Vec::new(), Vec::new());
    for (i, row) in estimable.iter().enumerate() {
        for (k, ok) in row.iter().enumerate() {
            if *ok {
                yes.push(name(i, k));
            } else {
                no.push(name(i, k));
            }
        }
    }
    let mut s = String::new();
    let _ = write!(
        s,
        "  lever arms, plan {}: estimates {} of the nine components",
        plan.name,
        yes.len()
    );
    if no.is_empty() {
        let _ = writeln!(s, " (spins about the axes and the 45-degree diagonals)");
    } else {
        let _ = writeln!(
            s,
            "; {} cannot be (component k of axis i needs a spin with rate along both i and k, or an angular acceleration about the third axis): a diagonal:LO:HI:N item, the rate table's 45-degree fixture, estimates them",
            no.join(", ")
        );
    }
    if let Some(per) = noise_over_scale {
        let roll = (2.0 * std::f64::consts::PI * 300.0).powi(2);
        for ((i, b), c) in blocks.iter().enumerate().zip(&plan.criteria) {
            for (j, t) in b.formula.term_names().iter().enumerate() {
                let Some(k) = (0..3).find(|k| *t == crate::sensor::lever::column(i, *k)) else {
                    continue;
                };
                let sd = per * c.unscaled_covariance[(j, j)].sqrt();
                let _ = writeln!(
                    s,
                    "    sd({}) {:.3} um: up to {:.3} m/s^2 at a 300 Hz roll",
                    name(i, k),
                    sd * 1e6,
                    sd * roll
                );
            }
        }
    }
    s
}

/// `design evaluate`'s JSON.
#[must_use]
pub fn evaluate_json(blocks: &[Block], plans: &[PlanResult]) -> Value {
    json!({
        "schema": "calflash.design/1",
        "plans": plans.iter().map(|pl| json!({
            "name": pl.name,
            "variables": pl.points.names,
            "points": pl.points.rows,
            "blocks": blocks.iter().zip(&pl.criteria).map(|(b, c)| json!({
                "label": b.label,
                "terms": b.formula.term_names(),
                "criteria": c,
                "ieee_count": 4 * (c.p + 2),
                "unscaled_covariance": (0..c.p).map(|i| (0..c.p).map(|j| c.unscaled_covariance[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "fixture_std_errors": pl.fixture.as_ref().map(|f| f.iter().map(|(a, b)| json!({"without": a, "with": b})).collect::<Vec<_>>()),
        })).collect::<Vec<_>>(),
    })
}

/// Block `b`'s comparison as an HTML table, its recommendation in a box above it, the plans
/// under the IEEE count marked.
fn html_table(h: &mut String, block: &Block, b: usize, plans: &[PlanResult], titled: bool) {
    let p = block.formula.width();
    let ieee = 4 * (p + 2);
    if titled {
        let _ = writeln!(h, "<h2>Axis {}</h2>", esc(&block.label));
    }
    let _ = writeln!(
        h,
        "<p>{} ({p} parameters)</p>",
        esc(&block.formula.term_names().join(" + "))
    );
    if let Some(advice) = recommend(block, b, plans) {
        let class = if plans.iter().any(|pl| pl.criteria[b].n >= ieee) {
            "accept"
        } else {
            "review"
        };
        let _ = writeln!(h, "<p class=\"verdict {class}\">{}</p>", esc(&advice));
    }
    h.push_str("<table>\n<tr><th></th>");
    for pl in plans {
        let under = pl.criteria[b].n < ieee;
        let _ = write!(
            h,
            "<th{}>{}{}</th>",
            if under { " class=\"review\"" } else { "" },
            esc(&pl.name),
            if under { " (under the IEEE count)" } else { "" }
        );
    }
    h.push_str("</tr>\n");
    for r in rows(block, b, plans) {
        let _ = write!(h, "<tr><td>{}</td>", esc(&r.label));
        for (c, pl) in r.cells.iter().zip(plans) {
            let under = r.label == "observations n" && pl.criteria[b].n < ieee;
            let _ = write!(
                h,
                "<td{}>{}</td>",
                if under { " class=\"review\"" } else { "" },
                esc(c)
            );
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}

/// `design evaluate`'s HTML: the table and, with a curve variable, the prediction variance over
/// it for every plan with the plan's points marked.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn evaluate_html(
    model: &str,
    blocks: &[Block],
    plans: &[PlanResult],
    curve: Option<&Points>,
) -> Result<String, Error> {
    let mut h = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Test plans compared: model {0}</title>\n<style>{1}</style>\n</head>\n<body>\n<h1>Test plans compared: model {0}</h1>\n<p>{2} plan(s). M = X'X / n; a standard error is sigma times its sd/sigma; G and I are over the operating region (n x'(X'X)^-1 x is at least p, the number of parameters). A plan with fewer observations than the IEEE count 4(p+2) is marked: its residuals cannot test the model.</p>\n",
        esc(model),
        super::page::STYLE,
        plans.len()
    );
    for (b, block) in blocks.iter().enumerate() {
        html_table(&mut h, block, b, plans, blocks.len() > 1);
    }
    if let Some(c) = curve {
        let var = c.names[0].clone();
        for (b, block) in blocks.iter().enumerate() {
            let rows = c.model_rows(&block.formula);
            let series_pts: Vec<Vec<(f64, f64)>> = plans
                .iter()
                .map(|pl| {
                    let pv = criteria::prediction_variance(
                        &pl.criteria[b].unscaled_covariance,
                        1,
                        &rows,
                    );
                    c.rows.iter().zip(pv).map(|(r, v)| (r[0], v)).collect()
                })
                .collect();
            let marks: Vec<Vec<(f64, f64)>> = plans
                .iter()
                .map(|pl| {
                    let pv = criteria::prediction_variance(
                        &pl.criteria[b].unscaled_covariance,
                        1,
                        &pl.points.model_rows(&block.formula),
                    );
                    (0..pl.points.rows.len())
                        .map(|r| (pl.points.value(r, &var), pv[r]))
                        .collect()
                })
                .collect();
            let lo = plans
                .iter()
                .flat_map(|pl| (0..pl.points.rows.len()).map(|r| pl.points.value(r, &var)))
                .fold(f64::INFINITY, f64::min);
            let hi = plans
                .iter()
                .flat_map(|pl| (0..pl.points.rows.len()).map(|r| pl.points.value(r, &var)))
                .fold(f64::NEG_INFINITY, f64::max);
            let point_names: Vec<String> = plans
                .iter()
                .map(|pl| format!("{}: its points", pl.name))
                .collect();
            let mut series = Vec::new();
            for (k, pl) in plans.iter().enumerate() {
                series.push(Series::curve(&pl.name, &series_pts[k], k));
                series.push(Series::dots(&point_names[k], &marks[k], k));
            }
            let title = format!(
                "Prediction variance / sigma^2 over {var}{}",
                if blocks.len() > 1 {
                    format!(", axis {}", block.label)
                } else {
                    String::new()
                }
            );
            let fig = Figure {
                title: &title,
                x: &var,
                y: "x'(X'X)^-1 x",
                series,
                bands: if lo.is_finite() {
                    vec![(lo, hi)]
                } else {
                    Vec::new()
                },
                band_label: "range of the plans' points",
                zero_line: true,
                x_names: None,
            };
            figure(&mut h, &fig)?;
        }
    }
    h.push_str("</body>\n</html>\n");
    Ok(super::page::with_contents(&h))
}

/// What a search did, for the summary.
#[derive(Debug, Clone, Copy)]
pub struct Search<'a> {
    /// The criterion.
    pub criterion: Criterion,
    /// Observations.
    pub n: usize,
    /// What was searched (candidates, factors).
    pub over: &'a str,
    /// Restarts that reached the best value.
    pub hits: usize,
    /// How long it took.
    pub took: std::time::Duration,
    /// The plan file written.
    pub output: &'a Path,
}

/// `design optimize`'s terminal text.
#[must_use]
pub fn optimize_text(
    head: &Search<'_>,
    plan: &Points,
    blocks: &[Block],
    rows: &[PlanResult],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calflash design optimize  {:?}-optimal plan of {} observations over {}; {} restart(s) reached the best value; {:.2} s",
        head.criterion,
        head.n,
        head.over,
        head.hits,
        head.took.as_secs_f64()
    );
    // The distinct points as the model sees them.
    let vars: Vec<String> = crate::design::models::variables(blocks);
    let seen = Points {
        names: vars.clone(),
        rows: (0..plan.rows.len())
            .map(|r| vars.iter().map(|v| plan.value(r, v)).collect())
            .collect(),
    };
    for (row, count) in points::tally(&seen) {
        let _ = writeln!(
            s,
            "    {count:>4} x  {}",
            vars.iter()
                .zip(&row)
                .map(|(n, v)| format!("{n} = {}", num(*v)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(
        s,
        "  written to {} (for `calflash simulate --plan-file` and a test station)",
        head.output.display()
    );
    let _ = writeln!(
        s,
        "  against other plans (efficiency of each against the best listed):"
    );
    s.push_str(&table(blocks, rows));
    s
}

/// Rows of `design predict`: per block, the expected errors and the Monte Carlo's.
pub type Predicted = (Block, Expected, Option<MonteCarlo>);

fn ratio(a: f64, b: f64) -> String {
    format!("{:+.1} %", 100.0 * (a / b - 1.0))
}

/// `design predict`'s terminal text.
#[must_use]
pub fn predict_text(plan: &str, noise: f64, at: &Points, results: &[Predicted]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calflash design predict  plan {plan}, noise {noise} counts (1 sigma)"
    );
    for (b, e, mc) in results {
        if results.len() > 1 {
            let _ = writeln!(s, "  axis {}", b.label);
        }
        let _ = writeln!(
            s,
            "    {:<28} {:>14} {:>14} {:>10}",
            "standard error of", "expected", "simulated", "difference"
        );
        for (k, name) in b.formula.term_names().iter().enumerate() {
            let sim = mc.as_ref().map(|m| m.terms[k]);
            let _ = writeln!(
                s,
                "    {name:<28} {:>14} {:>14} {:>10}",
                num(e.terms[k]),
                sim.map_or("-".into(), num),
                sim.map_or(String::new(), |v| ratio(v, e.terms[k]))
            );
        }
        for (r, row) in at.rows.iter().enumerate() {
            let label = at
                .names
                .iter()
                .zip(row)
                .map(|(n, v)| format!("{n}={}", num(*v)))
                .collect::<Vec<_>>()
                .join(",");
            let sim = mc.as_ref().map(|m| m.at[r]);
            let _ = writeln!(
                s,
                "    {:<28} {:>14} {:>14} {:>10}",
                format!("prediction at {label}"),
                num(e.at[r]),
                sim.map_or("-".into(), num),
                sim.map_or(String::new(), |v| ratio(v, e.at[r]))
            );
        }
        if let Some(m) = mc {
            let _ = writeln!(
                s,
                "    simulated: {} calibrations of the simulator's unit through the plan, the model fitted each time",
                m.runs
            );
        }
    }
    s
}

/// `design predict`'s JSON.
#[must_use]
pub fn predict_json(plan: &str, noise: f64, at: &Points, results: &[Predicted]) -> Value {
    json!({
        "schema": "calflash.design-predict/1",
        "plan": plan,
        "noise": noise,
        "operating_points": {"variables": at.names, "rows": at.rows},
        "blocks": results.iter().map(|(b, e, mc)| json!({"label": b.label, "terms": b.formula.term_names(), "expected": e, "monte_carlo": mc})).collect::<Vec<_>>(),
    })
}
