//! A mission profile's summary as text.

use std::fmt::Write;

use crate::mission::Profile;
use crate::mission::summary::{BINS, Summary};

const G: f64 = 9.806_65;
const AXES: [&str; 3] = ["x", "y", "z"];

/// The summary as the terminal shows it; `k2` (ug/g^2 per axis) adds the rectification error.
#[must_use]
pub fn text(p: &Profile, s: &Summary, k2: Option<[f64; 3]>) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Mission profile {}: {} samples over {:.3} s (step {:.3e} s, {:.0} Hz)",
        p.source.display(),
        s.samples,
        s.duration,
        s.step,
        1.0 / s.step
    );
    for n in &s.notes {
        let _ = writeln!(o, "  note: {n}");
    }
    let _ = writeln!(
        o,
        "\n  {:<6} {:>12} {:>12} {:>12} {:>12}   time at each of {BINS} levels, min to max (%)",
        "", "min", "max", "mean", "rms"
    );
    for r in &s.ranges {
        let shares: Vec<String> = r
            .time_share
            .iter()
            .map(|v| format!("{:.0}", 100.0 * v))
            .collect();
        let _ = writeln!(
            o,
            "  {:<6} {:>12.4} {:>12.4} {:>12.4} {:>12.4}   {}",
            r.name,
            r.min,
            r.max,
            r.mean,
            r.rms,
            shares.join(" ")
        );
    }
    let _ = writeln!(
        o,
        "  (f in m/s^2, w in rad/s, dw in rad/s^2, temp in C, volt in V)"
    );
    if let Some(pk) = &s.peak {
        let _ = writeln!(
            o,
            "\n  Peak specific force: {:.1} m/s^2 ({:.1} g) along {}{} at t = {:.4} s",
            pk.value.abs(),
            pk.value.abs() / G,
            if pk.value < 0.0 { "-" } else { "+" },
            AXES[pk.axis],
            pk.t
        );
    }
    if let Some(sp) = &s.spin {
        let over: Vec<String> = sp
            .over_time
            .iter()
            .map(|(t, r)| format!("{t:.1} s {r:.1}"))
            .collect();
        let _ = writeln!(
            o,
            "  Spin about {}: peak {:.1} rev/s ({:.0} deg/s); over the flight (rev/s): {}",
            AXES[sp.axis],
            sp.peak_rev_s,
            sp.peak_rev_s * 360.0,
            over.join(", ")
        );
    }
    match &s.no_vibration {
        Some(why) => {
            let _ = writeln!(o, "  Vibration: not measured: {why}");
        }
        None => {
            let _ = writeln!(
                o,
                "\n  Vibration above {} Hz (specific force less its moving average; in a rolling unit the transverse\n  rigid-body forces turn at the spin rate and count here too):",
                s.vibration_above
            );
            for v in &s.vibration {
                let bands: Vec<String> = v
                    .bands
                    .iter()
                    .map(|(lo, hi, ms)| format!("{lo:.0}-{hi:.0} Hz {:.3e}", ms.sqrt()))
                    .collect();
                let rect = match k2 {
                    Some(k) => format!(
                        "K2 {} ug/g^2 rectifies {:.2} ug",
                        k[v.axis],
                        k[v.axis] * v.mean_square_g2
                    ),
                    None => format!(
                        "K2 of 1 ug/g^2 rectifies {:.3} ug",
                        v.rectification_ug_per_ug_g2
                    ),
                };
                let _ = writeln!(
                    o,
                    "    {}: rms {:.4} g, peak at {:.1} Hz; {rect}; band rms (g): {}",
                    AXES[v.axis],
                    v.mean_square_g2.sqrt(),
                    v.peak_hz,
                    bands.join(", ")
                );
                if let (Some(first), Some(last)) = (v.transients.first(), v.transients.last()) {
                    let _ = writeln!(
                        o,
                        "       {} of {} segments left out as transients (over ten times the median's mean square), from t = {first:.3} s to {last:.3} s",
                        v.transients.len(),
                        v.segments
                    );
                }
            }
        }
    }
    o
}

/// One plan over a mission, per block: the prediction's standard deviation in units of the
/// output noise, averaged (RMS) and at its worst, over the flight's moments the equipment
/// reaches and over the rest (extrapolation).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PlanOverMission {
    /// The plan.
    pub plan: String,
    /// Observations.
    pub n: usize,
    /// Per block: `tr(C B)` over the reach (the mean prediction variance, sigma^2 units).
    pub mean_inside: Vec<f64>,
    /// The largest `f' C f` there.
    pub worst_inside: Vec<f64>,
    /// `tr(C B)` beyond the reach.
    pub mean_beyond: Vec<f64>,
    /// The largest `f' C f` there.
    pub worst_beyond: Vec<f64>,
}

/// A set of plans over one mission.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OverMission {
    /// The profile.
    pub profile: String,
    /// What set the reach ("the candidates", "the plans").
    pub reach: String,
    /// Per block: its label, the share of the flight inside the reach, and what is beyond.
    pub blocks: Vec<(String, f64, String)>,
    /// Variables assumed (a flight without a temperature column).
    pub assumed: Vec<String>,
    /// The plans.
    pub plans: Vec<PlanOverMission>,
}

/// The plans over the mission as the terminal shows them: per block, each plan's RMS and worst
/// prediction error in units of the noise (1 sigma) where the bench reaches and beyond it, and
/// its mean prediction variance against the first plan's.
#[must_use]
pub fn plans_text(m: &OverMission) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "\nOver the mission {} (prediction error in units of the output noise, 1 sigma):",
        m.profile
    );
    if !m.assumed.is_empty() {
        let _ = writeln!(
            o,
            "  the profile does not give {}: the bench's value is assumed",
            m.assumed.join(", ")
        );
    }
    let width = m
        .plans
        .iter()
        .map(|p| p.plan.len())
        .max()
        .unwrap_or(8)
        .clamp(12, 40);
    for (b, (label, inside, beyond)) in m.blocks.iter().enumerate() {
        let _ = writeln!(
            o,
            "  {}{} % of the flight within what {} reach; beyond: {beyond}",
            if m.blocks.len() > 1 {
                format!("axis {label}: ")
            } else {
                String::new()
            },
            crate::design::space::percent(*inside),
            m.reach
        );
        let _ = writeln!(
            o,
            "    {:<width$} {:>5} {:>10} {:>10} {:>12} {:>10} {:>10}",
            "plan", "n", "rms", "worst", "variance/1st", "rms beyond", "worst"
        );
        let first = m.plans.first().map_or(1.0, |p| p.mean_inside[b]);
        for p in &m.plans {
            let beyond = |v: f64| {
                if *inside < 1.0 {
                    crate::report::terminal::num(v.sqrt())
                } else {
                    "-".to_string()
                }
            };
            let _ = writeln!(
                o,
                "    {:<width$} {:>5} {:>10.4} {:>10.4} {:>12.3} {:>10} {:>10}",
                clip(&p.plan, width),
                p.n,
                p.mean_inside[b].sqrt(),
                p.worst_inside[b].sqrt(),
                p.mean_inside[b] / first,
                beyond(p.mean_beyond[b]),
                beyond(p.worst_beyond[b]),
            );
        }
    }
    o
}

/// `text` cut to `width` characters, its end marked.
fn clip(text: &str, width: usize) -> String {
    if text.chars().count() <= width {
        text.to_string()
    } else {
        let head: String = text.chars().take(width.saturating_sub(3)).collect();
        format!("{head}...")
    }
}
