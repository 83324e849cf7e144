//! `calflash fit` from the command line: the messages users read for bad input (exact text,
//! the file path replaced by `<FILE>`), the exit code, and that no output file is left behind.

mod common;

use common::calflash;
use std::path::Path;

const GOOD: &str =
    "rate,temp,volts\n-100,20,1.5\n-50,25,2.0\n0,30,2.5\n50,20,3.0\n100,25,3.51\n150,30,4.0\n";

fn bad_input(name: &str, content: &[u8], model: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(name);
    std::fs::write(&file, content).unwrap();
    let (code, stdout, stderr) = calflash(
        dir.path(),
        &["fit", name, "--model", model, "--json", "out.json"],
    );
    assert_eq!(code, 1, "{name}: exit code; stderr: {stderr}");
    assert!(stdout.is_empty(), "{name}: printed {stdout}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        !dir.path().join("out.json").exists(),
        "{name}: an output file was left behind"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left,
        [std::ffi::OsString::from(name)],
        "{name}: stray files {left:?}"
    );
    stderr.trim_end().replace(name, "<FILE>")
}

#[test]
fn bad_input_gets_one_clear_line_and_no_output() {
    let m = "volts ~ 1 + rate + temp";
    let cases: Vec<(&str, Vec<u8>, &str, &str)> = vec![
        (
            "missing column",
            b"rate,volts\n1,2\n".to_vec(),
            m,
            "calflash: <FILE>: the model uses `temp` (in term temp), but the file has no such column; its columns are: rate, volts",
        ),
        (
            "missing response",
            b"rate,temp\n1,2\n".to_vec(),
            m,
            "calflash: <FILE>: the model uses `volts` (in the response), but the file has no such column; its columns are: rate, temp",
        ),
        (
            "non-numeric cell",
            b"rate,temp,volts\n1,20,2\n2,x20,3\n".to_vec(),
            m,
            "calflash: <FILE>:3:2: `x20` in column `temp` is not a number",
        ),
        (
            "NaN",
            b"rate,temp,volts\n1,20,NaN\n".to_vec(),
            m,
            "calflash: <FILE>:2:3: `NaN` in column `volts` is not a finite number; remove the observation or fix the value",
        ),
        (
            "infinity",
            b"rate temp volts\n1 20 2\n2 inf 3\n".to_vec(),
            m,
            "calflash: <FILE>:3:2: `inf` in column `temp` is not a finite number; remove the observation or fix the value",
        ),
        (
            "empty file",
            b"".to_vec(),
            m,
            "calflash: <FILE>: the file is empty; expected a header row naming the columns, then observations",
        ),
        (
            "header only",
            b"rate,temp,volts\n".to_vec(),
            m,
            "calflash: <FILE>: the header has no observations under it",
        ),
        (
            "ragged row",
            b"rate,temp,volts\n1,20,2\n2,3\n".to_vec(),
            m,
            "calflash: <FILE>:3: 2 fields, but the header has 3",
        ),
        (
            "fewer observations than terms",
            b"rate,temp,volts\n1,20,2\n2,25,3\n3,20,4\n".to_vec(),
            "volts ~ 1 + rate + temp + rate:temp",
            "calflash: <FILE>: 3 observations cannot fit 4 terms: at least 5 are needed for one residual degree of freedom",
        ),
        (
            "constant column",
            b"rate,temp,volts\n1,25,2\n2,25,3\n3,25,4.1\n4,25,5\n".to_vec(),
            m,
            "calflash: <FILE>: temp is not observable: it is constant (25) over all 4 observations, so it cannot be told apart from the intercept; vary it, or drop the term",
        ),
        (
            "two rates for a quadratic",
            b"rate,temp,volts\n-1,20,2\n1,25,3\n-1,30,2.1\n1,20,3.1\n".to_vec(),
            "volts ~ 1 + rate + rate^2",
            "calflash: <FILE>: rate^2 is not observable: rate takes only 2 distinct values; it needs at least 3",
        ),
        (
            "unknown variable",
            GOOD.as_bytes().to_vec(),
            "volts ~ 1 + rate + tmp",
            "calflash: <FILE>: the model uses `tmp` (in term tmp), but the file has no such column; its columns are: rate, temp, volts",
        ),
        (
            "malformed formula",
            GOOD.as_bytes().to_vec(),
            "volts ~ 1 + rate +",
            "calflash: model: expected a term, found the end of the formula at column 19 of `volts ~ 1 + rate +`",
        ),
        (
            "not text",
            vec![
                0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, 0, 0, 0, 0x0d, 0xff,
            ],
            m,
            "calflash: <FILE>:1: not text (a binary file?); expected UTF-8 text with a header row",
        ),
    ];
    for (what, content, model, expected) in cases {
        let got = bad_input("data.csv", &content, model);
        assert_eq!(got, expected, "{what}");
    }
}

#[test]
fn a_fit_writes_its_json_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("d.csv"), GOOD).unwrap();
    let (code, stdout, stderr) = calflash(
        dir.path(),
        &[
            "fit",
            "d.csv",
            "--model",
            "volts ~ rate + temp",
            "--json",
            "fit.json",
            "--predict-at",
            "rate=10,temp=25",
            "--curve",
            "rate=-200:200:5",
        ],
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("model  volts ~ 1 + rate + temp"),
        "{stdout}"
    );
    assert!(
        stdout.contains("prediction at rate=10,temp=25:"),
        "{stdout}"
    );
    assert!(stdout.ends_with("report: fit.json\n"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("fit.json")).unwrap())
            .unwrap();
    assert_eq!(json["schema"], "calflash.fit/1");
    for key in [
        "terms",
        "coefficients",
        "std_errors",
        "covariance",
        "t",
        "p",
        "rss",
        "sigma2",
        "dof",
        "r2",
        "adj_r2",
        "f",
        "aic",
        "bic",
        "condition_number",
        "vif",
        "residuals",
        "leverage",
        "student_internal",
        "student_external",
        "cooks_distance",
        "dffits",
        "dfbetas",
        "predictions",
        "curve",
    ] {
        assert!(!json[key].is_null(), "{key} missing");
    }
    assert_eq!(json["terms"], serde_json::json!(["1", "rate", "temp"]));
    assert_eq!(json["dfbetas"].as_array().unwrap().len(), 6);
    assert_eq!(json["curve"]["points"].as_array().unwrap().len(), 5);
    assert!(json["predictions"][0]["variance"].as_f64().unwrap() > 0.0);
    // JSON to standard output.
    let (code, stdout, _) = calflash(
        dir.path(),
        &["fit", "d.csv", "--model", "volts ~ rate", "--json", "-"],
    );
    assert_eq!(code, 0);
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(json["n_obs"], 6);
}

#[test]
fn bad_options_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("d.csv"), GOOD).unwrap();
    let cases = [
        (
            vec!["--predict-at", "rate=1"],
            "calflash: prediction point: give a value for `temp` too (the model volts ~ 1 + rate + temp uses it)",
        ),
        (
            vec!["--predict-at", "rate=x,temp=1"],
            "calflash: --predict-at: `x` is not a number (in `rate=x`)",
        ),
        (
            vec!["--curve", "speed=0:1:5"],
            "calflash: --curve: `speed` is not a variable of the model volts ~ 1 + rate + temp",
        ),
        (
            vec!["--compare", "volts ~ rate + other"],
            "calflash: --compare: volts ~ 1 + rate + other is not nested in volts ~ 1 + rate + temp (same response, and only terms the full model has)",
        ),
        (
            vec!["--holdout-every", "100"],
            "calflash: --holdout-every 100: only 6 observations, none held out",
        ),
    ];
    for (extra, expected) in cases {
        let mut args = vec![
            "fit",
            "d.csv",
            "--model",
            "volts ~ rate + temp",
            "--json",
            "o.json",
        ];
        args.extend(extra.iter());
        let (code, _, stderr) = calflash(dir.path(), &args);
        assert_eq!((code, stderr.trim_end()), (1, expected), "{extra:?}");
        assert!(!dir.path().join("o.json").exists());
    }
    // Options outside their domain are refused as the command line is read (usage, exit 2).
    let (code, _, stderr) = calflash(
        dir.path(),
        &["fit", "d.csv", "--model", "volts ~ rate", "--alpha", "1.5"],
    );
    assert_eq!(code, 2);
    assert!(
        stderr.starts_with(
            "error: invalid value '1.5' for '--alpha <ALPHA>': a significance level between 0 and 1"
        ),
        "{stderr}"
    );
}

#[test]
fn help_lists_every_preset_and_plan_item() {
    let d = tempfile::tempdir().unwrap();
    let (code, out, _) = calflash(d.path(), &["design", "optimize", "--help"]);
    assert_eq!(code, 0);
    for word in [
        "accel-lever",
        "gyro-gsens",
        "triad-nonlinear",
        "diagonal:LO:HI:N",
        "--mission",
    ] {
        assert!(
            out.contains(word),
            "design optimize --help lacks {word}:\n{out}"
        );
    }
    let (_, out, _) = calflash(d.path(), &["simulate", "--help"]);
    for word in ["diagonal:LO:HI:N", "--flight", "--flight-truth"] {
        assert!(out.contains(word), "simulate --help lacks {word}:\n{out}");
    }
}

#[test]
fn a_simulated_still_recording_gives_allan_its_noise_back() {
    let d = tempfile::tempdir().unwrap();
    let (code, out, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--still",
            "3600",
            "--bias-walk",
            "0.05,0.02",
            "-o",
            "still.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("360000 samples at 100 Hz"), "{out}");
    let (code, said, err) = calflash(
        d.path(),
        &["allan", "still.csv", "--sensor", "gyro", "--json", "g.json"],
    );
    assert_eq!(code, 0, "{err}");
    // The random walk and the walk are resolved; a term the record does not resolve is said
    // to be so, never printed as a 0.
    assert!(said.contains("random walk 0.2"), "{said}");
    assert!(!said.contains(" 0 counts"), "{said}");
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--still",
            "60",
            "-o",
            "short.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let (code, said, err) = calflash(d.path(), &["allan", "short.csv", "--sensor", "gyro"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        said.contains("rate random walk not resolved in this record"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("g.json")).unwrap()).unwrap();
    for axis in json["sensors"][0]["axes"].as_array().unwrap() {
        let terms = &axis["terms"];
        // 2 counts of white noise a sample at 100 Hz: 0.2 counts/sqrt(Hz).
        let n = terms["random_walk"].as_f64().unwrap();
        assert!((n / 0.2 - 1.0).abs() < 0.05, "{axis}");
        // The stated walk of 0.02 counts/sqrt(s), read from one hour.
        let k = terms["rate_random_walk"].as_f64().unwrap();
        assert!((0.01..0.03).contains(&k), "{axis}");
    }
}

/// One word, one meaning (issue 35): every command's `--help` is read; `--units` is physical
/// units wherever it appears, the sample rate is `--sample-rate` everywhere, `--noise` is an
/// observation's noise (design) and a blob's noise terms are `--noise-terms`; the old
/// spellings are still taken, unlisted.
#[test]
fn each_option_word_means_one_thing_in_every_command() {
    let d = tempfile::tempdir().unwrap();
    let (_, top, _) = calflash(d.path(), &["--help"]);
    let commands: Vec<&str> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(commands.len() > 15, "{top}");
    let mut helps: Vec<(String, String)> = Vec::new();
    for c in &commands {
        let (_, h, _) = calflash(d.path(), &[c, "--help"]);
        helps.push(((*c).to_string(), h.clone()));
        // Subcommands of a command (design, db) too.
        for sub in h
            .lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter_map(|l| l.split_whitespace().next())
            .filter(|s| *s != "help")
        {
            let (_, h, _) = calflash(d.path(), &[c, sub, "--help"]);
            helps.push((format!("{c} {sub}"), h));
        }
    }
    // The option's own line and its description, up to the next option.
    let option = |help: &str, name: &str| -> Option<String> {
        let mut lines = help.lines().skip_while(|l| {
            !l.trim_start()
                .split([' ', ','])
                .any(|w| w == name || w.starts_with(&format!("{name}=")))
        });
        let first = lines.next()?;
        let rest: Vec<&str> = lines
            .take_while(|l| !l.trim_start().starts_with('-'))
            .collect();
        Some(format!("{first} {}", rest.join(" ")))
    };
    for (c, h) in &helps {
        assert!(option(h, "--rate").is_none(), "calflash {c}: --rate");
        if let Some(u) = option(h, "--units") {
            assert!(
                u.contains("m/s^2") || u.contains("physical"),
                "calflash {c}: {u}"
            );
        }
        if let Some(n) = option(h, "--noise") {
            assert!(c.starts_with("design"), "calflash {c}: {n}");
        }
    }
    for c in ["apply", "health", "selfcal", "allan", "simulate"] {
        let h = &helps.iter().find(|(n, _)| n == c).unwrap().1;
        assert!(option(h, "--sample-rate").is_some(), "calflash {c}: {h}");
    }
    let cal = &helps.iter().find(|(n, _)| n == "calibrate").unwrap().1;
    assert!(option(cal, "--serials").is_some() && option(cal, "--noise-terms").is_some());
    // The old spellings still parse (an error of another kind, not an unknown option).
    for args in [
        &[
            "apply", "--blob", "x.blob", "in.csv", "--rate", "100", "-o", "o.csv",
        ][..],
        &[
            "calibrate",
            "x.csv",
            "--sensor",
            "imu",
            "--fixture",
            "--units",
            "u1=A",
            "--out-dir",
            "o",
        ],
        &[
            "calibrate",
            "x.csv",
            "--sensor",
            "imu",
            "--serial",
            "S",
            "--noise",
            "a.json,g.json",
        ],
    ] {
        let (code, _, err) = calflash(d.path(), args);
        assert_ne!(code, 0);
        assert!(!err.contains("unexpected argument"), "{args:?}: {err}");
    }
}

/// The summary in a datasheet's units (issue 35): bias in mg or deg/h per temperature from
/// the converter's mid-scale, scale factor's 1-sigma in ppm, misalignment in mrad, each the
/// fit's numbers converted; and it says which temperature the printed fit is for.
#[test]
fn calibrate_says_its_fit_in_engineering_units() {
    let d = tempfile::tempdir().unwrap();
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let (code, out, err) = calflash(
        d.path(),
        &[
            "calibrate",
            bench.to_str().unwrap(),
            "--sensor",
            "imu",
            "--serial",
            "E-1",
            "--no-db",
            "--report",
            "e1.html",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("  fit at 25.0 C (the record"), "{out}");
    // The report's first screen: the verdict, the same datasheet lines, the checks that
    // passed folded under one line.
    let page = std::fs::read_to_string(d.path().join("e1.html")).unwrap();
    let sheet = page
        .find("<b>In engineering units</b>")
        .expect("the datasheet");
    assert!(sheet < page.find("<h2>").unwrap_or(usize::MAX));
    for line in out.lines().filter(|l| l.contains(": bias (")) {
        assert!(
            page.contains(&format!("<li>{}</li>", line.trim().replace('&', "&amp;"))),
            "{line}"
        );
    }
    assert!(page.contains("check(s) passed (ACCEPT)</summary>"));
    assert!(!page.contains("<li><b>ACCEPT</b>"));
    let fit = out
        .lines()
        .find(|l| l.starts_with("  a_x: 1 "))
        .expect(&out);
    let value = |line: &str, name: &str| -> f64 {
        let at = line.find(&format!("{name} ")).unwrap() + name.len() + 1;
        line[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (b0, s, sy) = (value(fit, "1"), value(fit, "f_x"), value(fit, "f_y"));
    let eng = out
        .lines()
        .find(|l| l.trim_start().starts_with("a_x: bias (mg)"))
        .expect(&out);
    let bias_25: f64 = eng
        .split(", ")
        .find(|p| p.ends_with("at 25.0 C"))
        .and_then(|p| {
            p.split_whitespace()
                .find(|w| w.starts_with('+') || w.starts_with('-'))
        })
        .unwrap()
        .parse()
        .unwrap();
    let expected = (b0 - 32_768.0) / s / 9.806_65e-3;
    assert!(
        (bias_25 - expected).abs() < 0.01,
        "{bias_25} vs {expected}: {eng}"
    );
    let mrad = value(eng, "f_y");
    assert!((mrad - sy / s * 1e3).abs() < 0.01, "{eng}");
    assert!(eng.contains(" ppm)") && eng.contains("mrad"), "{eng}");
    let gyro = out
        .lines()
        .find(|l| l.trim_start().starts_with("g_x: bias (deg/h)"))
        .expect(&out);
    assert!(gyro.contains("counts per rad/s"), "{gyro}");
    // --quiet: the verdict, what is not ACCEPT, the engineering units and the files.
    let (code, quiet, err) = calflash(
        d.path(),
        &[
            "calibrate",
            bench.to_str().unwrap(),
            "--sensor",
            "imu",
            "--serial",
            "E-1",
            "--no-db",
            "--quiet",
        ],
    );
    assert_eq!(code, 0, "{quiet}{err}");
    assert!(
        out.lines().count() > 25 && quiet.lines().count() < 12,
        "{quiet}"
    );
    assert!(
        quiet.contains("unit E-1: ACCEPT")
            && quiet.contains("a_x: bias (mg)")
            && !quiet.contains("note ")
            && !quiet.contains("ACCEPT a_x"),
        "{quiet}"
    );
}

/// `allan` of a recording of both sensors analyses both (as of two files), writes one JSON of
/// both that `calibrate --noise-terms` takes twice, an HTML report with each axis' slope lines
/// and read-off points, and Kalibr's `imu.yaml` with the largest axis of each sensor.
#[test]
fn allan_analyses_both_sensors_and_writes_a_report_and_kalibrs_file() {
    let d = tempfile::tempdir().unwrap();
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--still",
            "900",
            "--bias-walk",
            "0.05,0.02",
            "-o",
            "still.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let (code, said, err) = calflash(
        d.path(),
        &[
            "allan",
            "still.csv",
            "--scale",
            "412,4770",
            "--json",
            "both.json",
            "--report",
            "allan.html",
            "--kalibr",
            "imu.yaml",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        said.contains("accelerometer in m/s^2 and gyro in rad/s"),
        "{said}"
    );
    assert!(
        said.contains("  accelerometer x: VRW ") && said.contains("  gyro z: ARW "),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("both.json")).unwrap())
            .unwrap();
    assert_eq!(json["schema"], "calflash.allan/2");
    let sensors = json["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), 2);
    assert_eq!(
        (&sensors[0]["sensor"], &sensors[0]["unit"]),
        (&"accel".into(), &"m/s^2".into())
    );
    assert_eq!(
        (&sensors[1]["sensor"], &sensors[1]["unit"]),
        (&"gyro".into(), &"rad/s".into())
    );
    // Kalibr's file: the largest axis' white noise of each sensor, as the JSON has it.
    let yaml = std::fs::read_to_string(d.path().join("imu.yaml")).unwrap();
    let value = |key: &str| -> f64 {
        yaml.lines()
            .find_map(|l| l.strip_prefix(&format!("{key}: ")))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{key} in {yaml}"))
    };
    let largest = |s: usize, key: &str| {
        sensors[s]["axes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["terms"][key].as_f64().unwrap())
            .fold(0.0, f64::max)
    };
    for (key, s) in [
        ("accelerometer_noise_density", 0),
        ("gyroscope_noise_density", 1),
    ] {
        assert!(
            (value(key) / largest(s, "random_walk") - 1.0).abs() < 1e-6,
            "{yaml}"
        );
    }
    assert!(value("accelerometer_random_walk") > 0.0 && value("gyroscope_random_walk") > 0.0);
    assert_eq!(value("update_rate"), 100.0);
    // The report: the terms of both sensors, six figures, each with its slope lines.
    let html = std::fs::read_to_string(d.path().join("allan.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 6, "six axes");
    assert_eq!(html.matches("slope -1/2: N = ").count(), 6);
    assert!(html.contains("where N, B and K are read") && html.contains("Kalibr imu.yaml"));
    // The record is white noise and a random walk: no bias instability or ramp is drawn or
    // stated (IEEE 952's flat line would sit under the curve), and the gyro's terms are given
    // in a datasheet's units too.
    assert!(!html.contains("slope 0: B"), "a bias instability drawn");
    for t in ["bias instability", "rate ramp", "ramp"] {
        assert!(!said.contains(&format!("{t} 0")), "{said}");
    }
    assert_eq!(
        said.matches("bias instability not resolved in this record")
            .count(),
        6,
        "{said}"
    );
    assert!(
        html.contains("deg/sqrt(h)") && html.contains("deg/h/sqrt(h)"),
        "the gyro's terms in deg/sqrt(h) and deg/h/sqrt(h)"
    );
    // One file of both serves `calibrate --noise-terms` for both sensors.
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/imu_bench.csv");
    let (code, out, err) = calflash(
        d.path(),
        &[
            "calibrate",
            bench.to_str().unwrap(),
            "--sensor",
            "imu",
            "--serial",
            "IMU-A-1",
            "--noise-terms",
            "both.json,both.json",
            "--blob",
            "u.blob",
            "--no-db",
        ],
    );
    assert!(code == 0 || code == 3, "{out}{err}");
    assert!(d.path().join("u.blob").is_file());
    // Kalibr needs both sensors in SI: refused before anything is written.
    let (code, _, err) = calflash(
        d.path(),
        &[
            "allan",
            "still.csv",
            "--sensor",
            "gyro",
            "--scale",
            "4770",
            "--kalibr",
            "k.yaml",
            "--json",
            "k.json",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("--kalibr: Kalibr's imu.yaml takes both sensors in SI units; this run analyses the gyro in rad/s"),
        "{err}"
    );
    assert!(!d.path().join("k.yaml").exists() && !d.path().join("k.json").exists());
    let (code, _, err) = calflash(d.path(), &["allan", "still.csv", "--scale", "1,2,3"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--scale: both sensors are analysed: two values"),
        "{err}"
    );
    // Two files: both analysed (the accelerometer's file was once ignored).
    common::write_recording(
        &calflash::sim::recording::Tumble::default().record(),
        d.path(),
    );
    let (code, said, err) = calflash(d.path(), &["allan", "acc.txt", "gyro.txt"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        said.contains("accelerometer x: ") && said.contains("gyro x: "),
        "{said}"
    );
}

/// `calibrate --help` lists the column names of an observation file itself (it once pointed
/// to the rustdoc of `calflash::columns`).
#[test]
fn calibrate_help_lists_the_columns() {
    let d = tempfile::tempdir().unwrap();
    let (code, help, _) = calflash(d.path(), &["calibrate", "--help"]);
    assert_eq!(code, 0);
    assert!(!help.contains("calflash::columns"), "{help}");
    for column in [
        "`input`",
        "`output`",
        "`f_x f_y f_z`",
        "`a_x a_y a_z`",
        "`w_x w_y w_z`",
        "`g_x g_y g_z`",
        "`dw_x dw_y dw_z`",
        "`h_x h_y h_z`",
        "`temp`",
        "`volt`",
    ] {
        assert!(help.contains(column), "{column} in {help}");
    }
}
