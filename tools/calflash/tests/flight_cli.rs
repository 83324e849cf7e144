//! In flight: a simulated shell's IMU navigated with its unit's calibration against GNSS and
//! a barometer; the filter fits the data, and a launch shift of one bias is found and
//! estimated. Bad inputs are named.

mod common;

use std::path::Path;

use common::calflash;

const TRUTH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/data/spinning_round.truth.json"
);

fn ok(dir: &Path, args: &[&str]) -> String {
    exits(dir, args, 0)
}

/// Runs `args` in `dir`, which must exit with `code` (`flight`: 3 SHIFTED); its output.
fn exits(dir: &Path, args: &[&str], code: i32) -> String {
    let (got, out, err) = calflash(dir, args);
    assert_eq!(got, code, "{args:?}: {out}{err}");
    out
}

/// The spinning round calibrated on its rig: `round.blob`.
fn calibrated(dir: &Path) {
    common::simulate_rig(dir, TRUTH, &[]);
    ok(
        dir,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "ROUND-1",
            "--blob",
            "round.blob",
            "--json",
            "round.json",
            "--db",
            "units.sqlite",
        ],
    );
}

/// `compare CALIBRATION.json FLIGHT.json`: the flight's report held against the calibration it
/// judged, one verdict and its exit code.
fn compared(dir: &Path, flight: &str) -> (i32, String, String) {
    calflash(dir, &["compare", "round.json", flight])
}

fn fly(dir: &Path, shift: Option<&str>) -> serde_json::Value {
    let mut extra = vec!["--baro", "b.csv", "--seed", "7"];
    if let Some(s) = shift {
        extra.extend(["--launch-shift", s]);
    }
    common::simulate_flight(
        dir,
        TRUTH,
        (
            "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=20",
            "2000",
        ),
        "s.csv",
        &extra,
    );
    let (code, out, err) = calflash(
        dir,
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--baro",
            "b.csv",
            "--json",
            "f.json",
            "--innovations",
            "nu.csv",
            "--report",
            "f.html",
            "--db",
            "units.sqlite",
        ],
    );
    // The verdict's exit code: 3 SHIFTED, 4 FILTER DOES NOT FIT, 0 otherwise.
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("f.json")).unwrap()).unwrap();
    let expected = match v["verdict"].as_str().unwrap() {
        "SHIFTED" => 3,
        "FILTER DOES NOT FIT" => 4,
        _ => 0,
    };
    assert_eq!(code, expected, "{out}{err}");
    let page = std::fs::read_to_string(dir.join("f.html")).unwrap();
    // Six figures, and the innovations one panel per kind of measurement the flight has.
    let innovations = page
        .split("<h2>Innovations</h2>")
        .nth(1)
        .and_then(|s| s.split("<h2").next())
        .unwrap_or("");
    let kinds = v["consistency"]["kinds"].as_array().unwrap().len();
    assert!(
        page.contains("<h1>Unit ROUND-1 in flight</h1>\n<p class=\"verdict ")
            && innovations.matches("<svg").count() == kinds
            && page.matches("<svg").count() == 6 + kinds,
        "{}",
        &page[..300]
    );
    // The page names the history's record of the check (issue 68).
    let made = calflash::report::provenance::read(&page).unwrap();
    assert!(
        made.record
            .as_deref()
            .is_some_and(|r| r.starts_with("db:") && r.ends_with(" in units.sqlite")),
        "{:?}",
        made.record
    );
    let nu = std::fs::read_to_string(dir.join("nu.csv")).unwrap();
    assert!(
        nu.starts_with("t,measurement,innovation,sigma,taken\n") && nu.contains(",position_east,"),
        "{}",
        &nu[..200.min(nu.len())]
    );
    assert!(out.contains("the filter's fit"), "{out}");
    serde_json::from_str(&std::fs::read_to_string(dir.join("f.json")).unwrap()).unwrap()
}

fn term<'a>(v: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    v["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["name"] == name)
        .unwrap()
}

#[test]
fn a_shell_flight_fits_and_a_launch_shift_of_one_bias_is_found() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    let held = fly(d.path(), None);
    let c = &held["consistency"];
    let inside = c["inside_95"].as_f64().unwrap() / c["innovations"].as_f64().unwrap();
    assert!(c["fits"].as_bool().unwrap() && inside > 0.95, "{c}");
    assert!(held["track_rms_m"].as_f64().unwrap() < 10.0, "{held}");
    assert!(
        !term(&held, "accel bias x")["shifted"].as_bool().unwrap(),
        "{held}"
    );
    // The unit history holds the calibration's record: its whole model is the prior.
    assert_eq!(held["prior"]["source"], "record", "{}", held["prior"]);
    assert!(
        held["prior"]["from"]
            .as_str()
            .unwrap()
            .starts_with("the unit history's record"),
        "{}",
        held["prior"]
    );
    // 0.8 m/s^2 is four of the calibration's sigmas of that bias at the round's spin (at rest
    // it is known to 0.1; spinning, its misalignment's error turns thousands of m/s^2 of
    // centripetal force across it into 0.19 along it).
    let sigma = term(&held, "accel bias x")["prior_sigma"].as_f64().unwrap();
    assert!((0.12..0.3).contains(&sigma), "{sigma}");
    let shifted = fly(d.path(), Some("ax=0.8"));
    assert_eq!(shifted["verdict"], "SHIFTED", "{shifted}");
    assert!(term(&shifted, "accel bias x")["shifted"].as_bool().unwrap());
    let (code, out, err) = compared(d.path(), "f.json");
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        out.contains("verdict: CHANGED: 1 shifted in flight (accel bias x)")
            && out.contains("accel bias x: ")
            && out.contains("SHIFTED"),
        "{out}"
    );
    // A flight record is compared after the calibration it judged, not before it.
    let (code, _, err) = calflash(d.path(), &["compare", "f.json", "round.json"]);
    assert_ne!(code, 0);
    assert!(err.contains("a flight report comes second"), "{err}");
    let found = shifted["shifts"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["term"] == "accel bias x")
        .unwrap();
    // The flight finds the shift plus the calibration's own error at the spin (1-sigma 0.19).
    let x = found["estimate"].as_f64().unwrap();
    assert!((x - 0.8).abs() < 0.6, "{found}");
    assert!(
        !term(&shifted, "gyro scale x")["shifted"].as_bool().unwrap(),
        "{shifted}"
    );
    // The history's record edited after it was written (red team four: the blob's factors
    // were taken instead without a word): not taken, and said.
    let conn = rusqlite::Connection::open(d.path().join("units.sqlite")).unwrap();
    let edited = conn
        .execute(
            "UPDATE records SET record = replace(record, 'rig.csv', 'rig2.csv') WHERE kind = 'fit'",
            [],
        )
        .unwrap();
    assert_eq!(edited, 1);
    drop(conn);
    let tampered = fly(d.path(), None);
    assert_eq!(
        tampered["prior"]["source"], "factors",
        "{}",
        tampered["prior"]
    );
    let said = tampered["history_refused"][0].as_str().unwrap();
    assert!(said.contains("fails its seal"), "{said}");
}

/// The guide's round given its blob alone, no record and no history (`--no-db`): the prior is
/// the blob's covariance factors', the record's within 10 %, and a 0.8 m/s^2 axial bias shift
/// on a 4 s shell is named as with the record. Before, the blob alone stated the axial bias to
/// 42 m/s^2 (a term the selection dropped, kept at 1e-7 of the bias's sigma by the factor's
/// jitter, times a cube of 10^4 m/s^2) and the verdict was HELD.
#[test]
fn the_blob_alone_names_the_shift_the_record_names() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    common::simulate_flight(
        d.path(),
        TRUTH,
        (
            "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=4",
            "2000",
        ),
        "s.csv",
        &["--baro", "b.csv", "--launch-shift", "ax=0.8"],
    );
    let args = [
        "flight",
        "s.csv",
        "--blob",
        "round.blob",
        "--record",
        "round.json",
        "--gnss",
        "g.csv",
        "--baro",
        "b.csv",
        "--no-db",
        "--json",
        "f.json",
        "--track",
        "track.csv",
    ];
    let out = exits(d.path(), &args, 3);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    assert!(
        term(&v, "accel bias x")["shifted"].as_bool().unwrap(),
        "{out}"
    );
    blob_alone_as_the_record(d.path(), &args, &v, "the guide's round");
    let alone: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("alone.json")).unwrap())
            .unwrap();
    assert!(
        term(&alone, "accel bias x")["shifted"].as_bool().unwrap(),
        "{alone}"
    );
}

/// The README's whole shell flight (62 s): its setback leaves the navigation lost, and the
/// first fix after it puts the navigation back, as the device's filter does; without that, the
/// filter drifted after apogee, refused every fix that would have brought it back and did not
/// fit (75 % inside, 452 refused).
#[test]
fn a_whole_shell_flight_is_put_back_on_its_fixes_after_the_setback_and_fits() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    common::simulate_flight(
        d.path(),
        TRUTH,
        ("shell:lat=39.4,lon=-8.3,azimuth=60,rest=2", "2000"),
        "s.csv",
        &["--baro", "b.csv"],
    );
    let out = ok(
        d.path(),
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--baro",
            "b.csv",
            "--json",
            "f.json",
            "--no-db",
        ],
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    let c = &v["consistency"];
    let inside = c["inside_95"].as_f64().unwrap() / c["innovations"].as_f64().unwrap();
    assert!(
        c["fits"].as_bool().unwrap() && inside > 0.95 && c["refused"] == 0,
        "{out}"
    );
    assert_eq!(v["verdict"], "HELD", "{out}");
    let (code, said, err) = compared(d.path(), "f.json");
    assert_eq!(code, 0, "{said}{err}");
    assert!(said.contains("verdict: UNCHANGED"), "{said}");
    let resets = v["navigation_resets"].as_array().unwrap();
    assert!(
        !resets.is_empty() && resets[0].as_f64().unwrap() < 2.0,
        "{out}"
    );
    assert!(out.contains("the navigation put back on GNSS"), "{out}");
}

#[test]
fn a_roll_gyro_scale_factor_shifted_at_launch_is_found_at_a_round_s_spin() {
    // 0.3 % at 1,500 to 1,900 rad/s: the roll angle runs away at 5 rad/s, beyond what the
    // filter can linearise from the calibration's prior; the search over hypotheses finds it.
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    let v = fly(d.path(), Some("swx=0.003"));
    assert_eq!(v["verdict"], "SHIFTED", "{v}");
    let t = term(&v, "gyro scale x");
    assert!(t["shifted"].as_bool().unwrap(), "{v}");
    let x = t["estimate"].as_f64().unwrap();
    // The flight reaches a few 1e-6; its estimate carries the calibration's residual (under
    // 1e-4, the stated allowance; the calibration states its own error with the terms its
    // choice dropped, 8e-5, so the estimate's 1-sigma is 7e-5).
    let sigma = t["sigma"].as_f64().unwrap();
    assert!(
        (x - 0.003).abs() < 1e-4 && sigma < 1e-4 && (x - 0.003).abs() < 3.0 * sigma,
        "{t}"
    );
    assert!(
        !term(&v, "accel bias x")["shifted"].as_bool().unwrap(),
        "{v}"
    );
}

/// Through a 300 rev/s spin the smoothed position stays within its stated bounds: against the
/// simulated truth, every epoch after the first fix puts the navigation back is within 4 of
/// its 1-sigma on each axis, and 95 % within 2.
#[test]
fn the_smoothed_position_stays_within_its_stated_bounds_through_the_spin() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    let spec = "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=20";
    common::simulate_flight(
        d.path(),
        TRUTH,
        (spec, "2000"),
        "s.csv",
        &[
            "--baro",
            "b.csv",
            "--flight-truth",
            "truth.csv",
            "--seed",
            "7",
        ],
    );
    let v = {
        ok(
            d.path(),
            &[
                "flight",
                "s.csv",
                "--blob",
                "round.blob",
                "--gnss",
                "g.csv",
                "--baro",
                "b.csv",
                "--track",
                "track.csv",
                "--json",
                "f.json",
                "--no-db",
            ],
        );
        serde_json::from_str::<serde_json::Value>(
            &std::fs::read_to_string(d.path().join("f.json")).unwrap(),
        )
        .unwrap()
    };
    let reset = v["navigation_resets"][0].as_f64().unwrap();
    let mut launch = calflash::sim::flight::spec::Launch::parse(spec).unwrap();
    let site = launch.site_mut().expect("the spec places the launch");
    let read = |name: &str| -> Vec<Vec<f64>> {
        let text = std::fs::read_to_string(d.path().join(name)).unwrap();
        text.lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let truth = read("truth.csv");
    let t0 = truth[0][0];
    let mut z = Vec::new();
    for row in read("track.csv").iter().filter(|r| r[0] > reset) {
        let k = (((row[0] - t0) * 2000.0).round() as usize).min(truth.len() - 1);
        let r = nalgebra::Vector3::new(truth[k][1], truth[k][2], truth[k][3]);
        let (lat, lon, h) = site.geodetic(&r);
        let (e, n, u) = map_3d::geodetic2enu(
            row[1].to_radians(),
            row[2].to_radians(),
            row[3],
            lat.to_radians(),
            lon.to_radians(),
            h,
            map_3d::Ellipsoid::WGS84,
        );
        z.extend([e / row[4], n / row[5], u / row[6]]);
    }
    let worst = z.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let inside = z.iter().filter(|x| x.abs() < 2.0).count() as f64 / z.len() as f64;
    println!(
        "{} epochs: worst {worst:.2} sigma, {:.1} % within 2",
        z.len() / 3,
        100.0 * inside
    );
    assert!(z.len() > 300, "{}", z.len());
    assert!(
        worst < 4.0 && inside > 0.95,
        "worst {worst}, inside {inside}"
    );
}

/// `--record` must be the record of the blob's calibration: another unit's (or another
/// calibration of this one) is refused naming both data hashes, and a file that is no record
/// is named.
#[test]
fn a_record_of_another_calibration_or_no_record_at_all_is_refused() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    let other = d.path().join("other");
    std::fs::create_dir(&other).unwrap();
    common::simulate_rig(&other, TRUTH, &["--seed", "2"]);
    ok(
        d.path(),
        &[
            "calibrate",
            "other/rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "ROUND-2",
            "--json",
            "other.json",
            "--no-db",
            "--quiet",
        ],
    );
    common::simulate_flight(
        d.path(),
        TRUTH,
        (
            "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=12",
            "2000",
        ),
        "s.csv",
        &[],
    );
    std::fs::write(
        d.path().join("not.json"),
        "{\"schema\": \"calflash.flight/1\"}",
    )
    .unwrap();
    // Another fit of the very data the blob was made from (a linear model): its record is not
    // the blob's (a record of a linear fit turned a SHIFTED flight into HELD).
    ok(
        d.path(),
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--linear",
            "--serial",
            "ROUND-1",
            "--json",
            "linear.json",
            "--no-db",
            "--quiet",
        ],
    );
    // Another unit's record of the same calibration.
    let mut renamed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("round.json")).unwrap())
            .unwrap();
    renamed["serial"] = "ROUND-9".into();
    std::fs::write(d.path().join("renamed.json"), renamed.to_string()).unwrap();
    for (record, says) in [
        (
            "other.json",
            "it is the record of unit ROUND-2; the blob is unit ROUND-1's",
        ),
        // An edited record is refused by its seal before its serial is compared.
        ("renamed.json", "its seal does not match its content"),
        (
            "linear.json",
            "it is the record of another fit of the same data",
        ),
        ("not.json", "not a calibration record"),
    ] {
        let args = [
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--record",
            record,
            "--no-db",
        ];
        let (code, out, err) = calflash(d.path(), &args);
        assert_ne!(code, 0, "{out}");
        assert!(
            err.contains(&format!("--record {record}: {says}")),
            "{record}: {err}"
        );
    }
    // An output onto the record would replace the input it reads: refused, the record kept.
    let before = std::fs::read(d.path().join("round.json")).unwrap();
    let (code, _, err) = calflash(
        d.path(),
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--record",
            "round.json",
            "--json",
            "round.json",
            "--no-db",
        ],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("--json round.json: that is the file --record reads"),
        "{err}"
    );
    assert_eq!(std::fs::read(d.path().join("round.json")).unwrap(), before);
    // Units a logger gets wrong: a barometer in hPa, an antenna's arm in mm.
    let baro = "t,P\n0,1013.2\n0.1,1013.3\n0.2,1013.1\n";
    std::fs::write(d.path().join("hpa.csv"), baro).unwrap();
    let (code, _, err) = calflash(
        d.path(),
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--baro",
            "hpa.csv",
            "--no-db",
        ],
    );
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("hpa.csv: its first pressure") && err.contains("hPa"),
        "{err}"
    );
    let (code, _, err) = calflash(
        d.path(),
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--lever",
            "50,0,0",
            "--no-db",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("in m, not mm"), "{err}");
    // GNSS times in ms, angles in radians, and a CRLF file's line numbers.
    let gnss = std::fs::read_to_string(d.path().join("g.csv")).unwrap();
    let mut lines = gnss.lines();
    let head = lines.next().unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let write = |name: &str, end: &str, f: &dyn Fn(&mut Vec<f64>)| {
        let mut text = format!("{head}{end}");
        for r in &rows {
            let mut r = r.clone();
            f(&mut r);
            let r: Vec<String> = r.iter().map(f64::to_string).collect();
            text += &format!("{}{end}", r.join(","));
        }
        std::fs::write(d.path().join(name), text).unwrap();
    };
    write("ms.csv", "\n", &|r| r[0] *= 1000.0);
    write("rad.csv", "\n", &|r| {
        r[1] = r[1].to_radians();
        r[2] = r[2].to_radians();
    });
    write("crlf.csv", "\r\n", &|_| ());
    let crlf = std::fs::read_to_string(d.path().join("crlf.csv")).unwrap();
    let mut crlf: Vec<&str> = crlf.split("\r\n").collect();
    let mut row: Vec<&str> = crlf[11].split(',').collect();
    row[1] = "north";
    let row = row.join(",");
    crlf[11] = &row;
    std::fs::write(d.path().join("crlf.csv"), crlf.join("\r\n")).unwrap();
    for (file, says) in [
        ("ms.csv", "if its times are in milliseconds"),
        ("rad.csv", "they look like radians"),
        ("crlf.csv", "crlf.csv line 12, column `latitude`: `north`"),
    ] {
        let (code, _, err) = calflash(
            d.path(),
            &[
                "flight",
                "s.csv",
                "--blob",
                "round.blob",
                "--gnss",
                file,
                "--no-db",
            ],
        );
        assert_eq!(code, 1, "{file}: {err}");
        assert!(err.contains(says), "{file}: {err}");
    }
    // A GNSS antenna is three coordinates.
    let (code, _, err) = calflash(
        d.path(),
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            TRUTH,
            "--flight",
            "shell:seconds=2",
            "-o",
            "x.csv",
            "--gnss",
            "xg.csv",
            "--gnss-antenna",
            "1,2",
        ],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("--gnss-antenna: 3 comma-separated values, 2 given"),
        "{err}"
    );
    assert!(!d.path().join("x.csv").exists() && !d.path().join("xg.csv").exists());
    // Its own record is taken.
    let out = ok(
        d.path(),
        &[
            "flight",
            "s.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--record",
            "round.json",
            "--no-db",
        ],
    );
    assert!(
        out.contains("prior: the calibration's own covariance, its whole model over the flight's rates (round.json)"),
        "{out}"
    );
}

#[test]
fn gnss_that_does_not_overlap_the_imu_a_flight_without_a_launch_and_a_rate_too_slow_for_the_spin_are_named()
 {
    let d = tempfile::tempdir().unwrap();
    let mut imu = String::from("t,f_x,f_y,f_z,w_x,w_y,w_z\n");
    for i in 0..500 {
        imu.push_str(&format!("{},0,0,9.8,0,0,0\n", f64::from(i) * 0.01));
    }
    std::fs::write(d.path().join("imu.csv"), imu).unwrap();
    std::fs::write(
        d.path().join("late.csv"),
        "t,latitude,longitude\n100,39.4,-8.3\n101,39.4,-8.3001\n",
    )
    .unwrap();
    let (code, _, err) = calflash(d.path(), &["flight", "imu.csv", "--gnss", "late.csv"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("do not overlap")
            && err.contains("100 to 101 s")
            && err.contains("0 to 4.99 s"),
        "{err}"
    );
    std::fs::write(
        d.path().join("g.csv"),
        "t,latitude,longitude,satellites\n1,39.4,-8.3,193\n2,39.4,-8.3,9\n3,39.4,-8.3001,9\n",
    )
    .unwrap();
    let (code, _, err) = calflash(d.path(), &["flight", "imu.csv", "--gnss", "g.csv"]);
    assert_ne!(code, 0);
    assert!(err.contains("no launch"), "{err}");
    std::fs::write(
        d.path().join("bad.csv"),
        "t,latitude,longitude\n1,95,-8.3\n",
    )
    .unwrap();
    let (code, _, err) = calflash(d.path(), &["flight", "imu.csv", "--gnss", "bad.csv"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("bad.csv line 2") && err.contains("latitude"),
        "{err}"
    );
}

/// A flight the GNSS horizontal position failed: the verdict's reason, which must name that
/// kind first, and its runs of refused fixes.
fn gnss_refused(v: &serde_json::Value) -> (String, serde_json::Value) {
    let why = v["why"].as_str().unwrap().to_string();
    assert!(why.starts_with("GNSS horizontal position: "), "{why}");
    let runs = v["consistency"]["kinds"]
        .as_array()
        .unwrap()
        .iter()
        .find(|k| k["kind"] == "GNSS horizontal position")
        .unwrap()["refused_runs"]
        .clone();
    (why, runs)
}

#[test]
fn a_rocket_flight_fits_and_finds_a_launch_shift_of_its_axial_bias() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    common::simulate_flight(
        d.path(),
        TRUTH,
        (
            "rocket:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=60",
            "1000",
        ),
        "r.csv",
        &["--baro", "b.csv", "--launch-shift", "ax=0.4", "--seed", "3"],
    );
    exits(
        d.path(),
        &[
            "flight",
            "r.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--baro",
            "b.csv",
            "--json",
            "f.json",
            "--no-db",
        ],
        3,
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    let c = &v["consistency"];
    assert!(c["fits"].as_bool().unwrap(), "{c}");
    assert_eq!(v["verdict"], "SHIFTED", "{v}");
    assert!(
        term(&v, "accel bias x")["shifted"].as_bool().unwrap(),
        "{v}"
    );
    // A rocket that rolls a few turns a second barely shows its roll gyro's scale factor:
    // what the flight alone determines of it is several times wider than the calibration's
    // (6.4 times since the calibration states its error with the terms its choice dropped),
    // and it is not named.
    let roll = term(&v, "gyro scale x");
    assert!(!roll["shifted"].as_bool().unwrap(), "{v}");
    assert!(
        roll["flight_sigma"]
            .as_f64()
            .is_none_or(|f| f > 5.0 * roll["prior_sigma"].as_f64().unwrap()),
        "{v}"
    );
    assert!(
        v["track_rms_m"].as_f64().unwrap() < 10.0 && v["height_rms_m"].as_f64().unwrap() < 10.0,
        "{v}"
    );
    // Every 4th fix after the launch held out of the filter: the smoothed track holds on
    // them, as it does on the fixes it saw.
    let held = &flown(d.path(), "g.csv", &["--hold-out", "4"], 3)["held_out"];
    assert!(held["believed"].as_bool().unwrap(), "{held}");
    assert!(held["fixes"].as_u64().unwrap() > 20, "{held}");
    // A receiver fault: from 25 to 35 s its fixes are 300 m east of where it is. The GNSS
    // position fails on its own (the barometer still fits), the run of refused fixes is
    // named, and no calibration shift is.
    let gnss = std::fs::read_to_string(d.path().join("g.csv")).unwrap();
    let mut lines = gnss.lines();
    let mut faulty = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let mut cols: Vec<String> = line.split(',').map(str::to_string).collect();
        let t: f64 = cols[0].parse().unwrap();
        if (25.0..35.0).contains(&t) {
            let lat: f64 = cols[1].parse().unwrap();
            let lon: f64 = cols[2].parse().unwrap();
            let east = 300.0 / (6_378_137.0 * lat.to_radians().cos());
            cols[2] = format!("{:.9}", lon + east.to_degrees());
        }
        faulty.push_str(&cols.join(","));
        faulty.push('\n');
    }
    std::fs::write(d.path().join("faulty.csv"), faulty).unwrap();
    let v = flown(d.path(), "faulty.csv", &[], 4);
    let (why, runs) = gnss_refused(&v);
    assert!(
        runs.as_array().unwrap().iter().any(|r| {
            let (from, to) = (r["from"].as_f64().unwrap(), r["to"].as_f64().unwrap());
            (24.0..28.0).contains(&from) && (30.0..36.0).contains(&to)
        }),
        "{why}"
    );
    assert_eq!(v["shifts"].as_array().unwrap().len(), 0, "{v}");
    // The receiver's own fault is not cleared: its fixes step by 300 m at the span's ends.
    assert!(
        !why.contains("the receiver did not lose the track"),
        "{why}"
    );
    // The receiver fault as written: its fixes frozen from 25 to 35 s (each the 25 s
    // fix again), then, from 35 s on, 300 m east of where it is.
    let mut lines = gnss.lines();
    let mut frozen = format!("{}\n", lines.next().unwrap());
    let mut held: Option<(String, String)> = None;
    for line in lines {
        let mut cols: Vec<String> = line.split(',').map(str::to_string).collect();
        let t: f64 = cols[0].parse().unwrap();
        if (25.0..35.0).contains(&t) {
            let (lat, lon) = held
                .get_or_insert_with(|| (cols[1].clone(), cols[2].clone()))
                .clone();
            cols[1] = lat;
            cols[2] = lon;
        } else if t >= 35.0 {
            let lat: f64 = cols[1].parse().unwrap();
            let lon: f64 = cols[2].parse().unwrap();
            let east = 300.0 / (6_378_137.0 * lat.to_radians().cos());
            cols[2] = format!("{:.9}", lon + east.to_degrees());
        }
        frozen.push_str(&cols.join(","));
        frozen.push('\n');
    }
    std::fs::write(d.path().join("frozen.csv"), frozen).unwrap();
    let v = flown(d.path(), "frozen.csv", &[], 4);
    let (why, runs) = gnss_refused(&v);
    assert!(
        runs.as_array()
            .unwrap()
            .iter()
            .any(|r| (24.0..36.0).contains(&r["from"].as_f64().unwrap())),
        "{why}\n{runs}"
    );
    assert_eq!(v["shifts"].as_array().unwrap().len(), 0, "{v}");
    assert!(
        !why.contains("the receiver did not lose the track"),
        "{why}"
    );
    // A logger's clock that stuck for one sample (red team four: this passed silently, with
    // the clean log's verdict): refused, naming the line.
    let imu = std::fs::read_to_string(d.path().join("r.csv")).unwrap();
    let mut stuck = String::new();
    let mut before = String::new();
    for (i, line) in imu.lines().enumerate() {
        let (t, rest) = line.split_once(',').unwrap();
        if i == 101 {
            stuck.push_str(&format!("{before},{rest}\n"));
        } else {
            stuck.push_str(&format!("{line}\n"));
        }
        before = t.to_string();
    }
    std::fs::write(d.path().join("stuck.csv"), stuck).unwrap();
    let (code, out, err) = calflash(
        d.path(),
        &[
            "flight",
            "stuck.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--no-db",
        ],
    );
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("stuck.csv line 102") && err.contains("is not after the line above's"),
        "{err}"
    );
}

/// `flight r.csv` with the round's blob, `gnss` and the barometer, `extra` options, exiting
/// with `code`: its JSON record.
fn flown(dir: &Path, gnss: &str, extra: &[&str], code: i32) -> serde_json::Value {
    let mut args = vec![
        "flight",
        "r.csv",
        "--blob",
        "round.blob",
        "--gnss",
        gnss,
        "--baro",
        "b.csv",
        "--json",
        "f.json",
        "--no-db",
    ];
    args.extend(extra);
    exits(dir, &args, code);
    serde_json::from_str(&std::fs::read_to_string(dir.join("f.json")).unwrap()).unwrap()
}

/// A rocket's GNSS antenna a metre forward of the IMU: as the rocket pitches over, the arm's
/// turn `C (w x l)` adds to the antenna's velocity, and the filter carries it in its velocity
/// updates (without it this flight does not fit: 58 % of the innovations inside, 551 refused).
#[test]
fn a_rocket_s_antenna_a_metre_forward_is_carried_in_the_velocity_too() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    common::simulate_flight(
        d.path(),
        TRUTH,
        (
            "rocket:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=30",
            "1000",
        ),
        "r.csv",
        &["--gnss-antenna", "1.0,0,0.15"],
    );
    ok(
        d.path(),
        &[
            "flight",
            "r.csv",
            "--blob",
            "round.blob",
            "--gnss",
            "g.csv",
            "--lever",
            "1.0,0,0.15",
            "--json",
            "f.json",
            "--no-db",
        ],
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    let c = &v["consistency"];
    let inside = c["inside_95"].as_f64().unwrap() / c["innovations"].as_f64().unwrap();
    assert!(c["fits"].as_bool().unwrap() && inside > 0.95, "{c}");
    assert_eq!(c["refused"], 0, "{c}");
}

/// The real Hedy rocket flight: its physical IMU log, its GNSS (a receiver that holds stale
/// fixes and tracks 3 to 5 satellites through the boost) and its barometer, with the options
/// the guide documents. Its filter loses the track from about 20 s (east innovations of
/// 600 m against a 1-sigma of 19 m): the fit is judged per kind, so the barometer's 2,200
/// good innovations do not hide the GNSS's failing ones, and the verdict is FILTER DOES NOT
/// FIT naming the span, what the recording shows there, and no calibration shift; the fixes
/// held out of the filter say the same with no truth.
/// Issue 65: `--hold-out 4` on our simulated shells, the receiver's own noise given: pooled
/// over four flights, 92 to 98 % of the held-out fixes are within 3 sigma of the smoothed
/// track (97.1 % where the stated sigmas are true), and each flight's track is believed.
#[test]
fn held_out_fixes_are_within_3_sigma_as_often_as_stated_on_our_shells() {
    let d = tempfile::tempdir().unwrap();
    calibrated(d.path());
    let (mut within, mut fixes) = (0, 0);
    for seed in ["1", "2", "3", "4"] {
        common::simulate_flight(
            d.path(),
            TRUTH,
            ("shell:lat=39.4,lon=-8.3,azimuth=60,rest=2", "2000"),
            "s.csv",
            &["--baro", "b.csv", "--seed", seed],
        );
        let (code, out, err) = calflash(
            d.path(),
            &[
                "flight",
                "s.csv",
                "--blob",
                "round.blob",
                "--gnss",
                "g.csv",
                "--baro",
                "b.csv",
                "--gnss-noise",
                "2,4",
                "--hold-out",
                "4",
                "--json",
                "f.json",
                "--no-db",
            ],
        );
        assert!(code == 0 || code == 3, "seed {seed}: {out}{err}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap())
                .unwrap();
        let held = &v["held_out"];
        assert!(held["believed"].as_bool().unwrap(), "seed {seed}: {held}");
        within += held["within_3_sigma"].as_u64().unwrap();
        fixes += held["fixes"].as_u64().unwrap();
    }
    let share = within as f64 / fixes as f64;
    println!("our shells: {within} of {fixes} held-out fixes within 3 sigma ({share:.3})");
    assert!(
        fixes > 400 && (0.92..=0.98).contains(&share),
        "{within} of {fixes}"
    );
}

#[test]
fn the_hedy_flight_does_not_fit_its_gnss_and_says_where() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/hedy-rocket");
    if !dir.join("imu.csv").is_file() {
        println!(
            "hedy flight: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            dir.display()
        );
        return;
    }
    let d = tempfile::tempdir().unwrap();
    let p = |f: &str| dir.join(f).display().to_string();
    let out = exits(
        d.path(),
        &[
            "flight",
            &p("imu.csv"),
            "--imu-columns",
            "t=ts,fx=Ax:m/s^2,fy=Ay:m/s^2,fz=Az:m/s^2,wx=Gx:deg/s,wy=Gy:deg/s,wz=Gz:deg/s",
            "--gnss",
            &p("gnssInfo.csv"),
            "--baro",
            &p("baro.csv"),
            "--baro-noise",
            "4",
            "--hold-out",
            "4",
            "--json",
            "h.json",
            "--report",
            "h.html",
            "--track",
            "h_track.csv",
        ],
        4,
    );
    // The page shows each kind's fit and the held-out fixes, not only the pooled share.
    let page = std::fs::read_to_string(d.path().join("h.html")).unwrap();
    let table = page
        .split("<h2>The fit, kind by kind</h2>")
        .nth(1)
        .and_then(|t| t.split("</table>").next())
        .unwrap_or_else(|| panic!("no table of the kinds' fits"));
    assert!(
        table.contains("<td>GNSS horizontal position</td>")
            && table.contains("DOES NOT FIT")
            && table.contains("<td>barometer</td>")
            && table.contains(" to 36.4 s"),
        "{table}"
    );
    assert!(
        page.contains("Held out: every 4th fix") && page.contains("the track cannot be believed"),
        "no held-out fixes on the page"
    );
    // The innovations drawn kind by kind, each panel titled with its share inside.
    let innovations = page.split("<h2>Innovations</h2>").nth(1).unwrap();
    let innovations = innovations.split("<h2").next().unwrap();
    for kind in ["GNSS horizontal position: ", "barometer: "] {
        assert!(innovations.contains(kind), "no panel of {kind}");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("h.json")).unwrap()).unwrap();
    assert_eq!(v["verdict"], "FILTER DOES NOT FIT", "{out}");
    let kinds = v["consistency"]["kinds"].as_array().unwrap();
    let kind = |name: &str| kinds.iter().find(|k| k["kind"] == name).unwrap();
    let gnss = kind("GNSS horizontal position");
    assert!(!gnss["fits"].as_bool().unwrap(), "{gnss}");
    assert!(kind("barometer")["fits"].as_bool().unwrap(), "{out}");
    // The run of refused fixes lies in the boost and coast, where the receiver tracked few
    // satellites.
    let runs = gnss["refused_runs"].as_array().unwrap();
    assert!(
        runs.iter().any(|r| r["count"].as_u64().unwrap() >= 10
            && (15.0..25.0).contains(&r["from"].as_f64().unwrap())
            && (30.0..40.0).contains(&r["to"].as_f64().unwrap())),
        "{gnss}"
    );
    // The cause: the receiver's fixes over the span hold together (within their stated noise
    // of one smooth path, though most used 4 or 5 satellites), so the IMU's prediction lost
    // the track, not the receiver.
    let why = v["why"].as_str().unwrap();
    assert!(
        why.starts_with("GNSS horizontal position: ")
            && why.contains(" refused from ")
            && why.contains("hold together (within ")
            && why.contains("the receiver did not lose the track, the IMU's prediction did")
            && why.contains("fewer than 6 satellites, and still agree"),
        "{why}"
    );
    assert!(v["diagnosis"]["weak_fixes"].as_u64().unwrap() > 5, "{v}");
    let (n, rms) = (
        v["diagnosis"]["fixes_from_smooth_path"][0]
            .as_u64()
            .unwrap(),
        v["diagnosis"]["fixes_from_smooth_path"][1]
            .as_f64()
            .unwrap(),
    );
    assert!(n >= 20 && rms < 2.5 * 3.0, "{n} fixes, {rms} m");
    // The flight computer's own estimate (`flightInfo.csv`, its barometer and accelerometer)
    // is an independent witness of the height: over the span the smoothed track's height above
    // the pad is within 50 m of it (about 5 km up), so the vertical held and what was lost is
    // the horizontal, the attitude's.
    let witness: Vec<(f64, f64)> = std::fs::read_to_string(dir.join("flightInfo.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (c[0], c[1])
        })
        .collect();
    let at = |t: f64| {
        let k = witness
            .partition_point(|w| w.0 < t)
            .clamp(1, witness.len() - 1);
        let (a, b) = (witness[k - 1], witness[k]);
        a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0)
    };
    let track: Vec<Vec<f64>> = std::fs::read_to_string(d.path().join("h_track.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let pad: Vec<f64> = track.iter().filter(|r| r[0] < 0.0).map(|r| r[3]).collect();
    let pad = pad.iter().sum::<f64>() / pad.len() as f64;
    let worst = track
        .iter()
        .filter(|r| (17.0..=36.4).contains(&r[0]))
        .map(|r| (r[3] - pad - at(r[0])).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 50.0,
        "the track's height is {worst} m from the flight computer's"
    );
    // No term is named: the estimates of a filter that lost its track are not findings.
    assert_eq!(v["shifts"].as_array().unwrap().len(), 0, "{v}");
    assert!(!out.contains("SHIFTED"), "{out}");
    // Held out, the fixes are far from the smoothed track: under 90 % within 3 sigma.
    let held = &v["held_out"];
    assert!(!held["believed"].as_bool().unwrap(), "{held}");
    assert!(
        held["within_3_sigma"].as_f64().unwrap() / held["fixes"].as_f64().unwrap() < 0.9,
        "{held}"
    );
    assert!(out.contains("the track cannot be believed"), "{out}");
    // The receiver's "no fix" rows and the minute it held one fix are counted and left out.
    assert!(
        v["gnss_no_fix"].as_u64().unwrap() > 50 && v["gnss_repeated"].as_u64().unwrap() > 100,
        "{v}"
    );
}

/// An independent simulator's flights (`../shared/data/reference-flights`: McCoy 6-DOF shells
/// over a rotating WGS-84 Earth, GNSS acquiring after muzzle exit with correlated errors; the
/// unit calibrated from its own bench file): the shifted 155 mm shell is SHIFTED naming its two
/// shifted terms, each within 3 of its 1-sigma of the truth; the 105 mm shell is HELD; the
/// RocketPy rocket's filter fits (95 % of its innovations inside), its heading is within its
/// 1-sigma of the truth, and its transverse gyro bias shift (+5e-3 rad/s) is named, or left
/// unnamed with the flight's own 1-sigma of it printed beside the smallest shift the flight
/// names (above the true one: CANNOT TELL); on every flight the smoothed track is within 3 of
/// its 1-sigma of the truth on at least 95 % of the epochs.
#[test]
fn the_reference_flights_are_named_and_held_and_their_tracks_within_their_bounds() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/reference-flights");
    if !root.join("shell155/imu.csv").is_file() {
        println!(
            "reference flights: SKIPPED, {} is absent (it lives beside the checkout in CI)",
            root.display()
        );
        return;
    }
    // The rocket's transverse gyro bias shift (+5e-3 rad/s at ignition, 3 of the flight's own
    // 1-sigma of its change at launch) moves the observed terms together without naming one:
    // SHIFTED, none named.
    for (case, lever, verdict, shifts, drawn) in [
        (
            "shell155",
            "0.05,0,0",
            "SHIFTED",
            &[("accel bias x", 0.06), ("gyro scale x", 2.0e-4)][..],
            "2,4",
        ),
        ("shell105", "0.03,0,0", "HELD", &[][..], "2,4"),
        ("rocket_calisto", "0.2,0,0.02", "SHIFTED", &[][..], "1.5,3"),
    ] {
        let rocket = case.starts_with("rocket");
        let d = tempfile::tempdir().unwrap();
        let p = |f: &str| root.join(case).join(f).display().to_string();
        ok(
            d.path(),
            &[
                "calibrate",
                &p("bench.csv"),
                "--sensor",
                "imu",
                "--nonlinear",
                "--codes",
                if rocket { "signed16" } else { "signed24" },
                "--thermal",
                "table",
                "--serial",
                "REF",
                "--blob",
                "unit.blob",
                "--json",
                "unit.json",
                "--no-db",
                "--quiet",
            ],
        );
        let (imu, gnss, baro) = (p("imu.csv"), p("gnss.csv"), p("baro.csv"));
        let mut args = vec![
            "flight",
            &imu,
            "--blob",
            "unit.blob",
            "--record",
            "unit.json",
            "--gnss",
            &gnss,
            "--baro",
            &baro,
            "--lever",
            lever,
            "--no-db",
            "--json",
            "f.json",
            "--track",
            "track.csv",
        ];
        if rocket {
            // Its barometer reads the true static pressure (no port error).
            args.extend(["--baro-cp", "0"]);
        }
        let out = exits(d.path(), &args, if verdict == "SHIFTED" { 3 } else { 0 });
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap())
                .unwrap();
        assert_eq!(v["verdict"], verdict, "{case}: {out}");
        let named: Vec<&str> = v["terms"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|t| t["shifted"].as_bool().unwrap())
            .map(|t| t["name"].as_str().unwrap())
            .collect();
        assert_eq!(named.len(), shifts.len(), "{case}: {out}");
        for (name, truth) in shifts {
            let t = term(&v, name);
            let (x, s) = (
                t["estimate"].as_f64().unwrap(),
                t["sigma"].as_f64().unwrap(),
            );
            assert!(
                t["shifted"].as_bool().unwrap() && (x - truth).abs() <= 3.0 * s,
                "{case} {name}: {x} +- {s} against {truth}: {out}"
            );
        }
        if case == "shell155" {
            // Opened alone (the terms it correlates with at their calibration), the axial bias
            // is what the flight determines of it: 4.0e-3 m/s^2; with every term opened at
            // once the axial scale factor took part of it, 9.4e-3.
            let s = term(&v, "accel bias x")["sigma"].as_f64().unwrap();
            assert!(s < 5e-3, "{case}: accel bias x 1-sigma {s}: {out}");
        }
        // What the flight cannot tell apart is said, not hidden.
        assert!(v["undecided"].is_array(), "{case}: {v}");
        let k = &v["consistency"];
        let inside = k["inside_95"].as_f64().unwrap() / k["innovations"].as_f64().unwrap();
        assert!(inside >= 0.95, "{case}: {inside}: {out}");
        // The heading at rest within its 1-sigma of the truth's (a turn about the vertical
        // after the levelling's shortest rotation).
        let truth_heading = heading_of(&root.join(case).join("truth_trajectory.csv"));
        let (h, hs) = (
            v["heading_deg"][0].as_f64().unwrap(),
            v["heading_deg"][1].as_f64().unwrap(),
        );
        let off = (h - truth_heading + 540.0).rem_euclid(360.0) - 180.0;
        if rocket {
            assert!(
                off.abs() <= hs,
                "{case}: heading {h} +- {hs} against {truth_heading}"
            );
            // Its transverse gyro bias: named, or the flight's own 1-sigma of its change at
            // launch printed beside the smallest change it names (19 times in 20), which the
            // true shift is below: CANNOT TELL, said.
            let gy = term(&v, "gyro bias y");
            if !gy["shifted"].as_bool().unwrap() {
                let u = v["unseen"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|u| u["term"] == "gyro bias y")
                    .unwrap_or_else(|| panic!("{case}: gyro bias y neither named nor unseen: {v}"));
                let (from, sd) = (
                    u["smallest"].as_f64().unwrap(),
                    u["sigma"].as_f64().unwrap(),
                );
                assert!(
                    from > 5.0e-3 && from >= 4.0 * sd,
                    "{case}: gyro bias y named from {from} (1-sigma {sd}), not named at 5e-3: {out}"
                );
                let cal = u["calibration"].as_f64().unwrap();
                let line = format!(
                    "| gyro bias y | named from {from:.2e} rad/s | the flight's own 1-sigma {sd:.2e}, the calibration's {cal:.2e} |"
                );
                assert!(out.contains(&line), "{line} not in {out}");
                assert!(out.contains("CANNOT TELL"), "{out}");
            }
        }
        // A term named is not among those the flight could not see, and one that is has one
        // figure of what the flight alone tells of it: the table's is the list's.
        for u in v["unseen"].as_array().unwrap() {
            let name = u["term"].as_str().unwrap();
            assert!(!named.contains(&name), "{case}: {u} named and unseen");
            let table = term(&v, name)["flight_sigma"].as_f64();
            assert_eq!(
                table,
                u["sigma"].as_f64(),
                "{case}: {name}'s flight alone in the table and the list"
            );
        }
        // The smoothed track against the truth (its 200 Hz rows), epoch by epoch.
        let truth = truth_positions(&root.join(case).join("truth_trajectory.csv"));
        let track = std::fs::read_to_string(d.path().join("track.csv")).unwrap();
        let (mut inside, mut n) = (0, 0);
        for line in track.lines().skip(1) {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let Some(at) = truth.iter().position(|r| r[0] >= v[0]).filter(|&k| k > 0) else {
                continue;
            };
            let (a, b) = (truth[at - 1], truth[at]);
            let u = (v[0] - a[0]) / (b[0] - a[0]);
            let true_at = [0, 1, 2].map(|k| a[1 + k] * (1.0 - u) + b[1 + k] * u);
            let e = calflash::nav::frame::level_position(
                &calflash::nav::input::Fix {
                    t: v[0],
                    lat_lon: (v[1], v[2]),
                    height: Some(v[3]),
                    velocity: None,
                    satellites: None,
                },
                (true_at[0], true_at[1], true_at[2]),
            );
            n += 1;
            inside += usize::from((0..3).all(|k| e[k].abs() <= 3.0 * v[4 + k]));
        }
        let share = inside as f64 / n as f64;
        println!("{case}: {verdict}; track within 3 sigma on {inside} of {n} epochs");
        // An epoch a fix or a pressure is taken at (the covariance steps between are
        // composed into the next): about ten a second.
        assert!(n > 150 && share >= 0.95, "{case}: {inside} of {n}");
        blob_alone_as_the_record(d.path(), &args, &v, case);
        // Issue 65: every 4th fix held out, the receiver's noise as its simulator drew it
        // (`scenario.json`): 92 to 98 % of them within 3 sigma of the smoothed track.
        let mut held_args: Vec<&str> = args.clone();
        held_args.extend(["--hold-out", "4", "--gnss-noise", drawn]);
        let (code, out, err) = calflash(d.path(), &held_args);
        assert!(code == 0 || code == 3, "{case}: {out}{err}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap())
                .unwrap();
        let held = &v["held_out"];
        let share = held["within_3_sigma"].as_f64().unwrap() / held["fixes"].as_f64().unwrap();
        println!("{case}: held out, {share:.3} within 3 sigma");
        assert!(
            held["fixes"].as_u64().unwrap() > 40 && (0.92..=0.98).contains(&share),
            "{case}: {held}"
        );
    }
}

/// The same flight given the blob alone (no record): the prior from the blob's covariance
/// factors is the record's within 10 % for every term, and the verdict is the same. Before the
/// factor's jitter was scaled to each feature's own variance, the spinning round's blob alone
/// stated an axial bias prior of 42 m/s^2 (the record's: 0.21) and missed its shift.
fn blob_alone_as_the_record(dir: &Path, args: &[&str], record: &serde_json::Value, case: &str) {
    let mut alone: Vec<&str> = Vec::with_capacity(args.len());
    let mut skip = false;
    for a in args {
        if skip {
            skip = false;
            continue;
        }
        match *a {
            "--record" => skip = true,
            "f.json" => alone.push("alone.json"),
            "track.csv" => alone.push("alone_track.csv"),
            a => alone.push(a),
        }
    }
    let (code, out, err) = calflash(dir, &alone);
    assert!(code == 0 || code == 3, "{case}, the blob alone: {out}{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("alone.json")).unwrap()).unwrap();
    assert_eq!(v["prior"]["source"], "factors", "{case}: {}", v["prior"]);
    assert_eq!(
        v["verdict"], record["verdict"],
        "{case}, the blob alone: {out}"
    );
    for t in record["terms"].as_array().unwrap() {
        let name = t["name"].as_str().unwrap();
        let (a, b) = (
            t["prior_sigma"].as_f64().unwrap(),
            term(&v, name)["prior_sigma"].as_f64().unwrap(),
        );
        println!("{case}: {name} prior from the record {a:.4e}, from the blob {b:.4e}");
        assert!(
            (b / a - 1.0).abs() <= 0.1,
            "{case}: {name}: the blob's prior {b} against the record's {a}"
        );
    }
}

/// The heading at rest of a reference flight's truth (its first row's attitude, body to NED),
/// as `flight` states it: the turn about the vertical that remains after the shortest rotation
/// taking the specific force at rest to up, degrees.
fn heading_of(path: &Path) -> f64 {
    use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    let at = |n: &str| row[head.iter().position(|h| *h == n).unwrap()];
    let q =
        UnitQuaternion::from_quaternion(Quaternion::new(at("q0"), at("q1"), at("q2"), at("q3")));
    let ned_to_enu = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let c = ned_to_enu * q.to_rotation_matrix().into_inner();
    let f = Vector3::new(at("f_x"), at("f_y"), at("f_z"));
    let up = UnitQuaternion::rotation_between(&f, &Vector3::z()).unwrap();
    let m = c * up.to_rotation_matrix().into_inner().transpose();
    m[(1, 0)].atan2(m[(0, 0)]).to_degrees()
}

/// Time, latitude, longitude (degrees) and height of a reference flight's truth rows.
fn truth_positions(path: &Path) -> Vec<[f64; 4]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let cols = [at("t"), at("lat_deg"), at("lon_deg"), at("h_m")];
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            cols.map(|k| f[k].parse().unwrap())
        })
        .collect()
}
