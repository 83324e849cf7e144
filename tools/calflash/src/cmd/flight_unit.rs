//! `calflash flight --port`: the flight filter running in the unit (`spincal::flight`), read
//! over the update protocol: its estimate, 1-sigma and counts as its flight loop last
//! published them.

use std::fmt::Write as _;
use std::time::Duration;

use spincal::flight::{Aiding, FlightReport, Phase};

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
    })
}
