//! The check between the stages: does each sensor's stage-one bias and scale factor still hold
//! in the assembled unit? Stage two estimates a bias change `beta_i` and the sensing row `m_i`
//! (through the stage-one polynomial, so `|m_i| = 1` when the scale factor held); each is
//! tested against zero change with a standard error that carries both stages (stage two's
//! scatter, and stage one's own error through the stage-two fit), Holm over the twelve tests.

use serde::Serialize;

use super::one::OUTPUTS;
use crate::sensor::{Finding, Verdict};
use crate::stats::dist::normal_two_sided;

/// One sensor's check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensorCheck {
    /// The output.
    pub output: String,
    /// The sensor's serial (stage one).
    pub serial: String,
    /// The stage-one record.
    pub record: String,
    /// The bias change, SI.
    pub bias_change: f64,
    /// Its standard error (both stages).
    pub bias_se: f64,
    /// Holm-adjusted decision: the bias moved.
    pub bias_moved: bool,
    /// The relative scale-factor change, `|m| - 1`.
    pub scale_change: f64,
    /// Its standard error.
    pub scale_se: f64,
    /// The scale factor moved.
    pub scale_moved: bool,
    /// The sensing direction's angle from the unit's axis, rad (the misalignment assembly
    /// made).
    pub misalignment: f64,
    /// The sensing direction, a unit vector in the unit's axes.
    pub direction: [f64; 3],
}

/// The check of all six sensors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// Family-wise level.
    pub alpha: f64,
    /// Per sensor.
    pub sensors: Vec<SensorCheck>,
}

/// What one sensor's stage-two fit says: the bias change and the sensing row, with the
/// covariance of `[beta, m0, m1, m2]` under "stage one holds" (both stages).
#[derive(Debug, Clone, PartialEq)]
pub struct Moved {
    /// The bias change, SI.
    pub beta: f64,
    /// The sensing row.
    pub m: [f64; 3],
    /// Covariance of `[beta, m0, m1, m2]`.
    pub cov: [[f64; 4]; 4],
}

/// Tests the six sensors (`moved[k]` of output `k`, with its serial and record) at
/// family-wise level `alpha`.
#[must_use]
pub fn check(moved: &[Moved], who: &[(String, String)], alpha: f64) -> Check {
    let mut p = Vec::new();
    let mut rows = Vec::new();
    for (k, m) in moved.iter().enumerate() {
        let own = k % 3;
        let norm = m.m.iter().map(|v| v * v).sum::<f64>().sqrt();
        // d|m| / dm = m / |m|.
        let g: [f64; 3] = m.m.map(|v| v / norm);
        let var_s: f64 = (0..3)
            .flat_map(|a| (0..3).map(move |b| (a, b)))
            .map(|(a, b)| g[a] * g[b] * m.cov[1 + a][1 + b])
            .sum();
        let (bias_se, scale_se) = (m.cov[0][0].max(0.0).sqrt(), var_s.max(0.0).sqrt());
        let scale_change = norm - 1.0;
        p.push(normal_two_sided(m.beta / bias_se));
        p.push(normal_two_sided(scale_change / scale_se));
        rows.push(SensorCheck {
            output: OUTPUTS[k].into(),
            serial: who[k].0.clone(),
            record: who[k].1.clone(),
            bias_change: m.beta,
            bias_se,
            bias_moved: false,
            scale_change,
            scale_se,
            scale_moved: false,
            misalignment: (m.m[own] / norm).clamp(-1.0, 1.0).acos(),
            direction: m.m.map(|v| v / norm),
        });
    }
    let rejected = crate::stats::multiple::holm(&p, alpha);
    for (k, r) in rows.iter_mut().enumerate() {
        r.bias_moved = rejected[2 * k];
        r.scale_moved = rejected[2 * k + 1];
    }
    Check {
        alpha,
        sensors: rows,
    }
}

/// A bias change this many of its sigmas is more than assembly moves a part.
const FAR_MOVED: f64 = 10.0;

/// A sensing direction no assembly tolerance explains (beyond 60 degrees of its axis): the
/// sensor mounted backwards or on another axis, or its record given for another output.
fn mounted_wrong(s: &SensorCheck) -> Option<String> {
    let (angle, d) = (s.misalignment, s.direction);
    if angle <= 60f64.to_radians() {
        return None;
    }
    let axes = ["x", "y", "z"];
    let own = axes.iter().position(|a| s.output.ends_with(a)).unwrap_or(0);
    let (k, _) = d
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .unwrap_or((own, &1.0));
    let sign = if d[k] < 0.0 { "-" } else { "+" };
    Some(if k == own && d[k] < 0.0 {
        format!(
            "senses along its own axis reversed ({:.1} degrees off, its scale factor negated): the sensor is mounted backwards; mount it as stage one had it, or calibrate it again as mounted",
            angle.to_degrees()
        )
    } else if k == own {
        format!(
            "senses {:.1} degrees off its axis: no assembly tolerance explains it; check the sensor's mounting and its record",
            angle.to_degrees()
        )
    } else {
        format!(
            "senses along the unit's {sign}{} axis, not {}: the sensor is mounted on another axis, or its record was given for another output (the records go in the order a_x,a_y,a_z,g_x,g_y,g_z as mounted)",
            axes[k], axes[own]
        )
    })
}

impl Check {
    /// The findings: REVIEW for each part that moved in assembly, else one ACCEPT saying stage
    /// one holds.
    #[must_use]
    pub fn findings(&self) -> Vec<Finding> {
        let mut out = Vec::new();
        for s in &self.sensors {
            let unit = if s.output.starts_with('a') {
                "m/s^2"
            } else {
                "rad/s"
            };
            if let Some(how) = mounted_wrong(s) {
                out.push(Finding {
                    verdict: Verdict::Reject,
                    text: format!(
                        "{} (sensor {}, stage one {}): {how}",
                        s.output, s.serial, s.record
                    ),
                });
                continue;
            }
            if s.scale_moved {
                out.push(Finding {
                    verdict: Verdict::Review,
                    text: format!(
                        "{} (sensor {}): the scale factor moved in assembly by {:+.1} ppm +- {:.1} (z = {:.1}; stage one {}): assembly stressed the part, stage two's scale factor is applied",
                        s.output,
                        s.serial,
                        s.scale_change * 1e6,
                        s.scale_se * 1e6,
                        s.scale_change / s.scale_se,
                        s.record
                    ),
                });
            }
            if s.bias_moved {
                out.push(Finding {
                    verdict: Verdict::Review,
                    text: format!(
                        "{} (sensor {}): the bias moved in assembly by {:+.3e} {unit} +- {:.1e} (z = {:.1}; stage one {}): stage two's bias is applied",
                        s.output,
                        s.serial,
                        s.bias_change,
                        s.bias_se,
                        s.bias_change / s.bias_se,
                        s.record
                    ),
                });
            }
        }
        // Two sensors of one kind that both moved by far more than assembly moves a part: their
        // records may have been given in each other's place.
        for family in ["a", "g"] {
            let far: Vec<&SensorCheck> = self
                .sensors
                .iter()
                .filter(|s| s.output.starts_with(family) && s.bias_moved)
                .filter(|s| (s.bias_change / s.bias_se).abs() >= FAR_MOVED)
                .collect();
            if far.len() >= 2 {
                let names: Vec<String> = far
                    .iter()
                    .map(|s| {
                        format!(
                            "{} (sensor {}, z {:.0})",
                            s.output,
                            s.serial,
                            s.bias_change / s.bias_se
                        )
                    })
                    .collect();
                out.push(Finding {
                    verdict: Verdict::Review,
                    text: format!(
                        "{} {} moved by more than {FAR_MOVED} of their sigmas: their stage-one records may be in each other's place; --as-built checks each record's sensor against the unit's as-built list",
                        names.join(", "),
                        if far.len() == 2 { "both" } else { "all" }
                    ),
                });
            }
        }
        if out.is_empty() {
            let worst = self
                .sensors
                .iter()
                .flat_map(|s| {
                    [
                        (s.bias_change / s.bias_se).abs(),
                        (s.scale_change / s.scale_se).abs(),
                    ]
                })
                .fold(0.0, f64::max);
            out.push(Finding {
                verdict: Verdict::Accept,
                text: format!(
                    "stage one holds for the six sensors: no bias or scale factor moved in assembly (Holm at {}; largest |z| {worst:.2})",
                    self.alpha
                ),
            });
        }
        out
    }

    /// The check as lines of text.
    #[must_use]
    pub fn lines(&self) -> Vec<String> {
        self.sensors
            .iter()
            .map(|s| {
                format!(
                    "{} {}: bias change {:+.3e} +- {:.1e}{}, scale change {:+.1} +- {:.1} ppm{}, sensing direction {:.3} mrad off its axis",
                    s.output,
                    s.serial,
                    s.bias_change,
                    s.bias_se,
                    if s.bias_moved { " MOVED" } else { "" },
                    s.scale_change * 1e6,
                    s.scale_se * 1e6,
                    if s.scale_moved { " MOVED" } else { "" },
                    s.misalignment * 1e3
                )
            })
            .collect()
    }
}
