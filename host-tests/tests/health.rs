//! The unit judges its calibration at rest (`spincal::health`): simulated units through the
//! device's corrector and monitor, on the host.
//!
//! The numbers the issue asks for are measured here and printed; `BENCHMARKS.md` records them.

use calflash::sim::rest::{Unit, face};
use nalgebra::Rotation3;
use spincal::correct::Flags;
use spincal::health::{Health, RestMonitor, Verdict};
use spincal::model::{Calibration, CalibrationData};

const RATE: f64 = 1000.0;

fn calibration(false_alarm: f32) -> Calibration {
    let mut data = CalibrationData::example_imu();
    if let Some(n) = &mut data.noise {
        n.false_alarm = false_alarm;
    }
    Calibration::new(data).expect("valid")
}

/// Each bias's 1-sigma wander over the whole ageing allowance (`K sqrt(t)`).
fn ageing_sigma(cal: &Calibration) -> Vec<f64> {
    let noise = cal.data().noise.expect("noise");
    noise
        .bias_walk
        .iter()
        .map(|k| f64::from(*k) * f64::from(noise.ageing_s).sqrt())
        .collect()
}

/// The stated 1-sigma of each bias at rest (25 C): what "n sigma" means below.
fn stated_sigma(cal: &Calibration) -> [f64; 6] {
    calflash::sim::rest::stated_sigma(cal).expect("covariance")
}

struct Run {
    health: Health,
    /// Seconds of the run when the verdict first became SUSPECT.
    suspect_at: Option<f64>,
    /// The flags of the last sample.
    last_flags: Flags,
}

/// Runs `unit` through `poses` (rest `seconds` in each, one-second turns between).
fn run(unit: &mut Unit<'_>, cal: &Calibration, poses: &[Rotation3<f64>], seconds: f64) -> Run {
    let mut monitor = RestMonitor::new(cal, RATE as f32).expect("health check");
    let mut n = 0u64;
    let mut suspect_at = None;
    let mut last_flags = Flags::NONE;
    let mut each = |imu: &mut spincal::correct::ImuCorrector<'_, u16>,
                    out: &spincal::correct::Corrected<6>| {
        n += 1;
        last_flags = out.flags;
        if monitor.observe_rest(imu, out) == Verdict::Suspect && suspect_at.is_none() {
            suspect_at = Some(n as f64 / RATE);
        }
    };
    for (k, pose) in poses.iter().enumerate() {
        if k > 0 {
            unit.turn(&poses[k - 1], pose, &mut each).unwrap();
        }
        unit.rest(pose, seconds, &mut each).unwrap();
    }
    Run {
        health: monitor.health(),
        suspect_at,
        last_flags,
    }
}

/// A rest pose for unit `k`: a face up and a roll about the vertical, all from `k`.
fn some_pose(k: u64) -> Rotation3<f64> {
    let axis = (k % 3) as usize;
    let sign = if (k / 3).is_multiple_of(2) { 1.0 } else { -1.0 };
    face(axis, sign, 0.7 * k as f64)
}

/// Handling: three rests with different faces up, each pose observing another accelerometer
/// direction.
fn handling(k: u64) -> [Rotation3<f64>; 3] {
    let roll = 0.37 * k as f64;
    [
        face(2, 1.0, roll) * Rotation3::from_euler_angles(0.3, -0.2, 0.0),
        face(0, 1.0, roll) * Rotation3::from_euler_angles(0.0, 0.25, 0.1),
        face(1, -1.0, roll) * Rotation3::from_euler_angles(-0.2, 0.0, 0.3),
    ]
}

/// How often units whose calibration holds are called anything but OK, and how often units
/// aged by the whole allowance are called SUSPECT, against the stated false-alarm rate.
#[test]
fn false_alarms_at_the_stated_rate() {
    let alpha = 0.05;
    let cal = calibration(alpha as f32);
    let sigma = stated_sigma(&cal);
    let ageing = ageing_sigma(&cal);
    let units = 400u64;
    let (mut not_ok, mut suspect) = (0u32, 0u32);
    for k in 0..units {
        let mut seed_unit = Unit::new(&cal, RATE, [0.0; 6], 9.81, 10_000 + k);
        // Holds: the calibration's own error, as stated.
        let holds: [f64; 6] = std::array::from_fn(|i| seed_unit.normal(sigma[i]));
        let gravity = 9.80 + 0.02 * (k as f64 + 0.5) / units as f64;
        let mut unit = Unit::new(&cal, RATE, holds, gravity, k);
        let r = run(&mut unit, &cal, &[some_pose(k)], 10.0);
        not_ok += u32::from(r.health.verdict != Verdict::Ok);
        // Aged: the calibration's error and the whole ageing allowance.
        let aged: [f64; 6] = std::array::from_fn(|i| {
            seed_unit.normal((sigma[i] * sigma[i] + ageing[i] * ageing[i]).sqrt())
        });
        let mut unit = Unit::new(&cal, RATE, aged, gravity, 50_000 + k);
        let r = run(&mut unit, &cal, &[some_pose(k)], 10.0);
        suspect += u32::from(r.health.verdict == Verdict::Suspect);
    }
    let se = (alpha * (1.0 - alpha) / units as f64).sqrt();
    let (p_drift, p_suspect) = (
        f64::from(not_ok) / units as f64,
        f64::from(suspect) / units as f64,
    );
    eprintln!(
        "false alarms over {units} units, 10 s at rest, stated {alpha}: DRIFTED or worse when \
         the calibration holds {p_drift:.4}, SUSPECT when aged by the allowance {p_suspect:.4}"
    );
    assert!(p_drift <= alpha + 3.0 * se, "{p_drift}");
    assert!(p_suspect <= alpha + 3.0 * se, "{p_suspect}");
}

/// A bias shift of 1 sigma on every output: OK or DRIFTED, and the refined biases' 95 %
/// intervals cover the truth at least 95 % - 3.5 % of the time over 200 handled units. (These
/// units carry a bias and no other error, which is not what the prior describes, so the
/// intervals, which allow for the scale and misalignment errors a unit may carry, cover more;
/// the calibrated coverage is `a_units_own_calibration_error_is_carried_from_pose_to_pose`.)
#[test]
fn one_sigma_shifts_are_refined_within_their_stated_covariance() {
    let cal = calibration(1e-3);
    let sigma = stated_sigma(&cal);
    let units = 200u64;
    let (mut covered, mut total) = (0u32, 0u32);
    let mut per_output = [0u32; 6];
    let mut verdicts = [0u32; 4];
    for k in 0..units {
        let shift: [f64; 6] = std::array::from_fn(|i| {
            let sign = if (k >> i) & 1 == 0 { 1.0 } else { -1.0 };
            sign * sigma[i]
        });
        let gravity = 9.80 + 0.02 * ((k * 37 % units) as f64 + 0.5) / units as f64;
        let mut unit = Unit::new(&cal, RATE, shift, gravity, 1_000 + k);
        let r = run(&mut unit, &cal, &handling(k), 4.0);
        let h = &r.health;
        verdicts[h.verdict as usize] += 1;
        assert!(
            matches!(h.verdict, Verdict::Ok | Verdict::Drifted),
            "unit {k}: {h:?}"
        );
        for i in 0..6 {
            let inside =
                (f64::from(h.bias[i]) - shift[i]).abs() <= 1.96 * f64::from(h.bias_sigma[i]);
            covered += u32::from(inside);
            per_output[i] += u32::from(inside);
            total += 1;
        }
    }
    let coverage = f64::from(covered) / f64::from(total);
    eprintln!(
        "1-sigma shifts, {units} units handled through 3 poses, 4 s each: verdicts \
         [not-yet, ok, drifted, suspect] {verdicts:?}; 95 % intervals cover {coverage:.4} \
         (per output {per_output:?} of {units})"
    );
    assert!(coverage >= 0.95 - 0.035, "{coverage}");
}

/// A shift of 6 sigma on any one output is SUSPECT within 10 s of rest at 1 kHz (the
/// accelerometer's in a pose where its axis sees gravity), and every sample is flagged.
#[test]
fn six_sigma_shifts_are_suspect_within_ten_seconds() {
    let cal = calibration(1e-3);
    let sigma = stated_sigma(&cal);
    let mut slowest: f64 = 0.0;
    for axis in 0..6 {
        for k in 0..8u64 {
            let mut shift = [0.0; 6];
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            shift[axis] = 6.0 * sign * sigma[axis];
            let pose = if axis < 3 {
                face(axis, if k % 4 < 2 { 1.0 } else { -1.0 }, 0.4 * k as f64)
            } else {
                some_pose(k)
            };
            let mut unit = Unit::new(&cal, RATE, shift, 9.81, 7_000 + 10 * axis as u64 + k);
            let r = run(&mut unit, &cal, &[pose], 10.0);
            let at = r
                .suspect_at
                .unwrap_or_else(|| panic!("output {axis}, unit {k}: {:?}", r.health));
            slowest = slowest.max(at);
            assert!(r.last_flags.contains(Flags::CALIBRATION_SUSPECT));
        }
    }
    eprintln!("6-sigma shifts on each output, 48 units: SUSPECT after at most {slowest:.3} s");
    assert!(slowest <= 10.0);
}

/// The example IMU as a 1 g bench (tumble and rate table) calibrates it: the accelerometers'
/// calibrated range ends at 1 g, so a unit at rest with an axis vertical reads that axis at or
/// just beyond the range on about half its samples.
fn one_g_bench() -> Calibration {
    let mut data = CalibrationData::example_imu();
    if let spincal::model::Sensor::Imu { accel, .. } = &mut data.sensor {
        for c in accel.iter_mut() {
            c.range = spincal::model::Span::new(-9.806_65, 9.806_65);
        }
    }
    Calibration::new(data).expect("valid")
}

/// A rest reading beyond the calibrated range is censored by the range, not an outlier
/// (issue 30): after a 1 g bench, units resting with an axis vertical are judged OK as often
/// as the stated false-alarm rate allows, and the same unit shocked upward or downward by
/// 6 sigma is SUSPECT, not left unjudged or pulled down.
#[test]
fn a_reading_beyond_a_one_g_bench_is_judged_not_dropped() {
    let cal = one_g_bench();
    let sigma = stated_sigma(&cal);
    let units = 40u64;
    let mut not_ok = Vec::new();
    for k in 0..units {
        let axis = (k % 3) as usize;
        let sign = if (k / 3) % 2 == 0 { 1.0 } else { -1.0 };
        let pose = face(axis, sign, 0.3 * k as f64);
        let gravity = 9.80 + 0.02 * (k as f64 + 0.5) / units as f64;
        let mut unit = Unit::new(&cal, RATE, [0.0; 6], gravity, 90_000 + k);
        let r = run(&mut unit, &cal, &[pose], 10.0);
        if r.health.verdict != Verdict::Ok {
            not_ok.push((k, r.health.verdict, r.health.ignored_samples));
        }
        for shock in [6.0, -6.0] {
            let mut shift = [0.0; 6];
            shift[axis] = shock * sign * sigma[axis];
            let mut unit = Unit::new(&cal, RATE, shift, gravity, 95_000 + k);
            let r = run(&mut unit, &cal, &[pose], 10.0);
            assert_eq!(
                r.health.verdict,
                Verdict::Suspect,
                "unit {k}, axis {axis} shocked {shock:+} sigma along gravity: {:?}",
                r.health
            );
        }
    }
    eprintln!("1 g bench, {units} units at rest with an axis vertical: not OK {not_ok:?}");
    assert!(not_ok.len() <= 2, "{not_ok:?}");
}

/// The example IMU with an accelerometer covariance dominated by the sensitivity rows (scale
/// and misalignment, 2e-3 per axis) over the bias (2e-3 m/s^2): the error of a unit then
/// depends strongly on its pose.
fn scale_dominated() -> Calibration {
    let mut data = calibration(1e-3).into_data();
    if let spincal::model::Sensor::Imu {
        covariance: Some(sets),
        ..
    } = &mut data.sensor
    {
        for set in sets.as_mut_slice() {
            for l in &mut set.accel {
                let packed = l.as_flattened_mut();
                packed.fill(0.0);
                let diagonal = |i: usize| i * (i + 1) / 2 + i;
                packed[diagonal(0)] = 2e-3;
                for i in 1..4 {
                    packed[diagonal(i)] = 2e-3;
                }
                packed[diagonal(7)] = 1e-5;
            }
        }
    }
    Calibration::new(data).expect("valid")
}

/// Units that carry their own calibration error (bias, scale, misalignment and g-squared
/// errors drawn from the stated covariance, so that the error depends on the pose): after
/// one, two and three poses the refined accelerometer biases' 95 % intervals cover the error at
/// the last pose 95 % +- 3.5 % of the time over 300 units (issue 30: before, 0.95, 0.90 and
/// 0.75, as a pose change added the pose-dependent part as fresh noise).
#[test]
fn a_units_own_calibration_error_is_carried_from_pose_to_pose() {
    let cal = scale_dominated();
    let ageing = ageing_sigma(&cal);
    let units = 300u64;
    let mut coverage = Vec::new();
    for poses in 1..=3usize {
        let (mut covered, mut total) = (0u32, 0u32);
        let mut along = (0u32, 0u32);
        for k in 0..units {
            let gravity = 9.80 + 0.02 * ((k * 37 % units) as f64 + 0.5) / units as f64;
            // The health reports the aged prior's refinement: the unit has aged by a draw of
            // the allowance too.
            let mut seed = Unit::new(&cal, RATE, [0.0; 6], gravity, 80_000 + k);
            let aged: [f64; 6] = std::array::from_fn(|i| seed.normal(ageing[i]));
            let mut unit = Unit::new(&cal, RATE, aged, gravity, 40_000 + k);
            let theta = unit.draw_accel_error(&cal);
            let mut unit = unit.with_accel_error(theta);
            let handled = handling(k);
            let r = run(&mut unit, &cal, &handled[..poses], 4.0);
            let h = &r.health;
            let last = handled[poses - 1];
            let f = last.inverse() * nalgebra::Vector3::new(0.0, 0.0, gravity);
            let own = unit.accel_error(&[f[0], f[1], f[2]]);
            let truth: [f64; 3] = std::array::from_fn(|i| own[i] + aged[i]);
            let up = (0..3)
                .max_by(|&a, &b| f[a].abs().total_cmp(&f[b].abs()))
                .unwrap();
            for (i, t) in truth.iter().enumerate() {
                let inside = (f64::from(h.bias[i]) - t).abs() <= 1.96 * f64::from(h.bias_sigma[i]);
                covered += u32::from(inside);
                total += 1;
                if i == up {
                    along.0 += u32::from(inside);
                    along.1 += 1;
                }
            }
        }
        let c = f64::from(covered) / f64::from(total);
        let a = f64::from(along.0) / f64::from(along.1);
        coverage.push((poses, c, a));
    }
    eprintln!(
        "units with their own calibration error, {units} per row, 4 s a pose: (poses, coverage \
         of the accelerometer biases, along gravity) {coverage:?}"
    );
    for (poses, c, a) in coverage {
        assert!((c - 0.95).abs() <= 0.035, "{poses} pose(s): {c}");
        assert!(
            (a - 0.95).abs() <= 0.05,
            "{poses} pose(s) along gravity: {a}"
        );
    }
}

/// A shift within what ageing explains: DRIFTED, the refined biases applied as an overlay
/// (the corrected rate at rest comes back to zero) and the 1-sigma from the refined variance;
/// the calibration itself is untouched.
#[test]
fn a_drifted_unit_is_corrected_by_the_overlay_and_keeps_its_calibration() {
    let cal = calibration(1e-3);
    let sigma = stated_sigma(&cal);
    let mut shift = [0.0; 6];
    shift[3] = 4.5 * sigma[3];
    shift[2] = 4.5 * sigma[2];
    let mut unit = Unit::new(&cal, RATE, shift, 9.81, 99);
    let pose = face(2, 1.0, 0.2);
    let mut monitor = RestMonitor::new(&cal, RATE as f32).expect("health check");
    let mut each = |imu: &mut spincal::correct::ImuCorrector<'_, u16>,
                    out: &spincal::correct::Corrected<6>| {
        monitor.observe_rest(imu, out);
    };
    unit.rest(&pose, 10.0, &mut each).unwrap();
    let h = monitor.health();
    assert_eq!(h.verdict, Verdict::Drifted, "{h:?}");
    let overlay = *unit.imu.overlay().expect("the overlay is applied");
    for i in 0..6 {
        assert!(
            (overlay.bias[i] - h.bias[i]).abs() <= 2.0 * h.bias_sigma[i],
            "{overlay:?}"
        );
    }
    // After: the corrected gyro x at rest is back near Earth's rate, the accelerometer z near g.
    let mut sum = [0.0f64; 6];
    let mut sigmas = [0.0f32; 6];
    let n = 2000;
    unit.rest(&pose, n as f64 / RATE, &mut |imu, out| {
        for (s, v) in sum.iter_mut().zip(out.values) {
            *s += f64::from(v);
        }
        sigmas = imu.sigma(&out.values).expect("covariance");
    })
    .unwrap();
    let mean = sum.map(|s| s / f64::from(n));
    assert!(
        mean[3].abs() < 3e-4,
        "gyro x after the overlay: {}",
        mean[3]
    );
    assert!(
        (mean[2] - 9.81).abs() < 0.01,
        "accelerometer z after the overlay: {}",
        mean[2]
    );
    assert!(
        f64::from(sigmas[3]) < 0.5 * sigma[3],
        "refined 1-sigma {sigmas:?}"
    );
    // A fresh corrector of the same calibration has no overlay: nothing was written.
    let fresh = spincal::correct::ImuCorrector::<u16>::new(&cal, RATE as f32).expect("imu");
    assert!(fresh.overlay().is_none());
    assert_eq!(cal.data(), &calibration(1e-3).into_data());
}

/// NaN and saturated samples during rest are left out and counted; the verdict is the same.
#[test]
fn nan_and_saturated_samples_at_rest_are_ignored_and_counted() {
    let cal = calibration(1e-3);
    let mut unit = Unit::new(&cal, RATE, [0.0; 6], 9.81, 5);
    let mut monitor = RestMonitor::new(&cal, RATE as f32).expect("health check");
    let mut n = 0u32;
    unit.rest(&face(2, 1.0, 0.0), 5.0, &mut |imu, out| {
        n += 1;
        let mut out = *out;
        match n % 50 {
            7 => out.values[4] = f32::NAN,
            19 => out.flags |= Flags::SATURATED,
            _ => {}
        }
        monitor.observe_rest(imu, &out);
    })
    .unwrap();
    let h = monitor.health();
    assert_eq!(h.ignored_samples, 2 * 5000 / 50);
    assert_eq!(h.verdict, Verdict::Ok, "{h:?}");
    assert!(h.rest_windows >= 70, "{h:?}");
}

/// A unit that never rests (always turning) never judges: NOT-YET, every window moving.
#[test]
fn a_unit_that_never_rests_has_no_verdict() {
    let cal = calibration(1e-3);
    let mut unit = Unit::new(&cal, RATE, [0.0; 6], 9.81, 6);
    let mut monitor = RestMonitor::new(&cal, RATE as f32).expect("health check");
    let poses: Vec<_> = (0..6).map(some_pose).collect();
    for pair in poses.windows(2) {
        unit.turn(&pair[0], &pair[1], &mut |imu, out| {
            monitor.observe_rest(imu, out);
        })
        .unwrap();
    }
    let h = monitor.health();
    assert_eq!(h.verdict, Verdict::NotYet);
    assert_eq!(h.rest_windows, 0);
    assert!(h.moving_windows >= 70, "{h:?}");
    assert!(unit.imu.overlay().is_none());
}

/// Without noise terms or covariance factors the check says why it cannot run, and the unit
/// corrects as before.
#[test]
fn the_check_says_why_it_cannot_run() {
    let mut data = CalibrationData::example_imu();
    data.noise = None;
    let cal = Calibration::new(data).expect("valid");
    let err = RestMonitor::new(&cal, 1000.0).expect_err("no noise terms");
    assert_eq!(err, spincal::Error::HealthNoNoiseTerms);
    assert!(err.to_string().contains("still corrects"), "{err}");
    assert!(spincal::correct::ImuCorrector::<u16>::new(&cal, 1000.0).is_ok());

    let mut data = CalibrationData::example_imu();
    if let spincal::model::Sensor::Imu { covariance, .. } = &mut data.sensor {
        *covariance = None;
    }
    let cal = Calibration::new(data).expect("valid");
    assert_eq!(
        RestMonitor::new(&cal, 1000.0).expect_err("no covariance"),
        spincal::Error::HealthNoCovariance
    );
    let cal = Calibration::new(CalibrationData::example_triad()).expect("valid");
    assert_eq!(
        RestMonitor::new(&cal, 1000.0).expect_err("a triad"),
        spincal::Error::CorrectorWrongSensor
    );
    // Noise terms out of bounds, or on a triad, do not validate.
    let mut data = CalibrationData::example_imu();
    if let Some(n) = &mut data.noise {
        n.white[4] = 0.0;
    }
    let err = Calibration::new(data).expect_err("zero density");
    assert!(
        err.to_string().contains("white-noise density of output wy"),
        "{err}"
    );
    let mut data = CalibrationData::example_triad();
    data.noise = CalibrationData::example_imu().noise;
    assert!(Calibration::new(data).is_err());
}

/// `calflash health` against a unit on its link: the unit takes a rest recording through
/// `ObserveRest` and reports DRIFTED as the host's run of the same check does; the report is
/// recorded in the unit history; a calibration without noise terms gets the reason, and the
/// unit keeps correcting.
#[test]
fn calflash_health_reads_the_unit_over_its_link() {
    use calflash::cmd::flash::{FlashArgs, run as flash};
    use calflash::cmd::health::{HealthArgs, run as health};
    use host_tests::tcp_unit::{self, Fault, TcpUnit};

    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n);
    let example = CalibrationData::example_imu();
    let bytes = host_tests::golden::encode(&example);
    std::fs::write(path("imu.blob"), &bytes).unwrap();
    let cal = Calibration::new(example).unwrap();
    let session = calflash::sim::rest::Session {
        rate: 1000.0,
        shift_sigmas: [0.0, 0.0, 0.0, 4.5, 0.0, 0.0],
        poses: 2,
        hold: 3.0,
        aged_s: 0.0,
        seed: 3,
    };
    let raw = session.record(&cal).unwrap();
    let mut csv = Vec::new();
    calflash::sim::rest::write_csv(&raw, 1000.0, &mut csv).unwrap();
    std::fs::write(path("rest.csv"), csv).unwrap();

    let serial = cal.data().identity.serial.as_str().to_string();
    let unit = TcpUnit::serve(
        tcp_unit::device(tcp_unit::blank_flash(), &serial),
        Fault::None,
    );
    flash(&FlashArgs {
        blob: path("imu.blob"),
        port: unit.address(),
        force: false,
        force_rejected: false,
        timeout: 2.0,
        vectors: 1,
        db: Some(path("units.sqlite").into()),
        no_db: false,
        sign_key: None,
    })
    .unwrap();
    let flashed = unit.finish().into_store().into_inner();
    let args = |port: Option<String>, blob: Option<&str>, json: &str| HealthArgs {
        recording: Some(path("rest.csv")),
        blob: blob.map(path),
        port,
        timeout: 2.0,
        rate: None,
        temp: Some(25.0),
        volt: Some(3.3),
        json: Some(path(json)),
        report: None,
        db: Some(path("units.sqlite").into()),
        no_db: false,
    };
    let on_host = health(&args(None, Some("imu.blob"), "host.json")).unwrap();
    let (before, ops) = (flashed.mem.clone(), flashed.ops);
    let unit = TcpUnit::serve(tcp_unit::device(flashed, &serial), Fault::None);
    let in_unit = health(&args(Some(unit.address()), None, "unit.json")).unwrap();
    let after = unit.finish().into_store().into_inner();
    // The refinement lives in RAM: not a byte of the store was written (a power cut loses it
    // and the factory calibration is as it was).
    assert_eq!(after.ops, ops, "the health session wrote to the flash");
    assert_eq!(after.mem, before);
    assert_eq!(on_host, "DRIFTED");
    assert_eq!(in_unit, on_host);
    let read = |n: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(path(n)).unwrap()).unwrap()
    };
    let (h, u) = (read("host.json"), read("unit.json"));
    // The unit's stream restarts its rate derivative every 16 samples; the refined gyro bias
    // agrees with the host's to a small part of its 1-sigma.
    let bias = |v: &serde_json::Value| v["health"]["bias"][3].as_f64().unwrap();
    let sigma = h["health"]["bias_sigma"][3].as_f64().unwrap();
    assert!((bias(&h) - bias(&u)).abs() < 0.1 * sigma, "{h} {u}");
    let history = calflash::db::Db::open(&path("units.sqlite"))
        .unwrap()
        .history(&serial)
        .unwrap();
    let kinds: Vec<(String, String)> = history.into_iter().map(|e| (e.kind, e.outcome)).collect();
    assert_eq!(
        kinds,
        [
            ("flash".to_string(), "verified".to_string()),
            ("health".to_string(), "drifted".to_string()),
            ("health".to_string(), "drifted".to_string()),
        ]
    );

    // Without noise terms: the unit says why.
    let mut plain = CalibrationData::example_imu();
    plain.noise = None;
    std::fs::write(path("plain.blob"), host_tests::golden::encode(&plain)).unwrap();
    let unit = TcpUnit::serve(
        tcp_unit::device(tcp_unit::blank_flash(), &serial),
        Fault::None,
    );
    flash(&FlashArgs {
        blob: path("plain.blob"),
        port: unit.address(),
        force: false,
        force_rejected: false,
        timeout: 2.0,
        vectors: 1,
        db: None,
        no_db: true,
        sign_key: None,
    })
    .unwrap();
    let flashed = unit.finish().into_store().into_inner();
    let unit = TcpUnit::serve(tcp_unit::device(flashed, &serial), Fault::None);
    let mut a = args(Some(unit.address()), None, "plain.json");
    a.recording = None;
    let err = health(&a).unwrap_err().to_string();
    drop(unit.finish());
    assert!(
        err.contains("its calibration gives the health check nothing to run on")
            && err.contains("no noise terms (calflash calibrate --noise-terms)")
            && !err.contains("HealthUnavailable"),
        "{err}"
    );
}

/// The example device on the Cortex-M4F (QEMU) runs the health check over its link: given a
/// rest recording of a unit whose gyro drifted, it reports DRIFTED with the refined bias the
/// host's run of the same stream finds. Skips without QEMU unless SPINCAL_REQUIRE_QEMU=1.
#[test]
fn the_device_on_qemu_judges_its_calibration_at_rest() {
    use calflash::device::image::{Region, region_image};
    use host_tests::qemu;
    use host_tests::unit::QemuUnit;
    use spincal::correct::AnyImuCorrector;

    if !qemu::available_or_skip("the_device_on_qemu_judges_its_calibration_at_rest") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let example = CalibrationData::example_imu();
    let blob = host_tests::golden::encode(&example);
    let cal = Calibration::new(example).unwrap();
    let session = calflash::sim::rest::Session {
        rate: 1000.0,
        shift_sigmas: [0.0, 0.0, 0.0, 0.0, 4.5, 0.0],
        poses: 1,
        hold: 3.0,
        aged_s: 0.0,
        seed: 11,
    };
    let raw: Vec<[i32; 6]> = session
        .record(&cal)
        .unwrap()
        .iter()
        .map(|r| r.map(i32::from))
        .collect();
    // The host: the same stream in the same blocks (each block's first sample has no rate
    // derivative, as on the unit).
    let mut monitor = RestMonitor::new(&cal, 1000.0).unwrap();
    let (mut overlay, mut suspect) = (None, false);
    for block in raw.chunks(spincal::protocol::MAX_VECTORS) {
        let mut imu = AnyImuCorrector::new(&cal, 1000.0).unwrap();
        imu.set_overlay(overlay);
        imu.set_suspect(suspect);
        imu.set_environment(25.0, 3.3);
        for r in block {
            let out = imu.correct(*r);
            imu.observe_rest(&mut monitor, &out);
        }
        overlay = imu.overlay();
        suspect = monitor.health().verdict == Verdict::Suspect;
    }
    let host = monitor.health();

    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let (flash, log) = (dir.path().join("flash.bin"), dir.path().join("qemu.log"));
    std::fs::write(
        &flash,
        region_image(&blob, Region::from_memory_x()).unwrap(),
    )
    .unwrap();
    let unit = QemuUnit::power_on(&bin.join("device"), Some(&flash), &log).unwrap();
    let mut client = unit.connect(std::time::Duration::from_secs(10)).unwrap();
    for block in raw.chunks(spincal::protocol::MAX_VECTORS) {
        client.observe_rest(25.0, 3.3, block).unwrap();
    }
    let device = client.health().unwrap();
    drop(client);
    drop(unit);
    assert_eq!(host.verdict, Verdict::Drifted, "{host:?}");
    // Same arithmetic, same order: the Cortex-M4F reports the host's health bit for bit.
    assert_eq!(device, host);
}
