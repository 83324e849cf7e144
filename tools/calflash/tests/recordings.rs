//! Recordings as other IMUs and loggers write them (issue 14): signed codes, a logger's
//! preamble, a header, no timestamps; the real MPU-6050 recordings in `../shared/data/`
//! (skipped with a notice when they are absent, as in a user's clone) and signed-code
//! observation files made from the examples.

use std::path::{Path, PathBuf};

mod common;

use common::calflash;

fn mpu6050() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/mpu6050-imucalibration");
    if d.join("example_data_calibration.csv").is_file() {
        Some(d)
    } else {
        println!(
            "MPU-6050 recordings: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            d.display()
        );
        None
    }
}

fn arg(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The MPU-6050 logger's file (a preamble, a header, signed counts, no timestamps, about ten
/// poses): read as unsigned it is named signed; read as signed, the preamble's rate and rest
/// are used and the answer is "too few still poses", saying what was found.
#[test]
fn the_mpu6050_calibration_file_is_read_and_answered() {
    let Some(d) = mpu6050() else { return };
    let out = tempfile::tempdir().unwrap();
    let file = d.join("example_data_calibration.csv");
    let base = [
        "selfcal",
        arg(&file),
        "--g",
        "9.81",
        "--serial",
        "MPU-6050",
        "--no-db",
    ];
    let (code, _, err) = calflash(out.path(), &base);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("example_data_calibration.csv:6: ")
            && err.contains("codes below zero: the codes look signed; add --codes signed16"),
        "{err}"
    );
    let mut signed = base.to_vec();
    signed.extend(["--codes", "signed16", "--blob", "m.blob"]);
    let (code, said, err) = calflash(out.path(), &signed);
    println!("{said}{err}");
    assert_eq!(code, 1);
    assert!(
        err.contains("a logger's preamble states a rate of 100 Hz (line 1) and an initial rest of 36.5 s (line 3); not used: Logging Type, Waiting time"),
        "{err}"
    );
    assert!(err.contains("too few still poses: "), "{err}");
    assert!(
        err.contains("Found: 10 pose(s) facing 10 distinct directions held ")
            && err.contains(" at 100.0 Hz over 65.9 s after a 36.5 s rest. Record it again with 12 or more poses"),
        "{err}"
    );
    assert!(!out.path().join("m.blob").exists());
    // A rate on the command line that contradicts the preamble is named.
    signed.extend(["--rate", "200"]);
    let (code, _, err) = calflash(out.path(), &signed);
    assert_eq!(code, 1);
    assert!(
        err.contains(":1: the preamble states 100 Hz and --sample-rate 200 Hz"),
        "{err}"
    );
}

/// The MPU-6050's long still file, one file of six signed counts and no timestamps, gives an
/// Allan deviation in rad/s with its scale (131 counts per deg/s); the MEMS gyro's angle random
/// walk is a fraction of a degree per root hour.
#[test]
fn the_mpu6050_still_file_gives_an_allan_deviation_in_stated_units() {
    let Some(d) = mpu6050() else { return };
    let out = tempfile::tempdir().unwrap();
    let file = d.join("example_data_tinit_calc.csv");
    let per_rad_s = format!("{}", 131.0 * 180.0 / std::f64::consts::PI);
    let json = out.path().join("allan.json");
    let (code, said, err) = calflash(
        out.path(),
        &[
            "allan",
            arg(&file),
            "--sensor",
            "gyro",
            "--scale",
            &per_rad_s,
            "--json",
            arg(&json),
        ],
    );
    println!("{said}{err}");
    assert_eq!(code, 0, "{err}");
    assert!(
        said.contains("44930 samples at 100.00 Hz (449.3 s), gyro in rad/s"),
        "{said}"
    );
    for line in said.lines().skip(1) {
        let arw: f64 = line
            .split(" rad/s/sqrt(Hz) = ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!((0.1..2.0).contains(&arw), "{line}");
    }
}

/// A single-axis accelerometer logged in signed codes: read as unsigned the tool names the
/// format; with `--codes signed16` it calibrates as the unsigned original does, and the blob
/// keeps the signed rails.
#[test]
fn signed_observation_codes_are_named_and_calibrate_with_codes_signed16() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let src =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/single_accel.csv");
    let text = std::fs::read_to_string(&src).unwrap();
    let signed: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| match (i, l.rsplit_once(',')) {
            (0, _) | (_, None) => format!("{l}\n"),
            (_, Some((head, v))) => {
                format!("{head},{}\n", v.parse::<f64>().unwrap() - 32768.0)
            }
        })
        .collect();
    std::fs::write(d.join("signed.csv"), signed).unwrap();
    std::fs::copy(&src, d.join("unsigned.csv")).unwrap();
    let cal = |file: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            file,
            "--sensor",
            "single-accel",
            "--serial",
            "S-16",
            "--no-db",
        ];
        args.extend(extra);
        calflash(d, &args)
    };
    let (code, _, err) = cal("signed.csv", &[]);
    assert_eq!(code, 1);
    assert!(
        err.contains("codes below zero: the codes look signed; add --codes signed16 (the format given is unsigned16)"),
        "{err}"
    );
    let (code, said, err) = cal("signed.csv", &["--codes", "signed16", "--blob", "s.blob"]);
    assert_eq!(code, 0, "{said}{err}");
    let (code, plain, _) = cal("unsigned.csv", &[]);
    assert_eq!(code, 0);
    // The same verdict and coefficients but the bias, which moves by 32768 counts.
    let verdict = |s: &str| {
        s.lines()
            .next()
            .unwrap()
            .rsplit(':')
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(verdict(&said), verdict(&plain));
    let blob = spincal::blob::decode(&std::fs::read(d.join("s.blob")).unwrap()).unwrap();
    match &blob.data().sensor {
        spincal::model::Sensor::Single { rails, channel, .. } => {
            assert_eq!(*rails, spincal::model::Rails::signed(16));
            assert!(channel.center.abs() < 1000.0, "{}", channel.center);
        }
        _ => panic!("a single axis"),
    }
    // Applied to the signed codes, the correction gives the inputs back.
    let (code, _, err) = calflash(
        d,
        &[
            "apply",
            "signed.csv",
            "--blob",
            "s.blob",
            "--temp-column",
            "temp",
            "-o",
            "si.csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let si = std::fs::read_to_string(d.join("si.csv")).unwrap();
    let inputs: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    let worst = si
        .lines()
        .skip(1)
        .zip(&inputs)
        .map(|(l, x)| (l.split(',').nth(1).unwrap().parse::<f64>().unwrap() - x).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 0.05, "largest error {worst} m/s^2");
}

fn mpu9150() -> Option<PathBuf> {
    let d =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/mpu9150-imu-calib");
    if d.join("imu1.log").is_file() {
        Some(d)
    } else {
        println!(
            "MPU-9150 recordings: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            d.display()
        );
        None
    }
}

/// The two MPU-9150 units log m/s^2 and rad/s as their driver delivers them (six columns, no
/// header, no timestamp, 100 Hz, a 7 s rest). Read as counts they are named as not counts;
/// with `--units m/s2,rad/s` both calibrate in SI, the JSON states the units, and no blob is
/// written (the device corrects codes) unless the value of one code is given.
#[test]
fn the_mpu9150_recordings_calibrate_in_physical_units() {
    let Some(d) = mpu9150() else { return };
    let out = tempfile::tempdir().unwrap();
    for unit in ["imu1", "imu2"] {
        let file = d.join(format!("{unit}.log"));
        let base = [
            "selfcal",
            arg(&file),
            "--rate",
            "100",
            "--g",
            "9.8204",
            "--init-rest",
            "6",
            "--serial",
            unit,
            "--no-db",
        ];
        let (code, _, err) = calflash(out.path(), &base);
        assert_eq!(code, 1);
        assert!(err.contains("codes below zero"), "{err}");
        let mut si = base.to_vec();
        si.extend(["--units", "m/s2,rad/s", "--json", "r.json"]);
        let (code, said, err) = calflash(out.path(), &si);
        assert_eq!(code, 0, "{said}{err}");
        assert!(said.contains(": ACCEPT"), "{said}");
        assert!(
            said.contains("inputs  accelerometer in m/s^2, gyro in rad/s"),
            "{said}"
        );
        assert!(
            said.contains("device  no blob: the values are physical"),
            "{said}"
        );
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join("r.json")).unwrap())
                .unwrap();
        assert_eq!(r["inputs"]["accel"], "m/s^2");
        assert_eq!(r["inputs"]["gyro_file_unit"], "rad/s");
        // The fit is of a unit already near SI: scale within 1 %, |a| - g within 5 mm/s^2 RMS.
        let m = &r["accel"]["matrix_m_s2_per_count"];
        for i in 0..3 {
            let s = m[i][i].as_f64().unwrap();
            assert!((s - 1.0).abs() < 0.01, "{unit} M[{i}][{i}] = {s}");
        }
        assert!(r["accel"]["rms_m_s2"].as_f64().unwrap() < 5e-3);
        assert!(r["gyro"]["rms_deg"].as_f64().unwrap() < 1.0);
        // Three of each log's poses are slow turns the accelerometer's still test passes (the
        // gyro reads up to 70 mrad/s there against a bias steady to 2 mrad/s): found, and kept
        // out of the bias. The stored calibration's gravity-direction error between the poses'
        // means is within 10 % of imu_tk's on the same rotations (its in-sample figures in the
        // data README: 0.3221 and 0.3414 deg). It was below them when the fit ran between the
        // poses' means too, which fitted the poses' drift: held out that was 1.7 and 1.5 times
        // imu_tk's, now 0.63 and 0.50 times (held_out.rs).
        assert_eq!(
            r["gyro"]["turning_poses"].as_array().unwrap().len(),
            3,
            "{unit}"
        );
        let constant = r["gyro"]["constant_bias_rms_deg"].as_f64().unwrap();
        let imu_tk = if unit == "imu1" { 0.3221 } else { 0.3414 };
        assert!(constant < 1.10 * imu_tk, "{unit}: {constant} deg");
        // A blob needs codes.
        let mut blob = si.clone();
        blob.extend(["--blob", "u.blob"]);
        let (code, _, err) = calflash(out.path(), &blob);
        assert_eq!(code, 1);
        assert!(err.contains("--blob: the values are physical"), "{err}");
        assert!(!out.path().join("u.blob").exists());
        // With the value of one code (a +-8 g and +-500 deg/s setting: the gyro reaches 272
        // deg/s) the codes are calibrated, the blob written, and `apply` corrects the file
        // read the same way, and refuses it read as SI.
        let lsb = [
            "--lsb",
            "9.80665/4096,0.01745329/65.5",
            "--codes",
            "signed16",
        ];
        blob.extend(lsb);
        let (code, said, err) = calflash(out.path(), &blob);
        assert_eq!(code, 0, "{said}{err}");
        assert!(
            said.contains("inputs  accelerometer in codes of "),
            "{said}"
        );
        assert!(out.path().join("u.blob").is_file());
        let apply = [
            "apply",
            "--blob",
            "u.blob",
            "--recording",
            arg(&file),
            "--rate",
            "100",
            "--units",
            "m/s2,rad/s",
            "--output",
            "c.csv",
        ];
        let (code, _, err) = calflash(out.path(), &apply);
        assert_eq!(code, 1);
        assert!(
            err.contains("the values are physical and the blob corrects converter codes"),
            "{err}"
        );
        let mut apply = apply.to_vec();
        apply.extend(&lsb[..2]);
        let (code, said, err) = calflash(out.path(), &apply);
        assert_eq!(code, 0, "{said}{err}");
        std::fs::remove_file(out.path().join("u.blob")).unwrap();
    }
}

/// The realbench judge's hold-out split of the two MPU-9150 logs (`../shared/tools/realbench`:
/// the first 15 of 23 poses, to 99 s): on 15 poses the quadratic accelerometer terms pass their
/// F test (p = 0.008 and 0.004) but predict the poses held out worse (77 against 3.4 mm/s^2 on
/// the first log; on the second a fold cannot fit them at all), so they are not kept. Before,
/// the first was kept with the poses held out 400 times worse than the fit, and the second
/// stopped the calibration ("no convergence in 200 iterations").
/// A logger set for a decimal comma writes `;` between fields (issue 66: "1 fields; expected
/// 7"): the first MPU-9150 log written so is read as the same recording and gives the same fit.
#[test]
fn a_semicolon_file_with_decimal_commas_is_the_same_recording() {
    let Some(d) = mpu9150() else { return };
    let out = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(d.join("imu1.log")).unwrap();
    std::fs::write(
        out.path().join("semi.log"),
        text.replace('.', ",").replace(' ', ";"),
    )
    .unwrap();
    let fit = |file: &str, json: &str| {
        let (code, said, err) = calflash(
            out.path(),
            &[
                "selfcal",
                file,
                "--rate",
                "100",
                "--g",
                "9.8204",
                "--init-rest",
                "6",
                "--serial",
                "imu1",
                "--no-db",
                "--units",
                "m/s2,rad/s",
                "--json",
                json,
            ],
        );
        assert_eq!(code, 0, "{said}{err}");
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join(json)).unwrap()).unwrap();
        (r["accel"].clone(), r["gyro"].clone())
    };
    let original = fit(arg(&d.join("imu1.log")), "a.json");
    assert_eq!(fit("semi.log", "b.json"), original);
}

#[test]
fn a_few_poses_do_not_keep_quadratic_terms_the_poses_held_out_refute() {
    let Some(d) = mpu9150() else { return };
    let out = tempfile::tempdir().unwrap();
    for unit in ["imu1", "imu2"] {
        let text = std::fs::read_to_string(d.join(format!("{unit}.log"))).unwrap();
        let part: String = text.lines().take(9903).map(|l| format!("{l}\n")).collect();
        std::fs::write(out.path().join("part.log"), part).unwrap();
        let (code, said, err) = calflash(
            out.path(),
            &[
                "selfcal",
                "part.log",
                "--rate",
                "100",
                "--g",
                "9.8204",
                "--init-rest",
                "6",
                "--units",
                "m/s2,rad/s",
                "--serial",
                unit,
                "--no-db",
                "--json",
                "r.json",
            ],
        );
        assert_eq!(code, 0, "{unit}: {said}{err}");
        assert!(
            said.contains("not better on the poses held out: not kept"),
            "{said}"
        );
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join("r.json")).unwrap())
                .unwrap();
        assert_eq!(r["accel"]["quadratic_test"]["kept"], false, "{unit}");
        let ratio = r["accel"]["holdout"]["rms"].as_f64().unwrap()
            / r["accel"]["rms_m_s2"].as_f64().unwrap();
        assert!(ratio < 10.0, "{unit}: held out {ratio} times the fit");
    }
}

/// imucal's Ferraris session (`../shared/data/imucal-ferraris`, m/s^2 and deg/s, six faces
/// and three turns): its 13 poses are counted as facing their six directions (they were "1
/// distinct directions" in physical units), and the refusal says why 13 poses are not enough.
#[test]
fn a_six_face_session_in_physical_units_is_refused_for_its_directions() {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/imucal-ferraris/example_ferraris_session.csv");
    if !d.is_file() {
        println!("Ferraris session: SKIPPED, {} is absent", d.display());
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let (code, said, err) = calflash(
        out.path(),
        &[
            "selfcal",
            arg(&d),
            "--units",
            "m/s2,deg/s",
            "--sample-rate",
            "102.4",
            "--init-rest",
            "2.5",
            "--g",
            "9.81",
            "--serial",
            "F",
            "--no-db",
        ],
    );
    assert_eq!(code, 1, "{said}{err}");
    assert!(
        err.contains("13 pose(s) facing 6 distinct directions"),
        "{err}"
    );
    assert!(
        err.contains("The 13 poses face only 6 distinct directions"),
        "{err}"
    );
}

/// Units in a header's names (`ax_g`, `gx_dps`) are read and converted to SI; names in mixed
/// units, and `--units` that contradicts the header, are refused at the header's line.
#[test]
fn units_in_a_header_are_read_and_contradictions_named() {
    let out = tempfile::tempdir().unwrap();
    let p = out.path();
    let mut text = String::from("t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps\n");
    for k in 0..400 {
        text.push_str(&format!(
            "{},{:.5},{:.5},{:.5},{:.4},{:.4},{:.4}\n",
            10 * k,
            0.001 * f64::from(k % 3),
            -0.002,
            1.0 + 0.0005 * f64::from(k % 2),
            0.1 * f64::from(k % 5),
            -0.2,
            0.3
        ));
    }
    std::fs::write(p.join("g.csv"), &text).unwrap();
    let (code, said, err) = calflash(
        p,
        &["allan", "g.csv", "--sensor", "gyro", "--json", "a.json"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(said.contains("gyro in rad/s"), "{said}");
    let (code, _, err) = calflash(
        p,
        &["allan", "g.csv", "--sensor", "gyro", "--units", "g,rad/s"],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("g.csv:1: --units gives the gyro in rad/s where the header names deg/s"),
        "{err}"
    );
    std::fs::write(p.join("m.csv"), text.replacen("ay_g", "ay_mg", 1)).unwrap();
    let (code, _, err) = calflash(p, &["allan", "m.csv", "--sensor", "accel"]);
    assert_eq!(code, 1);
    assert!(
        err.contains(
            "m.csv:1: the header names the accelerometer's axes in mixed units (g, mg, g)"
        ),
        "{err}"
    );
    let (code, _, err) = calflash(
        p,
        &[
            "allan",
            "g.csv",
            "--sensor",
            "gyro",
            "--units",
            "counts,counts",
        ],
    );
    assert_eq!(code, 1);
    assert!(err.contains("where the header names deg/s"), "{err}");
    std::fs::write(p.join("c.txt"), "0 1 2 3\n0.01 1 2 3\n").unwrap();
    let (code, _, err) = calflash(p, &["allan", "c.txt", "--lsb", "1/16384,1/131"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("c.txt:1: --lsb gives the value of one code, for values in a physical unit; the gyro is in counts"),
        "{err}"
    );
}

/// A logger's CSV whose names the tool does not know (a millisecond stamp, `A1..A3`,
/// `R1..R3`, a die temperature, in another order): `--columns` picks them, the tumble
/// calibrates as the same recording with known names does, and the temperature is carried
/// into the record; a name the header does not have lists the ones it has, and `--columns` on
/// a file without a header is refused.
#[test]
fn columns_chosen_by_name_are_read_and_a_wrong_name_lists_the_header() {
    use calflash::sim::recording::Tumble;
    let out = tempfile::tempdir().unwrap();
    let p = out.path();
    let rec = Tumble::default().record();
    let mut text = String::from("R1,R2,R3,die_c,stamp,A1,A2,A3\n");
    for k in 0..rec.len() {
        let (a, g) = (rec.acc[k], rec.gyro[k]);
        text.push_str(&format!(
            "{},{},{},{:.2},{:.3},{},{},{}\n",
            g[0],
            g[1],
            g[2],
            25.0 + 0.001 * k as f64,
            rec.t[k] * 1e3,
            a[0],
            a[1],
            a[2]
        ));
    }
    std::fs::write(p.join("log.csv"), &text).unwrap();
    let columns = "t=stamp:ms,ax=A1,ay=A2,az=A3,gx=R1,gy=R2,gz=R3,temp=die_c";
    let base = [
        "selfcal", "log.csv", "--g", "9.81", "--serial", "T1", "--no-db", "--json", "r.json",
    ];
    let (code, _, err) = calflash(p, &base);
    assert_eq!(code, 1);
    assert!(err.contains("log.csv:2: 8 fields; expected 7"), "{err}");
    let mut chosen = base.to_vec();
    chosen.extend(["--columns", columns]);
    let (code, said, err) = calflash(p, &chosen);
    assert_eq!(code, 0, "{said}{err}");
    assert!(said.contains(": ACCEPT"), "{said}");
    assert!(said.contains("temperature  column die_c: 25 to "), "{said}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p.join("r.json")).unwrap()).unwrap();
    assert_eq!(r["recording"]["temperature"]["column"], "die_c");
    assert!((r["recording"]["rate_hz"].as_f64().unwrap() - rec.rate()).abs() < 1e-6);
    // The same samples with names the tool knows give the same fit.
    let known = text.replacen(
        "R1,R2,R3,die_c,stamp,A1,A2,A3",
        "gx,gy,gz,temperature,time_ms,ax,ay,az",
        1,
    );
    std::fs::write(p.join("known.csv"), known).unwrap();
    let mut plain = base.to_vec();
    plain[1] = "known.csv";
    plain[8] = "k.json";
    let (code, said, err) = calflash(p, &plain);
    assert_eq!(code, 0, "{said}{err}");
    let k: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p.join("k.json")).unwrap()).unwrap();
    assert_eq!(r["accel"]["parameters"], k["accel"]["parameters"]);
    assert_eq!(
        r["gyro"]["matrix_rad_s_per_count"],
        k["gyro"]["matrix_rad_s_per_count"]
    );
    // A name the header does not have.
    let mut wrong = base.to_vec();
    wrong.extend(["--columns", "t=stamp:ms,ax=A1,ay=A2,az=A4"]);
    let (code, _, err) = calflash(p, &wrong);
    assert_eq!(code, 1);
    assert!(
        err.contains(
            "log.csv:1: --columns names `A4`, which is not in the header; its columns are: R1, R2, R3, die_c, stamp, A1, A2, A3"
        ),
        "{err}"
    );
    // No header at all.
    std::fs::write(p.join("bare.txt"), "0 1 2 3 4 5 6\n0.01 1 2 3 4 5 6\n").unwrap();
    let mut bare = base.to_vec();
    bare[1] = "bare.txt";
    bare.extend(["--columns", columns]);
    let (code, _, err) = calflash(p, &bare);
    assert_eq!(code, 1);
    assert!(
        err.contains("bare.txt:1: --columns names columns, but the file has no header line"),
        "{err}"
    );
    // A role that is not one.
    let mut role = base.to_vec();
    role.extend(["--columns", "accel_x=A1"]);
    let (code, _, err) = calflash(p, &role);
    assert_eq!(code, 2);
    assert!(err.contains("`accel_x` is not a role"), "{err}");
}

/// A MATLAB level-5 file of double matrices (uncompressed), as `save -v6` writes one.
fn mat_file(arrays: &[(&str, usize, usize, Vec<f64>)]) -> Vec<u8> {
    let pad = |v: &mut Vec<u8>| {
        while !v.len().is_multiple_of(8) {
            v.push(0);
        }
    };
    let mut out = Vec::new();
    let mut text = b"MATLAB 5.0 MAT-file, written by the calflash tests".to_vec();
    text.resize(116, b' ');
    out.extend(text);
    out.extend([0u8; 8]);
    out.extend(0x0100u16.to_le_bytes());
    out.extend(b"IM");
    for (name, rows, cols, data) in arrays {
        assert_eq!(data.len(), rows * cols);
        let mut body = Vec::new();
        // Array flags: class double (6).
        body.extend(6u32.to_le_bytes());
        body.extend(8u32.to_le_bytes());
        body.extend(6u32.to_le_bytes());
        body.extend(0u32.to_le_bytes());
        // Dimensions.
        body.extend(5u32.to_le_bytes());
        body.extend(8u32.to_le_bytes());
        body.extend((*rows as i32).to_le_bytes());
        body.extend((*cols as i32).to_le_bytes());
        // Name.
        body.extend(1u32.to_le_bytes());
        body.extend((name.len() as u32).to_le_bytes());
        body.extend(name.as_bytes());
        pad(&mut body);
        // Real part, column-major.
        body.extend(9u32.to_le_bytes());
        body.extend(((data.len() * 8) as u32).to_le_bytes());
        for x in data {
            body.extend(x.to_le_bytes());
        }
        pad(&mut body);
        out.extend(14u32.to_le_bytes());
        out.extend((body.len() as u32).to_le_bytes());
        out.extend(body);
    }
    out
}

/// The simulated tumble kept as MATLAB files: one N x 7 matrix (time and six counts), and
/// variables named `time_ms`, `acc` and `gyro` (N x 3 each), both calibrate as the text file
/// does; a file without such arrays lists what it holds.
#[test]
fn matlab_files_are_read_as_recordings() {
    use calflash::sim::recording::Tumble;
    let out = tempfile::tempdir().unwrap();
    let p = out.path();
    let rec = Tumble::default().record();
    let n = rec.len();
    // Column-major N x 7.
    let mut whole = Vec::with_capacity(7 * n);
    whole.extend(rec.t.iter().copied());
    for j in 0..3 {
        whole.extend(rec.acc.iter().map(|v| v[j]));
    }
    for j in 0..3 {
        whole.extend(rec.gyro.iter().map(|v| v[j]));
    }
    std::fs::write(p.join("whole.mat"), mat_file(&[("imu", n, 7, whole)])).unwrap();
    let col = |x: &[[f64; 3]]| (0..3).flat_map(|j| x.iter().map(move |v| v[j])).collect();
    std::fs::write(
        p.join("named.mat"),
        mat_file(&[
            ("acc", n, 3, col(&rec.acc)),
            ("gyro", n, 3, col(&rec.gyro)),
            ("time_ms", n, 1, rec.t.iter().map(|t| t * 1e3).collect()),
        ]),
    )
    .unwrap();
    let mut text = String::new();
    for k in 0..n {
        let (a, g) = (rec.acc[k], rec.gyro[k]);
        text.push_str(&format!(
            "{} {} {} {} {} {} {}\n",
            rec.t[k], a[0], a[1], a[2], g[0], g[1], g[2]
        ));
    }
    std::fs::write(p.join("text.txt"), text).unwrap();
    let run = |file: &str| {
        let json = format!("{file}.json");
        let (code, said, err) = calflash(
            p,
            &[
                "selfcal", file, "--g", "9.81", "--serial", "M1", "--no-db", "--json", &json,
            ],
        );
        assert_eq!(code, 0, "{file}: {said}{err}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p.join(&json)).unwrap()).unwrap();
        v
    };
    let text = run("text.txt");
    for file in ["whole.mat", "named.mat"] {
        let m = run(file);
        assert_eq!(m["verdict"], text["verdict"], "{file}");
        let (a, b) = (&m["accel"]["parameters"], &text["accel"]["parameters"]);
        for k in 0..a.as_array().unwrap().len() {
            let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * y.abs().max(1.0),
                "{file}: {x} vs {y}"
            );
        }
    }
    // Two matrices that could each be the recording: refused, not one picked without a word
    // (issue 30).
    let mut both = Vec::with_capacity(14 * n);
    both.extend(rec.t.iter().copied());
    for j in 0..3 {
        both.extend(rec.acc.iter().map(|v| v[j]));
    }
    for j in 0..3 {
        both.extend(rec.gyro.iter().map(|v| v[j]));
    }
    let second = both.clone();
    std::fs::write(
        p.join("two.mat"),
        mat_file(&[("run1", n, 7, both), ("run2", n, 7, second)]),
    )
    .unwrap();
    let (code, _, err) = calflash(p, &["selfcal", "two.mat", "--g", "9.81", "--serial", "M1"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("2 matrices could be the recording (run1 [")
            && err.contains("run2 [")
            && err.contains("keep one per file"),
        "{err}"
    );
    std::fs::write(
        p.join("other.mat"),
        mat_file(&[("pressure", 4, 2, vec![1.0; 8])]),
    )
    .unwrap();
    let (code, _, err) = calflash(
        p,
        &["selfcal", "other.mat", "--g", "9.81", "--serial", "M1"],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("other.mat: no matrix of 7 or 6 columns")
            && err.contains("the file holds: pressure [4, 2]"),
        "{err}"
    );
    // A file beyond what is read whole is refused by its stated length, before it is read
    // (issue 30: the `matfile` crate parses the whole file).
    let huge = std::fs::File::create(p.join("huge.mat")).unwrap();
    huge.set_len(calflash::obs::recording::mat::MAX_MAT + 1)
        .unwrap();
    drop(huge);
    let (code, _, err) = calflash(p, &["selfcal", "huge.mat", "--g", "9.81", "--serial", "M1"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("huge.mat")
            && err.contains("longer than 1073741824 bytes")
            && err.contains("save it as text"),
        "{err}"
    );
    // A device named `.mat` is not read to the bound first.
    std::os::unix::fs::symlink("/dev/zero", p.join("zero.mat")).unwrap();
    let (code, _, err) = calflash(p, &["selfcal", "zero.mat", "--g", "9.81", "--serial", "M1"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("zero.mat: not a regular file"), "{err}");
}
