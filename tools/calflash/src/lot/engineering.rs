//! A lot's coefficient spread in the units a test engineer reads (issue 68: the lot's page gave
//! only the fit's converter counts). Each output's coefficients are divided by the lot's median
//! of the output's own scale factor (the largest of its linear terms, `f_x` for `a_x`), which
//! turns counts into the output's input unit; then a bias is said in mg or deg/h, the scale
//! factor in ppm, a cross-axis term in mrad, a gyro's g-sensitivity in deg/h/g, a square term
//! in mg/g^2 or ppm/(deg/s), a temperature term per C. A spread about the median needs no
//! converter mid-scale, which the history's records do not hold.

use super::Spread;

/// m/s^2 in one g (and in one mg, times 1e-3).
const G: f64 = 9.806_65;
/// deg/h in one rad/s.
const DEG_PER_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// A coefficient's spread across the lot in an engineering unit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Engineering {
    /// The unit (`mg`, `ppm`, `mrad`, `deg/h`, ...).
    pub unit: String,
    /// The MAD (scaled to a standard deviation) in it.
    pub mad: f64,
    /// The smallest unit's and the largest unit's distance from the lot's median in it.
    pub range: (f64, f64),
}

/// The input a linear factor is of: an accelerometer's (`f_*`), a gyro's (`w_*`), or the
/// single axis' (`input`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Input {
    Force,
    Rate,
    Other,
}

fn input_of(factor: &str) -> Option<Input> {
    if factor.starts_with("f_") {
        Some(Input::Force)
    } else if factor.starts_with("w_") {
        Some(Input::Rate)
    } else if factor == "input" || factor == "input_o" {
        Some(Input::Other)
    } else {
        None
    }
}

/// Each of `spread`'s coefficients (`OUTPUT:TERM`, as the lot names them) in an engineering
/// unit, `None` where the output has no scale factor in the lot or the term has no
/// datasheet unit (a table point beyond the first, `@T`, is said like the first).
#[must_use]
pub fn spread(spread: &[Spread]) -> Vec<Option<Engineering>> {
    let split = |name: &str| -> Option<(String, String)> {
        let (output, term) = name.split_once(':')?;
        let term = term.split_once('@').map_or(term, |(t, _)| t);
        Some((output.to_string(), term.to_string()))
    };
    // Each output's own scale factor: its largest linear term by the lot's median.
    let own = |output: &str| -> Option<(&str, f64)> {
        spread
            .iter()
            .filter_map(|s| {
                let (o, t) = s.name.split_once(':')?;
                (o == output && !t.contains('@') && input_of(t).is_some()).then_some((t, s.median))
            })
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    };
    spread
        .iter()
        .map(|s| {
            let (output, term) = split(&s.name)?;
            let (scale_term, scale) = own(&output)?;
            if scale == 0.0 {
                return None;
            }
            let kind = input_of(scale_term)?;
            let (unit, k) = unit_of(&term, scale_term, kind)?;
            let k = k / scale.abs();
            Some(Engineering {
                unit,
                mad: s.mad * k,
                range: ((s.min - s.median) * k, (s.max - s.median) * k),
            })
        })
        .collect()
}

/// The engineering unit of term `term` of an output whose own scale factor is `own` (of input
/// `kind`), and the factor from the term's coefficient divided by that scale factor.
fn unit_of(term: &str, own: &str, kind: Input) -> Option<(String, f64)> {
    // The output's own unit: mg, deg/h, or the single axis' input unit.
    let (out_unit, out_k) = match kind {
        Input::Force => ("mg", 1e3 / G),
        Input::Rate => ("deg/h", DEG_PER_H),
        Input::Other => ("input units", 1.0),
    };
    let factors: Vec<&str> = term.split(':').collect();
    let with_temp = factors.len() == 2 && factors[1] == "temp";
    let base = factors[0];
    let per_c = if with_temp { "/C" } else { "" };
    if factors.len() > 2 || (factors.len() == 2 && !with_temp) {
        return None;
    }
    if base == "1" {
        return Some((out_unit.to_string(), out_k));
    }
    if base == "temp" && factors.len() == 1 {
        return Some((format!("{out_unit}/C"), out_k));
    }
    if base == own {
        return Some((format!("ppm{per_c}"), 1e6));
    }
    if let Some(b) = base.strip_suffix("^2").filter(|b| *b == own) {
        return match input_of(b)? {
            Input::Force => Some((format!("mg/g^2{per_c}"), 1e3 * G)),
            Input::Rate => Some((
                format!("ppm/(deg/s){per_c}"),
                1e6 * std::f64::consts::PI / 180.0,
            )),
            Input::Other => Some((format!("ppm/input unit{per_c}"), 1e6)),
        };
    }
    match (kind, input_of(base)?) {
        // Another axis of the same input: a misalignment.
        (a, b) if a == b => Some((format!("mrad{per_c}"), 1e3)),
        // A gyro's reading per g of specific force.
        (Input::Rate, Input::Force) => Some((format!("deg/h/g{per_c}"), DEG_PER_H * G)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(name: &str, median: f64, mad: f64) -> Spread {
        Spread {
            name: name.to_string(),
            median,
            mad,
            min: median - 2.0 * mad,
            max: median + 3.0 * mad,
            engineering: None,
        }
    }

    /// An accelerometer of 1670 counts per g (170.3 per m/s^2) and a gyro of 900 counts per
    /// rad/s: a bias MAD of 40 counts is 23.95 mg, a scale MAD of 2 counts per g 1198 ppm, a
    /// cross-axis term of 0.17 counts per m/s^2 1 mrad, the gyro's g-sensitivity of 0.01
    /// counts per m/s^2 about 22.5 deg/h/g.
    #[test]
    fn counts_become_mg_ppm_mrad_and_deg_per_h_per_g() {
        let k = 1670.0 / G;
        let got = spread(&[
            s("a_x:1", 32768.0, 40.0),
            s("a_x:f_x", k, 2.0 / G),
            s("a_x:f_y", 0.0, 0.001 * k),
            s("a_x:f_x^2", 0.0, 1e-3 * k / G),
            s("g_x:1", 32768.0, 9.0),
            s("g_x:w_x", 900.0, 0.9),
            s("g_x:f_z", 0.0, 0.01),
            s("g_x:temp", 0.0, 0.9),
            s("a_x:1@60", 32770.0, 40.0),
        ]);
        let e = |i: usize| got[i].clone().unwrap();
        assert_eq!(e(0).unit, "mg");
        assert!((e(0).mad - 40.0 / 1670.0 * 1e3).abs() < 1e-9, "{:?}", e(0));
        assert_eq!(e(0).range, (-2.0 * e(0).mad, 3.0 * e(0).mad));
        assert_eq!(e(1).unit, "ppm");
        assert!((e(1).mad - 2.0 / 1670.0 * 1e6).abs() < 1e-6);
        assert_eq!(e(2).unit, "mrad");
        assert!((e(2).mad - 1.0).abs() < 1e-12);
        assert_eq!(e(3).unit, "mg/g^2");
        assert!((e(3).mad - 1.0).abs() < 1e-9, "1e-3 g per g^2 is 1 mg/g^2");
        assert_eq!(e(4).unit, "deg/h");
        assert!((e(4).mad - 0.01 * DEG_PER_H).abs() < 1e-9);
        assert_eq!(e(6).unit, "deg/h/g");
        assert!((e(6).mad - 0.01 / 900.0 * DEG_PER_H * G).abs() < 1e-9);
        assert_eq!(e(7).unit, "deg/h/C");
        assert_eq!(
            e(8).unit,
            "mg",
            "a table point beyond the first, as the first"
        );
        // A term without a datasheet unit, and an output without a scale factor, are not said.
        let none = spread(&[
            s("a_x:f_x", k, 1.0),
            s("a_x:f_x:f_y", 0.0, 1.0),
            s("b:1", 1.0, 1.0),
        ]);
        assert!(none[1].is_none() && none[2].is_none(), "{none:?}");
    }
}
