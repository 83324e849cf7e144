//! The noise terms as a person reads them: each in the record's unit and, for a gyro or an
//! accelerometer in SI units, in a datasheet's (deg/sqrt(h), deg/h, mg, m/s/sqrt(h)); a term
//! the record does not resolve is said to be so, never printed as 0.

use super::allan::NoiseTerms;
use crate::report::terminal::num;

/// What a term is called and its value, as said.
pub struct Said {
    /// The term's name (`ARW`, `VRW`, `bias instability`, ...).
    pub name: &'static str,
    /// Its value with units, or "not resolved in this record".
    pub value: String,
}

/// What a term the record does not resolve is said to be.
pub const NOT_RESOLVED: &str = "not resolved in this record";

/// The five terms of `t` (random walk, bias instability, rate random walk, quantization, ramp)
/// in the unit of the record, `unit`: `rad/s` for a gyro and `m/s^2` for an accelerometer get
/// a datasheet's units beside SI's.
#[must_use]
pub fn terms(t: &NoiseTerms, unit: &str) -> [Said; 5] {
    let deg = 180.0 / std::f64::consts::PI;
    let show = |v: f64, units: &[(f64, &str)]| -> String {
        if v > 0.0 {
            units
                .iter()
                .map(|(k, u)| format!("{} {u}", num(v * k)))
                .collect::<Vec<_>>()
                .join(" = ")
        } else {
            NOT_RESOLVED.to_string()
        }
    };
    let said = |name, value| Said { name, value };
    match unit {
        "rad/s" => [
            said(
                "ARW",
                show(
                    t.random_walk,
                    &[(1.0, "rad/s/sqrt(Hz)"), (deg * 60.0, "deg/sqrt(h)")],
                ),
            ),
            said(
                "bias instability",
                show(
                    t.bias_instability,
                    &[(1.0, "rad/s"), (deg * 3600.0, "deg/h")],
                ),
            ),
            said(
                "RRW",
                show(
                    t.rate_random_walk,
                    &[
                        (1.0, "rad/s/sqrt(s)"),
                        (deg * 3600.0 * 60.0, "deg/h/sqrt(h)"),
                    ],
                ),
            ),
            said("quantization", show(t.quantization, &[(1.0, "rad")])),
            said("rate ramp", show(t.rate_ramp, &[(1.0, "rad/s^2")])),
        ],
        "m/s^2" => [
            said(
                "VRW",
                show(
                    t.random_walk,
                    &[(1.0, "m/s^2/sqrt(Hz)"), (60.0, "m/s/sqrt(h)")],
                ),
            ),
            said(
                "bias instability",
                show(
                    t.bias_instability,
                    &[(1.0, "m/s^2"), (1.0 / 9.80665e-3, "mg")],
                ),
            ),
            said(
                "acceleration random walk",
                show(t.rate_random_walk, &[(1.0, "m/s^2/sqrt(s)")]),
            ),
            said("quantization", show(t.quantization, &[(1.0, "m/s")])),
            said("ramp", show(t.rate_ramp, &[(1.0, "m/s^3")])),
        ],
        _ => [
            said(
                "random walk",
                show(t.random_walk, &[(1.0, &format!("{unit}/sqrt(Hz)"))]),
            ),
            said("bias instability", show(t.bias_instability, &[(1.0, unit)])),
            said(
                "rate random walk",
                show(t.rate_random_walk, &[(1.0, &format!("{unit}/sqrt(s)"))]),
            ),
            said(
                "quantization",
                show(t.quantization, &[(1.0, &format!("{unit} s"))]),
            ),
            said("ramp", show(t.rate_ramp, &[(1.0, &format!("{unit}/s"))])),
        ],
    }
}

/// The five terms on one line: `ARW ...; bias instability ...; RRW ...; quantization ...;
/// rate ramp ...`.
#[must_use]
pub fn line(t: &NoiseTerms, unit: &str) -> String {
    terms(t, unit)
        .iter()
        .map(|s| format!("{} {}", s.name, s.value))
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gyro_in_si_is_said_in_a_datasheets_units_and_a_missing_term_as_not_resolved() {
        let t = NoiseTerms {
            quantization: 0.0,
            random_walk: 1e-4,
            bias_instability: 0.0,
            rate_random_walk: 1e-6,
            rate_ramp: 0.0,
        };
        let l = line(&t, "rad/s");
        assert!(
            l.starts_with("ARW ") && l.contains("rad/s/sqrt(Hz) = 0.3437"),
            "{l}"
        );
        assert!(l.contains("deg/sqrt(h)"), "{l}");
        assert!(
            l.contains("bias instability not resolved in this record"),
            "{l}"
        );
        assert!(l.contains("deg/h/sqrt(h)"), "{l}");
        let counts = line(&t, "counts");
        assert!(
            counts.contains("random walk") && !counts.contains("deg"),
            "{counts}"
        );
    }
}
