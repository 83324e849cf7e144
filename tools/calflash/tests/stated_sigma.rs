//! The unit's stated 1-sigma against the record's: at every unflagged sample of a flight, the
//! 1-sigma the device computes from the blob's covariance factors (`calflash apply --sigma`,
//! the firmware crate's own f32 arithmetic) is within 10 % of the one the record's full
//! covariance gives at the same corrected values in f64 (`sensor::record::stated`), and never
//! more than 10 % below it.
//!
//! Cases: the guide's spinning round (`spin-rig.md`, selection on) through the guide's 3 s shell
//! and a 25 s one (`mission.md`: the setback, the spin to 300 rev/s and its decay); the IMU bench
//! unit of the README's tour over its tour; and the independent simulator's reference units
//! (`../shared/data/reference-flights`, calibrated from their `bench.csv` at five table points)
//! through their own flights, at every table point.
//!
//! Before the covariance factor's jitter was scaled to each feature's own variance, a term the
//! selection dropped kept a standard error of 1e-7 of the bias's, which the round's cube of
//! 10^4 m/s^2 turned into a stated 1-sigma of 20,000 m/s^2 (the round's a_z stated 245 m/s^2
//! against a true error of 0.24).

mod common;

use std::path::{Path, PathBuf};

use calflash::sensor::record::Record;
use calflash::sensor::record::stated::PointStatement;
use common::calflash;

const ROUND: &str = "examples/data/spinning_round.truth.json";
const BENCH: &str = "examples/data/imu_bench.truth.json";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn run(dir: &Path, args: &[&str]) -> String {
    let (code, out, err) = calflash(dir, args);
    assert_eq!(code, 0, "calflash {args:?}: {out}\n{err}");
    out
}

/// What `apply --sigma` wrote: per sample its corrected values, flags and stated 1-sigmas.
struct Applied {
    values: Vec<[f32; 6]>,
    flags: Vec<u32>,
    sigma: Vec<[f32; 6]>,
}

fn read_applied(path: &Path) -> Applied {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let values_at = ["ax", "ay", "az", "wx", "wy", "wz"].map(at);
    let sigma_at = [
        "sigma_ax", "sigma_ay", "sigma_az", "sigma_wx", "sigma_wy", "sigma_wz",
    ]
    .map(at);
    let flags_at = at("flags");
    let mut out = Applied {
        values: Vec::new(),
        flags: Vec::new(),
        sigma: Vec::new(),
    };
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        out.values
            .push(values_at.map(|k| cells[k].parse().unwrap_or(f32::NAN)));
        out.sigma
            .push(sigma_at.map(|k| cells[k].parse().unwrap_or(f32::NAN)));
        out.flags.push(cells[flags_at].parse().unwrap());
    }
    out
}

/// The worst ratios of the unit's 1-sigma over the record's, per output, over the unflagged
/// samples; and how many were compared.
fn worst_ratios(applied: &Applied, statement: &PointStatement) -> ([(f64, f64); 6], usize) {
    let mut worst = [(f64::INFINITY, 0.0f64); 6];
    let mut n = 0;
    for ((v, s), flags) in applied
        .values
        .iter()
        .zip(&applied.sigma)
        .zip(&applied.flags)
    {
        if *flags != 0 {
            continue;
        }
        n += 1;
        let record = statement.sigma(&v.map(f64::from));
        for k in 0..6 {
            let r = f64::from(s[k]) / record[k];
            worst[k].0 = worst[k].0.min(r);
            worst[k].1 = worst[k].1.max(r);
        }
    }
    (worst, n)
}

fn check(name: &str, applied: &Applied, statement: &PointStatement) {
    let (worst, n) = worst_ratios(applied, statement);
    println!(
        "{name}: {n} unflagged samples; unit / record per output (lowest, highest): {worst:.4?}"
    );
    assert!(n >= 30, "{name}: only {n} unflagged samples");
    for (k, (lo, hi)) in worst.iter().enumerate() {
        assert!(
            *lo >= 0.9 && *hi <= 1.1,
            "{name}, output {k}: the unit states {lo:.4} to {hi:.4} of the record's 1-sigma"
        );
    }
}

fn record(path: &Path) -> Record {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn the_guides_round_states_the_records_error_through_a_shell() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = root().join(ROUND);
    let truth = truth.to_str().unwrap();
    run(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            truth,
            "--plan",
            "tumble:24",
            "--plan",
            "rate:-1900:1900:9",
            "--plan",
            "diagonal:-1900:1900:9",
            "--plan",
            "centrifuge:1:1500:6",
            "-o",
            "rig.csv",
        ],
    );
    run(
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
            "--json",
            "round.json",
            "--no-db",
            "-q",
        ],
    );
    let rec = record(&d.join("round.json"));
    let statement = PointStatement::of(&rec.points[0]).unwrap();
    for seconds in [3, 25] {
        let csv = format!("shell{seconds}.csv");
        run(
            d,
            &[
                "simulate",
                "--sensor",
                "imu",
                "--truth",
                truth,
                "--flight",
                &format!("shell:seconds={seconds}"),
                "-o",
                &csv,
            ],
        );
        run(
            d,
            &[
                "apply",
                "--blob",
                "round.blob",
                &csv,
                "--time-column",
                "t",
                "--sigma",
                "-o",
                "si.csv",
            ],
        );
        let applied = read_applied(&d.join("si.csv"));
        check(
            &format!("the round, {seconds} s shell"),
            &applied,
            &statement,
        );
        // The setback and the muzzle's spin-up are flagged, never stated silently small.
        let flagged = applied.flags.iter().filter(|f| **f != 0).count();
        assert!(flagged > 0, "{seconds} s: the setback flagged nothing");
        if seconds == 3 {
            // The guide's accuracy check (`mission.md`): no output's stated 1-sigma is
            // overstated or understated, and the page says it holds. Before, a_z stated 245
            // m/s^2 against an RMS error of 3.8 and the page said "holds" all the same.
            let out = run(
                d,
                &[
                    "apply",
                    "--blob",
                    "round.blob",
                    &csv,
                    "--time-column",
                    "t",
                    "--reference",
                    "-o",
                    "si.csv",
                    "--report",
                    "shell3.html",
                ],
            );
            assert_eq!(out.matches(" | holds | ").count(), 6, "{out}");
            let page = std::fs::read_to_string(d.join("shell3.html")).unwrap();
            assert!(page.contains("class=\"verdict accept\">Holds:"), "{page}");
        }
    }
}

#[test]
fn the_bench_unit_states_the_records_error_over_its_tour() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = root().join(BENCH);
    run(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            truth.to_str().unwrap(),
            "--plan",
            "tumble:24",
            "--plan",
            "rate:-8:8:9",
            "-o",
            "tour.csv",
        ],
    );
    run(
        d,
        &[
            "calibrate",
            "tour.csv",
            "--sensor",
            "imu",
            "--serial",
            "TOUR-0001",
            "--blob",
            "tour.blob",
            "--json",
            "tour.json",
            "--no-db",
            "-q",
        ],
    );
    run(
        d,
        &[
            "apply",
            "--blob",
            "tour.blob",
            "tour.csv",
            "--sigma",
            "-o",
            "si.csv",
        ],
    );
    let rec = record(&d.join("tour.json"));
    let statement = PointStatement::of(&rec.points[0]).unwrap();
    check(
        "the bench unit, its tour",
        &read_applied(&d.join("si.csv")),
        &statement,
    );
}

/// The shared data beside the checkout, or `None` with a printed notice.
fn reference_flights(test: &str) -> Option<PathBuf> {
    let d = root().join("../shared/data/reference-flights");
    if d.is_dir() {
        Some(d)
    } else {
        println!(
            "{test}: SKIPPED: {} is not beside the checkout",
            d.display()
        );
        None
    }
}

#[test]
fn the_reference_units_state_their_records_error_through_their_flights() {
    let Some(data) = reference_flights("the_reference_units_state_their_records_error") else {
        return;
    };
    for (case, codes) in [
        ("shell155", "signed24"),
        ("shell105", "signed24"),
        ("rocket_calisto", "signed16"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let case_dir = data.join(case);
        let bench = case_dir.join("bench.csv");
        run(
            d,
            &[
                "calibrate",
                bench.to_str().unwrap(),
                "--sensor",
                "imu",
                "--nonlinear",
                "--codes",
                codes,
                "--thermal",
                "table",
                "--serial",
                "REF",
                "--blob",
                "unit.blob",
                "--json",
                "unit.json",
                "--no-db",
                "-q",
            ],
        );
        let rec = record(&d.join("unit.json"));
        let imu = case_dir.join("imu.csv");
        for point in &rec.points {
            let temp = point.temp.unwrap();
            run(
                d,
                &[
                    "apply",
                    "--blob",
                    "unit.blob",
                    imu.to_str().unwrap(),
                    "--time-column",
                    "t",
                    "--temp",
                    &temp.to_string(),
                    "--sigma",
                    "-o",
                    "si.csv",
                ],
            );
            let statement = PointStatement::of(point).unwrap();
            check(
                &format!("{case} at {temp} C"),
                &read_applied(&d.join("si.csv")),
                &statement,
            );
        }
    }
}
