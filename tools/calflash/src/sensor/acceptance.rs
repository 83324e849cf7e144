//! The acceptance checks every workflow shares (noise, inversion error, outliers, the device's
//! f32 correction against f64), and the outputs at or beyond the ADC rails, left out of every
//! fit and said.

use std::path::Path;

use spincal::model::Rails;

use super::{Finding, Options, PointFit, Verdict, WorkflowError, table};
use crate::stats::pure_error;

/// The stored correction's distance from the exact inverse beyond which a unit is rejected
/// when it also exceeds the noise: 10 ppm of the calibrated full scale. Between what the device
/// resolves and this, it is a REVIEW that says the figure.
const INVERSE_SHARE_OF_FULL_SCALE: f64 = 1e-5;

/// A fit whose residual noise is significantly above the noise of its repeated observations
/// (or of its observations at rest fitted alone) by this factor or more misses a term:
/// REVIEW; by [`MISFIT_REJECT`] or more, REJECT (its coefficients have absorbed what the model
/// lacks, and its stated 1-sigma is the misfit's, not the sensor's).
const MISFIT_REVIEW: f64 = 2.0;
/// See [`MISFIT_REVIEW`].
const MISFIT_REJECT: f64 = 10.0;

/// The fits held against their noise.
#[derive(Default)]
struct Misfits {
    /// How many passed.
    held: usize,
    /// The largest ratio among them, and where.
    worst: Option<(f64, String)>,
}

/// The acceptance checks every workflow shares.
pub(crate) fn findings(
    points: &[PointFit],
    axis_names: &[String],
    units: &[&str],
    opts: &Options,
    device_error: &[f64],
) -> Vec<Finding> {
    let mut out = Vec::new();
    // What the device can represent of each output: eight f32 steps at the output's full scale,
    // or a tenth of one converter code, whichever is larger. The f32 correction is held to it;
    // so is the stored correction's distance from the exact inverse, beside a tenth of the
    // noise (averaged bench readings can be quieter than what the device resolves, so their
    // noise alone is not the yardstick: 0.7e-3 m/s^2 at 1,764 m/s^2 is 0.4 ppm of the input).
    let full_scale = |a: usize| {
        points
            .iter()
            .flat_map(|p| p.axes.get(a).map(|x| x.input.iter()).into_iter().flatten())
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let tolerance = |a: usize| {
        let full_scale = full_scale(a);
        let code = points
            .iter()
            .filter_map(|p| p.axes.get(a))
            .map(|x| 1.0 / x.coef(&x.own).abs())
            .filter(|q| q.is_finite())
            .fold(0.0f64, f64::max);
        (8.0 * f64::from(f32::EPSILON) * full_scale).max(0.1 * code)
    };
    // The outlier test is the unit's, not each fit's: a fit's Bonferroni p-value is held at
    // `alpha` over all the unit's fits (its axes at each table point; one continuous model's
    // points are one fit), so that a clean unit of six axes is not called REVIEW six times as
    // often as one of a single axis.
    let fits = axis_names.len()
        * if points.len() > 1
            && points.windows(2).all(|w| {
                w[0].axes
                    .iter()
                    .zip(&w[1].axes)
                    .all(|(a, b)| a.lines == b.lines)
            })
        {
            1
        } else {
            points.len()
        };
    // The fits whose residual noise was held against a noise estimate made without the model,
    // and the largest ratio among those that passed.
    let mut misfits = Misfits::default();
    for (a, name) in axis_names.iter().enumerate() {
        // Points of one continuous model share its outliers: each is named once.
        let mut named: Vec<Vec<u64>> = Vec::new();
        let shared = points.len() > 1
            && points
                .windows(2)
                .all(|w| w[0].axes[a].lines == w[1].axes[a].lines);
        let noise = points.iter().map(|p| p.noise[a]).fold(0.0, f64::max);
        let inv = points
            .iter()
            .map(|p| p.inversion_error[a])
            .fold(0.0, f64::max);
        let unit = units[a];
        match opts.max_noise {
            Some(limit) if noise > limit => out.push(Finding {
                verdict: Verdict::Reject,
                text: format!(
                    "{name}: residual noise {noise:.3e} {unit} exceeds the limit {limit:.3e}"
                ),
            }),
            Some(limit) => out.push(Finding {
                verdict: Verdict::Accept,
                text: format!(
                    "{name}: residual noise {noise:.3e} {unit} within the limit {limit:.3e}"
                ),
            }),
            None => {}
        }
        let resolved = tolerance(a);
        let full_scale = full_scale(a);
        out.push(if inv <= 0.1 * noise || inv <= resolved {
            Finding {
                verdict: Verdict::Accept,
                text: format!(
                    "{name}: the device's correction is within {inv:.2e} {unit} of the exact inverse over the calibrated range ({:.1e} of the noise, {:.1e} of what the device resolves)",
                    inv / noise,
                    inv / resolved
                ),
            }
        } else if inv <= noise.max(INVERSE_SHARE_OF_FULL_SCALE * full_scale) {
            Finding {
                verdict: Verdict::Review,
                text: format!(
                    "{name}: the device's correction is {inv:.2e} {unit} from the exact inverse ({:.1} ppm of the calibrated full scale {full_scale:.4e}, {:.2} of the noise {noise:.2e}): more than the device resolves ({resolved:.2e}); hold it against the requirement",
                    1e6 * inv / full_scale,
                    inv / noise
                ),
            }
        } else {
            Finding {
                verdict: Verdict::Reject,
                text: format!(
                    "{name}: the device's correction is {inv:.2e} {unit} from the exact inverse, more than the noise {noise:.2e} and {:.0} ppm of the calibrated full scale {full_scale:.4e}: the forward model is too nonlinear for the device's correction form",
                    1e6 * inv / full_scale
                ),
            }
        });
        for p in points {
            let f = &p.axes[a].fit;
            let where_ = table::describe(&table::Point {
                temp: p.temp,
                volt: p.volt,
                rows: vec![],
            });
            let at: Vec<u64> = f
                .influence
                .outliers
                .iter()
                .filter(|(_, p_value)| p_value * fits as f64 <= opts.alpha)
                .map(|(i, _)| p.axes[a].lines[*i])
                .collect();
            if !at.is_empty() && !named.contains(&at) {
                let lines: Vec<String> = at.iter().map(u64::to_string).collect();
                named.push(at);
                let where_ = if shared {
                    "all temperatures".to_string()
                } else {
                    where_
                };
                out.push(Finding {
                    verdict: Verdict::Review,
                    text: format!("{name} at {where_}: outliers at line {}", lines.join(", ")),
                });
            }
            // One continuous model is one fit: held once.
            if shared && !std::ptr::eq(p, &points[0]) {
                continue;
            }
            let Some(reference) = &p.axes[a].noise_reference else {
                continue;
            };
            let test = pure_error::test(f.sigma2, f.dof, &reference.noise);
            let where_ = if shared {
                "all temperatures".to_string()
            } else {
                table::describe(&table::Point {
                    temp: p.temp,
                    volt: p.volt,
                    rows: vec![],
                })
            };
            let misfit = test.p_value * fits as f64 <= opts.alpha;
            let verdict = match test.ratio {
                r if misfit && r >= MISFIT_REJECT => Verdict::Reject,
                r if misfit && r >= MISFIT_REVIEW => Verdict::Review,
                _ => Verdict::Accept,
            };
            if verdict == Verdict::Accept {
                if misfits.worst.as_ref().is_none_or(|(r, _)| test.ratio > *r) {
                    misfits.worst = Some((test.ratio, format!("{name} at {where_}")));
                }
                misfits.held += 1;
                continue;
            }
            let scale = (f.sigma2.sqrt() / p.noise[a]).abs();
            out.push(Finding {
                verdict,
                text: format!(
                    "{name} at {where_}: the model does not fit: residual noise {:.3e} {unit} is {:.1} times the noise of {} ({:.3e} {unit}; F = {:.3e}, p = {:.1e}): a term the observations need is missing from the model (a lever-arm component, a nonlinear or cross-axis term) or an input column is wrong",
                    p.noise[a],
                    test.ratio,
                    reference.source.words(),
                    reference.noise.variance.sqrt() / scale,
                    test.f,
                    test.p_value
                ),
            });
        }
    }
    if let Some((ratio, at)) = misfits.worst {
        out.push(Finding {
            verdict: Verdict::Accept,
            text: format!(
                "the residual noise of {} fit(s) is held against the noise of their repeated observations or observations at rest: the largest is {ratio:.2} times it ({at}); a misfit is named from {MISFIT_REVIEW} times",
                misfits.held
            ),
        });
    }
    // No blob (the device refused the calibration): nothing of the device's to compare.
    if device_error.is_empty() {
        return out;
    }
    let (ratio, worst) = device_error
        .iter()
        .enumerate()
        .map(|(a, e)| (e / tolerance(a), a))
        .fold((0.0, 0), |best, x| if x.0 > best.0 { x } else { best });
    let (name, unit) = (
        axis_names.get(worst).map_or("", String::as_str),
        units.get(worst).copied().unwrap_or(""),
    );
    let e = device_error.get(worst).copied().unwrap_or(0.0);
    out.push(Finding {
        verdict: if ratio <= 1.0 {
            Verdict::Accept
        } else {
            Verdict::Review
        },
        text: format!(
            "the device's f32 correction matches the f64 correction to {ratio:.1e} of what it can hold at most (eight f32 steps at full scale or a tenth of a code; {name}: {e:.2e} {unit} against {:.2e})",
            tolerance(worst)
        ),
    });
    out
}

/// Outputs at or beyond the ADC rails that leave nothing to fit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RailsError {
    /// Codes beyond the rails that another format of the same width reads.
    #[error("{advice} (the format given is {given})")]
    OtherFormat {
        /// Which format they show, and the option that reads it.
        advice: String,
        /// The format given.
        given: String,
    },
    /// Every observation has an output at or beyond the rails.
    #[error(
        "every observation has an output at or beyond the ADC rails {} and {} (lines {lines}): check --codes",
        rails.lo,
        rails.hi
    )]
    Every {
        /// The rails.
        rails: Rails,
        /// The first lines, listed.
        lines: String,
    },
}

/// Removes the observations whose outputs are at or beyond the ADC rails (saturated codes, or
/// values no converter of these rails can give: a typing slip, a logger's sentinel) so that
/// none is ever fitted. Returns the finding that names them (`None` when there are none).
///
/// # Errors
/// When no observation is left.
pub(crate) fn exclude_beyond_rails(
    table: &mut crate::obs::Table,
    outputs: &[&str],
    rails: &Rails,
    path: &Path,
) -> Result<Option<Finding>, WorkflowError> {
    let beyond = |below: bool| {
        outputs
            .iter()
            .filter_map(|c| table.column(c))
            .flatten()
            .filter(|x| {
                if below {
                    **x < f64::from(rails.lo)
                } else {
                    **x > f64::from(rails.hi)
                }
            })
            .count()
    };
    let fail = |source: RailsError| WorkflowError::Rails {
        path: path.to_path_buf(),
        source,
    };
    if let Some(advice) = crate::obs::codes::mismatch(beyond(true), beyond(false), *rails) {
        return Err(fail(RailsError::OtherFormat {
            advice,
            given: crate::obs::codes::name(*rails),
        }));
    }
    let bad: Vec<usize> = (0..table.len())
        .filter(|&r| {
            outputs.iter().any(|c| {
                table.column(c).is_some_and(|v| {
                    let x = v[r];
                    !(x > f64::from(rails.lo) && x < f64::from(rails.hi))
                })
            })
        })
        .collect();
    if bad.is_empty() {
        return Ok(None);
    }
    let lines: Vec<String> = bad
        .iter()
        .take(10)
        .map(|r| table.lines[*r].to_string())
        .collect();
    let more = if bad.len() > 10 {
        format!(" and {} more", bad.len() - 10)
    } else {
        String::new()
    };
    if bad.len() == table.len() {
        return Err(fail(RailsError::Every {
            rails: *rails,
            lines: format!("{}{more}", lines.join(", ")),
        }));
    }
    let keep: Vec<usize> = (0..table.len()).filter(|r| !bad.contains(r)).collect();
    *table = table.select(&keep);
    Ok(Some(Finding {
        verdict: Verdict::Review,
        text: format!(
            "{} observation(s) with an output at or beyond the ADC rails {} and {} were left out of the fit: line {}{more}",
            bad.len(),
            rails.lo,
            rails.hi,
            lines.join(", ")
        ),
    }))
}
