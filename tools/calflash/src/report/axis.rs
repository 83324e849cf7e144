//! An axis' ticks and their labels: round steps (1, 2 or 5 times a power of ten), one number
//! format for every label of an axis (never "0.001" beside "8.00000e-4"), and decades on a
//! logarithmic axis.

/// How an axis' labels are written: the same way for all of them.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    /// Fixed point with this many decimals.
    Fixed(usize),
    /// A mantissa with this many decimals times a power of ten shared by the axis.
    Scientific { exp: i32, decimals: usize },
    /// Powers of ten, written as such (10⁻³).
    Decade,
}

/// The ticks of one axis: labelled (bold) and grid-only (light) values, and their format.
#[derive(Debug, Clone)]
pub struct Ticks {
    /// Labelled values, ascending.
    pub bold: Vec<f64>,
    /// Grid lines between them.
    pub light: Vec<f64>,
    format: Format,
}

/// The round step (1, 2 or 5 times a power of ten) at or above `raw`.
fn round_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag)
}

/// Multiples of `step` in `[lo, hi]`, with a value within rounding of zero made zero.
fn multiples(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last)
        .map(|k| k as f64 * step)
        .map(|v| if v.abs() < step * 1e-9 { 0.0 } else { v })
        .collect()
}

/// The format that writes every multiple of `step` up to `largest` in magnitude the same way,
/// with as few digits as tell them apart.
fn format_for(largest: f64, step: f64) -> Format {
    let step_exp = (step.log10() + 1e-9).floor() as i32;
    if largest == 0.0 {
        return Format::Fixed(0);
    }
    let exp = (largest.log10() + 1e-9).floor() as i32;
    if (-3..5).contains(&exp) && step_exp >= -5 {
        Format::Fixed(usize::try_from(-step_exp).unwrap_or(0))
    } else {
        Format::Scientific {
            exp,
            decimals: usize::try_from(exp - step_exp).unwrap_or(0).min(6),
        }
    }
}

impl Ticks {
    /// About `most` labelled ticks over `[lo, hi]` on a linear axis.
    #[must_use]
    pub fn linear(lo: f64, hi: f64, most: usize) -> Self {
        let span = hi - lo;
        if !(span > 0.0 && span.is_finite()) {
            return Self {
                bold: vec![lo],
                light: Vec::new(),
                format: format_for(lo.abs(), lo.abs().max(1.0)),
            };
        }
        let step = round_step(span / most.max(2) as f64);
        let bold = multiples(lo, hi, step);
        let largest = bold.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        // Light lines at fifths of a step of 1 or 5, quarters of a step of 2.
        let first_digit = step / 10f64.powf((step.log10() + 1e-9).floor());
        let parts = if (first_digit - 2.0).abs() < 1e-6 {
            4.0
        } else {
            5.0
        };
        Self {
            light: multiples(lo, hi, step / parts),
            format: format_for(largest, step),
            bold,
        }
    }

    /// The ticks of a logarithmic axis over `[lo, hi]` (both above zero): each decade labelled
    /// when the axis spans two or more, else round values as on a linear axis.
    #[must_use]
    pub fn log(lo: f64, hi: f64) -> Self {
        let (d0, d1) = (
            (lo.log10() - 1e-9).ceil() as i32,
            (hi.log10() + 1e-9).floor() as i32,
        );
        if d1 - d0 >= 1 {
            // At most about ten labelled decades.
            let every = usize::try_from((d1 - d0) / 10 + 1).unwrap_or(1);
            let bold = (d0..=d1).step_by(every).map(|d| 10f64.powi(d)).collect();
            let light = (d0 - 1..=d1)
                .flat_map(|d| (2..10).map(move |m| f64::from(m) * 10f64.powi(d)))
                .filter(|v| (lo..=hi).contains(v))
                .collect();
            return Self {
                bold,
                light,
                format: Format::Decade,
            };
        }
        let mut t = Self::linear(lo, hi, 6);
        t.bold.retain(|v| *v > 0.0);
        t.light.retain(|v| *v > 0.0);
        t
    }

    /// The label of `v`, one of the ticks.
    #[must_use]
    pub fn label(&self, v: f64) -> String {
        match self.format {
            Format::Fixed(d) => format!("{v:.d$}"),
            Format::Scientific { exp, decimals } => {
                if v == 0.0 {
                    "0".to_string()
                } else {
                    format!("{:.decimals$}e{exp}", v / 10f64.powi(exp))
                }
            }
            Format::Decade => decade(v),
        }
    }
}

/// 10 to the power nearest log10(`v`), written with a superscript (1 and 10 as such).
fn decade(v: f64) -> String {
    let d = v.log10().round() as i32;
    match d {
        0 => "1".to_string(),
        1 => "10".to_string(),
        _ => {
            let sup: String = d
                .to_string()
                .chars()
                .map(|c| match c {
                    '-' => '⁻',
                    '0' => '⁰',
                    '1' => '¹',
                    '2' => '²',
                    '3' => '³',
                    '4' => '⁴',
                    '5' => '⁵',
                    '6' => '⁶',
                    '7' => '⁷',
                    '8' => '⁸',
                    _ => '⁹',
                })
                .collect();
            format!("10{sup}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(t: &Ticks) -> Vec<String> {
        t.bold.iter().map(|v| t.label(*v)).collect()
    }

    #[test]
    fn every_label_of_an_axis_is_written_the_same_way() {
        // The case the issue saw: 0.001 beside 8.00000e-4.
        let t = Ticks::linear(-2e-5, 1.05e-3, 6);
        assert_eq!(
            labels(&t),
            ["0.0000", "0.0002", "0.0004", "0.0006", "0.0008", "0.0010"]
        );
        let t = Ticks::linear(-3.2e-6, 4.1e-6, 8);
        assert_eq!(
            labels(&t),
            [
                "-3e-6", "-2e-6", "-1e-6", "0", "1e-6", "2e-6", "3e-6", "4e-6"
            ]
        );
        let t = Ticks::linear(32_700.0, 33_600.0, 8);
        assert_eq!(labels(&t), ["32800", "33000", "33200", "33400", "33600"]);
        let t = Ticks::linear(-1.0, 1.0, 5);
        assert_eq!(labels(&t), ["-1.0", "-0.5", "0.0", "0.5", "1.0"]);
        let t = Ticks::linear(1.0e6, 3.0e6, 4);
        assert_eq!(labels(&t), ["1.0e6", "1.5e6", "2.0e6", "2.5e6", "3.0e6"]);
        // Every label different, and a tick never more than one step from its neighbour.
        for (lo, hi) in [(0.0, 7.3e-4), (-91.0, 13.0), (1.2345, 1.2351), (-5e9, 5e9)] {
            let t = Ticks::linear(lo, hi, 8);
            let l = labels(&t);
            let mut u = l.clone();
            u.dedup();
            assert_eq!(u, l, "{lo} {hi}");
            assert!((2..=12).contains(&l.len()), "{lo} {hi}: {l:?}");
        }
    }

    #[test]
    fn a_log_axis_is_labelled_by_decade() {
        let t = Ticks::log(0.007, 2300.0);
        assert_eq!(labels(&t), ["10⁻²", "10⁻¹", "1", "10", "10²", "10³"]);
        let near = |x: f64| t.light.iter().any(|v| (v / x - 1.0).abs() < 1e-12);
        assert!(near(0.02) && near(2000.0) && !near(0.005));
        assert!(t.light.iter().all(|v| (0.007..=2300.0).contains(v)));
        // Within one decade: round values, one format.
        let t = Ticks::log(2.0e-4, 9.0e-4);
        assert_eq!(labels(&t), ["2e-4", "4e-4", "6e-4", "8e-4"]);
        // Thirty decades: about ten labels.
        assert!(Ticks::log(1e-15, 1e15).bold.len() <= 11);
    }
}
