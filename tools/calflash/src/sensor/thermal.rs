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

use std::fmt::Write as _;

use nalgebra::DMatrix;

use super::{AxisFit, WorkflowError};
use crate::formula::{Formula, INTERCEPT, Term};
use crate::obs::Table;
use crate::stats::select;

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
/// The smallest temperature span a temperature model is fitted over, C.
pub const MIN_SPAN: f64 = 5.0;
/// Temperatures a unit under test can plausibly be at, C.
pub const PLAUSIBLE: (f64, f64) = (-100.0, 200.0);
/// Readings closer than this are one temperature when counting the distinct ones, C.
const DISTINCT: f64 = 0.5;

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

/// What a temperature column supports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// The range.
    pub scale: Scale,
    /// Distinct temperatures (readings within 0.5 C counted once).
    pub distinct: usize,
    /// The highest order the temperatures support.
    pub max_order: u32,
    /// The reading step when a ramp's temperatures are reported in steps (whole degrees, say).
    pub quantum: Option<f64>,
}

/// The step all readings are whole multiples of (at least 0.05 C), if there is one.
fn quantum(temps: &[f64]) -> Option<f64> {
    [0.05, 0.1, 0.25, 0.5, 1.0, 2.0]
        .into_iter()
        .rev()
        .find(|q| temps.iter().all(|t| ((t / q).round() * q - t).abs() < 1e-9))
}

/// Checks the temperature column of `table` for a temperature model and says what it supports.
///
/// # Errors
/// A message naming the line: a reading that is not a temperature (non-finite, or outside
/// [`PLAUSIBLE`]); a span under [`MIN_SPAN`] (which supports no temperature term); readings that
/// jump back and forth as no chamber does (a column mix-up).
pub fn check(table: &Table, column: &str) -> Result<Support, WorkflowError> {
    let path = std::path::Path::new(&table.path);
    let Some(temps) = table.column(column) else {
        return Err(WorkflowError::msg(
            path,
            format!(
                "a temperature model needs the column `{column}` (the sensor's temperature, C); the file has: {}",
                table.names.join(", ")
            ),
        ));
    };
    for (i, t) in temps.iter().enumerate() {
        if !(t.is_finite() && (PLAUSIBLE.0..=PLAUSIBLE.1).contains(t)) {
            return Err(WorkflowError::msg(
                path,
                format!(
                    "line {}: {column} = {t} is not a temperature a unit is calibrated at; expected {} to {} C",
                    table.lines[i], PLAUSIBLE.0, PLAUSIBLE.1
                ),
            ));
        }
    }
    let lo = temps.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = temps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi - lo < MIN_SPAN {
        return Err(WorkflowError::msg(
            path,
            format!(
                "the temperatures span {:.1} C ({lo} to {hi} C); a temperature model needs at least {MIN_SPAN} C, and this spread supports temperature terms of order: none (calibrate at one temperature without a temperature model, or widen the ramp)",
                hi - lo
            ),
        ));
    }
    jumps(temps, &table.lines, hi - lo).map_err(|e| WorkflowError::msg(path, e))?;
    let mut sorted = temps.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut distinct = 0usize;
    let mut last = f64::NEG_INFINITY;
    for t in sorted {
        if t - last > DISTINCT {
            distinct += 1;
            last = t;
        }
    }
    let max_order = MAX_ORDER.min(distinct.saturating_sub(1) as u32);
    Ok(Support {
        scale: Scale { lo, hi },
        distinct,
        max_order,
        // Steps matter along a ramp; a few setpoints are whole numbers by choice.
        quantum: if distinct >= 10 { quantum(temps) } else { None },
    })
}

/// Readings in file order that jump back and forth by more than a tenth of the span, more often
/// than a chamber's cycles could (at least 3 reversals and 5 % of the readings): the column
/// holds something else.
fn jumps(temps: &[f64], lines: &[u64], span: f64) -> Result<(), String> {
    let big = 0.1 * span;
    let mut last_sign = 0.0;
    let mut reversals = Vec::new();
    for (i, w) in temps.windows(2).enumerate() {
        let d = w[1] - w[0];
        if d.abs() > big {
            if last_sign != 0.0 && d.signum() != last_sign {
                reversals.push(i + 1);
            }
            last_sign = d.signum();
        }
    }
    if reversals.len() >= 3 && reversals.len() * 20 >= temps.len() {
        let at: Vec<String> = reversals
            .iter()
            .take(3)
            .map(|&i| format!("line {} ({} after {})", lines[i], temps[i], temps[i - 1]))
            .collect();
        return Err(format!(
            "the temperatures jump back and forth by more than {big:.1} C {} times in {} readings, as no chamber does ({}, ...): is the temperature column holding another quantity?",
            reversals.len(),
            temps.len(),
            at.join(", ")
        ));
    }
    Ok(())
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

/// Weights that even out the observations' density over the temperature range, or `None`
/// when it is even enough (the fullest of 10 bins at most twice the emptiest, counting only
/// bins with observations): each observation weighs the inverse of its bin's share, scaled to
/// a mean of 1 and kept within 0.1 to 10. Where a ramp crowds the observations, an unweighted
/// fit would follow the curve there at the expense of the sparse part of the range.
#[must_use]
pub fn density_weights(temps: &[f64], scale: &Scale) -> Option<Vec<f64>> {
    const BINS: usize = 10;
    let bin = |t: f64| {
        let u = (t - scale.lo) / (scale.hi - scale.lo);
        ((u * BINS as f64) as usize).min(BINS - 1)
    };
    let mut counts = [0usize; BINS];
    for t in temps {
        counts[bin(*t)] += 1;
    }
    let filled: Vec<usize> = counts.iter().copied().filter(|c| *c > 0).collect();
    let (lo, hi) = (filled.iter().min()?, filled.iter().max()?);
    if *hi <= 2 * *lo {
        return None;
    }
    let raw: Vec<f64> = temps.iter().map(|t| 1.0 / counts[bin(*t)] as f64).collect();
    let mean = raw.iter().sum::<f64>() / raw.len() as f64;
    Some(raw.iter().map(|w| (w / mean).clamp(0.1, 10.0)).collect())
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

/// How the sensor's temperature (`temp`, the one fitted) follows the chamber's
/// (`chamber_temp`), in words, when both are given: the median of their difference, and with a
/// `time` column the median delay after which the chamber had the sensor's temperature (a
/// first-order lag behind a ramp shows as that delay; self-heating as the difference).
#[must_use]
pub fn lag(table: &Table) -> Option<String> {
    use crate::columns as col;
    let sensor = table.column(col::TEMP)?;
    let chamber = table.column(col::CHAMBER_TEMP)?;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let offset = median(sensor.iter().zip(chamber).map(|(s, c)| s - c).collect())?;
    let mut text = format!(
        "the sensor's temperature differs from the chamber's by {offset:+.2} C (median); the fit uses the sensor's"
    );
    if let Some(time) = table.column(col::TIME) {
        // Where the chamber ramps monotonically, the time it had each sensor reading.
        let rising = chamber.windows(2).all(|w| w[1] >= w[0]);
        let falling = chamber.windows(2).all(|w| w[1] <= w[0]);
        if rising || falling {
            let sign = if rising { 1.0 } else { -1.0 };
            let delays: Vec<f64> = sensor
                .iter()
                .zip(time)
                .filter_map(|(s, t)| {
                    let k = chamber.partition_point(|c| sign * c < sign * s);
                    let (c0, c1) = (chamber.get(k.checked_sub(1)?)?, chamber.get(k)?);
                    let (t0, t1) = (time[k - 1], time[k]);
                    let at = if c1 == c0 {
                        t0
                    } else {
                        t0 + (t1 - t0) * (s - c0) / (c1 - c0)
                    };
                    Some(t - at)
                })
                .collect();
            match median(delays) {
                Some(d) if d >= 0.0 => {
                    let _ = write!(
                        text,
                        "; it reads what the chamber read {d:.0} s earlier (median lag)"
                    );
                }
                Some(d) => {
                    let _ = write!(
                        text,
                        "; it reads what the chamber reaches {:.0} s later (self-heating, or a warmer mount)",
                        -d
                    );
                }
                None => {}
            }
        }
    }
    Some(text)
}

/// Breakpoints for the device's table over `scale`: from the two ends, the temperature where
/// `ratio` is worst is added until `ratio(points)` is at most 1 or `max` points are used.
/// `ratio(points)` gives the worst departure of the interpolated table from the continuous
/// model (against what is allowed) and the temperature where it is; the last is returned.
pub fn breakpoints(
    scale: &Scale,
    max: usize,
    ratio: impl Fn(&[f64]) -> (f64, f64),
) -> (Vec<f64>, (f64, f64)) {
    let mut points = vec![scale.lo, scale.hi];
    loop {
        let (r, at) = ratio(&points);
        if r <= 1.0 || points.len() >= max || points.iter().any(|p| (p - at).abs() < 1e-9) {
            return (points, (r, at));
        }
        let i = points.partition_point(|p| *p < at);
        points.insert(i, at);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(temps: Vec<f64>) -> Table {
        let n = temps.len();
        Table {
            path: "ramp.csv".into(),
            names: vec!["temp".into()],
            columns: vec![temps],
            lines: (2..n as u64 + 2).collect(),
        }
    }

    #[test]
    fn a_ramp_supports_high_orders_and_a_narrow_one_none() {
        let ramp = table(
            (0..400)
                .map(|i| -40.0 + 110.0 * f64::from(i) / 399.0)
                .collect(),
        );
        let s = check(&ramp, "temp").unwrap();
        assert_eq!(s.max_order, MAX_ORDER);
        assert_eq!(s.scale.x(-40.0), -1.0);
        let narrow = table((0..100).map(|i| 24.0 + 3.0 * f64::from(i) / 99.0).collect());
        let e = check(&narrow, "temp").unwrap_err().to_string();
        assert!(e.contains("span 3.0 C") && e.contains("order: none"), "{e}");
        let whole = table((0..400).map(|i| (f64::from(i) / 4.0).round()).collect());
        assert_eq!(check(&whole, "temp").unwrap().quantum, Some(1.0));
    }

    #[test]
    fn readings_that_are_not_temperatures_are_located() {
        let mut t: Vec<f64> = (0..50).map(f64::from).collect();
        t[7] = -300.0;
        let e = check(&table(t), "temp").unwrap_err().to_string();
        assert!(e.contains("line 9: temp = -300"), "{e}");
        let mixed = table(
            (0..200)
                .map(|i| if i % 2 == 0 { 9.8 } else { -9.8 })
                .collect(),
        );
        let e = check(&mixed, "temp").unwrap_err().to_string();
        assert!(
            e.contains("jump back and forth") && e.contains("line 4"),
            "{e}"
        );
        // A chamber cycling three times between soaks is not a mix-up.
        let cycles = table(
            (0..600)
                .map(|i| if (i / 100) % 2 == 0 { -40.0 } else { 85.0 })
                .collect(),
        );
        assert!(check(&cycles, "temp").is_ok());
    }

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

    #[test]
    fn weights_even_out_a_crowded_ramp_only() {
        let scale = Scale {
            lo: -40.0,
            hi: 70.0,
        };
        let even: Vec<f64> = (0..400)
            .map(|i| -40.0 + 110.0 * f64::from(i) / 399.0)
            .collect();
        assert!(density_weights(&even, &scale).is_none());
        // Fast at first, slow at the end: the hot end is crowded.
        let r = crate::sim::ramp::Ramp {
            from: -40.0,
            to: 70.0,
            seconds: 7200.0,
            uneven: true,
            lag: 0.0,
            self_heating: None,
            step: None,
        };
        let temps = r.temperatures(400).sensor;
        let w = density_weights(&temps, &scale).unwrap();
        assert!((w.iter().sum::<f64>() / 400.0 - 1.0).abs() < 0.05);
        assert!(w[0] > 3.0 * w[399], "{} {}", w[0], w[399]);
    }

    #[test]
    fn breakpoints_are_added_where_the_table_is_worst() {
        // A kink at 10 C: the table needs a point there and nowhere else.
        let scale = Scale {
            lo: -40.0,
            hi: 70.0,
        };
        let curve = |t: f64| (t - 10.0).abs();
        let (p, r) = breakpoints(&scale, 16, |pts: &[f64]| {
            (0..=110)
                .map(|i| {
                    let t = -40.0 + f64::from(i);
                    let k = pts.partition_point(|p| *p <= t).clamp(1, pts.len() - 1);
                    let (a, b) = (pts[k - 1], pts[k]);
                    let lin = curve(a) + (curve(b) - curve(a)) * (t - a) / (b - a);
                    ((lin - curve(t)).abs() / 0.01, t)
                })
                .fold((0.0, 0.0), |m, x| if x.0 > m.0 { x } else { m })
        });
        assert_eq!(p, [-40.0, 10.0, 70.0]);
        assert!(r.0 <= 1.0);
    }
}
