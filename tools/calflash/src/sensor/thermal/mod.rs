//! Continuous temperature models: every coefficient of a sensor's model as a polynomial in the
//! temperature, fitted in one regression with all the observations wherever their
//! temperatures fall (a chamber ramp, a unit warming up, or a few exact setpoints, which are a
//! special case of the same thing).
//!
//! The scaled temperature is `x = (temp - t0) / half`, from -1 to 1 over the calibrated range,
//! and a coefficient is a series of Legendre polynomials in it,
//! `c(T) = c0 + c1 P1(x) + ... + ck Pk(x)`: the model gains the columns `temp_leg1 ...
//! temp_legk` (`P_i(x)`) and the terms `term:temp_leg_i`. Legendre polynomials are orthogonal
//! over an even ramp, so the estimate of one order hardly moves when the next is tested (with
//! powers of `x`, `x` and `x^3` are 92 % correlated and a test that keeps `x^3` out biases the
//! stated error of `x`'s coefficient), and the fit stays well conditioned up to order 9. Each
//! coefficient's order `k` is chosen from the data by forward partial F tests (one or two
//! orders at a time, so that an odd curve such as a tanh is not stopped by its missing even
//! order), at a Bonferroni level over the candidates of each step, up to what the spread of
//! the temperatures supports. The model at one temperature is the linear combination of the
//! coefficients `J(T) b`, with covariance `J C J'` ([`crate::stats::Fit::combined`]).

pub mod data;
pub mod device;

pub use data::{MIN_SPAN, PLAUSIBLE, Support, check, density_weights, lag};

use nalgebra::DMatrix;

use super::{AxisFit, WorkflowError};
use crate::formula::{Formula, INTERCEPT, Term};
use crate::obs::Table;
use crate::stats::select;

/// The scaled supply voltage column, -1 to 1 over the voltages observed: the bias and the
/// scale factor of a continuous model are linear in it (`1 ... + volt_leg1` and
/// `input:volt_leg1`), so the device's blend between the two ends is exact.
pub const VOLT: &str = "volt_leg1";

/// What `--thermal-order` did not do, when it was given and is not used: the observations hold
/// one temperature, or the temperatures are a table of setpoints fitted point by point.
#[must_use]
pub fn unused_order(
    order: Option<u32>,
    continuous: bool,
    temperature_varies: bool,
) -> Option<String> {
    let order = order?;
    if !temperature_varies {
        return Some(format!(
            "--thermal-order {order} is not used: the observations hold one temperature"
        ));
    }
    (!continuous).then(|| {
        format!(
            "--thermal-order {order} is not used: the temperatures are a table of setpoints, each fitted on its own (--thermal continuous fits one model over them)"
        )
    })
}

/// `term:volt_leg1`.
#[must_use]
pub fn volt_term(term: &str) -> String {
    Term::var(term).times(VOLT, 1).name()
}

/// The prefix of the temperature columns: `temp_leg3` is `P3(x)`.
pub const PREFIX: &str = "temp_leg";

/// The column of the Legendre polynomial of order `k` in the scaled temperature.
#[must_use]
pub fn column(k: u32) -> String {
    format!("{PREFIX}{k}")
}

/// `P_k(x)` by Bonnet's recurrence.
#[must_use]
pub fn legendre(k: u32, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if k == 0 {
        return p0;
    }
    for n in 1..k {
        let n = f64::from(n);
        let p2 = ((2.0 * n + 1.0) * x * p1 - n * p0) / (n + 1.0);
        p0 = p1;
        p1 = p2;
    }
    p1
}
/// The highest order of a coefficient's temperature polynomial.
pub const MAX_ORDER: u32 = 9;
/// The calibrated temperature range and the scaled temperature `x` over it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Lowest temperature, C.
    pub lo: f64,
    /// Highest temperature, C.
    pub hi: f64,
}

impl Scale {
    /// The middle of the range, `t0`.
    #[must_use]
    pub fn center(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }

    /// Half the span.
    #[must_use]
    pub fn half(&self) -> f64 {
        0.5 * (self.hi - self.lo)
    }

    /// `x` at temperature `t`.
    #[must_use]
    pub fn x(&self, t: f64) -> f64 {
        (t - self.center()) / self.half()
    }
}

/// Readies `table` for a continuous temperature model: checks its temperature column
/// ([`check`]), adds the temperature columns (and the scaled supply voltage when it varies),
/// and says in `notes` what it found (the range, the reading step, the lag behind the chamber,
/// the weights, the voltage span).
///
/// # Errors
/// [`check`]'s, and supply voltages that are not ([`data::supply`]).
pub fn prepare(table: &mut Table, notes: &mut Vec<String>) -> Result<Prepared, WorkflowError> {
    use crate::columns as col;
    let volts = match table.column(col::VOLT) {
        Some(v) if v.iter().any(|x| *x != v[0]) => {
            let (lo, hi) = data::supply(table)?;
            let scale = Scale { lo, hi };
            let y: Vec<f64> = v.iter().map(|x| scale.x(*x)).collect();
            table.push_column(VOLT, y);
            notes.push(format!(
                "the supply voltage varies from {lo} to {hi} V: the bias and the scale factor are linear in it ({VOLT} = (volt - {:.3}) / {:.3}), and the device blends between the two ends",
                scale.center(),
                scale.half()
            ));
            Some(scale)
        }
        _ => None,
    };
    let s = check(table, col::TEMP)?;
    notes.push(format!(
        "continuous temperature model over {:.1} to {:.1} C ({} distinct temperatures{}): every coefficient is a series of Legendre polynomials temp_legK of x = (temp - {:.2}) / {:.2}",
        s.scale.lo,
        s.scale.hi,
        s.distinct,
        s.quantum
            .map_or(String::new(), |q| format!(", read in steps of {q} C")),
        s.scale.center(),
        s.scale.half()
    ));
    push_columns(table, col::TEMP, &s.scale, s.max_order);
    if let Some(lag) = lag(table) {
        notes.push(lag);
    }
    // A ramp's density is evened out; a few setpoints are what they are.
    let weights = if s.distinct >= 10 {
        density_weights(table.column(col::TEMP).unwrap_or_default(), &s.scale)
    } else {
        None
    };
    if let Some(w) = &weights {
        let (lo, hi) = w
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
        notes.push(format!(
            "the observations crowd in part of the temperature range: the temperature model is fitted with weights that even out their density ({lo:.2} to {hi:.2}), its covariance the sandwich estimate"
        ));
    }
    Ok(Prepared {
        support: s,
        weights,
        volts,
    })
}

/// What [`prepare`] found.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// What the temperatures support.
    pub support: Support,
    /// Weights that even out a crowded ramp.
    pub weights: Option<Vec<f64>>,
    /// The supply voltage's span, when it varies.
    pub volts: Option<Scale>,
}

/// Adds the temperature columns `P_1(x) ... P_max(x)` of `table`'s column `temp`.
pub fn push_columns(table: &mut Table, temp: &str, scale: &Scale, max: u32) {
    let x: Vec<f64> = table
        .column(temp)
        .unwrap_or_default()
        .iter()
        .map(|t| scale.x(*t))
        .collect();
    for k in 1..=max {
        table.push_column(&column(k), x.iter().map(|v| legendre(k, *v)).collect());
    }
}

/// Term `j` of `base` (in `term_names` order) times `P_k`; `k` at least 1.
fn thermal_term(base: &Formula, j: usize, k: u32) -> Term {
    let shift = usize::from(base.intercept);
    if base.intercept && j == 0 {
        Term::var(&column(k))
    } else {
        base.terms[j - shift].times(&column(k), 1)
    }
}

/// `base` with `term:temp_leg1 ... term:temp_legk` for each term's order `k` (`orders` in
/// `term_names` order): the base terms first, so their coefficients are the values at `t0`.
#[must_use]
pub fn expand(base: &Formula, orders: &[u32]) -> Formula {
    let mut f = base.clone();
    for (j, &k) in orders.iter().enumerate() {
        for i in 1..=k {
            f.terms.push(thermal_term(base, j, i));
        }
    }
    f
}

/// `formula` without its temperature terms.
#[must_use]
pub fn base_of(formula: &Formula) -> Formula {
    let mut f = formula.clone();
    f.terms.retain(|t| !is_thermal(&t.name()));
    f
}

/// Whether a term name is a temperature term.
#[must_use]
pub fn is_thermal(name: &str) -> bool {
    name.split(':').any(|f| {
        f.strip_prefix(PREFIX)
            .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// A model whose coefficients vary with temperature, fitted over every observation.
#[derive(Debug, Clone)]
pub struct ThermalFit {
    /// The model at one temperature.
    pub base: Formula,
    /// Each coefficient's order (`base.term_names()` order).
    pub orders: Vec<u32>,
    /// The calibrated range.
    pub scale: Scale,
    /// The fit of the expanded model.
    pub fit: AxisFit,
    /// How each order was chosen, in words.
    pub reasons: Vec<String>,
    /// The observations' temperatures, in the fit's order.
    pub temps: Vec<f64>,
}

impl ThermalFit {
    /// `J(T)`: row `r` gives base coefficient `r` at temperature `t` from the expanded ones.
    fn jacobian(&self, t: f64) -> DMatrix<f64> {
        let names = self.base.term_names();
        let x = self.scale.x(t);
        let mut j = DMatrix::zeros(names.len(), self.fit.fit.p);
        for (r, name) in names.iter().enumerate() {
            if let Some(c) = self.fit.index(name) {
                j[(r, c)] = 1.0;
            }
            for k in 1..=self.orders[r] {
                let n = thermal_term(&self.base, r, k).name();
                if let Some(c) = self.fit.index(&n) {
                    j[(r, c)] = legendre(k, x);
                }
            }
        }
        j
    }

    /// The model at temperature `t`: the base model's coefficients there, with their
    /// covariance and tests (the residuals and influence stay the whole fit's).
    #[must_use]
    pub fn at(&self, t: f64) -> AxisFit {
        let j = self.jacobian(t);
        AxisFit {
            formula: self.base.clone(),
            fit: self.fit.fit.combined(self.base.term_names(), &j),
            full: None,
            ..self.fit.clone()
        }
    }

    /// The coefficients at `t` and their covariance, without the rest of a fit (cheap).
    #[must_use]
    pub fn coefficients_at(&self, t: f64) -> (Vec<f64>, DMatrix<f64>) {
        let j = self.jacobian(t);
        let b = nalgebra::DVector::from_column_slice(&self.fit.fit.coefficients);
        let c = &j * &self.fit.fit.covariance * j.transpose();
        ((&j * b).iter().copied().collect(), c)
    }
}

/// Fits `base` with each coefficient's temperature order chosen from the data (or `fixed` for
/// every coefficient), at most `support.max_order`, over observations at `temps`; `fit` fits a
/// formula over the observations
/// (which have the temperature columns, [`push_columns`]).
///
/// # Errors
/// The fit's, for the model with every order at 0 (the others are candidates only).
pub fn choose(
    base: &Formula,
    (support, temps): (&Support, &[f64]),
    alpha: f64,
    fixed: Option<u32>,
    fit: &dyn Fn(&Formula) -> Result<AxisFit, WorkflowError>,
) -> Result<ThermalFit, WorkflowError> {
    let names = base.term_names();
    let max = support.max_order;
    let scale = support.scale;
    let supported = format!(
        "the most {} distinct temperatures over {:.1} C support",
        support.distinct,
        scale.hi - scale.lo
    );
    // What the observations can estimate of each coefficient's temperature dependence (a
    // still unit in a ramp, with a multi-position run at one temperature, says nothing of
    // how the scale factor changes).
    // In term order, each given the ones before it at theirs: the bias first.
    let mut caps = vec![0u32; names.len()];
    for j in 0..names.len() {
        caps[j] = estimable(base, j, max, &caps, fit);
    }
    if let Some(k) = fixed {
        let orders: Vec<u32> = caps.iter().map(|c| k.min(max).min(*c)).collect();
        let k = k.min(max);
        let f = fit(&expand(base, &orders))?;
        return Ok(ThermalFit {
            base: base.clone(),
            reasons: vec![format!(
                "every coefficient's temperature polynomial has order {k} (--thermal-order{})",
                if k == max {
                    format!(", {supported}")
                } else {
                    String::new()
                }
            )],
            orders,
            scale,
            fit: f,
            temps: temps.to_vec(),
        });
    }
    let mut orders = vec![0u32; names.len()];
    let mut current = fit(&expand(base, &orders))?;
    let mut last_p: Vec<Option<f64>> = vec![None; names.len()];
    loop {
        // Every candidate: one more power of one coefficient, or two (an odd or even curve).
        let mut candidates = Vec::new();
        for j in 0..names.len() {
            for step in 1..=2 {
                if orders[j] + step <= caps[j] {
                    let mut o = orders.clone();
                    o[j] += step;
                    if let Ok(f) = fit(&expand(base, &o)) {
                        // The Wald test of the added orders: the partial F test for least
                        // squares, and still valid for a weighted fit's sandwich covariance.
                        let added: Vec<String> = (orders[j] + 1..=o[j])
                            .map(|k| thermal_term(base, j, k).name())
                            .collect();
                        if let Some(test) = select::wald(&f.fit, &added) {
                            candidates.push((j, step, test, f));
                        }
                    }
                }
            }
        }
        let m = candidates.len().max(1) as f64;
        for (j, step, test, _) in &candidates {
            if *step == 1 {
                last_p[*j] = Some(test.p);
            }
        }
        // The most significant at the Bonferroni level; one power before two.
        let best = candidates
            .into_iter()
            .filter(|c| c.2.p < alpha / m)
            .min_by(|a, b| {
                (a.1, a.2.p)
                    .partial_cmp(&(b.1, b.2.p))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
        let Some((j, step, _, f)) = best else { break };
        orders[j] += step;
        current = f;
    }
    let reasons = names
        .iter()
        .enumerate()
        .map(|(j, n)| {
            let what = if n == INTERCEPT {
                "bias (1)".to_string()
            } else {
                n.clone()
            };
            let k = orders[j];
            if k == max {
                format!("{what}: order {k}, {supported}")
            } else if k == caps[j] {
                format!(
                    "{what}: order {k}, the most these observations can estimate (its temperature terms of higher order are combinations of the other terms: the temperature does not vary where this term does)"
                )
            } else {
                match last_p[j] {
                    Some(p) => format!(
                        "{what}: order {k} (one more power of the temperature: p = {p:.3}, not significant)"
                    ),
                    None => format!("{what}: order {k}"),
                }
            }
        })
        .collect();
    Ok(ThermalFit {
        base: base.clone(),
        orders,
        scale,
        fit: current,
        reasons,
        temps: temps.to_vec(),
    })
}

/// The highest order (at most `max`) of coefficient `j`'s temperature polynomial that the
/// observations can estimate, the other coefficients at `given` orders.
pub fn estimable(
    base: &Formula,
    j: usize,
    max: u32,
    given: &[u32],
    fit: &dyn Fn(&Formula) -> Result<AxisFit, WorkflowError>,
) -> u32 {
    let mut orders = given.to_vec();
    orders.resize(base.width(), 0);
    (1..=max)
        .rev()
        .find(|k| {
            orders[j] = *k;
            fit(&expand(base, &orders)).is_ok()
        })
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expanded_terms_and_the_model_at_a_temperature() {
        let base = crate::formula::parse("output ~ 1 + input").unwrap();
        let f = expand(&base, &[2, 1]);
        assert_eq!(
            f.term_names(),
            ["1", "input", "temp_leg1", "temp_leg2", "input:temp_leg1"]
        );
        assert!(!is_thermal("input") && !is_thermal("temp_leg"));
        assert!((legendre(3, 0.5) - 0.5 * (5.0 * 0.125 - 1.5)).abs() < 1e-15);
        assert!(f.terms.iter().skip(1).all(|t| is_thermal(&t.name())));
        assert_eq!(base_of(&f), base);
    }
}
