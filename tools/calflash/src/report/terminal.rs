//! The terminal summary of `calflash fit`: what a person reads at a glance.

use std::fmt::Write as _;

use crate::regression::Regression;
use crate::stats::Fit;

/// Six significant digits, fixed or exponent form as fits; `-` for an undefined value.
#[must_use]
pub fn num(x: f64) -> String {
    if x.is_nan() {
        return "-".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let a = x.abs();
    if (1e-3..1e6).contains(&a) {
        let decimals = (5 - a.log10().floor() as i32).clamp(0, 8) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{x:.5e}")
    }
}

/// `x` with its sign, as [`num`] writes it: `+0.25`, `-3`.
#[must_use]
pub fn signed(x: f64) -> String {
    if x > 0.0 {
        format!("+{}", num(x))
    } else {
        num(x)
    }
}

/// A p-value: two significant digits, and `<1e-300` below that.
#[must_use]
pub fn pval(p: f64) -> String {
    if p.is_nan() {
        "-".into()
    } else if p < 1e-300 {
        "<1e-300".into()
    } else if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}

/// The summary as text.
#[must_use]
pub fn render(reg: &Regression) -> String {
    let mut s = String::new();
    model(&mut s, reg);
    coefficients(&mut s, &reg.fit);
    goodness(&mut s, reg);
    influence(&mut s, reg);
    checks(&mut s, reg);
    s
}

/// The file, the model and the backward elimination that led to it.
fn model(s: &mut String, reg: &Regression) {
    let f = &reg.fit;
    let _ = writeln!(
        s,
        "calflash fit  {}  ({} observations, {} terms, {} residual dof)",
        reg.file.display(),
        f.n,
        f.p,
        f.dof
    );
    let _ = writeln!(s, "model  {}", reg.formula);
    if let Some(e) = &reg.elimination {
        let _ = writeln!(s, "       backward elimination from {}:", e.start);
        if e.steps.is_empty() {
            let _ = writeln!(
                s,
                "         every term is significant at {}; nothing dropped",
                f.alpha
            );
        }
        for st in &e.steps {
            let _ = writeln!(
                s,
                "         dropped {}: p = {} > {} (AIC {} -> {})",
                st.dropped,
                pval(st.p_value),
                f.alpha,
                num(st.aic_before),
                num(st.aic_after)
            );
        }
        for (t, p) in &e.protected {
            let _ = writeln!(
                s,
                "         kept {t} (p = {}) because a kept term contains it",
                pval(*p)
            );
        }
    }
}

/// Each term's coefficient, standard error, t, p, interval and VIF.
fn coefficients(s: &mut String, f: &Fit) {
    let level = 100.0 * (1.0 - f.alpha);
    let width = f.names.iter().map(String::len).max().unwrap_or(4).max(4);
    let _ = writeln!(
        s,
        "\n{:<width$}  {:>13}  {:>11}  {:>10}  {:>8}  {:>29}  {:>8}",
        "term",
        "coefficient",
        "std error",
        "t",
        "p",
        format!("{level:.0}% interval"),
        "VIF"
    );
    for j in 0..f.p {
        let vif = f.vif[j].map_or("-".into(), num);
        let mark = if f.p_values[j] > f.alpha {
            "  not significant"
        } else {
            ""
        };
        let _ = writeln!(
            s,
            "{:<width$}  {:>13}  {:>11}  {:>10}  {:>8}  {:>29}  {:>8}{mark}",
            f.names[j],
            num(f.coefficients[j]),
            num(f.std_errors[j]),
            num(f.t[j]),
            pval(f.p_values[j]),
            format!("[{}, {}]", num(f.ci_lower[j]), num(f.ci_upper[j])),
            vif
        );
    }
}

/// The fit as a whole: sigma, R^2, F, the information criteria, the condition number, the
/// Durbin-Watson statistic and the runs test of the residuals.
fn goodness(s: &mut String, reg: &Regression) {
    let f = &reg.fit;
    let _ = writeln!(
        s,
        "\nresidual sigma {} (dof {})   R^2 {}   adj R^2 {}   F {} (p {})",
        num(f.sigma2.sqrt()),
        f.dof,
        num(f.r2),
        num(f.adj_r2),
        num(f.f),
        pval(f.f_p)
    );
    let _ = writeln!(
        s,
        "AIC {}   BIC {}   condition number {}   Durbin-Watson {}",
        num(f.aic),
        num(f.bic),
        num(f.condition_number),
        num(f.durbin_watson)
    );
    let runs: Vec<String> = reg
        .runs
        .iter()
        .map(|(o, t)| format!("{o} z = {:.2} (p {})", t.z, pval(t.p)))
        .collect();
    let _ = writeln!(s, "residual pattern (runs test): {}", runs.join("; "));
}

/// The outliers and the influential observations, by line.
fn influence(s: &mut String, reg: &Regression) {
    let (f, inf) = (&reg.fit, &reg.fit.influence);
    if inf.outliers.is_empty() {
        let _ = writeln!(
            s,
            "outliers: none (|externally studentized residual| > {} at {} with Bonferroni)",
            num(inf.thresholds.outlier),
            f.alpha
        );
    } else {
        let list: Vec<String> = inf
            .outliers
            .iter()
            .take(10)
            .map(|(i, p)| {
                format!(
                    "line {} (t = {}, p = {})",
                    reg.lines[*i],
                    num(inf.student_external[*i]),
                    pval(*p)
                )
            })
            .collect();
        let _ = writeln!(
            s,
            "OUTLIERS ({} with |t| > {}, Bonferroni at {}): {}",
            inf.outliers.len(),
            num(inf.thresholds.outlier),
            f.alpha,
            first_ten(&list, inf.outliers.len())
        );
    }
    if !inf.influential.is_empty() {
        let list: Vec<String> = inf
            .influential
            .iter()
            .take(10)
            .map(|(i, _)| {
                format!(
                    "line {} (Cook {}, DFFITS {})",
                    reg.lines[*i],
                    num(inf.cooks_distance[*i]),
                    num(inf.dffits[*i])
                )
            })
            .collect();
        let _ = writeln!(
            s,
            "influential ({}; Cook > {} or |DFFITS| > {}): {}",
            inf.influential.len(),
            num(inf.thresholds.cooks_distance),
            num(inf.thresholds.dffits),
            first_ten(&list, inf.influential.len())
        );
    }
}

/// The first ten of `total` items, listed, and how many more there are.
fn first_ten(listed: &[String], total: usize) -> String {
    let more = total.saturating_sub(10);
    if more > 0 {
        format!("{} and {more} more", listed.join(", "))
    } else {
        listed.join(", ")
    }
}

/// What was asked besides the fit: a reduced model, a hold-out, predictions, a curve, and the
/// warnings.
fn checks(s: &mut String, reg: &Regression) {
    let f = &reg.fit;
    if let Some(c) = &reg.comparison {
        let _ = writeln!(
            s,
            "against {}: partial F = {} on ({}, {}) dof, p = {}: {}",
            c.reduced,
            num(c.test.f),
            c.test.df_num,
            c.test.df_den,
            pval(c.test.p),
            if c.test.p < f.alpha {
                "the extra terms matter; keep the full model"
            } else {
                "the extra terms do not matter at this level; the reduced model will do"
            }
        );
    }
    if let Some(h) = &reg.holdout {
        let _ = writeln!(
            s,
            "hold-out (every {}th observation, {} held out, {} fitted): RMS error {}, max {}; the fit predicts RMS {}",
            h.every,
            h.n_test,
            h.n_train,
            num(h.rms_error),
            num(h.max_abs_error),
            num(h.predicted_rms)
        );
    }
    for p in &reg.predictions {
        let at: Vec<String> =
            p.at.iter()
                .map(|(k, v)| format!("{k}={}", num(*v)))
                .collect();
        let _ = writeln!(
            s,
            "prediction at {}: {} (1-sigma of the fit {}; of a new observation {})",
            at.join(","),
            num(p.prediction.value),
            num(p.prediction.variance.sqrt()),
            num(p.prediction.observation_variance.sqrt())
        );
    }
    if let Some(c) = &reg.curve {
        let _ = writeln!(
            s,
            "prediction curve over {} (observed {} to {}): 1-sigma of the fit from {} to {}",
            c.variable,
            num(c.observed.0),
            num(c.observed.1),
            num(c
                .points
                .iter()
                .map(|p| p.1.variance)
                .fold(f64::INFINITY, f64::min)
                .sqrt()),
            num(c
                .points
                .iter()
                .map(|p| p.1.variance)
                .fold(0.0, f64::max)
                .sqrt())
        );
    }
    for w in &reg.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_list_names_its_first_ten_and_counts_the_rest() {
        let ten: Vec<String> = (1..=10).map(|i| format!("line {i}")).collect();
        assert!(first_ten(&ten, 10).ends_with("line 10"));
        assert!(first_ten(&ten, 13).ends_with("line 10 and 3 more"));
    }

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(2.5), "2.5");
        assert_eq!(num(123_456.789), "123457");
        assert_eq!(num(0.001_234_567), "0.00123457");
        assert_eq!(num(1.5e-7), "1.50000e-7");
        assert_eq!(num(-3.25e9), "-3.25000e9");
        assert_eq!(num(f64::NAN), "-");
        assert_eq!(pval(0.5), "0.500");
        assert_eq!(pval(2e-9), "2.0e-9");
        assert_eq!(pval(0.0), "<1e-300");
    }
}
