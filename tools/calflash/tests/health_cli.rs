//! The health check from the command line: an IMU calibrated with its noise terms
//! (`calibrate --noise`, from `calflash allan` files), a simulated unit at rest
//! (`simulate --rest`), and `calflash health` judging it: OK when nothing moved, SUSPECT (exit
//! 3) when a gyro bias moved by 6 sigma; the refusals name what is wrong.

mod common;

use std::path::Path;

use common::{allan, calflash};

/// `calflash health RECORDING --blob u.blob` at the environment the simulator used, and `extra`.
fn health(dir: &Path, recording: &str, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "health", recording, "--blob", "u.blob", "--temp", "25", "--volt", "3.3",
    ];
    args.extend_from_slice(extra);
    calflash(dir, &args)
}

#[test]
fn calibrate_with_noise_then_judge_a_unit_at_rest() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let bench = bench.display().to_string();
    allan(d, "accel.json", "m/s^2", 1.5e-3, 1.6e-5);
    allan(d, "gyro.json", "rad/s", 2.0e-4, 8.0e-7);
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "IMU-H-1",
            "--blob",
            "u.blob",
            "--json",
            "fit.json",
            "--no-db",
            "--noise",
            "accel.json,gyro.json",
            "--ageing",
            "1h",
            "--gravity",
            "9.80:9.82",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let bytes = std::fs::read(d.join("u.blob")).unwrap();
    let cal = spincal::blob::decode(&bytes).unwrap();
    let noise = cal.data().noise.expect("the blob carries the noise terms");
    assert_eq!(noise.white[3], 2.0e-4);
    assert_eq!(noise.ageing_s, 3600.0);
    assert_eq!(noise.false_alarm, 1e-3);

    for (shift, word, exit) in [("0,0,0,0,0,0", "OK", 0), ("0,0,0,0,0,-6", "SUSPECT", 3)] {
        let (code, out, err) = calflash(
            d,
            &[
                "simulate", "--sensor", "imu", "--rest", "u.blob", "--shift", shift, "--poses",
                "2", "--hold", "4", "-o", "rest.csv",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        let (code, out, err) = health(d, "rest.csv", &["--db", "units.sqlite"]);
        assert_eq!(code, exit, "{out}{err}");
        assert!(
            out.contains(&format!("unit IMU-H-1 (rest.csv): {word}")),
            "{out}"
        );
        assert!(out.contains("recorded as db:"), "{out}");
        if exit == 0 {
            let (_, out, err) = health(d, "rest.csv", &["--no-db", "--json", "ok.json"]);
            let (code, said, _) = calflash(d, &["compare", "fit.json", "ok.json"]);
            assert_eq!(code, 0, "{out}{err}{said}");
            assert!(said.contains("verdict: UNCHANGED: no bias moved"), "{said}");
        }
    }
    // Ten years of the stored random walk: far beyond the hour the calibration allows.
    let (code, out, err) = calflash(
        d,
        &[
            "simulate", "--sensor", "imu", "--rest", "u.blob", "--aged", "3650d", "--poses", "1",
            "--hold", "3", "-o", "aged.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = health(d, "aged.csv", &["--no-db"]);
    assert_eq!(code, 3, "{out}{err}");
    // With the history down, SUSPECT keeps its exit code and the failure is said beside it
    // (it exited 1, as if nothing had been judged).
    let (code, out, err) = health(
        d,
        "aged.csv",
        &[
            "--db",
            "postgres://calflash@127.0.0.1:1/nothing_listens_here",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    assert!(out.contains(": SUSPECT"), "{out}");
    assert!(err.contains("SUSPECT but is not in the history"), "{err}");
    // The last report (gyro z 6 sigma off) held against the calibration it judged.
    let (code, out, err) = health(
        d,
        "rest.csv",
        &[
            "--no-db",
            "--json",
            "health.json",
            "--report",
            "health.html",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    // The report: the verdict and what it means, and gyro z's bias in its stated sigmas.
    let page = std::fs::read_to_string(d.join("health.html")).unwrap();
    assert!(
        page.contains("<p class=\"verdict reject\">SUSPECT</p>") && page.contains("recalibrate"),
        "{page}"
    );
    let wz = page
        .split("<tr><td>wz</td>")
        .nth(1)
        .and_then(|r| r.split("</tr>").next())
        .unwrap();
    let ratio: f64 = wz
        .rsplit("<td>")
        .next()
        .and_then(|c| c.strip_suffix("</td>"))
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("{wz}"));
    assert!(ratio < -3.0, "gyro z 6 sigma off: {wz}");
    assert_eq!(page.matches("<svg").count(), 1);
    // The figure names the outputs on its axis, and a refined 1-sigma wider than the
    // calibration's is explained (the aged start, one pose), naming the outputs it is for.
    for name in ["ax", "ay", "az", "wx", "wy", "wz"] {
        assert!(
            page.contains(&format!("\n{name}\n</text>")),
            "{name} on the axis: {page}"
        );
    }
    assert!(!page.contains("1-3 accelerometer"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("health.json")).unwrap()).unwrap();
    let wider = (0..6).any(|i| {
        let (a, b) = (
            json["health"]["bias_sigma"][i].as_f64().unwrap_or(0.0),
            json["health"]["stated_sigma"][i].as_f64().unwrap_or(0.0),
        );
        b > 0.0 && a > 1.05 * b
    });
    assert_eq!(
        page.contains("Why the refined 1-sigma of "),
        wider,
        "{}",
        json["health"]
    );
    let (code, out, err) = calflash(d, &["compare", "fit.json", "health.json"]);
    assert_eq!(code, 3, "one verdict and its exit code: {out}{err}");
    let moved: Vec<&str> = out.lines().filter(|l| l.ends_with("MOVED")).collect();
    assert_eq!(moved.len(), 1, "{out}");
    assert!(moved[0].trim_start().starts_with("wz:"), "{out}");
    assert!(
        out.contains(
            "verdict: CHANGED: 1 bias(es) moved beyond the calibration's stated 1-sigma (wz)"
        ),
        "{out}"
    );
    let (code, _, err) = calflash(d, &["compare", "health.json", "fit.json"]);
    assert_ne!(code, 0);
    assert!(err.contains("comes second"), "{err}");
    let (_, out, _) = calflash(d, &["history", "IMU-H-1", "--db", "units.sqlite"]);
    assert!(out.contains("health") && out.contains("suspect"), "{out}");

    // Refusals.
    let refused = |args: &[&str], expected: &str| {
        let (code, out, err) = calflash(d, args);
        assert_ne!(code, 0, "{args:?}: {out}");
        assert!(err.contains(expected), "{args:?}: {err}");
    };
    refused(
        &[
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "X",
            "--no-db",
            "--noise",
            "accel.json",
        ],
        "two files",
    );
    refused(
        &[
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "X",
            "--no-db",
            "--noise",
            "gyro.json,accel.json",
        ],
        "gyro.json: field \"unit\"",
    );
    refused(
        &[
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "X",
            "--no-db",
            "--noise",
            "accel.json,gyro.json",
            "--gravity",
            "9.0:9.8",
        ],
        "--gravity 9:9.8: expected LO:HI",
    );
    refused(&["health", "rest.csv"], "give --port");
    // A blob without noise terms: the check says it cannot run, and why.
    let (code, _, err) = calflash(
        d,
        &[
            "calibrate",
            &bench,
            "--sensor",
            "imu",
            "--serial",
            "IMU-H-2",
            "--blob",
            "plain.blob",
            "--no-db",
        ],
    );
    assert_eq!(code, 0, "{err}");
    refused(
        &["health", "rest.csv", "--blob", "plain.blob", "--no-db"],
        "no noise terms",
    );
}

/// A simulated unit at rest writes the temperature it rested at, and `health` corrects it
/// there: an unshifted unit of a calibration over -40 to 85 C is OK without `--temp` (issue 35:
/// it read DRIFTED at the span's middle). A recording without a temperature says which it
/// assumed and how far the calibration moves over the span.
#[test]
fn the_temperature_at_rest_is_the_recordings_or_said_to_be_assumed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    allan(d, "accel.json", "m/s^2", 1.5e-3, 1.6e-5);
    allan(d, "gyro.json", "rad/s", 2.0e-4, 8.0e-7);
    let (code, out, err) = calflash(
        d,
        &[
            "calibrate",
            &bench.display().to_string(),
            "--sensor",
            "imu",
            "--serial",
            "IMU-T-1",
            "--blob",
            "u.blob",
            "--no-db",
            "--noise",
            "accel.json,gyro.json",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = calflash(
        d,
        &[
            "simulate", "--sensor", "imu", "--rest", "u.blob", "--poses", "2", "--hold", "4",
            "--seed", "5", "-o", "rest.csv",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = calflash(d, &["health", "rest.csv", "--blob", "u.blob", "--no-db"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("(rest.csv): OK"), "{out}");
    assert!(
        out.contains("temperature  25.00 C, the mean of the recording's column temp"),
        "{out}"
    );
    // The same samples without their temperature.
    let text = std::fs::read_to_string(d.join("rest.csv")).unwrap();
    let bare: Vec<String> = text
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect();
    std::fs::write(d.join("bare.csv"), bare.join("\n") + "\n").unwrap();
    let (_, out, err) = calflash(d, &["health", "bare.csv", "--blob", "u.blob", "--no-db"]);
    assert!(
        out.contains("temperature  assumed 22.5 C, the middle of the calibrated span -40 to 85 C")
            && out.contains("the calibration moves by up to"),
        "{out}{err}"
    );
}
