//! What a temperature column says before a model is fitted to it: whether its readings are
//! temperatures, what order their spread supports, whether they are read in steps, where they
//! crowd, and how the sensor's reading follows the chamber's.

use std::fmt::Write as _;

use super::{MAX_ORDER, Scale};
use crate::obs::Table;
use crate::sensor::WorkflowError;

/// The smallest temperature span a temperature model is fitted over, C.
pub const MIN_SPAN: f64 = 5.0;
/// Temperatures a unit under test can plausibly be at, C.
pub const PLAUSIBLE: (f64, f64) = (-100.0, 200.0);
/// Readings closer than this are one temperature when counting the distinct ones, C.
const DISTINCT: f64 = 0.5;

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
    let fail = |source: ColumnError| WorkflowError::Temperatures {
        path: table.path.clone(),
        source,
    };
    let Some(temps) = table.column(column) else {
        return Err(fail(ColumnError::Missing {
            column: column.into(),
            found: table.names.join(", "),
        }));
    };
    for (i, t) in temps.iter().enumerate() {
        if !(t.is_finite() && (PLAUSIBLE.0..=PLAUSIBLE.1).contains(t)) {
            return Err(fail(ColumnError::NotATemperature {
                line: table.lines[i],
                column: column.into(),
                value: *t,
            }));
        }
    }
    let lo = temps.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = temps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi - lo < MIN_SPAN {
        return Err(fail(ColumnError::Narrow { lo, hi }));
    }
    jumps(temps, &table.lines, hi - lo).map_err(|j| fail(j.into()))?;
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

/// A temperature or voltage column a model cannot follow.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ColumnError {
    /// The file has no temperature column.
    #[error(
        "a temperature model needs the column `{column}` (the sensor's temperature, C); the file has: {found}"
    )]
    Missing {
        /// The column.
        column: String,
        /// The file's columns, listed.
        found: String,
    },
    /// A reading that is not a temperature.
    #[error(
        "line {line}: {column} = {value} is not a temperature a unit is calibrated at; expected {} to {} C",
        PLAUSIBLE.0,
        PLAUSIBLE.1
    )]
    NotATemperature {
        /// The file's line.
        line: u64,
        /// The column.
        column: String,
        /// The reading.
        value: f64,
    },
    /// A span too narrow for any temperature term.
    #[error(
        "the temperatures span {:.1} C ({lo} to {hi} C); a temperature model needs at least {MIN_SPAN} C, and this spread supports temperature terms of order: none (calibrate at one temperature without a temperature model, or widen the ramp)",
        hi - lo
    )]
    Narrow {
        /// The lowest reading, C.
        lo: f64,
        /// The highest, C.
        hi: f64,
    },
    /// Readings that jump as no chamber does.
    #[error(transparent)]
    Jumps(#[from] Jumps),
    /// A reading that is not a supply voltage.
    #[error("line {line}: volt = {value} is not a supply voltage; expected 0 to 1000 V")]
    NotAVoltage {
        /// The file's line.
        line: u64,
        /// The reading.
        value: f64,
    },
}

/// A temperature column that jumps back and forth as no chamber does.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the temperatures jump back and forth by more than {by:.1} C {times} times in {readings} readings, as no chamber does ({at}, ...): is the temperature column holding another quantity?"
)]
pub struct Jumps {
    /// The jump that counts, C.
    pub by: f64,
    /// Reversals.
    pub times: usize,
    /// Readings.
    pub readings: usize,
    /// The first reversals, with their lines.
    pub at: String,
}

/// Readings in file order that jump back and forth by more than a tenth of the span, more often
/// than a chamber's cycles could (at least 3 reversals and 5 % of the readings): the column
/// holds something else.
fn jumps(temps: &[f64], lines: &[u64], span: f64) -> Result<(), Jumps> {
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
        return Err(Jumps {
            by: big,
            times: reversals.len(),
            readings: temps.len(),
            at: at.join(", "),
        });
    }
    Ok(())
}

/// The span of the `volt` column, checked: every reading a supply voltage (finite, 0 to
/// 1000 V).
///
/// # Errors
/// The first reading that is not, by line.
pub fn supply(table: &Table) -> Result<(f64, f64), WorkflowError> {
    use crate::columns as col;
    let v = table.column(col::VOLT).unwrap_or_default();
    if let Some(i) = v
        .iter()
        .position(|x| !(x.is_finite() && *x > 0.0 && *x <= 1000.0))
    {
        return Err(WorkflowError::Temperatures {
            path: table.path.clone(),
            source: ColumnError::NotAVoltage {
                line: table.lines[i],
                value: v[i],
            },
        });
    }
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Ok((lo, hi))
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
    // Where the chamber ramps monotonically, the time it had each sensor reading.
    let delay = table.column(col::TIME).and_then(|time| {
        let rising = chamber.windows(2).all(|w| w[1] >= w[0]);
        let falling = chamber.windows(2).all(|w| w[1] <= w[0]);
        if !(rising || falling) {
            return None;
        }
        let sign = if rising { 1.0 } else { -1.0 };
        median(
            sensor
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
                .collect(),
        )
    });
    if offset.abs() < 0.005 && delay.is_none_or(|d| d.abs() < 0.5) {
        return Some(
            "the sensor's temperature follows the chamber's (median difference under 0.01 C)"
                .into(),
        );
    }
    let mut text = format!(
        "the sensor's temperature differs from the chamber's by {offset:+.2} C (median); the fit uses the sensor's"
    );
    match delay {
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
    Some(text)
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
        let err = check(&narrow, "temp").unwrap_err();
        assert!(
            matches!(
                &err,
                WorkflowError::Temperatures {
                    source: ColumnError::Narrow { .. },
                    ..
                }
            ),
            "{err:?}"
        );
        let e = err.to_string();
        assert!(e.contains("span 3.0 C") && e.contains("order: none"), "{e}");
        let whole = table((0..400).map(|i| (f64::from(i) / 4.0).round()).collect());
        assert_eq!(check(&whole, "temp").unwrap().quantum, Some(1.0));
    }

    #[test]
    fn readings_that_are_not_temperatures_are_located() {
        let mut t: Vec<f64> = (0..50).map(f64::from).collect();
        t[7] = -300.0;
        let err = check(&table(t), "temp").unwrap_err();
        assert!(
            matches!(
                &err,
                WorkflowError::Temperatures {
                    source: ColumnError::NotATemperature { line: 9, .. },
                    ..
                }
            ),
            "{err:?}"
        );
        let e = err.to_string();
        assert!(e.contains("line 9: temp = -300"), "{e}");
        let mixed = table(
            (0..200)
                .map(|i| if i % 2 == 0 { 9.8 } else { -9.8 })
                .collect(),
        );
        let err = check(&mixed, "temp").unwrap_err();
        assert!(
            matches!(&err, WorkflowError::Temperatures { source: ColumnError::Jumps(j), .. } if j.times >= 3),
            "{err:?}"
        );
        assert!(std::error::Error::source(&err).is_some());
        let e = err.to_string();
        assert!(
            e.starts_with("ramp.csv: ")
                && e.contains("jump back and forth")
                && e.contains("line 4"),
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
    fn the_lag_behind_the_chamber_is_measured() {
        let ramp = |lag: f64| {
            let r = crate::sim::ramp::Ramp {
                from: -40.0,
                to: 70.0,
                seconds: 7200.0,
                uneven: false,
                lag,
                self_heating: None,
                step: None,
            }
            .temperatures(400);
            Table {
                path: "ramp.csv".into(),
                names: vec!["temp".into(), "chamber_temp".into(), "time".into()],
                columns: vec![r.sensor, r.chamber, r.time],
                lines: (2..402).collect(),
            }
        };
        let text = lag(&ramp(120.0)).unwrap();
        let secs: f64 = text
            .split("read ")
            .nth(1)
            .and_then(|t| t.split(" s").next())
            .and_then(|t| t.parse().ok())
            .unwrap();
        assert!((100.0..=125.0).contains(&secs), "{text}");
        assert!(lag(&ramp(0.0)).unwrap().contains("follows the chamber's"));
    }
}
