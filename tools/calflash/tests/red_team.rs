//! The tool tried as a careless user and a hostile one would (issue 13; the list is kept in
//! `RELIABILITY.md`). Every command runs under the watchdog of `common/watchdog.rs`; the newer
//! commands' cases (issue 30) are in `red_team_units.rs`.

use std::path::{Path, PathBuf};
use std::process::Stdio;

#[path = "common/watchdog.rs"]
mod watchdog;
use watchdog::{Ran, calflash, calflash_with, cli, listing};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data")
}

/// A copy of example `src` in `dir` as `name`, with line `line`'s field `column` (0-based)
/// replaced by `value`.
fn edited(src: &str, dir: &Path, name: &str, line: usize, column: usize, value: &str) {
    let text = std::fs::read_to_string(examples().join(src)).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<&str> = lines[line - 1].split(',').collect();
    fields[column] = value;
    lines[line - 1] = fields.join(",");
    std::fs::write(dir.join(name), lines.join("\n") + "\n").unwrap();
}

/// A fresh directory holding a copy of the examples `names`.
fn bench(names: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for n in names {
        std::fs::copy(examples().join(n), dir.path().join(n)).unwrap();
    }
    dir
}

/// `calflash calibrate` of a single-axis file as unit RT-1, unrecorded, with `extra`.
fn calibrate_single(dir: &Path, data: &str, extra: &str) -> Ran {
    cli(
        dir,
        &format!("calibrate {data} --sensor single-accel --serial RT-1 --no-db {extra}"),
    )
}

fn blob_in(dir: &Path, name: &str) -> spincal::model::Calibration {
    spincal::blob::decode(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

// ---- A unit can be given a calibration that should never reach it ----

#[test]
fn a_rejected_fit_writes_no_blob_unless_forced_and_then_says_so() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    let strict = "--max-noise 1e-6 --blob r.blob --json r.json";
    let r = calibrate_single(d, "single_accel.csv", strict);
    assert_eq!(r.code(), Some(3), "{}{}", r.out, r.err);
    assert!(r.out.contains("unit RT-1: REJECT"), "{}", r.out);
    assert!(!d.join("r.blob").exists(), "no blob for a REJECT");
    assert!(
        r.out
            .contains("blob: none written to r.blob: the calibration is judged REJECT"),
        "{}",
        r.out
    );
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(record["blob"], "", "the record holds no blob");

    let r = calibrate_single(d, "single_accel.csv", &format!("{strict} --force-blob"));
    assert_eq!(r.code(), Some(3));
    assert!(blob_in(d, "r.blob").data().identity.fit_rejected);
    // An accepted fit's blob is not marked.
    let r = calibrate_single(d, "single_accel.csv", "--blob ok.blob");
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    assert!(!blob_in(d, "ok.blob").data().identity.fit_rejected);
}

#[test]
fn outputs_at_or_beyond_the_rails_are_left_out_of_the_fit_and_named() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    assert_eq!(
        calibrate_single(d, "single_accel.csv", "--blob c.blob").code(),
        Some(0)
    );
    let center = |c: &spincal::model::Calibration| match &c.data().sensor {
        spincal::model::Sensor::Single { channel, .. } => channel.center,
        _ => unreachable!(),
    };
    let good = center(&blob_in(d, "c.blob"));
    for value in ["1e20", "70000", "65535", "-3", "1e308", "1e200"] {
        edited("single_accel.csv", d, "rail.csv", 6, 6, value);
        let r = calibrate_single(d, "rail.csv", "--blob rail.blob");
        assert_eq!(r.code(), Some(0), "{value}: {}{}", r.out, r.err);
        assert!(
            r.out.contains(
                "REVIEW 1 observation(s) with an output at or beyond the ADC rails 0 and 65535 \
                 were left out of the fit: line 6"
            ),
            "{value}: {}",
            r.out
        );
        let c = center(&blob_in(d, "rail.blob"));
        assert!((c - good).abs() < 1.0, "{value}: centre {c} against {good}");
        // Applied, its corrections follow the input (not one constant for every sample).
        let r = cli(
            d,
            "apply rail.csv --blob rail.blob --temp-column temp -o applied.csv",
        );
        assert_eq!(r.code(), Some(0), "{}", r.err);
        let text = std::fs::read_to_string(d.join("applied.csv")).unwrap();
        let values: Vec<f64> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(largest > 9.0, "{value}: corrections {values:?}");
    }
    // Every output on a rail: nothing to fit, and the message says why.
    let text = std::fs::read_to_string(d.join("single_accel.csv")).unwrap();
    let railed: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| match (i, l.rsplit_once(',')) {
            (0, _) | (_, None) => format!("{l}\n"),
            (_, Some((head, _))) => format!("{head},65535\n"),
        })
        .collect();
    std::fs::write(d.join("all_railed.csv"), railed).unwrap();
    calibrate_single(d, "all_railed.csv", "--blob x.blob").expect(1, "rails", "all railed");
    assert!(!d.join("x.blob").exists());
}

#[test]
fn a_triad_count_beyond_the_rails_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    edited("imu_bench.csv", d, "imu.csv", 4, 9, "1e308");
    let r = cli(
        d,
        "calibrate imu.csv --sensor accel --serial RT-3 --no-db --blob t.blob",
    );
    assert_ne!(r.code(), Some(1), "{}{}", r.out, r.err);
    assert!(
        r.out.contains("ADC rails") && r.out.contains("line 4"),
        "{}",
        r.out
    );
}

#[test]
fn a_command_that_fails_leaves_none_of_its_outputs() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    calibrate_single(
        d,
        "single_accel.csv",
        "--blob b.blob --report missing_dir/x.html",
    )
    .expect(
        1,
        "--report missing_dir/x.html: the directory missing_dir does not exist",
        "report into a missing directory",
    );
    assert_eq!(listing(d), ["single_accel.csv"], "nothing written");
}

// ---- It hangs or panics ----

#[test]
fn values_too_large_to_square_get_a_located_error_not_a_hang() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    edited("single_accel.csv", d, "big.csv", 6, 6, "1e308");
    calflash(d, &["fit", "big.csv", "--model", "output ~ 1 + input"]).expect(
        1,
        "the fit overflows: its sums of squares exceed the largest f64, and the largest value is \
         at line 6 (output = 1e308, input = ",
        "fit 1e308",
    );
    edited("single_accel.csv", d, "wide.csv", 6, 0, "1e200");
    let says = "wide.csv: line 6: the term input^2 overflows to inf (input = 1e200)";
    calflash(
        d,
        &["fit", "wide.csv", "--model", "output ~ 1 + input + input^2"],
    )
    .expect(1, says, "fit 1e200");
    calibrate_single(d, "wide.csv", "").expect(1, says, "calibrate 1e200");
}

#[test]
fn models_and_options_that_used_to_hang_or_panic_are_refused() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    let cal = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "single_accel.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "RT-1",
            "--no-db",
        ];
        args.extend(extra);
        calflash(d, &args)
    };
    cal(&["--model", "output ~ 1"]).expect(
        1,
        "without the term `input` the model has no scale factor",
        "output ~ 1",
    );
    cal(&["--model", "volts ~ 1 + input"]).expect(
        1,
        "the single-axis workflow's response is the `output` column",
        "volts ~",
    );
    for (option, says) in [
        ("--breakpoint nan", "'nan' for '--breakpoint <BREAKPOINT>'"),
        ("--alpha nan", "'nan' for '--alpha <ALPHA>'"),
        ("--alpha=-1", "'-1' for '--alpha <ALPHA>'"),
        ("--alpha -1", "'-1' for '--alpha <ALPHA>'"),
    ] {
        calibrate_single(d, "single_accel.csv", option).expect(2, says, option);
    }
}

#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    use std::os::unix::process::ExitStatusExt as _;
    let dir = bench(&["single_accel.csv"]);
    // A pipe whose reader is gone before calflash writes a byte, as `| head -0` leaves it.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let line = "calibrate single_accel.csv --sensor single-accel --serial RT-2 --no-db";
    let args: Vec<&str> = line.split_whitespace().collect();
    let r = calflash_with(dir.path(), &args, Stdio::from(writer));
    assert_eq!(r.status.signal(), Some(13), "ended by SIGPIPE, as `cat` is");
    assert_eq!(r.err, "", "no 'failed printing to stdout'");
}

#[test]
fn sizes_beyond_reason_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A staging file a killed run left behind goes the next time a command writes here.
    std::fs::write(d.join(".calflash-4000000000-abc.tmp"), "stale").unwrap();
    let single = "--model single";
    let at = "--at input=1";
    for (line, code, says) in [
        (
            format!("design evaluate {single} --plan head:1000000000"),
            1,
            "`1000000000` is not a count from 1 to 1000000",
        ),
        (
            format!("design evaluate {single} --plan head:1000000,head:1000"),
            1,
            "1001000 conditions with every temperature, voltage and repeat; a plan holds at \
             most 1000000",
        ),
        (
            "simulate --sensor single-accel --plan head:100000000 -o s.csv".into(),
            1,
            "`100000000` is not a count from 1 to 1000000",
        ),
        (
            "simulate --sensor single-accel --plan head:1000 --repeat 10000 -o s.csv".into(),
            1,
            "a plan holds at most 1000000",
        ),
        (
            "simulate --sensor imu --spin 300:3600 --sample-rate 10000 -o f.csv".into(),
            1,
            "a flight holds at most 1e7",
        ),
        (
            format!("design optimize {single} --n 1000000 --output p.csv"),
            2,
            "'1000000' for '--n <N>': a count from 1 to 100000 is expected",
        ),
        (
            format!("design predict {single} --plan head:10 {at} --monte-carlo 100000000"),
            2,
            "a count from 10 to 100000 is expected",
        ),
        (
            format!("design predict {single} --plan head:100000 {at} --monte-carlo 100000"),
            1,
            "is 10000000000 simulated observations; at most 1e9",
        ),
        (
            format!(
                "design optimize {single} --grid input=-1:1:1000 \
                 --region input=-1:1:1000000000000 --n 10 --output p.csv"
            ),
            2,
            "N is at most 1000000",
        ),
    ] {
        cli(d, &line).expect(code, says, &line);
    }
    let r = cli(d, "simulate --sensor single-accel --plan head:10 -o s.csv");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert_eq!(listing(d), ["s.csv"], "the stale staging file is gone");
}

// ---- It destroys or misfiles the user's work ----

#[test]
fn no_output_may_be_an_input_or_another_output() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    let original = std::fs::read(d.join("single_accel.csv")).unwrap();
    let r = calibrate_single(d, "single_accel.csv", "--blob b.blob --json a.json");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    std::fs::copy(d.join("a.json"), d.join("b.json")).unwrap();
    std::fs::hard_link(d.join("single_accel.csv"), d.join("link.csv")).unwrap();
    let before = listing(d);
    std::fs::create_dir(d.join("sub")).unwrap();
    let cal = "calibrate single_accel.csv --sensor single-accel --serial RT-1";
    for line in [
        format!("{cal} --no-db --blob single_accel.csv"),
        format!("{cal} --no-db --blob ./sub/../link.csv"),
        format!("{cal} --no-db --blob x.out --json ./x.out"),
        format!("{cal} --db single_accel.csv"),
        "apply single_accel.csv --blob b.blob -o link.csv".into(),
        "image --blob b.blob --hex b.blob".into(),
        "compare a.json b.json --json a.json".into(),
        "simulate --sensor single-accel --plan head:5 -o t --write-truth t".into(),
    ] {
        let r = cli(d, &line);
        assert_eq!(r.code(), Some(1), "{line}: {}{}", r.out, r.err);
        assert!(
            r.err.contains("the command would replace its own input")
                || r.err.contains("name one file"),
            "{line}: {}",
            r.err
        );
    }
    std::fs::remove_dir(d.join("sub")).unwrap();
    assert_eq!(listing(d), before, "nothing added");
    assert_eq!(
        std::fs::read(d.join("single_accel.csv")).unwrap(),
        original,
        "the input is intact"
    );
}

#[test]
fn history_and_compare_never_create_a_database_and_a_newer_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cli(d, "history RT-1 --db nowhere/units.sqlite").expect(1, "nowhere/units.sqlite", "history");
    let r = cli(d, "compare db:1 db:2 --db none.sqlite");
    assert_eq!(r.code(), Some(1));
    assert_eq!(listing(d), Vec::<String>::new(), "no database created");

    // A database written by a newer calflash.
    let c = rusqlite::Connection::open(d.join("newer.sqlite")).unwrap();
    c.execute_batch("PRAGMA user_version = 99;").unwrap();
    drop(c);
    cli(d, "history RT-1 --db newer.sqlite").expect(1, "99", "history of a newer database");
    std::fs::copy(
        examples().join("single_accel.csv"),
        d.join("single_accel.csv"),
    )
    .unwrap();
    cli(
        d,
        "calibrate single_accel.csv --sensor single-accel --serial RT-1 --db newer.sqlite",
    )
    .expect(1, "99", "calibrate into a newer database");
}

// ---- It accepts nonsense and answers with confident output ----

#[test]
fn nonsense_options_are_refused_naming_the_option() {
    let dir = bench(&["single_accel.csv", "fine_steps.csv"]);
    let d = dir.path();
    let cal = "calibrate single_accel.csv --sensor single-accel --serial RT-1 --no-db";
    let selfcal = "selfcal r.txt --g 9.81 --serial A";
    let predict = "design predict --model single --at input=1";
    let flash = "flash --blob b.blob --port tcp:127.0.0.1:9";
    let before = listing(d);
    for (line, option) in [
        (format!("{cal} --alpha 2"), "--alpha <ALPHA>"),
        (format!("{cal} --alpha 0"), "--alpha <ALPHA>"),
        (format!("{cal} --alpha 1"), "--alpha <ALPHA>"),
        (format!("{cal} --max-noise nan"), "--max-noise <MAX_NOISE>"),
        ("compare a.json b.json --alpha 2".into(), "--alpha <ALPHA>"),
        (
            format!("{selfcal} --init-rest=-5"),
            "--init-rest <INIT_REST>",
        ),
        (
            format!("{selfcal} --init-rest nan"),
            "--init-rest <INIT_REST>",
        ),
        (format!("{selfcal} --window 0"), "--window <WINDOW>"),
        (
            format!("{predict} --plan head:10 --noise=-1"),
            "--noise <NOISE>",
        ),
        (
            "design evaluate --model single --plan head:10 --noise=-2".into(),
            "--noise <NOISE>",
        ),
        (
            "design evaluate --model single --plan head:10 --scale 0".into(),
            "--scale <SCALE>",
        ),
        (
            format!("{predict} --grid input=-9:9:11 --target nan"),
            "--target <TARGET>",
        ),
        (
            format!("{predict} --grid input=-9:9:11 --target=-1"),
            "--target <TARGET>",
        ),
        (
            "design optimize --model single --grid input=-1:1:11 --region input=-1:1:0 --n 10 \
             --output p.csv"
                .into(),
            "--region <REGION>",
        ),
        (format!("{flash} --timeout 0"), "--timeout <TIMEOUT>"),
        (format!("{flash} --vectors 0"), "--vectors <VECTORS>"),
        (
            "simulate --sensor single-accel --plan head:5 --temps nan -o s.csv".into(),
            "--temps <TEMPS>",
        ),
        (
            "threshold fine_steps.csv --scale 0".into(),
            "--scale <SCALE>",
        ),
        (
            "threshold fine_steps.csv --scale 400 --bias inf".into(),
            "--bias <BIAS>",
        ),
    ] {
        let r = cli(d, &line);
        r.expect(2, "error: invalid value", &line);
        assert!(r.err.contains(option), "{line}: {}", r.err);
        assert_eq!(r.out, "", "{line}: nothing confident on stdout");
    }
    assert_eq!(listing(d), before, "nothing written");
}

#[test]
fn design_answers_only_about_what_the_model_reads() {
    let dir = tempfile::tempdir().unwrap();
    let r = cli(
        dir.path(),
        "design predict --model single --plan head:10 --at nope=1",
    );
    r.expect(
        1,
        "--at `nope=1`: the model reads no `nope`; it reads input",
        "--at nope=1",
    );
    assert_eq!(r.out, "");
}

#[test]
fn a_given_bias_is_used_even_when_the_run_has_an_input_of_zero() {
    let dir = bench(&["fine_steps.csv"]);
    let run = |extra: &str| {
        let r = cli(
            dir.path(),
            &format!("threshold fine_steps.csv --scale 400 {extra}"),
        );
        assert_eq!(r.code(), Some(0), "{}", r.err);
        r.out
    };
    let own = run("");
    let given = run("--bias 32000");
    assert!(own.contains("(the run's mean at input 0)"), "{own}");
    assert!(
        given.contains("output at zero input  32000 counts (--bias; the run's mean at input 0 is "),
        "{given}"
    );
    assert_ne!(own, given, "the bias changes the figures");
}

#[test]
fn simulated_values_are_finite_and_codes_stay_within_the_rails() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cli(
        d,
        "simulate --sensor single-accel --plan centrifuge:0:1e308:5 -o c.csv",
    )
    .expect(
        1,
        "`1e308` is not a number from -100000 to 100000 g",
        "centrifuge",
    );
    let r = cli(
        d,
        "simulate --sensor single-accel --plan fine:-2000:2000:41 --quantize -o q.csv",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(
        r.out
            .contains("saturated at the unsigned16 converter's rails 0 and 65535"),
        "{}",
        r.out
    );
    let text = std::fs::read_to_string(d.join("q.csv")).unwrap();
    for line in text.lines().skip(1) {
        let v: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!((0.0..=65535.0).contains(&v) && v.fract() == 0.0, "{line}");
    }
}

#[test]
fn an_allan_sample_too_large_to_square_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text: String = (0..400)
        .map(|i| {
            let g = if i == 150 {
                "1e300".to_string()
            } else {
                format!("{}", 32768 + i % 7)
            };
            let t = f64::from(i) * 0.01;
            format!("{t:.2},32768,32770,36000,{g},32769,32767\n")
        })
        .collect();
    std::fs::write(d.join("still.csv"), text).unwrap();
    cli(d, "allan still.csv --sensor gyro").expect(
        1,
        "still.csv:151: gyro axis x = 1e300: too large for the Allan deviation",
        "allan",
    );
}

// ---- Byte-order marks, negative values, long lines ----

#[test]
fn a_byte_order_mark_is_stripped_and_said() {
    let dir = bench(&["single_accel.csv"]);
    let d = dir.path();
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend(std::fs::read(d.join("single_accel.csv")).unwrap());
    std::fs::write(d.join("bom.csv"), bom).unwrap();
    let a = calibrate_single(d, "single_accel.csv", "");
    let b = calibrate_single(d, "bom.csv", "");
    assert_eq!(b.code(), Some(0), "{}", b.err);
    assert!(
        b.err
            .contains("bom.csv starts with a UTF-8 byte-order mark; it is ignored"),
        "{}",
        b.err
    );
    let body = |s: &str| s.lines().skip(1).collect::<Vec<_>>().join("\n");
    assert_eq!(body(&a.out), body(&b.out), "the same fit");
}

#[test]
fn negative_option_values_need_no_equals_sign() {
    let dir = tempfile::tempdir().unwrap();
    let r = cli(
        dir.path(),
        "simulate --sensor accel --plan tumble:6 --temps -40,25 -o t.csv",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(r.out.contains("12 observations"), "{}", r.out);
}

#[test]
fn a_huge_line_is_not_echoed_whole() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = "7".repeat(20_000_000);
    std::fs::write(d.join("long.csv"), format!("input,output\n1,{line}\n")).unwrap();
    let r = calibrate_single(d, "long.csv", "");
    r.expect(1, "long.csv:2:2:", "a 20 MB line");
    assert!(r.err.len() < 400, "{} bytes of error", r.err.len());
    assert!(r.err.contains("(20000000 bytes)"), "{}", r.err);
}
