//! The spinning round from the command line, as the README shows it: a spin-rig calibration,
//! a simulated flight, and `apply` holding the corrected flight against its truth; `apply`
//! refuses to guess a lever-arm calibration's sample rate and flags a sample after a time step
//! that is not the rate.

mod common;

use std::path::Path;

use common::calflash;

fn ok(dir: &Path, args: &[&str]) -> String {
    let (code, out, err) = calflash(dir, args);
    assert_eq!(code, 0, "{args:?}: {err}{out}");
    out
}

fn truth() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/data/spinning_round.truth.json")
        .display()
        .to_string()
}

/// The `| name | mean | rms | sigma | ...` rows of `apply --reference` (the robust figures
/// after them).
fn figures(out: &str) -> Vec<(String, f64, f64, f64)> {
    out.lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l
                .trim()
                .trim_matches('|')
                .split('|')
                .map(str::trim)
                .collect();
            let [name, mean, rms, sigma, ..] = cells[..] else {
                return None;
            };
            Some((
                name.to_string(),
                mean.parse().ok()?,
                rms.parse().ok()?,
                sigma.parse().ok()?,
            ))
        })
        .collect()
}

#[test]
fn a_spin_rig_calibration_flies_at_300_hz_within_three_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = truth();
    common::simulate_rig(d, &truth, &["--seed", "4"]);
    let out = ok(
        d,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "ROUND-0300",
            "--blob",
            "round.blob",
            "--no-db",
        ],
    );
    assert!(out.contains("unit ROUND-0300: ACCEPT"), "{out}");
    assert!(out.contains("all nine lever-arm components"), "{out}");
    let out = ok(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            &truth,
            "--spin",
            "300:0.5",
            "--sample-rate",
            "2000",
            "--coning",
            "1:10",
            "--seed",
            "8",
            "-o",
            "flight.csv",
        ],
    );
    assert!(out.contains("1000 samples at 2000 Hz"), "{out}");
    let out = ok(
        d,
        &[
            "apply",
            "--blob",
            "round.blob",
            "flight.csv",
            "--time-column",
            "t",
            "--reference",
            "-o",
            "si.csv",
            "--report",
            "flight.html",
        ],
    );
    assert!(out.contains("(1 flagged)"), "{out}");
    // Robust figures beside the RMS, and the error along the flight drawn per unit.
    assert!(out.contains("| median error | robust spread |"), "{out}");
    let html = std::fs::read_to_string(d.join("flight.html")).unwrap();
    // One figure per output, each titled by it (none hides another), a verdict, the units in
    // their own column.
    assert_eq!(html.matches(": error along the recording, ").count(), 6);
    assert!(html.contains("ax: error along the recording, m/s^2"));
    assert!(html.contains("wz: error along the recording, rad/s"));
    assert!(
        html.contains("<p class=\"verdict accept\">Holds: "),
        "{html}"
    );
    assert!(html.contains("<td>ax</td><td>m/s^2</td>"), "{html}");
    assert!(
        !html.contains(" m/s^2</td><td>"),
        "a unit in a figure's cell: {html}"
    );
    assert!(out.contains("2000.000000 Hz from the timestamps"), "{out}");
    let rows = figures(&out);
    assert_eq!(rows.len(), 6, "{out}");
    for (name, mean, _, sigma) in &rows {
        // The mean over 999 samples: the calibration's error and the noise's share of it.
        let noise = if name.starts_with('a') { 1.2 } else { 0.09 } / 999f64.sqrt();
        assert!(
            mean.abs() <= 3.0 * sigma.hypot(noise),
            "{name}: mean error {mean} against 1-sigma {sigma}\n{out}"
        );
    }
    // The corrected file: one row per sample, flags, the first sample's derivative unknown.
    let si = std::fs::read_to_string(d.join("si.csv")).unwrap();
    let mut lines = si.lines();
    assert_eq!(
        lines.next(),
        Some("line,ax,ay,az,wx,wy,wz,flags,flag_names")
    );
    assert!(
        lines
            .next()
            .unwrap()
            .ends_with(",32,rate-derivative-unknown"),
        "{si:.300}"
    );
    assert_eq!(si.lines().count(), 1001);
}

#[test]
fn a_lever_arm_calibration_needs_the_rate_and_flags_off_rate_steps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = truth();
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            &truth,
            "--plan",
            "tumble:24",
            "--plan",
            "rate:-1900:1900:5",
            "--plan",
            "diagonal:-1900:1900:5",
            "--plan",
            "centrifuge:1:1500:4",
            "-o",
            "rig.csv",
        ],
    );
    ok(
        d,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--serial",
            "R-1",
            "--blob",
            "r.blob",
            "--no-db",
        ],
    );
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            &truth,
            "--spin",
            "150:0.05",
            "--sample-rate",
            "1000",
            "-o",
            "f.csv",
        ],
    );
    // No rate and no timestamps: refused, saying what to give.
    let (code, out, err) = calflash(d, &["apply", "--blob", "r.blob", "f.csv", "-o", "si.csv"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("has lever arms")
            && err.contains("--sample-rate HZ")
            && err.contains("--time-column"),
        "{err}"
    );
    assert!(!d.join("si.csv").exists());
    // A stated rate the timestamps contradict.
    let (code, _, err) = calflash(
        d,
        &[
            "apply",
            "--blob",
            "r.blob",
            "f.csv",
            "--rate",
            "2000",
            "--time-column",
            "t",
            "-o",
            "si.csv",
        ],
    );
    assert_eq!(code, 1);
    assert!(err.contains("disagrees with the timestamps"), "{err}");
    // A dropped sample: the one after the gap is flagged.
    let text = std::fs::read_to_string(d.join("f.csv")).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .enumerate()
        .filter(|(i, _)| *i != 21)
        .map(|(_, l)| l)
        .collect();
    std::fs::write(d.join("gap.csv"), kept.join("\n") + "\n").unwrap();
    let out = ok(
        d,
        &[
            "apply",
            "--blob",
            "r.blob",
            "gap.csv",
            "--rate",
            "1000",
            "--time-column",
            "t",
            "-o",
            "si.csv",
        ],
    );
    assert!(out.contains("(2 flagged)"), "{out}");
    assert!(
        out.contains("1 time steps are not the rate (first before line 22)"),
        "{out}"
    );
    let si = std::fs::read_to_string(d.join("si.csv")).unwrap();
    let row: Vec<&str> = si.lines().nth(21).unwrap().split(',').collect();
    assert_eq!(
        (row[0], row[8]),
        ("22", "rate-derivative-unknown"),
        "{si:.2000}"
    );
}

#[test]
fn design_evaluate_names_the_lever_components_a_plan_cannot_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(
        dir.path(),
        &[
            "design",
            "evaluate",
            "--sensor",
            "accel",
            "--model",
            "accel-lever",
            "--plan",
            "tumble:24,rate:-1900:1900:9",
            "--plan",
            "tumble:24,rate:-1900:1900:9,diagonal:-1900:1900:9",
            "--noise",
            "2",
            "--scale",
            "1.67",
        ],
    );
    assert!(
        out.contains("plan tumble:24,rate:-1900:1900:9: estimates 3 of the nine components; r_xy, r_xz, r_yx, r_yz, r_zx, r_zy cannot be"),
        "{out}"
    );
    assert!(
        out.contains("a diagonal:LO:HI:N item, the rate table's 45-degree fixture"),
        "{out}"
    );
    assert!(
        out.contains("plan tumble:24,rate:-1900:1900:9,diagonal:-1900:1900:9: estimates 9 of the nine components"),
        "{out}"
    );
    // Standard errors in micrometres: 2 counts of noise at 1.67 counts per m/s^2.
    let sd: Vec<f64> = out
        .lines()
        .filter_map(|l| l.trim().strip_prefix("sd(r_yz) "))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    assert_eq!(sd.len(), 1, "{out}");
    assert!(sd[0] > 0.05 && sd[0] < 1.0, "{sd:?}");
    // The two plans share no model: one report would compare nothing.
    let (code, _, err) = calflash(
        dir.path(),
        &[
            "design",
            "evaluate",
            "--sensor",
            "accel",
            "--model",
            "accel-lever",
            "--plan",
            "rate:-1900:1900:9",
            "--plan",
            "rate:-1900:1900:9,diagonal:-1900:1900:9",
            "--json",
            "d.json",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("estimate different lever-arm components"),
        "{err}"
    );
}

#[test]
fn a_quiet_high_range_unit_passes_the_f32_check() {
    // The spinning round (+-2000 g, +-2000 rad/s) with a twentieth of its noise, as averaged
    // bench readings give: the device's f32 arithmetic is held against what f32 holds at full
    // scale and a tenth of a code, not against that noise (which sent such units to REVIEW).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(truth()).unwrap()).unwrap();
    for s in ["accel", "gyro"] {
        truth[s]["noise"] = serde_json::json!([0.1, 0.1, 0.1]);
    }
    std::fs::write(d.join("quiet.json"), truth.to_string()).unwrap();
    common::simulate_rig(d, "quiet.json", &[]);
    let (_, out, err) = calflash(
        d,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "QUIET-1",
            "--no-db",
        ],
    );
    let line = out
        .lines()
        .find(|l| l.contains("the device's f32 correction"))
        .unwrap_or_else(|| panic!("{out}{err}"));
    assert!(line.trim_start().starts_with("ACCEPT"), "{line}");
}

/// A unit the device cannot hold (its g-sensitivity, fed the lever term, makes the rate
/// unbounded inside the rails) is a REJECT with its record and the reason, not a failure
/// that leaves nothing (it exited 1 with no record).
#[test]
fn a_unit_the_device_cannot_hold_is_rejected_with_its_record() {
    let dir = tempfile::tempdir().unwrap();
    let mut truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(truth()).unwrap()).unwrap();
    for row in truth["gyro"]["g"].as_array_mut().unwrap() {
        for v in row.as_array_mut().unwrap() {
            *v = (v.as_f64().unwrap() * 30.0).into();
        }
    }
    let t = dir.path().join("big_g.json");
    std::fs::write(&t, truth.to_string()).unwrap();
    common::simulate_rig(dir.path(), t.to_str().unwrap(), &[]);
    let (code, out, err) = calflash(
        dir.path(),
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "BIG-G",
            "--blob",
            "big.blob",
            "--json",
            "big.json",
            "--no-db",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    assert!(out.contains("unit BIG-G: REJECT"), "{out}");
    assert!(
        out.contains("REJECT the device cannot hold this calibration: at this sample rate the g-sensitivity's feedback of the lever term")
            && out.contains("Hz: the unit is too nonlinear"),
        "{out}"
    );
    assert!(!dir.path().join("big.blob").exists());
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("big.json")).unwrap())
            .unwrap();
    assert_eq!(record["verdict"], "reject");
    assert_eq!(record["blob"], "");
}
