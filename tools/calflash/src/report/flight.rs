//! What `calflash flight` says: the verdict first, the filter's fit to the data, each sensor
//! error against the calibration, and the trajectory against GNSS and the barometer.

use std::fmt::Write as _;

use crate::nav::check::{Checked, PriorSource};
use crate::nav::input::FixCounts;

/// The terminal text.
#[must_use]
pub fn text(serial: &str, c: &Checked, counts: &FixCounts) -> String {
    let mut s = String::new();
    let v = &c.verdict;
    let _ = writeln!(s, "calflash flight: unit {serial}: {}: {}", v.word, v.why);
    let k = &v.consistency;
    let _ = writeln!(
        s,
        "  the filter's fit: {} of {} GNSS and barometer innovations inside their 95 % bounds ({:.1} %), mean NIS {:.2} (1 when its covariance is right), {} refused beyond 5 sigma",
        k.inside_95,
        k.innovations,
        100.0 * k.inside_95 as f64 / k.innovations.max(1) as f64,
        k.mean_nis,
        k.refused
    );
    let _ = writeln!(
        s,
        "  GNSS: {} rows, {} without a fix, {} repeating the last fix (left out); heading at rest {:.1} +- {:.1} deg from the track",
        counts.rows, counts.no_fix, counts.repeated, c.heading_deg.0, c.heading_deg.1
    );
    let _ = writeln!(
        s,
        "  {:.2} s at rest before launch; noise densities from it: accelerometer {:.3e} m/s^2/sqrt(Hz), gyro {:.3e} rad/s/sqrt(Hz); {:.3} s of flagged samples navigated on doubt; barometer left out {:.1} s near and beyond Mach 1",
        c.rest_seconds, c.noise.0, c.noise.1, c.pass.flagged_seconds, c.pass.baro_skipped_seconds
    );
    match &c.prior {
        PriorSource::Calibration => {
            let _ = writeln!(s, "  prior: the calibration's own covariance");
        }
        PriorSource::Stated(p) => {
            let _ = writeln!(
                s,
                "  prior: no covariance in a calibration, so a stated one (--prior): accelerometer bias {} m/s^2, gyro bias {:.3e} rad/s, scale factors {} and {}",
                p.accel_bias, p.gyro_bias, p.accel_scale, p.gyro_scale
            );
        }
    }
    if k.fits {
        let _ = writeln!(
            s,
            "  | term | calibration 1-sigma | in flight | 1-sigma | learnt | z | p | |"
        );
        for t in &v.terms {
            let (z, p) = match (t.z, t.p) {
                (Some(z), Some(p)) => (format!("{z:+.2}"), format!("{p:.3}")),
                _ => ("-".into(), "-".into()),
            };
            let mark = if t.shifted {
                "SHIFTED"
            } else if t.z.is_none() {
                "not observed"
            } else {
                ""
            };
            let _ = writeln!(
                s,
                "  | {} {} | {:.3e} | {:+.3e} | {:.3e} | {:.0} % | {z} | {p} | {mark} |",
                t.name,
                t.unit,
                t.prior_sigma,
                t.estimate,
                t.sigma,
                100.0 * t.learnt
            );
        }
        if let Some((chi2, dof, p)) = v.overall {
            let _ = writeln!(
                s,
                "  overall over the observed terms: chi-square {chi2:.2} on {dof} dof, p = {p:.3}"
            );
        }
        for (name, x, sd) in &c.shifts {
            let _ = writeln!(
                s,
                "  {name}: shifted by {x:+.4e} +- {sd:.2e} (the flight alone, its prior opened)"
            );
        }
    }
    if let Some((rms, n)) = c.track_rms {
        let _ = writeln!(
            s,
            "  smoothed horizontal track against {n} GNSS fixes: RMS {rms:.2} m"
        );
    }
    if let Some((rms, n)) = c.height_rms {
        let _ = writeln!(
            s,
            "  smoothed height against {n} barometer readings: RMS {rms:.2} m"
        );
    }
    s
}

/// The JSON record.
#[must_use]
pub fn json(serial: &str, c: &Checked, counts: &FixCounts) -> serde_json::Value {
    serde_json::json!({
        "schema": "calflash.flight/1",
        "kind": "flight",
        "serial": serial,
        "verdict": c.verdict.word,
        "why": c.verdict.why,
        "consistency": c.verdict.consistency,
        "terms": c.verdict.terms,
        "overall": c.verdict.overall,
        "shifts": c.shifts.iter().map(|(n, x, s)| serde_json::json!({"term": n, "estimate": x, "sigma": s})).collect::<Vec<_>>(),
        "track_rms_m": c.track_rms.map(|x| x.0),
        "height_rms_m": c.height_rms.map(|x| x.0),
        "heading_deg": [c.heading_deg.0, c.heading_deg.1],
        "gnss_rows": counts.rows,
        "gnss_no_fix": counts.no_fix,
        "gnss_repeated": counts.repeated,
        "flagged_seconds": c.pass.flagged_seconds,
    })
}

/// Every innovation as CSV: `t, measurement, innovation, sigma, taken`.
#[must_use]
pub fn innovations_csv(said: &[crate::nav::run::Said]) -> String {
    use crate::nav::run::Kind;
    let mut s = String::from("t,measurement,innovation,sigma,taken\n");
    for x in said {
        let what = match x.kind {
            Kind::Pad => "pad".to_string(),
            Kind::Position(a) => format!("position_{}", ["east", "north", "up"][a.min(2)]),
            Kind::Velocity(a) => format!("velocity_{}", ["east", "north", "up"][a.min(2)]),
            Kind::Baro => "baro".to_string(),
        };
        let _ = writeln!(
            s,
            "{},{what},{},{},{}",
            x.t,
            x.value,
            x.sigma,
            u8::from(x.taken)
        );
    }
    s
}
