//! The sensor workflows from the command line: simulate, calibrate (blob, report, record),
//! apply, compare, threshold; the report is valid XHTML with its figures; bad plans and data get
//! one clear line and a non-zero exit.

mod common;

use std::path::Path;

use common::calflash;

fn ok(dir: &Path, args: &[&str]) -> String {
    let (code, out, err) = calflash(dir, args);
    assert_eq!(code, 0, "{args:?}: {err}{out}");
    out
}

/// Every element closes, every attribute is quoted: the report parses as XML.
fn well_formed(text: &str) -> Vec<String> {
    let mut reader = quick_xml::Reader::from_str(text);
    let mut starts = Vec::new();
    loop {
        match reader.read_event() {
            Ok(quick_xml::events::Event::Eof) => break,
            Ok(quick_xml::events::Event::Start(e) | quick_xml::events::Event::Empty(e)) => {
                starts.push(String::from_utf8_lossy(e.name().as_ref()).into_owned());
            }
            Ok(_) => {}
            Err(e) => panic!(
                "report is not well formed at {}: {e}",
                reader.buffer_position()
            ),
        }
    }
    starts
}

#[test]
fn simulate_calibrate_report_apply() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:36",
            "--plan",
            "sweep:-9:9:10",
            "--temps=-40,25,85",
            "-o",
            "obs.csv",
            "--write-truth",
            "truth.json",
        ],
    );
    let out = ok(
        d,
        &[
            "calibrate",
            "obs.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "A-1",
            "--blob",
            "a.blob",
            "--report",
            "a.html",
            "--json",
            "a.json",
        ],
    );
    // A perfect unit is accepted, or (one time in twenty, Bonferroni at 0.05 over the unit's
    // fits) sent to review for a chance outlier; never rejected.
    assert!(
        out.starts_with("calflash calibrate  obs.csv  unit A-1: ACCEPT")
            || out.starts_with("calflash calibrate  obs.csv  unit A-1: REVIEW"),
        "{out}"
    );
    assert!(out.contains("preset ieee-single expands to:"), "{out}");
    assert!(
        out.contains("test   asymmetry about 0:") && out.contains("test   hysteresis:"),
        "{out}"
    );
    let html = std::fs::read_to_string(d.join("a.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    let tags = well_formed(&html);
    // Verdict first.
    let first_p = html.find("<p class=\"verdict").unwrap();
    assert!(first_p < html.find("<h2>").unwrap());
    // Figures: asymmetry, hysteresis, residuals against input and order, the 1-sigma curve, and
    // bias and scale against temperature.
    let svgs = tags.iter().filter(|t| *t == "svg").count();
    assert_eq!(svgs, 7, "{svgs} figures");
    for svg in html.split("<svg").skip(1) {
        let body = &svg[..svg.find("</svg>").unwrap()];
        assert!(
            body.contains("<circle") || body.contains("<polyline") || body.contains("<path"),
            "an empty figure"
        );
    }
    for title in [
        "residuals against the input",
        "residuals in test order",
        "1-sigma calibration error over the range",
        "against temperature",
        "asymmetry about 0",
        "hysteresis",
    ] {
        assert!(html.contains(title), "missing figure: {title}");
    }
    // Against temperature in a datasheet's units: the bias at zero input in the input's unit
    // (not counts with the mid-scale in them), the scale factor's change in ppm.
    assert!(
        html.contains(": bias change from 25.0 C (m/s^2) against"),
        "{html}"
    );
    assert!(html.contains(": scale factor change from "), "{html}");
    assert!(!html.contains("bias (counts) against temperature"));
    // The record reads back; the blob decodes.
    let rec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("a.json")).unwrap()).unwrap();
    assert_eq!(rec["schema"], "calflash.calibration/1");
    assert_eq!(rec["points"].as_array().unwrap().len(), 3);
    let bytes = std::fs::read(d.join("a.blob")).unwrap();
    spincal::blob::decode(&bytes).unwrap();
    // apply: the observation file's outputs, corrected at each row's temperature.
    let out = ok(
        d,
        &[
            "apply",
            "--blob",
            "a.blob",
            "obs.csv",
            "--temp-column",
            "temp",
            "--volt",
            "5",
            "--sigma",
            "-o",
            "corr.csv",
        ],
    );
    assert!(
        out.contains("samples corrected with unit A-1's calibration"),
        "{out}"
    );
    let corr = std::fs::read_to_string(d.join("corr.csv")).unwrap();
    let obs = std::fs::read_to_string(d.join("obs.csv")).unwrap();
    let mut lines = corr.lines();
    assert_eq!(
        lines.next(),
        Some("line,value,flags,flag_names,sigma_value")
    );
    for (c, o) in lines.zip(obs.lines().skip(1)) {
        let c: Vec<&str> = c.split(',').collect();
        let input: f64 = o.split(',').next().unwrap().parse().unwrap();
        let value: f64 = c[1].parse().unwrap();
        // Noise of 2 counts at 408 counts per m/s^2: every corrected value within 6 sigma.
        assert!(
            (value - input).abs() < 6.0 * 2.0 / 408.0 + 0.01,
            "{input} -> {value}"
        );
    }
}

#[test]
fn compare_finds_what_moved() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (seed, name) in [("1", "before"), ("2", "after")] {
        ok(
            d,
            &[
                "simulate",
                "--sensor",
                "gyro",
                "--plan",
                "rate:-6:6:7",
                "--plan",
                "tumble:6",
                "--seed",
                seed,
                "-o",
                &format!("{name}.csv"),
            ],
        );
        ok(
            d,
            &[
                "calibrate",
                &format!("{name}.csv"),
                "--sensor",
                "gyro",
                "--serial",
                "G-9",
                "--json",
                &format!("{name}.json"),
            ],
        );
    }
    // Two calibrations of one unshocked unit: held at 5 % over all their tests together.
    let (code, out, err) = calflash(d, &["compare", "before.json", "after.json"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("verdict: UNCHANGED"), "{out}");
    assert!(
        !out.contains("MOVED") && !out.contains("CHANGED\n"),
        "{out}"
    );
    // After a shock: the z bias moved by 30 counts.
    std::fs::write(d.join("shock.json"), r#"{"bias":[32786.0,32429.5,32547.3],"s":[[898.2,2.7,0.9],[-2.25,902.7,3.6],[1.08,-3.15,900.9]],"g":[[0.18,-0.09,0.045],[0.07,0.13,-0.03],[-0.02,0.05,0.27]]}"#).unwrap();
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "gyro",
            "--plan",
            "rate:-6:6:7",
            "--plan",
            "tumble:6",
            "--seed",
            "3",
            "--truth",
            "shock.json",
            "-o",
            "shock.csv",
        ],
    );
    ok(
        d,
        &[
            "calibrate",
            "shock.csv",
            "--sensor",
            "gyro",
            "--serial",
            "G-9",
            "--json",
            "shocked.json",
        ],
    );
    let (code, out, err) = calflash(
        d,
        &[
            "compare",
            "before.json",
            "shocked.json",
            "--json",
            "cmp.json",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    // The shock moved the z bias by 30 counts.
    let verdict = out.lines().find(|l| l.starts_with("verdict: ")).unwrap();
    assert!(
        verdict.starts_with("verdict: CHANGED: ") && verdict.contains("g_z"),
        "{out}"
    );
    assert!(
        out.contains("g_z: chi-square") && out.contains("CHANGED"),
        "{out}"
    );
    let moved_line = out.lines().find(|l| l.contains("MOVED")).unwrap();
    assert!(moved_line.trim_start().starts_with('1'), "{moved_line}");
    let cmp: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("cmp.json")).unwrap()).unwrap();
    assert_eq!(cmp.as_array().unwrap().len(), 3);
    // Different units are refused.
    ok(
        d,
        &[
            "calibrate",
            "shock.csv",
            "--sensor",
            "gyro",
            "--serial",
            "OTHER",
            "--json",
            "other.json",
        ],
    );
    let (code, _, err) = calflash(d, &["compare", "before.json", "other.json"]);
    assert_eq!(code, 1);
    assert_eq!(
        err.trim(),
        "calflash: the records are of different units: G-9 and OTHER (compare calibrations of one unit)"
    );
}

#[test]
fn threshold_and_dead_band_from_a_fine_step_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("db.json"),
        r#"{"dead_band": 0.021, "noise": 0.05, "k2": 0.0, "k3": 0.0, "kp": 0.0, "ko": 0.0}"#,
    )
    .unwrap();
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "fine:-0.05:0.05:21",
            "--repeat",
            "8",
            "--truth",
            "db.json",
            "-o",
            "fine.csv",
        ],
    );
    let out = ok(d, &["threshold", "fine.csv", "--scale", "408"]);
    assert!(
        out.contains("dead band             [-0.025, 0.025]"),
        "{out}"
    );
    assert!(
        out.contains("threshold             0.025 (positive), -0.025 (negative)"),
        "{out}"
    );
    assert!(out.contains("resolution            0.005"), "{out}");
}

fn refused(d: &Path, args: &[&str], expected: &str) {
    let (code, out, err) = calflash(d, args);
    assert_eq!(code, 1, "{args:?}: {out}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(expected),
        "{args:?}:\n{err}\nexpected: {expected}"
    );
}

#[test]
fn plans_and_data_that_cannot_support_the_workflow_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A dividing head turns gravity in the x-z plane only: a triad's y axis sees no input.
    ok(
        d,
        &[
            "simulate", "--sensor", "accel", "--plan", "head:12", "-o", "head.csv",
        ],
    );
    refused(
        d,
        &[
            "calibrate",
            "head.csv",
            "--sensor",
            "accel",
            "--serial",
            "X",
        ],
        "head.csv: a_x at the single table point: f_y is not observable: it is 0 for every observation",
    );
    // Two input levels cannot give a quadratic the user asks for; the preset's higher terms
    // are dropped with the reason and the bias and scale factor fitted (issue 30).
    std::fs::write(
        d.join("two.csv"),
        "input,output\n-9.8,28900\n9.8,36900\n-9.8,28901\n9.8,36899\n-9.8,28899\n9.8,36901\n",
    )
    .unwrap();
    refused(
        d,
        &[
            "calibrate",
            "two.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--model",
            "output ~ 1 + input + input^2",
        ],
        "input^2 is not observable: input takes only 2 distinct values; it needs at least 3",
    );
    let out = ok(
        d,
        &[
            "calibrate",
            "two.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--no-db",
        ],
    );
    assert!(
        out.contains("dropped input^2 from the preset: input^2 is not observable: input takes only 2 distinct values"),
        "{out}"
    );
    // Missing reference columns.
    std::fs::write(d.join("nocol.csv"), "angle,output\n0,1\n1,2\n").unwrap();
    refused(
        d,
        &[
            "calibrate",
            "nocol.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
        ],
        "nocol.csv: missing the column `input` (the reference input, SI units); the file has: angle, output",
    );
    refused(
        d,
        &["calibrate", "nocol.csv", "--sensor", "imu", "--serial", "X"],
        "missing the columns f_x, f_y, f_z, w_x, w_y, w_z, a_x, a_y, a_z, g_x, g_y, g_z",
    );
    // A temperature breakpoint with too few observations.
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "single-accel",
            "--plan",
            "head:12",
            "--temps=-40,25",
            "-o",
            "t.csv",
        ],
    );
    let mut text = std::fs::read_to_string(d.join("t.csv")).unwrap();
    let header = text.lines().next().unwrap().to_string();
    let temp_col = header.split(',').position(|c| c == "temp").unwrap();
    let hot: Vec<String> = text
        .lines()
        .skip(1)
        .take(3)
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(String::from).collect();
            f[temp_col] = "85".into();
            f.join(",")
        })
        .collect();
    text.push_str(&(hot.join("\n") + "\n"));
    std::fs::write(d.join("t.csv"), text).unwrap();
    refused(
        d,
        &[
            "calibrate",
            "t.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--thermal",
            "table",
            "--no-db",
        ],
        "85.0 C has 3 observations; the model output ~ 1 + input + input^2 + input_o",
    );
    // By default the setpoints are one continuous model, which the three readings at 85 C
    // extend there.
    let out = ok(
        d,
        &[
            "calibrate",
            "t.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "X",
            "--no-db",
        ],
    );
    assert!(
        out.contains("continuous temperature model over -40.0 to 85.0 C (3 distinct temperatures)"),
        "{out}"
    );
    // A plan item that is not one.
    refused(
        d,
        &[
            "simulate", "--sensor", "imu", "--plan", "tumble:7", "-o", "x.csv",
        ],
        "plan item `tumble:7`: tumbles have 6, 12, 18, 24 or 26 positions",
    );
    refused(
        d,
        &[
            "calibrate",
            "two.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "much-too-long-serial-number",
        ],
        "--serial `much-too-long-serial-number`: the device stores 1 to 16 printable ASCII characters",
    );
    assert!(!d.join("x.csv").exists());
}
