//! `calflash design optimize --stage-one-candidates`: the best two-stage plans at one stage's
//! budget against the best one-stage plan, the winner said both ways by the costs, the plans
//! written usable by `simulate` and `calibrate`; and `design evaluate --stage-one --mission`,
//! the comparison over a flight's moments.

mod common;

use std::path::Path;

use common::calflash;

const UNIT: [&str; 6] = [
    "--candidates",
    "tumble:26",
    "--candidates",
    "rate:-8:8:4",
    "--candidates",
    "diagonal:-8:8:2",
];

fn optimize(d: &Path, sensor: &str, stage_one: &str, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "design",
        "optimize",
        "--model",
        "triad-nonlinear",
        "--sensor",
        sensor,
        "--temps=-20,25,70",
        "--n",
        "74",
        "--stage-one-candidates",
        stage_one,
        "--stage-one-output",
        "s1.csv",
        "--unit-output",
        "unit.csv",
        "-o",
        "one.csv",
    ];
    args.extend(UNIT);
    args.extend(extra);
    calflash(d, &args)
}

/// The rows of the best share in the table (`share`, stage one a sensor, stage two, cost two,
/// cost one, two, one, two/one, at equal cost).
fn best_row(out: &str) -> Vec<f64> {
    let share: f64 = out
        .lines()
        .find_map(|l| l.trim().strip_prefix("best two stages: share "))
        .and_then(|l| l.split(';').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no best share in\n{out}"));
    out.lines()
        .filter_map(|l| {
            let v: Vec<f64> = l.split_whitespace().map_while(|s| s.parse().ok()).collect();
            (v.len() == 9 && (v[0] - share).abs() < 1e-9).then_some(v)
        })
        .next()
        .unwrap_or_else(|| panic!("no row for share {share} in\n{out}"))
}

fn rows(d: &Path, name: &str) -> (String, usize) {
    let text = std::fs::read_to_string(d.join(name)).unwrap();
    let header = text.lines().next().unwrap().to_string();
    (header, text.lines().count() - 1)
}

#[test]
fn two_stages_designed_at_one_stages_budget_win_where_stage_one_is_cheap() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A sensor's dividing head at a twentieth of the unit's rate table and chamber.
    let (code, out, err) = optimize(
        d,
        "accel",
        "head:56",
        &["--cost-stage-one", "0.05", "--cost-unit", "5"],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("at one stage's budget of 222 unit observations (74 at each of 3"),
        "{out}"
    );
    let best = best_row(&out);
    // Every share's two stages cost at most one stage's budget.
    assert!(best[3] <= best[4] + 1e-9 && best[4] == 1110.0, "{best:?}");
    assert!(best[8] < 0.9, "{best:?}\n{out}");
    assert!(out.contains("two stages win"), "{out}");
    // The plans written: stage one at every temperature, the unit once, one stage everywhere.
    let (h1, n1) = rows(d, "s1.csv");
    assert_eq!(h1, "input,input_p,input_o,temp,volt");
    assert_eq!(n1 as f64, best[1]);
    let (h2, n2) = rows(d, "unit.csv");
    assert!(h2.starts_with("f_x,f_y,f_z,w_x,w_y,w_z"), "{h2}");
    assert_eq!(n2 as f64, best[2]);
    assert_eq!(rows(d, "one.csv").1, 222);
    // They are plans a station runs: stage one of a sensor through its plan, calibrated as the
    // guide says, and one stage through its own.
    for (sensor, plan, extra) in [
        (
            "single-accel",
            "s1.csv",
            &["--keep-all-terms", "--asymmetry", "keep"][..],
        ),
        ("imu", "one.csv", &["--keep-all-terms"][..]),
    ] {
        let (code, out, err) = calflash(
            d,
            &[
                "simulate",
                "--sensor",
                sensor,
                "--plan-file",
                plan,
                "-o",
                "obs.csv",
            ],
        );
        assert_eq!(code, 0, "{out}{err}");
        let mut args = vec![
            "calibrate",
            "obs.csv",
            "--sensor",
            sensor,
            "--serial",
            "S",
            "--no-db",
            "--thermal",
            "table",
        ];
        args.extend(extra);
        let (code, out, err) = calflash(d, &args);
        assert!(code == 0 && out.contains("ACCEPT"), "{sensor}: {out}{err}");
    }
}

#[test]
fn one_stage_wins_where_the_unit_and_a_sensor_cost_alike() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, out, err) = optimize(
        d,
        "gyro",
        "rate:-8:8:9",
        &[
            "--stage-one-other",
            "head:12",
            "--cost-stage-one",
            "0.2",
            "--cost-unit",
            "1",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    let best = best_row(&out);
    assert!(best[8] > 1.0, "{best:?}\n{out}");
    assert!(out.contains("one stage wins"), "{out}");
    // At equal costs the other family's stage one alone costs more than one stage: said so.
    let (code, out, err) = optimize(d, "gyro", "rate:-8:8:9", &[]);
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("one stage wins: the other family's stage one alone"),
        "{err}"
    );
    // Costs far from 1 in six significant digits (red team four: 301 digits, or 0).
    let (code, out, err) = optimize(d, "gyro", "rate:-8:8:9", &["--cost-stage-one=1e300"]);
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("cost 5.04000e302)") && !err.contains("000000000000"),
        "{err}"
    );
    let (code, out, err) = optimize(
        d,
        "gyro",
        "rate:-8:8:9",
        &["--cost-stage-one=1e-300", "--cost-unit=1e-300"],
    );
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("budget (") && !err.contains("budget (0)"),
        "{err}"
    );
}

#[test]
fn the_two_stage_design_refuses_what_it_cannot_honour() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, _, err) = calflash(
        d,
        &[
            "design",
            "optimize",
            "--model",
            "triad",
            "--sensor",
            "accel",
            "--n",
            "74",
            "--candidates",
            "tumble:26",
            "--stage-one-candidates",
            "head:56",
            "--stage-one-output",
            "s1.csv",
            "--unit-output",
            "unit.csv",
            "-o",
            "one.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("--model triad-nonlinear"), "{err}");
    let (code, _, err) = calflash(
        d,
        &[
            "design",
            "optimize",
            "--model",
            "triad-nonlinear",
            "--sensor",
            "accel",
            "--n",
            "74",
            "--candidates",
            "tumble:26",
            "--stage-one-candidates",
            "head:56",
            "-o",
            "one.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("give --stage-one-output and --unit-output"),
        "{err}"
    );
    // The costs mean nothing without the two-stage design.
    let (code, _, err) = calflash(
        d,
        &[
            "design",
            "optimize",
            "--model",
            "triad",
            "--sensor",
            "accel",
            "--n",
            "24",
            "--candidates",
            "tumble:26",
            "--cost-unit",
            "3",
            "-o",
            "one.csv",
        ],
    );
    assert_ne!(code, 0);
    assert!(err.contains("--stage-one-candidates"), "{err}");
    assert!(!d.join("one.csv").exists() && !d.join("s1.csv").exists());
}

/// A flight at 20 C turning up to `top` rad/s about each axis in turn, gravity along z.
fn mission(d: &Path, top: f64) -> String {
    let mut text = String::from("t,w_x,w_y,w_z,f_x,f_y,f_z,temp\n");
    for i in 0..300 {
        let t = f64::from(i) * 0.01;
        let w = top * (t * 2.0).sin();
        let axis = i % 3;
        let ws: Vec<String> = (0..3)
            .map(|k| if k == axis { w.to_string() } else { "0".into() })
            .collect();
        text.push_str(&format!("{t},{},0,0.5,9.79,20\n", ws.join(",")));
    }
    std::fs::write(d.join("flight.csv"), text).unwrap();
    "flight.csv".into()
}

fn evaluate(d: &Path, extra: &[&str]) -> (i32, String, String) {
    let unit = "tumble:26,rate:-8:8:4,diagonal:-8:8:2";
    let mut args = vec![
        "design",
        "evaluate",
        "--model",
        "triad-nonlinear",
        "--sensor",
        "gyro",
        "--temps=-20,25,70",
        "--stage-one",
        "rate:-8:8:9",
        "--plan",
        unit,
        "--plan",
        unit,
    ];
    args.extend(extra);
    calflash(d, &args)
}

/// `(two stages, one stage)` of the gyros' calibrated line.
fn gyro_errors(out: &str) -> (f64, f64) {
    let line = out
        .lines()
        .find(|l| l.contains(", gyros: two stages "))
        .unwrap_or_else(|| panic!("no gyro line in\n{out}"));
    let after = |key: &str| -> f64 {
        let at = line.find(key).unwrap() + key.len();
        line[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    (after("two stages "), after(", one stage "))
}

#[test]
fn the_stage_comparison_over_a_mission_takes_the_flights_moments_the_plans_reach() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, out, err) = evaluate(d, &[]);
    assert_eq!(code, 0, "{out}{err}");
    let range = gyro_errors(&out);
    // A gentle flight at 20 C: at most 4 rad/s, inside the plans' 8; one stage's error is
    // below the range's (its cubic's uncertainty grows to the range's ends), two stages' moved.
    let flight = mission(d, 4.0);
    let (code, out, err) = evaluate(d, &["--mission", &flight]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("over the mission flight.csv (300 moments"),
        "{out}"
    );
    assert!(
        out.contains("left out: 0.0 % of them for the accelerometers, 0.0 % for the gyros"),
        "{out}"
    );
    let gentle = gyro_errors(&out);
    assert!(
        gentle.1 < 0.95 * range.1 && gentle.0 != range.0,
        "{gentle:?} {range:?}"
    );
    // The design at one budget judges over the same moments.
    let (code, out, err) = optimize(
        d,
        "gyro",
        "rate:-8:8:9",
        &[
            "--stage-one-other",
            "head:12",
            "--cost-stage-one",
            "0.05",
            "--cost-unit",
            "1",
            "--mission",
            &flight,
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("averaged over the mission flight.csv (300 moments"),
        "{out}"
    );
    assert!(out.contains("two stages win"), "{out}");
    // A flight to 12 rad/s: the moments beyond 8 are extrapolation, counted and left out.
    let flight = mission(d, 12.0);
    let (code, out, err) = evaluate(d, &["--mission", &flight]);
    assert_eq!(code, 0, "{out}{err}");
    let share: f64 = out
        .split(" % for the gyros")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!((20.0..60.0).contains(&share), "{share}\n{out}");
    // A flight wholly beyond the plans: refused, naming the file.
    let mut text = String::from("t,w_x,w_y,w_z,f_x,f_y,f_z\n");
    for i in 0..10 {
        text.push_str(&format!("{},100,0,0,0,0,9.8\n", f64::from(i) * 0.01));
    }
    std::fs::write(d.join("spin.csv"), text).unwrap();
    let (code, _, err) = evaluate(d, &["--mission", "spin.csv"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("spin.csv: no moment of the flight is within the plans' reach"),
        "{err}"
    );
}
