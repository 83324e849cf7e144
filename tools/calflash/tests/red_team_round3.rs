//! Round three (issue 45): the newer surfaces tried as a careless or hostile user would.
//! Nothing a user typed is lost or read without bound, and a message points the right way.
//! Every command runs under the watchdog; the list is kept in `RELIABILITY.md`.

mod common;
#[path = "common/watchdog.rs"]
mod watchdog;

use std::path::Path;

use watchdog::{Ran, calflash, cli, listing};

fn ok(r: &Ran, what: &str) {
    assert_eq!(r.code(), Some(0), "{what}: {}{}", r.out, r.err);
}

/// A short simulated flight in `d`: `f.csv`, its truth `truth.json`, its GNSS `g.csv`.
fn flight(d: &Path) {
    ok(
        &cli(
            d,
            "simulate --sensor imu --flight rocket:seconds=3,rest=1 --sample-rate 200 -o f.csv --flight-truth truth.json --gnss g.csv",
        ),
        "the flight",
    );
}

#[test]
fn no_output_of_simulate_replaces_an_input_or_another_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    flight(d);
    let before = listing(d);
    // --gnss onto the truth it was given, --baro onto -o.
    cli(
        d,
        "simulate --sensor imu --flight rocket:seconds=3 --sample-rate 200 -o f2.csv --truth truth.json --gnss truth.json",
    )
    .expect(1, "--gnss truth.json", "--gnss onto --truth");
    cli(
        d,
        "simulate --sensor imu --flight rocket:seconds=3 --sample-rate 200 -o f2.csv --gnss f2g.csv --baro f2.csv",
    )
    .expect(1, "--baro f2.csv and -o name one file", "--baro onto -o");
    assert_eq!(listing(d), before, "a refused command wrote something");
    // --stages onto a file: refused naming the option, not "File exists".
    std::fs::write(d.join("stages"), "x").unwrap();
    cli(
        d,
        "simulate --sensor imu --stages stages --plan tumble:6 -o unit.csv",
    )
    .expect(1, "--stages stages: that is a file", "--stages FILE");
    assert_eq!(std::fs::read_to_string(d.join("stages")).unwrap(), "x");
}

#[test]
fn readers_and_generators_are_bounded_and_say_how_to_lift_the_bound() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    flight(d);
    // A flight log longer than --max-samples is refused at the bound, naming the option.
    cli(d, "flight f.csv --gnss g.csv --no-db --max-samples 100").expect(
        1,
        "more than 100 ",
        "--max-samples",
    );
    let r = cli(d, "flight f.csv --gnss g.csv --no-db --max-samples 100");
    assert!(r.err.contains("--max-samples"), "{}", r.err);
    // A hand-turned recording of 3.2 GB is refused before it is made.
    cli(
        d,
        "simulate --sensor imu --tumble 1000 --sample-rate 100000 -o t.txt",
    )
    .expect(1, "--tumble: that is", "a huge tumble");
    assert!(!d.join("t.txt").exists());
}

#[test]
fn the_history_is_a_file_one_input_is_not_two_and_a_flight_flies() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A device as the history.
    ok(
        &cli(d, "simulate --sensor single-accel --plan head:12 -o s.csv"),
        "simulate",
    );
    let journal = || {
        std::fs::metadata("/dev/null-journal")
            .and_then(|m| m.modified())
            .ok()
    };
    let before = journal();
    cli(
        d,
        "calibrate s.csv --sensor single-accel --serial RT-3 --db /dev/null",
    )
    .expect(
        1,
        "/dev/null: the unit history must be a SQLite file",
        "--db /dev/null",
    );
    // Nothing written beside the device (an older build's run may have left one before).
    assert_eq!(journal(), before, "/dev/null-journal written");
    // One file as both sensors' recordings.
    std::fs::write(d.join("acc.txt"), "1 2 3\n4 5 6\n").unwrap();
    cli(d, "allan acc.txt acc.txt --scale 412,900").expect(
        1,
        "name one file",
        "allan with one file twice",
    );
    // A rocket that does not fly.
    for (spec, says) in [
        (
            "rocket:rail=0",
            "the rail (m; a rocket leaves a rail) must be from 0.1",
        ),
        ("rocket:thrust=10", "never leaves its rail"),
        ("rocket:burn=2,burn=3", "`burn` is given twice"),
    ] {
        cli(
            d,
            &format!("simulate --sensor imu --flight {spec} -o r.csv"),
        )
        .expect(1, says, spec);
    }
    // Temperatures a flight-less, chamber-less simulation would ignore.
    let r = cli(
        d,
        "simulate --sensor imu --tumble 3 --temps=-40,85 -o t.txt",
    );
    assert_eq!(r.code(), Some(2), "{}{}", r.out, r.err);
    assert!(r.err.contains("--temps"), "{}", r.err);
}

#[test]
fn messages_point_the_right_way() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    flight(d);
    // A GNSS file of three-satellite rows: its own name, and why.
    let g = std::fs::read_to_string(d.join("g.csv")).unwrap();
    let mut lines = g.lines();
    let head = lines.next().unwrap();
    assert!(head.ends_with(",satellites"), "{head}");
    let mut three = format!("{head}\n");
    for l in lines {
        three.push_str(&format!("{},3\n", l.rsplit_once(',').unwrap().0));
    }
    std::fs::write(d.join("g3.csv"), three).unwrap();
    calflash(d, &["flight", "f.csv", "--gnss", "g3.csv", "--no-db"]).expect(
        1,
        "g3.csv: no usable fix in its",
        "three satellites",
    );
    // compare of one record with itself.
    ok(
        &cli(d, "simulate --sensor single-accel --plan head:12 -o s.csv"),
        "simulate",
    );
    ok(
        &cli(
            d,
            "calibrate s.csv --sensor single-accel --serial RT-4 --no-db --json h.json",
        ),
        "calibrate",
    );
    cli(d, "compare h.json h.json").expect(1, "name one file", "compare h.json h.json");
    // A time step of 1e-300 s: said in a few characters, not 300 digits.
    let f = std::fs::read_to_string(d.join("f.csv")).unwrap();
    let mut out = String::new();
    for (k, l) in f.lines().enumerate() {
        if k == 0 {
            out.push_str(l);
        } else {
            let rest = l.split_once(',').unwrap().1;
            out.push_str(&format!("{:e},{rest}", (k - 1) as f64 * 1e-300));
        }
        out.push('\n');
    }
    std::fs::write(d.join("tiny.csv"), out).unwrap();
    let r = cli(d, "mission tiny.csv");
    assert_eq!(r.code(), Some(1), "{}{}", r.out, r.err);
    assert!(r.err.len() < 600, "{} bytes: {}", r.err.len(), r.err);
    // Rates in deg/s under SI names, beside angular accelerations in rad/s^2.
    let text = std::fs::read_to_string(d.join("f.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let w: Vec<usize> = ["w_x", "w_y", "w_z"]
        .iter()
        .map(|n| head.iter().position(|h| h == n).unwrap())
        .collect();
    let mut deg = head.join(",") + "\n";
    for l in lines {
        let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
        for &k in &w {
            let v: f64 = cells[k].parse().unwrap();
            cells[k] = format!("{}", v.to_degrees());
        }
        deg.push_str(&(cells.join(",") + "\n"));
    }
    std::fs::write(d.join("deg.csv"), deg).unwrap();
    cli(d, "mission deg.csv").expect(
        1,
        "the rates look like deg/s read as rad/s",
        "deg/s under SI names",
    );
    // One column for three roles.
    cli(d, "mission f.csv --mission-columns wx=w_x,wy=w_x,wz=w_x").expect(
        1,
        "column `w_x` is already",
        "one column three times",
    );
}
