//! The newer commands (batches and fixtures, keys and signing, images, the shared history,
//! health, lots, flights on the spin rig) tried as a careless and a hostile user would
//! (issue 30; the list is kept in `RELIABILITY.md`). Every command runs under the watchdog.

mod common;
#[path = "common/lot_history.rs"]
mod lot_history;
#[path = "common/watchdog.rs"]
mod watchdog;

use std::path::{Path, PathBuf};

use common::allan;
use watchdog::{Ran, calflash, cli, listing};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data")
}

/// Asserts the run failed with `code`, said `says` and did not panic.
fn refused(r: &Ran, code: i32, says: &str, what: &str) {
    r.expect(code, says, what);
}

/// A simulated single-axis accelerometer's observations in `dir/file`.
fn simulate(dir: &Path, file: &str, seed: u64) {
    let r = cli(
        dir,
        &format!(
            "simulate --sensor single-accel --plan head:36 --temps=-40,25,85 --seed {seed} -o {file}"
        ),
    );
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
}

/// `dir` with a rejected blob `r.blob` (forced out of a REJECT), an accepted one `ok.blob`
/// of the same unit, and a station key pair `st.key`/`st.pub`.
fn station(dir: &Path) {
    std::fs::copy(examples().join("single_accel.csv"), dir.join("s.csv")).unwrap();
    let base = "calibrate s.csv --sensor single-accel --serial RT-1 --no-db";
    let r = cli(
        dir,
        &format!("{base} --max-noise 1e-6 --force-blob --blob r.blob"),
    );
    assert_eq!(r.code(), Some(3), "{}{}", r.out, r.err);
    let r = cli(dir, &format!("{base} --blob ok.blob"));
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    let r = cli(dir, "keygen st");
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
}

// ---- Calibrations nobody approved reach a unit ----

#[test]
fn a_rejected_blob_goes_into_no_image_and_is_signed_by_no_key_unless_insisted_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    station(d);
    let before = listing(d);
    for line in [
        "image --blob r.blob --bin x.bin",
        "image --blob r.blob --hex x.hex",
        "image --blob r.blob --bin x.bin --hex x.hex --station-key st.pub",
        "sign --blob r.blob --sign-key st.key --counter 1 -o x.signed",
    ] {
        let r = cli(d, line);
        refused(&r, 1, "judged REJECT", line);
        assert!(r.err.contains("--force-rejected"), "{line}: {}", r.err);
        assert_eq!(listing(d), before, "{line}: nothing written");
    }
    // The accepted blob of the same unit goes through; the rejected one only when insisted on,
    // with a warning, and the mark travels with it.
    let r = cli(d, "image --blob ok.bin --bin x.bin");
    assert_ne!(r.code(), Some(0), "no such file");
    let r = cli(d, "image --blob ok.blob --bin ok.region");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let r = cli(
        d,
        "sign --blob r.blob --sign-key st.key --counter 1 -o r.signed --force-rejected",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(
        r.err.contains("WARNING") && r.err.contains("REJECT"),
        "{}",
        r.err
    );
    let signed = std::fs::read(d.join("r.signed")).unwrap();
    let cal = calflash::signing::calibration(&signed).unwrap();
    assert!(
        cal.data().identity.fit_rejected,
        "the signed record keeps the mark"
    );
    // A forced, signed, rejected blob still needs --force-rejected to go into an image.
    let r = cli(d, "image --blob r.signed --station-key st.pub --bin y.bin");
    refused(&r, 1, "judged REJECT", "the signed rejected blob");
    let r = cli(
        d,
        "image --blob r.signed --station-key st.pub --bin y.bin --force-rejected",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
}

#[test]
fn a_review_calibration_is_signed_only_when_the_station_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(examples().join("single_accel.csv"), d.join("s.csv")).unwrap();
    let r = cli(d, "keygen st");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    // One output on the converter's rail: the observation is left out, the unit is a REVIEW.
    let text = std::fs::read_to_string(d.join("s.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<&str> = lines[5].split(',').collect();
    fields[6] = "65535";
    lines[5] = fields.join(",");
    std::fs::write(d.join("rail.csv"), lines.join("\n") + "\n").unwrap();
    let run = |extra: &str| {
        let args: Vec<String> = format!(
            "calibrate rail.csv --sensor single-accel --serial RT-1 --no-db --counter 1 --blob b.blob {extra}"
        )
        .split_whitespace()
        .map(String::from)
        .collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"))
            .current_dir(d)
            .env("CALFLASH_SIGN_KEY", d.join("st.key"))
            .args(&args)
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stdout).into_owned();
        let signed = spincal::signed::parts(&std::fs::read(d.join("b.blob")).unwrap())
            .1
            .is_some();
        (said, signed)
    };
    let (said, signed) = run("");
    assert!(said.contains("REVIEW"), "{said}");
    assert!(
        !signed,
        "a REVIEW is not signed by the key in the environment: {said}"
    );
    assert!(said.contains("signed only after a review"), "{said}");
    let (said, signed) = run("--sign-review");
    assert!(signed, "{said}");
    assert!(said.contains("signed on --sign-review"), "{said}");
}

#[test]
fn the_two_key_files_are_not_interchangeable_and_weak_keys_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    station(d);
    let secret = std::fs::read_to_string(d.join("st.key")).unwrap();
    let secret_hex = secret.lines().nth(1).unwrap().trim().to_string();
    // The private key as the public one: refused, nothing written, the secret never echoed.
    let r = cli(d, "image --station-key st.key --bin x.bin --hex x.hex");
    refused(&r, 1, "PRIVATE key", "private key as --station-key");
    assert!(!d.join("x.bin").exists() && !d.join("x.hex").exists());
    assert!(!r.err.contains(&secret_hex) && !r.out.contains(&secret_hex));
    // The public key to sign with, readable by all: named as the public key, no chmod advice;
    // after a chmod 600 it still does not sign.
    for mode in [0o644, 0o600] {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(d.join("st.pub"), std::fs::Permissions::from_mode(mode)).unwrap();
        let r = cli(
            d,
            "sign --blob ok.blob --sign-key st.pub --counter 1 -o x.signed",
        );
        refused(&r, 1, "public key", "public key as --sign-key");
        assert!(!r.err.contains("chmod"), "{}", r.err);
        assert!(!d.join("x.signed").exists());
    }
    // Counter 0 (below any a unit holds) is refused; the largest there is is said to be.
    let r = cli(
        d,
        "sign --blob ok.blob --sign-key st.key --counter 0 -o x.signed",
    );
    refused(&r, 2, "--counter", "counter 0");
    let r = cli(
        d,
        "sign --blob ok.blob --sign-key st.key --counter 4294967295 -o x.signed",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(
        r.err.contains("the highest there is") && r.err.contains("only downgrades"),
        "{}",
        r.err
    );
    std::fs::remove_file(d.join("x.signed")).unwrap();
    // The same key twice.
    let r = cli(
        d,
        "image --station-key st.pub --station-key ./st.pub --bin x.bin",
    );
    refused(&r, 1, "the same station key twice", "one key twice");
    // A small-order point (the identity) and a non-point.
    let header = calflash::signing::PUBLIC_HEADER;
    let identity = format!("01{}", "00".repeat(31));
    for (name, hex, says) in [
        ("weak.pub", identity.as_str(), "small order"),
        (
            "bad.pub",
            &format!("02{}", "00".repeat(31))[..],
            "not a point",
        ),
    ] {
        std::fs::write(d.join(name), format!("{header}\n{hex}\n")).unwrap();
        let r = cli(d, &format!("image --station-key {name} --bin x.bin"));
        refused(&r, 1, says, name);
        assert!(!d.join("x.bin").exists());
    }
}

#[test]
fn keygen_appends_its_extensions_and_a_failed_pair_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = cli(d, "keygen station.v1");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert_eq!(listing(d), ["station.v1.key", "station.v1.pub"]);
    let r = cli(d, "keygen other.key");
    refused(&r, 1, "without extension", "a prefix with .key");
    // The public half cannot be written (its directory is missing): no private half is left,
    // so a rerun into a good place starts clean.
    let private = d.join("lone.key");
    let e = calflash::signing::keygen(&private, &d.join("missing/lone.pub")).unwrap_err();
    assert!(e.to_string().contains("missing"), "{e}");
    assert!(!private.exists(), "the private half was left behind");
    calflash::signing::keygen(&private, &d.join("lone.pub")).unwrap();
}

// ---- Inputs overwritten, records lost ----

#[test]
fn a_batch_never_writes_over_its_own_observations() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("in")).unwrap();
    simulate(d, "in/A-1.txt", 1);
    simulate(d, "in/A-2.txt", 2);
    let before = std::fs::read(d.join("in/A-1.txt")).unwrap();
    let r = cli(d, "calibrate in --sensor single-accel --out-dir in --no-db");
    refused(&r, 1, "A-1's summary", "--out-dir the input directory");
    assert!(r.err.contains("the file"), "{}", r.err);
    assert_eq!(std::fs::read(d.join("in/A-1.txt")).unwrap(), before);
    assert_eq!(listing(&d.join("in")), ["A-1.txt", "A-2.txt"]);
}

/// A fixture of two units (`u1_output`, `u2_output`) beside the shared columns.
fn fixture(d: &Path, prefixes: [&str; 2]) {
    simulate(d, "s1.csv", 1);
    simulate(d, "s2.csv", 2);
    let rows = |f: &str| -> Vec<Vec<String>> {
        std::fs::read_to_string(d.join(f))
            .unwrap()
            .lines()
            .map(|l| l.split(',').map(String::from).collect())
            .collect()
    };
    let (a, b) = (rows("s1.csv"), rows("s2.csv"));
    let last = a[0].len() - 1;
    let text: Vec<String> = a
        .iter()
        .zip(&b)
        .enumerate()
        .map(|(i, (ra, rb))| {
            let mut r = ra[..last].to_vec();
            if i == 0 {
                r.push(format!("{}_output", prefixes[0]));
                r.push(format!("{}_output", prefixes[1]));
            } else {
                r.push(ra[last].clone());
                r.push(rb[last].clone());
            }
            r.join(",")
        })
        .collect();
    std::fs::write(d.join("fixture.csv"), text.join("\n") + "\n").unwrap();
}

#[test]
fn a_serial_never_names_a_file_outside_the_folder_nor_two_units_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    fixture(d, ["u1", "u2"]);
    let base = "calibrate fixture.csv --fixture --sensor single-accel --out-dir out --no-db";
    for (units, says) in [
        ("u1=../x", "plain file name"),
        ("u1=/tmp/x", "plain file name"),
        ("u1=.hidden", "plain file name"),
        ("u1=A,u2=A", "each unit needs its own serial"),
        ("u1=A,u1=B", "named twice"),
        ("u1=u2", "two units are named u2"),
    ] {
        let r = cli(d, &format!("{base} --units {units}"));
        refused(&r, 1, says, units);
        assert!(
            listing(&d.join("out")).is_empty(),
            "{units}: nothing written"
        );
        assert!(!d.join("x.obs.csv").exists() && !Path::new("/tmp/x.obs.csv").exists());
    }
    // Units without --units are said to be recorded under their prefixes.
    let r = cli(d, base);
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    assert!(
        r.err.contains("u1, u2 recorded under their column prefix"),
        "{}",
        r.err
    );
    // A prefix that is a path.
    let e = tempfile::tempdir().unwrap();
    std::fs::create_dir(e.path().join("out")).unwrap();
    fixture(e.path(), ["..", "u2"]);
    let r = cli(e.path(), base);
    assert_ne!(r.code(), Some(0), "{}{}", r.out, r.err);
    assert!(listing(&e.path().join("out")).is_empty());
    assert!(!e.path().join("..obs.csv").exists());
}

#[test]
fn a_special_file_as_an_output_is_written_into_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("pipe");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("skipped: mkfifo is not available here");
        return;
    }
    // A link to the FIFO has the shape of /dev/stdout.
    std::os::unix::fs::symlink(&fifo, d.join("stdout")).unwrap();
    for out in ["pipe", "stdout"] {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        let r = cli(
            d,
            &format!("simulate --sensor single-accel --plan head:4 --seed 1 -o {out}"),
        );
        assert_eq!(r.code(), Some(0), "{out}: {}", r.err);
        let text = reader.join().unwrap();
        assert!(text.starts_with("input"), "{out}: {text}");
        let m = std::fs::metadata(&fifo).unwrap();
        assert!(!m.is_file(), "{out}: the FIFO became a file");
        assert!(
            std::fs::symlink_metadata(d.join("stdout"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
    }
}

#[test]
fn a_history_that_keeps_nothing_or_a_mistyped_url_is_refused_and_no_password_shown() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(examples().join("single_accel.csv"), d.join("s.csv")).unwrap();
    let base = [
        "calibrate",
        "s.csv",
        "--sensor",
        "single-accel",
        "--serial",
        "RT-1",
    ];
    for db in [
        "",
        ":memory:",
        "Postgress://u:s3cret@h/db",
        "postgress://u:s3cret@h/db",
        "postgres:/u:s3cret@h/db",
        " postgres://u:s3cret@h/db",
        "mysql://u:s3cret@h/db",
    ] {
        let mut args = base.to_vec();
        args.extend(["--db", db]);
        let r = calflash(d, &args);
        assert_eq!(r.code(), Some(1), "--db {db:?}: {}{}", r.out, r.err);
        assert!(!r.out.contains("recorded"), "--db {db:?}: {}", r.out);
        assert!(
            !r.err.contains("s3cret") && !r.out.contains("s3cret"),
            "{}",
            r.err
        );
        assert_eq!(listing(d), ["s.csv"], "--db {db:?}: nothing created");
        // The same from the environment.
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_calflash"))
            .current_dir(d)
            .env("CALFLASH_DB", db)
            .args(base)
            .output()
            .unwrap();
        let (o, e) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(1), "CALFLASH_DB={db:?}: {o}{e}");
        assert!(
            !o.contains("recorded as") && !e.contains("s3cret"),
            "{o}{e}"
        );
        assert_eq!(listing(d), ["s.csv"], "CALFLASH_DB={db:?}: nothing created");
    }
}

// ---- Crashes and the machine's memory ----

#[test]
fn a_blob_is_read_only_as_far_as_a_blob_can_be_long() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    station(d);
    for line in [
        "sign --blob /dev/zero --sign-key st.key --counter 1 -o x.signed",
        "image --blob /dev/zero --bin x.bin",
        "apply s.csv --blob /dev/zero -o x.csv",
        "health s.csv --blob /dev/zero",
        "flash --blob /dev/zero --port tcp://127.0.0.1:9",
    ] {
        let r = cli(d, line);
        refused(&r, 1, "/dev/zero: longer than", line);
        assert!(
            r.err.contains("not a calibration blob"),
            "{line}: {}",
            r.err
        );
    }
}

#[test]
fn a_line_is_read_only_as_far_as_a_line_can_be_long() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    for (line, says) in [
        ("allan /dev/zero", "/dev/zero:1: longer than"),
        (
            "selfcal /dev/zero --serial X --g 9.81",
            "/dev/zero:1: longer than",
        ),
        (
            "calibrate /dev/zero --sensor single-accel --serial X --no-db",
            "/dev/zero:1: longer than",
        ),
        (
            "fit /dev/zero --model output~input",
            "/dev/zero:1: longer than",
        ),
        (
            "calibrate /dev/zero --fixture --sensor single-accel --out-dir out --no-db",
            "line 1 is longer than",
        ),
        ("compare /dev/zero /dev/urandom", "/dev/zero: longer than"),
    ] {
        let r = cli(d, line);
        refused(&r, 1, says, line);
    }
}

/// The example IMU calibrated with noise terms into `dir/u.blob`, with `extra` options.
fn noisy_imu(dir: &Path, extra: &str) -> Ran {
    allan(dir, "accel.json", "m/s^2", 1.5e-3, 1.6e-5);
    allan(dir, "gyro.json", "rad/s", 2.0e-4, 8.0e-7);
    let bench = examples().join("imu_bench.csv");
    cli(
        dir,
        &format!(
            "calibrate {} --sensor imu --serial IMU-H-1 --blob u.blob --no-db --noise accel.json,gyro.json {extra}",
            bench.display()
        ),
    )
}

// ---- Wrong results at exit 0 ----

#[test]
fn an_ageing_beyond_a_century_is_refused_and_a_shift_beyond_the_codes_is_said() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for ageing in ["1e30d", "36526d", "1e12"] {
        let r = noisy_imu(d, &format!("--ageing {ageing}"));
        refused(&r, 2, "at most 100 years", ageing);
        assert!(!d.join("u.blob").exists());
    }
    let r = noisy_imu(d, "--ageing 365d");
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    for (line, says) in [
        (
            "simulate --sensor imu --rest u.blob --shift 1e9,0,0,0,0,0 --poses 1 --hold 0.2 -o r.csv",
            "output ax would have to read",
        ),
        (
            "simulate --sensor imu --rest u.blob --shift 0,0,0,0,0,1e12 --poses 2 --hold 0.2 -o r.csv",
            "output wz would have to read",
        ),
        (
            "simulate --sensor imu --rest u.blob --aged 1e30d --poses 1 --hold 0.2 -o r.csv",
            "at most 100 years",
        ),
    ] {
        let r = cli(d, line);
        assert_ne!(r.code(), Some(0), "{line}");
        assert!(r.err.contains(says), "{line}: {}", r.err);
        assert!(!r.err.contains("panicked"), "{line}: {}", r.err);
        assert!(!d.join("r.csv").exists());
    }
}

#[test]
fn a_lot_judged_at_a_tiny_alpha_still_names_a_unit_far_outside() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    lot_history::write(
        &d.join("units.sqlite"),
        "LOT-",
        60,
        1_750_000_000,
        3,
        |i, b, _| {
            if i == 7 {
                b[0] += 40_000.0;
            }
        },
    );
    for alpha in ["0.001", "1e-15", "1e-100", "1e-300"] {
        let r = cli(d, &format!("lot LOT- --db units.sqlite --alpha {alpha}"));
        assert_eq!(r.code(), Some(0), "{alpha}: {}{}", r.out, r.err);
        assert!(
            !r.out.contains("NaN") && !r.out.contains("inf"),
            "{alpha}: {}",
            r.out
        );
        assert!(r.out.contains("LOT-000007"), "{alpha}: {}", r.out);
        assert!(
            r.out.contains("1 of 60 units outside"),
            "{alpha}: {}",
            r.out
        );
    }
}

/// A lever-arm calibration `r.blob` of the spinning round's truth and a spin-rig flight
/// `f.csv` of it at 1000 Hz (`t` in seconds).
fn spin_flight(d: &Path, spin: &str) -> Ran {
    let truth = examples().join("spinning_round.truth.json");
    let truth = truth.display();
    let r = cli(
        d,
        &format!(
            "simulate --sensor imu --truth {truth} --plan tumble:24 --plan rate:-1900:1900:5 --plan diagonal:-1900:1900:5 --plan centrifuge:1:1500:4 -o rig.csv"
        ),
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let r = cli(
        d,
        "calibrate rig.csv --sensor imu --serial R-1 --blob r.blob --no-db",
    );
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    cli(
        d,
        &format!("simulate --sensor imu --truth {truth} --spin {spin} --sample-rate 1000 -o f.csv"),
    )
}

#[test]
fn a_time_column_in_milliseconds_is_read_as_milliseconds_and_rates_no_sensor_has_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = spin_flight(d, "150:0.05");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    // The same flight with its time in milliseconds, in a column that says so.
    let text = std::fs::read_to_string(d.join("f.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().replacen("t,", "t_ms,", 1);
    assert!(header.starts_with("t_ms,"), "{header}");
    let mut out = vec![header.clone()];
    for l in lines {
        let (t, rest) = l.split_once(',').unwrap();
        out.push(format!("{},{rest}", t.parse::<f64>().unwrap() * 1000.0));
    }
    std::fs::write(d.join("f_ms.csv"), out.join("\n") + "\n").unwrap();
    std::fs::write(
        d.join("f_stamp.csv"),
        out.join("\n").replacen("t_ms,", "stamp,", 1) + "\n",
    )
    .unwrap();
    let apply = |file: &str, time: &str, o: &str| {
        cli(
            d,
            &format!("apply --blob r.blob {file} --time-column {time} --reference -o {o}"),
        )
    };
    let s = apply("f.csv", "t", "s.csv");
    assert_eq!(s.code(), Some(0), "{}", s.err);
    for (file, time) in [
        ("f_ms.csv", "t_ms"),
        ("f_stamp.csv", "stamp:ms"),
        ("f.csv", "t:s"),
    ] {
        let r = apply(file, time, "ms.csv");
        assert_eq!(r.code(), Some(0), "{time}: {}", r.err);
        assert!(
            r.out.contains("1000.000000 Hz from the timestamps"),
            "{time}: {}",
            r.out
        );
        let [a, b] = ["s.csv", "ms.csv"].map(|f| std::fs::read_to_string(d.join(f)).unwrap());
        assert_eq!(a, b, "{time}: the same correction as with seconds");
    }
    // A time column whose name states no unit, and an unknown unit, are refused.
    let r = apply("f_stamp.csv", "stamp", "x.csv");
    refused(&r, 2, "cannot be read from its name", "stamp");
    let r = apply("f_stamp.csv", "stamp:min", "x.csv");
    refused(&r, 2, "min", "stamp:min");
    // Rates no sensor has.
    for rate in ["1e-9", "0", "1e6", "nan"] {
        let r = cli(
            d,
            &format!("apply --blob r.blob f.csv --rate {rate} -o x.csv"),
        );
        refused(&r, 2, "a sample rate from 0.1 Hz", rate);
    }
    assert!(!d.join("x.csv").exists());
}

#[test]
fn a_spin_that_jumps_in_one_sample_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = examples().join("spinning_round.truth.json");
    for profile in ["300:0.5,150-300:0.5", "50:0.1,150:0.1"] {
        let r = cli(
            d,
            &format!(
                "simulate --sensor imu --truth {} --spin {profile} --sample-rate 1000 -o f.csv",
                truth.display()
            ),
        );
        refused(&r, 1, "cannot jump in one sample", profile);
        assert!(!d.join("f.csv").exists());
    }
    let r = cli(
        d,
        &format!(
            "simulate --sensor imu --truth {} --spin 150-300:0.05,300:0.05 --sample-rate 1000 -o f.csv",
            truth.display()
        ),
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
}

#[test]
fn a_preset_term_the_plan_cannot_estimate_is_dropped_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // +-1, +-0.5 and 0 g at every temperature of a ramp: symmetric levels, on which
    // input:abs(input) is a combination of input and input^3.
    let g = 9.80665;
    let mut text = String::from("input,temp,output\n");
    let mut k = 0u32;
    for temp in [-40.0, 25.0, 85.0] {
        for level in [-1.0, -0.5, 0.0, 0.5, 1.0] {
            for _ in 0..4 {
                k += 1;
                let noise = f64::from(k * 7919 % 13) / 13.0 - 0.5;
                let x = level * g;
                let out =
                    32_768.0 + 3.0 * temp + 170.0 * x * (1.0 + 1e-4 * temp) + 0.05 * x * x + noise;
                text.push_str(&format!("{x},{temp},{out}\n"));
            }
        }
    }
    std::fs::write(d.join("sym.csv"), text).unwrap();
    let r = cli(
        d,
        "calibrate sym.csv --sensor single-accel --serial S-1 --no-db --blob s.blob",
    );
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    assert!(
        r.out.contains("dropped input:abs(input) from the preset")
            && r.out.contains("not observable"),
        "{}",
        r.out
    );
    assert!(d.join("s.blob").exists());
    // A term the user asked for by formula is not dropped: the fit says why it cannot be had.
    let r = calflash(
        d,
        &[
            "calibrate",
            "sym.csv",
            "--sensor",
            "single-accel",
            "--serial",
            "S-1",
            "--no-db",
            "--model",
            "output ~ 1 + input + input^3 + input:abs(input)",
        ],
    );
    refused(
        &r,
        1,
        "input:abs(input) is not observable",
        "the user's formula",
    );
}

// ---- Messages that mislead ----

#[test]
fn the_history_credits_a_key_only_with_a_signature_that_was_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = cli(d, "keygen st");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let key = calflash::signing::load_private(&d.join("st.key")).unwrap();
    let cal =
        spincal::model::Calibration::new(spincal::model::CalibrationData::example_imu()).unwrap();
    let serial = cal.data().identity.serial.as_str().to_string();
    let mut buf = vec![0u8; spincal::blob::MAX_BLOB_LEN];
    let n = spincal::blob::encode(&cal, &mut buf).unwrap();
    let signed = calflash::signing::sign(&buf[..n], &key, 3, false).unwrap();
    let (id, _) = calflash::signing::signer(&signed).unwrap();
    let mut db = calflash::db::Db::open(d.join("u.sqlite").as_path()).unwrap();
    // Refused by the unit (another key's id on it, say): it only claims the key.
    let refused = serde_json::json!({"error": "the unit refused it: unknown key"});
    db.record_flash(&serial, &signed, &refused, "failed")
        .unwrap();
    // Committed and verified by a provisioned unit.
    let verified = serde_json::json!({"trust": "provisioned", "signed_by": id});
    db.record_flash(&serial, &signed, &verified, "verified")
        .unwrap();
    // Committed by an unprovisioned unit, which checks no signature.
    let open = serde_json::json!({"trust": "unprovisioned", "signed_by": id});
    db.record_flash(&serial, &signed, &open, "verified")
        .unwrap();
    drop(db);
    let r = cli(d, &format!("history {serial} --db u.sqlite"));
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let lines: Vec<&str> = r.out.lines().filter(|l| l.contains(" flash ")).collect();
    assert_eq!(lines.len(), 3, "{}", r.out);
    assert!(
        lines[0].contains(&format!("claims key {id} #3 (unverified)")),
        "{}",
        lines[0]
    );
    assert!(
        lines[1].contains(&format!("signed by key {id} #3")),
        "{}",
        lines[1]
    );
    assert!(lines[2].contains("claims key"), "{}", lines[2]);
}

#[test]
fn a_link_that_answers_garbage_is_named_with_its_port_not_called_silent() {
    use std::io::{Read as _, Write as _};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    station(d);
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        if let Ok((mut s, _)) = listener.accept() {
            let mut buf = [0u8; 256];
            let _ = s.read(&mut buf);
            // A console's banner: text, never a frame's zero byte.
            let _ = s.write_all(&b"U-Boot 2024.01 login: "[..]);
            std::thread::sleep(std::time::Duration::from_secs(3));
        }
    });
    let r = cli(
        d,
        &format!("flash --blob ok.blob --port tcp://127.0.0.1:{port} --timeout 0.5 --no-db"),
    );
    refused(&r, 1, "no frame of the calflash protocol", "garbage");
    assert!(
        r.err.contains(&format!("tcp://127.0.0.1:{port}")),
        "{}",
        r.err
    );
    assert!(!r.err.contains("did not answer"), "{}", r.err);
}

#[test]
fn messages_name_the_option_or_the_file_at_fault() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // --gravity under its own name; a noise term too large for the device names its file.
    let r = noisy_imu(d, "--gravity 9.5:9.82");
    refused(&r, 1, "--gravity 9.5:9.82", "gravity");
    assert!(!r.err.contains("--noise"), "{}", r.err);
    allan(d, "huge.json", "m/s^2", 1e300, 1.6e-5);
    let bench = examples().join("imu_bench.csv");
    let r = cli(
        d,
        &format!(
            "calibrate {} --sensor imu --serial X --no-db --noise huge.json,gyro.json",
            bench.display()
        ),
    );
    refused(&r, 1, "huge.json: axes[0].terms.random_walk", "1e300");
    let r = noisy_imu(d, "--false-alarm 1e-300");
    refused(&r, 2, "from 1e-12 to 0.5", "--false-alarm 1e-300");
    // A one-sample recording is said to be one, not blamed on the blob.
    let r = noisy_imu(d, "");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    std::fs::write(d.join("one.csv"), "t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n").unwrap();
    let r = cli(d, "health one.csv --blob u.blob --no-db");
    refused(&r, 1, "one.csv: one sample", "one sample");
    assert!(!r.err.contains("u.blob"), "{}", r.err);
    let r = cli(d, "allan one.csv");
    refused(&r, 1, "one sample", "allan");
    assert!(!r.err.contains("inf s"), "{}", r.err);
    // Nanosecond timestamps under a name that says seconds: refused with the way out.
    let mut text = String::from("t,ax,ay,az,gx,gy,gz\n");
    for k in 0..200u64 {
        text.push_str(&format!(
            "{},100,200,16384,1,2,3\n",
            1_700_000_000_000_000_000 + k * 1_000_000
        ));
    }
    std::fs::write(d.join("ns.csv"), text).unwrap();
    let r = cli(d, "allan ns.csv");
    refused(&r, 1, "a rate no inertial sensor samples at", "ns as s");
    assert!(r.err.contains("t=NAME:ms"), "{}", r.err);
    // Options that would be ignored are said to be.
    let r = cli(
        d,
        "design evaluate --model single --plan head:12 --curve temp=-40:85:20",
    );
    refused(
        &r,
        1,
        "--curve temp=-40:85:20: the model reads no `temp`",
        "curve",
    );
    std::fs::copy(examples().join("single_accel.csv"), d.join("s.csv")).unwrap();
    let r = cli(
        d,
        "calibrate s.csv --sensor single-accel --serial X --no-db --thermal-order 2",
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    assert!(r.out.contains("--thermal-order 2 is not used"), "{}", r.out);
    // A history that cannot be written, and no file asked for: not "written but".
    let r = cli(
        d,
        "calibrate s.csv --sensor single-accel --serial X --db /proc/h.sqlite",
    );
    assert_ne!(r.code(), Some(0), "{}", r.out);
    assert!(
        r.err.contains("the calibration is NOT recorded") && !r.err.contains("written"),
        "{}",
        r.err
    );
    // Days that do not exist, and a reversed range.
    let r = cli(d, "lot X --since 2026-02-30 --db u.sqlite");
    refused(&r, 2, "no such day", "2026-02-30");
    let r = cli(
        d,
        "lot X --since 2026-03-01 --until 2026-02-01 --db u.sqlite",
    );
    refused(&r, 1, "--since is after --until", "reversed");
    assert!(!d.join("u.sqlite").exists());
}

#[test]
fn a_rate_step_no_airframe_makes_is_flagged_by_the_device_correction() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two steady flights, 300 and 150 Hz of roll, spliced: at sample 50 the rate jumps by
    // 942 rad/s in one millisecond (9.4e5 rad/s^2), while each row's truth has none.
    let r = spin_flight(d, "300:0.1");
    assert_eq!(r.code(), Some(0), "{}", r.err);
    std::fs::rename(d.join("f.csv"), d.join("a.csv")).unwrap();
    let r = cli(
        d,
        &format!(
            "simulate --sensor imu --truth {} --spin 150:0.1 --sample-rate 1000 -o b.csv",
            examples().join("spinning_round.truth.json").display()
        ),
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let [a, b] = ["a.csv", "b.csv"].map(|f| std::fs::read_to_string(d.join(f)).unwrap());
    let (a, b): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    assert_eq!(a[0], b[0], "the same columns");
    let spliced: Vec<&str> = a[..=50].iter().chain(&b[51..]).copied().collect();
    std::fs::write(d.join("f.csv"), spliced.join("\n") + "\n").unwrap();
    let apply = |extra: &str| {
        let r = cli(
            d,
            &format!("apply --blob r.blob f.csv --time-column t --reference -o o.csv {extra}"),
        );
        assert_eq!(r.code(), Some(0), "{extra}: {}{}", r.out, r.err);
        let text = std::fs::read_to_string(d.join("o.csv")).unwrap();
        let stepped: Vec<usize> = text
            .lines()
            .skip(1)
            .enumerate()
            .filter(|(_, l)| l.contains("rate-step"))
            .map(|(i, _)| i)
            .collect();
        (r.out, stepped)
    };
    // The device's default: the step's sample, and only it, is flagged, and the reference
    // figures (of unflagged samples) stay at the calibration's level.
    let (out, stepped) = apply("");
    assert_eq!(stepped, vec![50], "{out}");
    assert!(
        out.contains("1 sample(s) flagged rate-step: the rate changed faster than 5e5 rad/s^2"),
        "{out}"
    );
    // An airframe said to turn faster: nothing flagged, and the step's tangential term
    // (hundreds of m/s^2 on one sample) reaches the figures.
    let (out_wide, stepped) = apply("--max-angular-acceleration 1e7");
    assert!(stepped.is_empty(), "{out_wide}");
    // The worst absolute error of `az` (m/s^2) in the reference table.
    let worst_az = |out: &str| -> f64 {
        let row = out.lines().find(|l| l.starts_with("  | az |")).expect(out);
        let cell = row.split('|').nth(9).expect(row).trim();
        cell.split_whitespace().next().unwrap().parse().expect(row)
    };
    assert!(worst_az(&out) < 30.0, "{out}");
    assert!(worst_az(&out_wide) > 500.0, "{out_wide}");
    for bad in ["0", "-5", "nan", "1e40"] {
        let r = cli(
            d,
            &format!(
                "apply --blob r.blob f.csv --time-column t --max-angular-acceleration {bad} -o x.csv"
            ),
        );
        refused(&r, 2, "max-angular-acceleration", bad);
    }
    // Given for a calibration without a lever arm: said to be unused.
    let r = cli(
        d,
        &format!(
            "simulate --sensor imu --truth {} --plan tumble:24 --plan rate:-6:6:5 -o bench.csv",
            examples().join("imu_bench.truth.json").display()
        ),
    );
    assert_eq!(r.code(), Some(0), "{}", r.err);
    let r = cli(
        d,
        "calibrate bench.csv --sensor imu --serial B-1 --blob b.blob --no-db",
    );
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    let r = cli(
        d,
        "apply --blob b.blob bench.csv --rate 100 --max-angular-acceleration 10 -o x.csv",
    );
    assert_eq!(r.code(), Some(0), "{}{}", r.out, r.err);
    assert!(
        r.out
            .contains("--max-angular-acceleration is not used: this calibration has no lever arm"),
        "{}",
        r.out
    );
}
