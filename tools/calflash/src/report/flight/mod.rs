//! What `calflash flight` says: the verdict first, the filter's fit to the data, each sensor
//! error against the calibration, and the trajectory against GNSS and the barometer.

use crate::nav::verdict::DOES_NOT_FIT;
use std::fmt::Write as _;

use crate::nav::check::Checked;
use crate::nav::input::FixCounts;
use crate::nav::prior::PriorSource;

mod html;
pub use html::html;

/// The held-out fixes' lines (`flight --hold-out`).
#[must_use]
pub fn held_out_text(h: &crate::nav::consistency::HeldOut) -> String {
    format!(
        "  held out: every {}th fix after the launch ({} fixes) kept from the filter and the smoother: {} within 3 sigma of the smoothed track ({:.1} %, about 97 % where the stated sigmas are true; {:.1} % inside their 95 % bounds), RMS {:.2} m horizontally, the worst {:.1} sigma at {:.1} s: {}\n",
        h.every,
        h.fixes,
        h.within_3_sigma,
        100.0 * h.share(),
        100.0 * h.share_95(),
        h.rms_m,
        h.worst.0,
        h.worst.1,
        if h.believed {
            "the track can be believed"
        } else {
            "the track cannot be believed"
        }
    )
}

/// The terminal text.
#[must_use]
pub fn text(serial: &str, c: &Checked, counts: &FixCounts) -> String {
    let mut s = String::new();
    let v = &c.verdict;
    let _ = writeln!(s, "calflash flight: unit {serial}: {}: {}", v.word, v.why);
    let k = &v.consistency;
    let _ = writeln!(
        s,
        "  the filter's fit: {} of {} GNSS and barometer innovations inside their 95 % bounds ({:.1} %), mean NIS {:.2} over those taken (1 when its covariance is right), {} refused beyond 5 sigma",
        k.inside_95,
        k.innovations,
        100.0 * k.inside_95 as f64 / k.innovations.max(1) as f64,
        k.mean_nis,
        k.refused
    );
    for kind in &k.kinds {
        let runs: Vec<String> = kind.refused_runs.iter().map(ToString::to_string).collect();
        let _ = writeln!(
            s,
            "    {}: {} of {} inside ({:.1} %), mean NIS {:.2}, {} refused: {}{}",
            kind.kind,
            kind.inside_95,
            kind.innovations,
            100.0 * kind.inside_95 as f64 / kind.innovations.max(1) as f64,
            kind.mean_nis,
            kind.refused,
            if kind.fits { "fits" } else { "DOES NOT FIT" },
            if runs.is_empty() {
                String::new()
            } else {
                format!(" ({})", runs.join("; "))
            }
        );
    }
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
    if !c.pass.resets.is_empty() {
        let at: Vec<String> = c.pass.resets.iter().map(|t| format!("{t:.1}")).collect();
        let _ = writeln!(
            s,
            "  the navigation put back on GNSS {} time(s), at {} s: the first fix after it lost track (its velocity's 1-sigma over {} m/s, as a saturated setback leaves it)",
            c.pass.resets.len(),
            at.join(", "),
            spincal::flight::LOST_VELOCITY
        );
    }
    match &c.prior {
        PriorSource::Record(at) => {
            let _ = writeln!(
                s,
                "  prior: the calibration's own covariance, its whole model over the flight's rates ({at})"
            );
        }
        PriorSource::Factors => {
            let _ = writeln!(
                s,
                "  prior: the calibration's own covariance, from the blob's factors over the flight's rates"
            );
        }
        PriorSource::Stated(p) => {
            let _ = writeln!(
                s,
                "  prior: no covariance in a calibration, so a stated one (--prior): accelerometer bias {} m/s^2, gyro bias {:.3e} rad/s, scale factors {} and {}",
                p.accel_bias, p.gyro_bias, p.accel_scale, p.gyro_scale
            );
        }
    }
    if k.fits && c.verdict.word != DOES_NOT_FIT {
        let _ = writeln!(
            s,
            "  | term | calibration 1-sigma | in flight | 1-sigma | the flight alone, 1-sigma | z | p | |"
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
            let alone = t
                .flight_sigma
                .map_or_else(|| "nothing".to_string(), |f| format!("{f:.3e}"));
            let _ = writeln!(
                s,
                "  | {} {} | {:.3e} | {:+.3e} | {:.3e} | {alone} | {z} | {p} | {mark} |",
                t.name, t.unit, t.prior_sigma, t.estimate, t.sigma,
            );
        }
        if let Some((chi2, dof, p)) = v.overall {
            let _ = writeln!(
                s,
                "  overall over the observed terms: chi-square {chi2:.2} on {dof} dof, p = {p:.3}"
            );
        }
        let _ = writeln!(
            s,
            "  (z and p: each term on its own; SHIFTED: the terms a step-down test names, each tested given the shifts already named, as a shifted term drags the estimates its prior correlates with)"
        );
        let _ = writeln!(s, "  (the flight alone: {})", c.alone_from);
        for (name, x, sd) in &c.shifts {
            let _ = writeln!(
                s,
                "  {name}: shifted by {x:+.4e} +- {sd:.2e} (the flight alone, its prior opened)"
            );
        }
        if let Some(line) = undecided(c) {
            let _ = writeln!(s, "  {line}");
        }
        if !c.unseen.is_empty() {
            let _ = writeln!(s, "  not named, {UNSEEN_HEAD}:");
            for u in &c.unseen {
                let [from, sd, cal] = unseen_cells(c, u);
                let _ = writeln!(
                    s,
                    "  | {} | named from {from} | the flight's own 1-sigma {sd}, the calibration's {cal} |",
                    u.term
                );
            }
        }
    }
    if let Some((rms, n)) = c.track.track_rms {
        let _ = writeln!(
            s,
            "  smoothed horizontal track against {n} GNSS fixes: RMS {rms:.2} m"
        );
    }
    if let Some((rms, n)) = c.track.height_rms {
        let _ = writeln!(
            s,
            "  smoothed height against {n} barometer readings: RMS {rms:.2} m after their mean difference of {:+.2} m (the pad's height in the frame)",
            c.track.baro_offset.unwrap_or(0.0)
        );
    }
    s
}

/// What the list of terms not named says.
pub(super) const UNSEEN_HEAD: &str = "the smallest change at launch this flight names 19 times in 20 (each term's change opened alone, held against the flight's own 1-sigma of it and the calibration's, at the bar it was held to): a smaller one it CANNOT TELL from the calibration's own error and the flight's noise";

/// A term not named: the smallest change the flight names, with the unit, its own 1-sigma and
/// the calibration's.
pub(super) fn unseen_cells(c: &Checked, u: &crate::nav::check::Unseen) -> [String; 3] {
    let unit = c
        .verdict
        .terms
        .iter()
        .find(|t| t.name == u.term)
        .map_or("", |t| t.unit);
    [
        format!("{:.2e} {unit}", u.smallest).trim_end().to_string(),
        format!("{:.2e}", u.sigma),
        format!("{:.2e}", u.calibration),
    ]
}

/// The terms the flight cannot tell apart, in a sentence (`None` when there are none).
#[must_use]
pub fn undecided(c: &Checked) -> Option<String> {
    if c.undecided.is_empty() {
        return None;
    }
    let each: Vec<String> = c
        .undecided
        .iter()
        .map(|(n, x, sd)| format!("{n} ({x:+.3e} +- {sd:.2e})"))
        .collect();
    Some(format!(
        "the flight cannot tell what moved: each of {} alone explains it (its change opened alone), none fits the flight 6.8 times better than the others; they are the candidates the flight offers, not findings: a change of another term too small for it to name (listed below) may be what moved",
        each.join(", ")
    ))
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
        // A filter that does not fit names no shift: its estimates are not findings.
        "shifts": c.shifts.iter().filter(|_| c.verdict.word != DOES_NOT_FIT).map(|(n, x, s)| serde_json::json!({"term": n, "estimate": x, "sigma": s})).collect::<Vec<_>>(),
        "undecided": c.undecided.iter().map(|(n, x, s)| serde_json::json!({"term": n, "estimate": x, "sigma": s})).collect::<Vec<_>>(),
        "unseen": c.unseen,
        "track_rms_m": c.track.track_rms.map(|x| x.0),
        "height_rms_m": c.track.height_rms.map(|x| x.0),
        "heading_deg": [c.heading_deg.0, c.heading_deg.1],
        "gnss_rows": counts.rows,
        "gnss_no_fix": counts.no_fix,
        "gnss_repeated": counts.repeated,
        "flagged_seconds": c.pass.flagged_seconds,
        "navigation_resets": c.pass.resets,
        "prior": prior_json(&c.prior),
    })
}

/// Where the prior came from, for the record.
fn prior_json(p: &PriorSource) -> serde_json::Value {
    match p {
        PriorSource::Record(at) => serde_json::json!({"source": "record", "from": at}),
        PriorSource::Factors => serde_json::json!({"source": "factors"}),
        PriorSource::Stated(s) => serde_json::json!({
            "source": "stated",
            "accel_bias": s.accel_bias,
            "gyro_bias": s.gyro_bias,
            "accel_scale": s.accel_scale,
            "gyro_scale": s.gyro_scale,
        }),
    }
}

/// The smoothed trajectory as CSV: `t, latitude, longitude` (degrees), `height` (m above the
/// ellipsoid) and the 1-sigma of its east, north and up, m, at every epoch.
#[must_use]
pub fn track_csv(track: &crate::nav::track::Track) -> String {
    let (lat0, lon0, h0) = track.origin;
    let mut s = String::from("t,latitude,longitude,height,sd_east,sd_north,sd_up\n");
    for (t, [e, n, u], [se, sn, su]) in &track.trajectory {
        let (lat, lon, h) = map_3d::enu2geodetic(
            *e,
            *n,
            *u,
            lat0.to_radians(),
            lon0.to_radians(),
            h0,
            map_3d::Ellipsoid::WGS84,
        );
        let _ = writeln!(
            s,
            "{t},{:.9},{:.9},{h:.3},{se:.3},{sn:.3},{su:.3}",
            lat.to_degrees(),
            lon.to_degrees()
        );
    }
    s
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
