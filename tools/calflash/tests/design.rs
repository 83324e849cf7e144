//! `calflash design` from the command line: known optima come out, predictions are confirmed by
//! Monte Carlo through the simulator, triad tumbles compare as theory says, the fixture's
//! orientation error adds what it should, and bad input is refused with a clear message.

mod common;

use std::path::Path;

use serde_json::Value;

fn calflash(args: &[&str]) -> (i32, String, String) {
    common::calflash(Path::new("."), args)
}

fn ok(args: &[&str]) -> String {
    let (code, out, err) = calflash(args);
    assert_eq!(code, 0, "{args:?}\n{out}\n{err}");
    out
}

fn plan_values(path: &Path, column: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == column)
        .unwrap();
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn known_optima_come_out() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    // A straight line: half at each end.
    ok(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + x",
        "--grid",
        "x=-1:1:201",
        "--n",
        "10",
        "-o",
        &s(&p("line.csv")),
    ]);
    let mut v = plan_values(&p("line.csv"), "x");
    v.sort_by(f64::total_cmp);
    assert_eq!(v, [-1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
    // A quadratic: a third at each end and at the middle.
    ok(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + x + x^2",
        "--grid",
        "x=-1:1:201",
        "--n",
        "12",
        "-o",
        &s(&p("quad.csv")),
    ]);
    let v = plan_values(&p("quad.csv"), "x");
    for (at, want) in [(-1.0, 4), (0.0, 4), (1.0, 4)] {
        assert_eq!(
            v.iter().filter(|x| (**x - at).abs() < 1e-12).count(),
            want,
            "{v:?}"
        );
    }
    // The cubic: a quarter at each of -1, -1/sqrt 5, 1/sqrt 5, 1; D-efficiency at least 0.999
    // against the exact optimum.
    ok(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + x + x^2 + x^3",
        "--grid",
        "x=-1:1:2001",
        "--n",
        "12",
        "-o",
        &s(&p("cubic.csv")),
    ]);
    let r = 1.0 / 5f64.sqrt();
    let exact: String = std::iter::once("x\n".to_string())
        .chain(
            [-1.0, -r, r, 1.0]
                .repeat(3)
                .iter()
                .map(|x| format!("{x}\n")),
        )
        .collect();
    std::fs::write(p("exact.csv"), exact).unwrap();
    ok(&[
        "design",
        "evaluate",
        "--model",
        "~ 1 + x + x^2 + x^3",
        "--plan",
        &s(&p("cubic.csv")),
        "--plan",
        &s(&p("exact.csv")),
        "--json",
        &s(&p("cubic.json")),
    ]);
    let j = json(&p("cubic.json"));
    ok(&[
        "design",
        "evaluate",
        "--model",
        "~ 1 + x + x^2 + x^3",
        "--plan",
        &s(&p("cubic.csv")),
        "--plan",
        &s(&p("exact.csv")),
        "--curve",
        "x=-1.2:1.2:49",
        "--report",
        &s(&p("cubic.html")),
    ]);
    let html = std::fs::read_to_string(p("cubic.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 1);
    assert!(html.contains("range of the plans") && html.contains("D-efficiency vs best"));
    // A reviewer's page: a real table, a recommendation in a box, each plan under the IEEE
    // count of observations (4 (p + 2) = 24 here) marked as such.
    assert!(html.contains("<h1>Test plans compared: model"), "{html}");
    assert!(html.contains("<table>") && !html.contains("<pre>"));
    assert!(
        html.contains("class=\"verdict")
            && (html.contains("recommended: ") || html.contains("no plan has the IEEE")),
        "{html}"
    );
    let n = |k: usize| {
        j["plans"][k]["blocks"][0]["criteria"]["n"]
            .as_u64()
            .unwrap()
    };
    for k in 0..2 {
        let name = j["plans"][k]["name"].as_str().unwrap();
        assert_eq!(
            html.contains(&format!("{name} (under the IEEE count)")),
            n(k) < 24,
            "{name}: {} observations",
            n(k)
        );
    }
    let d = |k: usize| {
        j["plans"][k]["blocks"][0]["criteria"]["d"]
            .as_f64()
            .unwrap()
    };
    assert!(d(0) / d(1) >= 0.999, "{} {}", d(0), d(1));
}

#[test]
fn coordinate_exchange_searches_factor_levels_without_listing_them() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("c.csv");
    let plan = plan.to_str().unwrap();
    ok(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + x + x^2",
        "--grid",
        "x=-1:1:201",
        "--n",
        "12",
        "--method",
        "coordinate",
        "-o",
        plan,
    ]);
    let v = plan_values(Path::new(plan), "x");
    for (at, want) in [(-1.0, 4), (0.0, 4), (1.0, 4)] {
        assert_eq!(
            v.iter().filter(|x| (**x - at).abs() < 1e-12).count(),
            want,
            "{v:?}"
        );
    }
    // 41^3 combinations: the automatic choice is the coordinate exchange.
    let quad = "~ 1 + a + b + c + a^2 + b^2 + c^2 + a:b + a:c + b:c";
    let text = ok(&[
        "design",
        "optimize",
        "--model",
        quad,
        "--grid",
        "a=-1:1:41",
        "--grid",
        "b=-1:1:41",
        "--grid",
        "c=-1:1:41",
        "--n",
        "20",
        "--restarts",
        "3",
        "-o",
        plan,
    ]);
    assert!(
        text.contains("over 3 factors, 6.892e4 combinations (coordinate exchange)"),
        "{text}"
    );
    assert_eq!(plan_values(Path::new(plan), "c").len(), 20);
    // Listing 2001^2 candidates for the Fedorov exchange is refused with the way out.
    let (code, _, err) = calflash(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + a + b",
        "--grid",
        "a=-1:1:2001",
        "--grid",
        "b=-1:1:2001",
        "--n",
        "8",
        "--method",
        "fedorov",
        "-o",
        plan,
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("the candidates number 4.004e6, too many to list")
            && err.contains("--method coordinate"),
        "{err}"
    );
}

#[test]
fn predicted_errors_are_confirmed_by_the_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.json");
    // The IEEE single-axis preset on a 24-position dividing head, 2000 simulated calibrations.
    ok(&[
        "design",
        "predict",
        "--model",
        "single",
        "--plan",
        "head:24",
        "--at",
        "input=5",
        "--at",
        "input=-9",
        "--monte-carlo",
        "2000",
        "--json",
        out.to_str().unwrap(),
    ]);
    let j = json(&out);
    let b = &j["blocks"][0];
    let pairs = |key: &str| -> Vec<(f64, f64)> {
        b["expected"][key]
            .as_array()
            .unwrap()
            .iter()
            .zip(b["monte_carlo"][key].as_array().unwrap())
            .map(|(e, m)| (e.as_f64().unwrap(), m.as_f64().unwrap()))
            .collect()
    };
    for (e, m) in pairs("terms").into_iter().chain(pairs("at")) {
        assert!((m / e - 1.0).abs() < 0.10, "expected {e}, simulated {m}");
    }
    assert_eq!(pairs("terms").len(), 5);
    assert_eq!(pairs("at").len(), 2);
}

#[test]
fn the_fewest_observations_for_a_target_error() {
    let text = ok(&[
        "design",
        "predict",
        "--model",
        "~ output ~ 1 + input + input^2".trim_start_matches("~ "),
        "--candidates",
        "head:72",
        "--at",
        "input=5",
        "--target",
        "0.5",
        "--noise",
        "2",
    ]);
    // sd of the prediction at input = 5 is 2 sqrt(x'(X'X)^-1 x); the I-optimal three-level
    // plan needs n with 2 sqrt(c / n) <= 0.5.
    let n: usize = text
        .split("noise 2 counts: ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((8..200).contains(&n), "{text}");
    let worst: f64 = text
        .split("largest expected error ")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(worst <= 0.5, "{text}");
    // One fewer misses the target.
    let fewer = ok(&[
        "design",
        "predict",
        "--model",
        "output ~ 1 + input + input^2",
        "--candidates",
        "head:72",
        "--at",
        "input=5",
        "--target",
        &format!("{}", worst * 1.0001),
        "--noise",
        "2",
    ]);
    assert!(fewer.contains(&format!("noise 2 counts: {n} ")), "{fewer}");
}

#[test]
fn triad_tumbles_compare_as_theory_says() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.json");
    ok(&[
        "design",
        "evaluate",
        "--sensor",
        "accel",
        "--model",
        "triad",
        "--plan",
        "tumble:6",
        "--plan",
        "tumble:12",
        "--plan",
        "tumble:24",
        "--json",
        out.to_str().unwrap(),
    ]);
    let j = json(&out);
    let g: f64 = 9.806_65;
    // Gravity along the axes (6 and 24 positions): M = diag(1, g^2/3, g^2/3, g^2/3).
    let want = (g.powi(6) / 27.0).powf(0.25);
    for k in [0, 2] {
        for axis in 0..3 {
            let d = j["plans"][k]["blocks"][axis]["criteria"]["d"]
                .as_f64()
                .unwrap();
            assert!(
                (d / want - 1.0).abs() < 1e-12,
                "plan {k} axis {axis}: {d} vs {want}"
            );
        }
    }
    // The nonlinear triad cannot be had from 6 positions: each input takes 3 values.
    let (code, _, err) = calflash(&[
        "design",
        "evaluate",
        "--sensor",
        "accel",
        "--model",
        "triad-nonlinear",
        "--plan",
        "tumble:6",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("plan tumble:6 cannot estimate the model of axis x: "),
        "{err}"
    );
    assert!(err.contains("f_x takes only 3 distinct values"), "{err}");
    // An optimal orientation plan for it over a two-axis table's reach.
    let plan = dir.path().join("orient.csv");
    let text = ok(&[
        "design",
        "optimize",
        "--sensor",
        "accel",
        "--model",
        "triad-nonlinear",
        "--candidates",
        "sphere:200",
        "--n",
        "36",
        "-o",
        plan.to_str().unwrap(),
    ]);
    // No tumble can estimate it; the optimum beats spreading the 36 points over the sphere.
    assert!(
        text.contains("(plan tumble:24 x2 cannot estimate the model of axis x: "),
        "{text}"
    );
    let eff: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("D-efficiency vs best"))
        .flat_map(|l| l.split_whitespace().skip(3))
        .collect();
    assert_eq!(eff.len(), 6, "{text}");
    for axis in 0..3 {
        assert_eq!(eff[2 * axis], "1.0000", "{text}");
    }
    // For the linear triad the 24-position tumble is as good as the optimum over the sphere.
    let text = ok(&[
        "design",
        "optimize",
        "--sensor",
        "accel",
        "--model",
        "triad",
        "--candidates",
        "sphere:200",
        "--n",
        "24",
        "-o",
        plan.to_str().unwrap(),
    ]);
    let line = text
        .lines()
        .find(|l| l.contains("D-efficiency vs best"))
        .unwrap();
    let cols: Vec<f64> = line
        .split_whitespace()
        .skip(3)
        .map(|v| v.parse().unwrap())
        .collect();
    // optimal, tumble:6 x4, tumble:12 x2, tumble:24 x1, uniform
    assert_eq!(cols.len(), 5, "{text}");
    assert!(cols[3] >= 0.98 && cols[1] >= 0.98, "{line}");
}

#[test]
fn a_fixture_orientation_error_adds_what_it_should() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.json");
    let (noise, scale, deg) = (2.0f64, 400.0f64, 0.1f64);
    ok(&[
        "design",
        "evaluate",
        "--sensor",
        "accel",
        "--model",
        "triad",
        "--plan",
        "tumble:6",
        "--fixture-error",
        "0.1",
        "--noise",
        "2",
        "--scale",
        "400",
        "--json",
        out.to_str().unwrap(),
    ]);
    let j = json(&out);
    let f = &j["plans"][0]["fixture_std_errors"][0];
    let g: f64 = 9.806_65;
    // Axis x on a 6-position tumble: the poses along y and z (4 of 6) see (scale delta g)^2 more.
    let v = (scale * deg.to_radians() * g).powi(2);
    let se_bias = ((6.0 * noise * noise + 4.0 * v) / 36.0).sqrt();
    assert!(
        (f["with"][0].as_f64().unwrap() / se_bias - 1.0).abs() < 1e-9,
        "{f}"
    );
    assert!((f["without"][0].as_f64().unwrap() / (noise / 6f64.sqrt()) - 1.0).abs() < 1e-9);
    // The x scale comes from the +-x poses alone, which the error does not move.
    assert!(
        (f["with"][1].as_f64().unwrap() / f["without"][1].as_f64().unwrap() - 1.0).abs() < 1e-9
    );
}

#[test]
fn bad_input_is_refused_clearly() {
    let cases: [(&[&str], &str); 4] = [
        (
            &[
                "design",
                "evaluate",
                "--model",
                "~ 1 + rate + rate^2",
                "--plan",
                "head:12",
            ],
            "plan head:12: the model reads `rate`, which it does not set",
        ),
        (
            &[
                "design",
                "optimize",
                "--model",
                "~ 1 + x + x^2 + x^3",
                "--grid",
                "x=-1:1:3",
                "--n",
                "8",
                "-o",
                "/tmp/never.csv",
            ],
            "no set of the candidates estimates every parameter",
        ),
        (
            &[
                "design",
                "optimize",
                "--model",
                "~ 1 + rate",
                "--grid",
                "rate=-1000:1000:21",
                "--limit",
                "rate=-800:800",
                "--n",
                "4",
                "-o",
                "/tmp/never.csv",
            ],
            "the candidates, point 1: rate = -1000 is outside the equipment's limits -800 to 800",
        ),
        (
            &[
                "design",
                "evaluate",
                "--model",
                "~ 1 + x +",
                "--plan",
                "head:4",
            ],
            "--model:",
        ),
    ];
    for (args, says) in cases {
        let (code, out, err) = calflash(args);
        assert_eq!(code, 1, "{args:?}: {out}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    // A malformed grid is a usage error, refused as the option is parsed.
    let (code, _, err) = calflash(&[
        "design",
        "optimize",
        "--model",
        "~ 1 + x",
        "--grid",
        "x=-1:1",
        "--n",
        "4",
        "-o",
        "/tmp/never.csv",
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("'x=-1:1' for '--grid <GRID>': grid `x=-1:1`: not three fields after `=`"),
        "{err}"
    );
    assert!(!Path::new("/tmp/never.csv").exists());
    // So are a malformed limit and a malformed operating point.
    for (option, value, says) in [
        (
            "--limit",
            "rate=800",
            "'rate=800' for '--limit <NAME=LO:HI>': --limit `rate=800`: expected NAME=LO:HI",
        ),
        (
            "--at",
            "input=x",
            "'input=x' for '--at <NAME=VALUE[,...]>': --at `input=x`: `x` is not a finite number",
        ),
    ] {
        let (code, _, err) = calflash(&[
            "design", "predict", "--model", "single", "--plan", "head:10", option, value,
        ]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says), "{err}");
    }
}
