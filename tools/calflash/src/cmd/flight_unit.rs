//! `calflash flight --port`: the flight filter running in the unit (`spincal::flight`), read
//! over the update protocol: its estimate, 1-sigma, counts and its own verdict on its
//! calibration (`spincal::flight::verdict`) as its flight loop last published them.

use std::fmt::Write as _;
use std::time::Duration;

use spincal::flight::verdict::{TERM_NAMES, TERMS};
use spincal::flight::{Aiding, FlightReport, Phase, Verdict, Word};

use crate::cmd::Failure;
use crate::device::{Client, link::Link};
use crate::files::{Paths, Staged};

/// Reads the unit's flight filter on `port` (each reply awaited `timeout_s` seconds), writing
/// its JSON to `json` when given.
///
/// # Errors
/// The link's, or a unit that has published no flight filter state since power-on.
pub fn run(port: &str, timeout_s: f64, json_path: Option<&std::path::Path>) -> Result<(), Failure> {
    Paths::new().output("--json", json_path).check()?;
    let timeout = Duration::from_secs_f64(timeout_s);
    let link = Link::open(port, timeout)?;
    let mut client = Client::new(link, timeout);
    let id = client.identify().map_err(|e| format!("{port}: {e}"))?;
    let serial = id.unit.as_str().to_string();
    let Some(report) = client.flight().map_err(|e| format!("{port}: {e}"))? else {
        return Err(format!(
            "{port}: unit {serial} has published no flight filter state since power-on (its flight loop has not run)"
        )
        .into());
    };
    if let Some(path) = json_path {
        let json = serde_json::to_string_pretty(&json(&serial, &report))?;
        let mut staged = Staged::new();
        staged.write(path, |w| w.write_all(json.as_bytes()))?;
        staged.commit()?;
    }
    print!("{}", text(&serial, port, &report));
    Ok(())
}

fn phase(p: Phase) -> &'static str {
    match p {
        Phase::Levelling => "levelling",
        Phase::Pad => "on the pad",
        Phase::Flight => "in flight",
    }
}

const KINDS: [(Aiding, &str); 4] = [
    (Aiding::Pad, "pad"),
    (Aiding::Position, "GNSS position"),
    (Aiding::Velocity, "GNSS velocity"),
    (Aiding::Baro, "barometer"),
];

/// The report in words.
#[must_use]
pub fn text(serial: &str, port: &str, r: &FlightReport) -> String {
    let mut out = String::new();
    let launch = r.launch_us.map_or("no launch yet".to_string(), |t| {
        format!("launched at {:.3} s", t as f64 * 1e-6)
    });
    let _ = writeln!(
        out,
        "calflash flight: unit {serial} on {port}, its own flight filter {}, {launch}",
        phase(r.phase)
    );
    let row = |out: &mut String, name: &str, unit: &str, v: &[f32], s: &[f32]| {
        let cells: Vec<String> = v
            .iter()
            .zip(s)
            .map(|(v, s)| format!("{v:>+11.4e} +- {s:.2e}"))
            .collect();
        let _ = writeln!(out, "  {name:<22} {}  {unit}", cells.join("  "));
    };
    let (s, sig) = (&r.sensors, &r.sigma);
    row(&mut out, "position (E N U)", "m", &r.position, &sig[0..3]);
    row(&mut out, "velocity (E N U)", "m/s", &r.velocity, &sig[3..6]);
    let zero = [0.0f32; 3];
    row(&mut out, "attitude error 1-sigma", "rad", &zero, &sig[6..9]);
    row(
        &mut out,
        "accelerometer bias",
        "m/s^2",
        &s[0..3],
        &sig[9..12],
    );
    row(&mut out, "gyro bias", "rad/s", &s[3..6], &sig[12..15]);
    row(&mut out, "accelerometer scale", "", &s[6..9], &sig[15..18]);
    row(&mut out, "gyro scale", "", &s[9..12], &sig[18..21]);
    row(&mut out, "barometer bias", "m", &s[12..13], &sig[21..22]);
    verdict(&mut out, &r.verdict);
    let st = &r.stats;
    for (kind, name) in KINDS {
        let k = kind as usize;
        let nis = st
            .mean_nis(kind)
            .map_or("-".to_string(), |n| format!("{n:.2}"));
        let _ = writeln!(
            out,
            "  {name:<22} taken {:>6}  refused at the gate {:>5}  mean NIS {nis}",
            st.taken[k], st.refused[k]
        );
    }
    let _ = writeln!(
        out,
        "  fixes left out: {} not a position, {} too few satellites, {} stale, {} from the future, {} repeated, {} replaced",
        st.gnss_invalid,
        st.gnss_few_satellites,
        st.gnss_stale,
        st.gnss_future,
        st.gnss_repeated,
        st.gnss_dropped
    );
    let _ = writeln!(
        out,
        "  pressures left out: {} invalid, {} near Mach 1; {} samples navigated on doubt, {} time faults, {} navigation put back by a fix, {} covariance resets, {} epochs",
        st.baro_invalid,
        st.baro_transonic,
        st.doubted,
        st.time_faults,
        st.navigation_resets,
        st.resets,
        st.epochs
    );
    out
}

/// The round's verdict in words: the word and why, then each observed term's shift and z.
fn verdict(out: &mut String, v: &Verdict) {
    let named: Vec<&str> = (0..TERMS)
        .filter(|i| v.is_shifted(*i))
        .map(|i| TERM_NAMES[i])
        .collect();
    let unseen: Vec<&str> = (0..TERMS)
        .filter(|i| !v.is_observed(*i))
        .map(|i| TERM_NAMES[i])
        .collect();
    let (n, inside, refused, nis) = v.innovations;
    let why = match v.word {
        Word::NotYet => {
            "the launch's shift is not opened yet (no launch, or the setback goes on)".to_string()
        }
        Word::DoesNotFit if v.resets > 0 => format!(
            "its covariance was reset {} times: its estimates are no findings",
            v.resets
        ),
        Word::DoesNotFit => format!(
            "{:.1} % of {n} aiding innovations inside their 95 % bounds, {:.1} % refused, mean NIS {nis:.2}: the filter does not fit this flight, its estimates are no findings",
            100.0 * inside,
            100.0 * refused
        ),
        Word::Shifted if named.is_empty() => format!(
            "the observed terms together moved beyond what the filter expects had nothing shifted (chi-square {:.1} on {} degrees of freedom, p = {:.1e}), no one term named",
            v.chi2.0,
            v.observed.count_ones(),
            v.chi2.1
        ),
        Word::Shifted => format!("shifted in flight: {}", named.join(", ")),
        Word::CannotTell => "the flight observes no term".to_string(),
        Word::Held => format!(
            "the observed terms within what the filter expects had nothing shifted (chi-square {:.1} on {} degrees of freedom, p = {:.2})",
            v.chi2.0,
            v.observed.count_ones(),
            v.chi2.1
        ),
    };
    let _ = writeln!(out, "  the round's verdict: {}: {why}", v.word.as_str());
    if v.word != Word::NotYet {
        let _ = writeln!(
            out,
            "    held to {}",
            if v.carried {
                "the calibration's own error carried over this flight"
            } else {
                "the sensor errors' prior (no calibration covariance carried over the flight)"
            }
        );
    }
    for i in (0..TERMS).filter(|i| v.is_observed(*i)) {
        let _ = writeln!(
            out,
            "    {:<14} moved {:>+11.4e} since the setback, z {:>+6.2}{}",
            TERM_NAMES[i],
            v.shift[i],
            v.z[i],
            if v.is_shifted(i) { "  SHIFTED" } else { "" }
        );
    }
    if !unseen.is_empty() && v.word != Word::NotYet {
        let _ = writeln!(out, "    not observed: {}", unseen.join(", "));
    }
}

/// The round's verdict as JSON.
fn verdict_json(v: &Verdict) -> serde_json::Value {
    let finite = |x: f32| x.is_finite().then_some(x);
    serde_json::json!({
        "word": v.word.as_str(),
        "terms": (0..TERMS).map(|i| serde_json::json!({
            "name": TERM_NAMES[i],
            "moved": v.shift[i],
            "observed": v.is_observed(i),
            "z": finite(v.z[i]),
            "shifted": v.is_shifted(i),
        })).collect::<Vec<_>>(),
        "chi2": finite(v.chi2.0),
        "dof": v.observed.count_ones(),
        "p": finite(v.chi2.1),
        "aiding_innovations": v.innovations.0,
        "inside_95": finite(v.innovations.1),
        "refused": finite(v.innovations.2),
        "mean_nis": finite(v.innovations.3),
        "covariance_resets": v.resets,
        "calibration_carried": v.carried,
    })
}

/// The report as JSON (schema `calflash.flight-unit/1`).
#[must_use]
pub fn json(serial: &str, r: &FlightReport) -> serde_json::Value {
    let st = &r.stats;
    serde_json::json!({
        "schema": "calflash.flight-unit/1",
        "unit": serial,
        "phase": phase(r.phase),
        "launch_s": r.launch_us.map(|t| t as f64 * 1e-6),
        "position_m": r.position,
        "velocity_m_s": r.velocity,
        "attitude_wxyz": r.attitude,
        "sensors": {
            "accel_bias": &r.sensors[0..3],
            "gyro_bias": &r.sensors[3..6],
            "accel_scale": &r.sensors[6..9],
            "gyro_scale": &r.sensors[9..12],
            "baro_bias": r.sensors[12],
        },
        "sigma": r.sigma.to_vec(),
        "taken": st.taken,
        "refused": st.refused,
        "mean_nis": KINDS.map(|(k, _)| st.mean_nis(k)),
        "left_out": {
            "gnss_invalid": st.gnss_invalid,
            "gnss_few_satellites": st.gnss_few_satellites,
            "gnss_stale": st.gnss_stale,
            "gnss_future": st.gnss_future,
            "gnss_repeated": st.gnss_repeated,
            "gnss_replaced": st.gnss_dropped,
            "baro_invalid": st.baro_invalid,
            "baro_transonic": st.baro_transonic,
        },
        "doubted_samples": st.doubted,
        "time_faults": st.time_faults,
        "navigation_resets": st.navigation_resets,
        "covariance_resets": st.resets,
        "epochs": st.epochs,
        "inside_95": st.inside,
        "verdict": verdict_json(&r.verdict),
    })
}
