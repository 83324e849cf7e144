//! The f32 correction against the independent f64 reference, every code of a 16-bit channel,
//! environment sweeps beyond the tables, the identity fallback, batch against single samples,
//! and the 1-sigma calibration error.
use host_tests::golden::{Kind, Runner};
use host_tests::reference::{self, Value};
use proptest::collection::vec;
use proptest::prelude::*;
use spincal::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector, Flags};
use spincal::model::{Calibration, CalibrationData, Sensor};

/// The stated bound: the f32 output differs from the f64 reference by at most
/// `RELATIVE_BOUND` of the sum of the magnitudes of the terms that make the output (about 85
/// ulp of that sum: single precision rounds by 2^-24 = 6e-8 per operation and the IMU's deepest
/// path has about 30 operations, the table interpolation included) plus `FULL_SCALE_BOUND` of
/// the output's full scale (about 17 ulp of it: the hot path works on codes counted from the
/// edge of its window, not from the center, so its terms can reach full scale).
const RELATIVE_BOUND: f64 = 5e-6;
const FULL_SCALE_BOUND: f64 = 1e-6;

fn examples() -> Vec<(&'static str, CalibrationData, Kind)> {
    let mut v = host_tests::golden::examples();
    v.push((
        "imu_linear",
        CalibrationData::example_imu_linear(),
        Kind::imu(1000.0),
    ));
    v
}

fn rails_and_centers(data: &CalibrationData) -> Vec<(i32, i32, f32)> {
    match &data.sensor {
        Sensor::Single { rails, channel, .. } => vec![(rails.lo, rails.hi, channel.center)],
        Sensor::Triad {
            rails, channels, ..
        } => channels
            .iter()
            .map(|c| (rails.lo, rails.hi, c.center))
            .collect(),
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            ..
        } => accel
            .iter()
            .map(|c| (accel_rails.lo, accel_rails.hi, c.center))
            .chain(
                gyro.iter()
                    .map(|c| (gyro_rails.lo, gyro_rails.hi, c.center)),
            )
            .collect(),
    }
}

fn check_against_reference(
    data: &CalibrationData,
    kind: Kind,
    env: (f32, f32),
    raws: &[Vec<i32>],
) -> Result<(), TestCaseError> {
    let cal = Calibration::new(data.clone()).unwrap();
    let mut runner = Runner::new(&cal, kind);
    runner.set_environment(env.0, env.1);
    let rate = match kind {
        Kind::Imu(r, _) => f64::from(r),
        _ => 0.0,
    };
    let mut prev = None;
    for raw in raws {
        let (got, flags, _) = runner.correct(raw);
        let r = reference::correct(data, f64::from(env.0), f64::from(env.1), raw, rate, prev);
        let want = &r.values;
        for (i, (g, Value { y, mag, full_scale })) in got.iter().zip(want).enumerate() {
            let err = (f64::from(*g) - y).abs();
            let bound = RELATIVE_BOUND * mag + FULL_SCALE_BOUND * full_scale;
            prop_assert!(
                err <= bound,
                "output {i} for {raw:?} at {env:?}: f32 {g}, f64 {y}, error {err:e} > {bound:e}"
            );
        }
        let flags = Flags::from_bits_truncate(flags);
        prop_assert_eq!(
            flags.contains(Flags::SATURATED),
            r.saturated,
            "saturation of {:?}",
            raw
        );
        // The range flag may differ from the reference only within rounding of a boundary.
        if flags.contains(Flags::OUT_OF_RANGE) != r.out_of_range {
            prop_assert!(
                r.range_margin <= RELATIVE_BOUND,
                "range flag of {:?}: margin {:e}",
                raw,
                r.range_margin
            );
        }
        prev = r.lever;
    }
    Ok(())
}

fn raw_strategy(data: &CalibrationData) -> impl Strategy<Value = Vec<i32>> + use<> {
    let axes = rails_and_centers(data);
    axes.into_iter()
        .map(|(lo, hi, c)| {
            let c = c as i32;
            prop_oneof![
                8 => c - 8_000..c + 8_000,
                1 => lo..=hi,
                1 => any::<i32>(),
            ]
        })
        .collect::<Vec<_>>()
}

fn env_strategy(data: &CalibrationData) -> impl Strategy<Value = (f32, f32)> + use<> {
    let e = &data.environment;
    let (t0, t1) = (e.temperature_span.lo, e.temperature_span.hi);
    let (v0, v1) = (e.voltage_span.lo, e.voltage_span.hi);
    (
        prop_oneof![4 => t0 - 20.0..t1 + 20.0, 1 => Just(f32::NAN)],
        prop_oneof![4 => v0 - 1.0..v1 + 1.0, 1 => Just(f32::NAN)],
    )
}

fn case_strategy() -> impl Strategy<Value = (usize, (f32, f32), Vec<Vec<i32>>)> {
    (0..examples().len()).prop_flat_map(|case| {
        let data = examples().swap_remove(case).1;
        (
            Just(case),
            env_strategy(&data),
            vec(raw_strategy(&data), 40),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn f32_correction_agrees_with_f64_reference((case, env, raws) in case_strategy()) {
        let (_, data, kind) = examples().swap_remove(case);
        check_against_reference(&data, kind, env, &raws)?;
    }
}

#[test]
fn every_code_of_a_16_bit_channel_is_finite_and_flagged_exactly() {
    // Single axis: all 65,536 codes.
    let data = CalibrationData::example_single();
    let cal = Calibration::new(data.clone()).unwrap();
    let mut c = AnyAxisCorrector::new(&cal).unwrap();
    c.set_environment(25.0, 5.0);
    let Sensor::Single { channel, .. } = &data.sensor else {
        unreachable!()
    };
    let (mut saturated, mut out_of_range) = (0, 0);
    for code in 0..=65_535 {
        let out = c.correct(code);
        let y = out.values[0];
        assert!(y.is_finite(), "code {code}: {y}");
        assert_eq!(
            out.flags.contains(Flags::SATURATED),
            code == 0 || code == 65_535,
            "code {code}"
        );
        let outside = !(channel.range.lo <= y && y <= channel.range.hi);
        assert_eq!(
            out.flags.contains(Flags::OUT_OF_RANGE),
            outside,
            "code {code}: {y}"
        );
        assert!(
            !out.flags
                .contains(Flags::TEMPERATURE_CLAMPED | Flags::VOLTAGE_CLAMPED)
        );
        saturated += usize::from(out.flags.contains(Flags::SATURATED));
        out_of_range += usize::from(outside);
    }
    assert_eq!(saturated, 2);
    assert!(
        out_of_range > 1_000 && out_of_range < 20_000,
        "{out_of_range}"
    );

    // Each axis of the full IMU: all codes on one axis, the others at their centers.
    let data = CalibrationData::example_imu();
    let cal = Calibration::new(data.clone()).unwrap();
    let mut c = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    c.set_environment(20.0, 3.3);
    let centers: Vec<i32> = rails_and_centers(&data)
        .iter()
        .map(|(_, _, c)| *c as i32)
        .collect();
    for axis in 0..6 {
        for code in 0..=65_535 {
            let mut raw: [i32; 6] = centers.clone().try_into().unwrap();
            raw[axis] = code;
            let out = c.correct(raw);
            assert!(
                out.values.iter().all(|v| v.is_finite()),
                "axis {axis} code {code}"
            );
            assert_eq!(
                out.flags.contains(Flags::SATURATED),
                code == 0 || code == 65_535,
                "axis {axis} code {code}"
            );
        }
    }
}

#[test]
fn temperature_and_voltage_beyond_the_table_are_clamped_and_flagged() {
    let data = CalibrationData::example_single();
    let cal = Calibration::new(data).unwrap();
    let mut c = AnyAxisCorrector::new(&cal).unwrap();
    let raw = 40_000;
    c.set_environment(-40.0, 4.5);
    let edge = c.correct(raw);
    assert!(edge.flags.is_clean(), "{}", edge.flags);
    for t in [-40.5, -60.0, -1e30, f32::NEG_INFINITY] {
        c.set_environment(t, 4.5);
        let out = c.correct(raw);
        assert_eq!(out.values, edge.values, "clamped to the -40 C set at {t}");
        assert_eq!(out.flags, Flags::TEMPERATURE_CLAMPED);
    }
    c.set_environment(-40.0, 4.0);
    assert_eq!(c.correct(raw).values, edge.values);
    assert_eq!(c.correct(raw).flags, Flags::VOLTAGE_CLAMPED);
    c.set_environment(f32::INFINITY, 9.0);
    let hot = c.correct(raw);
    c.set_environment(85.0, 5.5);
    assert_eq!(hot.values, c.correct(raw).values);
    assert_eq!(
        hot.flags,
        Flags::TEMPERATURE_CLAMPED | Flags::VOLTAGE_CLAMPED
    );
    // A sweep across the whole span: flagged exactly outside it, outputs continuous inside.
    let mut last = None;
    for i in -200..=1_450 {
        let t = i as f32 * 0.1;
        c.set_environment(t, 5.0);
        let out = c.correct(raw);
        assert_eq!(
            out.flags.contains(Flags::TEMPERATURE_CLAMPED),
            !(-40.0..=85.0).contains(&t),
            "{t}"
        );
        if let Some(prev) = last {
            let step: f32 = out.values[0] - prev;
            assert!(step.abs() < 0.01, "jump of {step} at {t} C");
        }
        last = Some(out.values[0]);
    }
    // NaN: flagged, the middle of the span used, outputs finite.
    c.set_environment(f32::NAN, f32::NAN);
    let nan = c.correct(raw);
    assert!(nan.values[0].is_finite());
    assert_eq!(
        nan.flags,
        Flags::TEMPERATURE_CLAMPED | Flags::VOLTAGE_CLAMPED
    );
    // A fresh corrector flags until it is told the environment.
    let fresh = AnyAxisCorrector::new(&cal).unwrap();
    assert_eq!(
        fresh.correct(raw).flags,
        Flags::TEMPERATURE_CLAMPED | Flags::VOLTAGE_CLAMPED
    );
}

#[test]
fn identity_fallback_flags_every_sample() {
    let axis = spincal::correct::AxisCorrector::<i32>::identity();
    let triad = spincal::correct::TriadCorrector::<i32>::identity();
    let mut imu = AnyImuCorrector::identity();
    imu.set_environment(25.0, 3.3);
    for raw in [0, 1, 32_768, 65_535, -5, i32::MAX] {
        let a = axis.correct(raw);
        assert_eq!((a.values[0], a.flags), (raw as f32, Flags::NO_CALIBRATION));
        let t = triad.correct([raw; 3]);
        assert_eq!(t.flags, Flags::NO_CALIBRATION);
        let i = imu.correct([raw; 6]);
        assert_eq!(
            (i.values, i.flags),
            ([raw as f32; 6], Flags::NO_CALIBRATION)
        );
    }
    assert_eq!(imu.sigma(&[0.0; 6]), None);
}

#[test]
fn wrong_sensor_kind_and_bad_rate_are_refused() {
    let triad = Calibration::new(CalibrationData::example_triad()).unwrap();
    assert_eq!(
        AnyAxisCorrector::new(&triad).err(),
        Some(spincal::Error::CorrectorWrongSensor)
    );
    assert_eq!(
        AnyImuCorrector::new(&triad, 100.0).err(),
        Some(spincal::Error::CorrectorWrongSensor)
    );
    let imu = Calibration::new(CalibrationData::example_imu()).unwrap();
    assert_eq!(
        AnyTriadCorrector::new(&imu).err(),
        Some(spincal::Error::CorrectorWrongSensor)
    );
    for rate in [0.0, -1.0, f32::NAN, f32::INFINITY, 2.0e5] {
        assert_eq!(
            AnyImuCorrector::new(&imu, rate).err(),
            Some(spincal::Error::CorrectorBadSampleRate)
        );
    }
}

#[test]
fn a_lever_feedback_without_bound_is_refused_at_the_gate() {
    // The g-sensitivity feeds the previous lever term back into the rate. With a physical
    // unit the loop gain is tiny; with a g-sensitivity of 1 rad/s per m/s^2 and metre-long
    // arms it grows without bound, and validation refuses it: every validated calibration
    // makes a corrector at every legal rate.
    let mut data = CalibrationData::example_imu();
    if let Sensor::Imu {
        sets, lever_arm, ..
    } = &mut data.sensor
    {
        *lever_arm = Some([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        for s in sets.as_mut_slice() {
            s.g_sensitivity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        }
    }
    assert!(matches!(
        Calibration::new(data),
        Err(spincal::Error::InvalidUnboundedOutput {
            part: spincal::Part::Gyro,
            ..
        })
    ));
    let imu = Calibration::new(CalibrationData::example_imu()).unwrap();
    assert_eq!(
        imu.max_sample_rate_hz(),
        spincal::correct::MAX_SAMPLE_RATE_HZ
    );
    for rate in [1.0, 1000.0, spincal::correct::MAX_SAMPLE_RATE_HZ] {
        assert!(AnyImuCorrector::new(&imu, rate).is_ok(), "{rate} Hz");
    }
}

/// The lever term's tangential part takes the rate difference times the sample rate, so the
/// g-sensitivity's feedback of it grows with the rate: an independent unit with g-sensitivity
/// rows of 6.6e-4 rad/s per m/s^2 and 4 mm arms reached a loop gain of one at 100 kHz and was
/// refused outright, though bounded at any rate it runs at. The calibration is valid; a
/// corrector above the highest rate it is bounded at is refused, naming that rate.
#[test]
fn a_lever_feedback_bounded_only_below_a_rate_is_refused_above_it() {
    let mut data = CalibrationData::example_imu();
    if let Sensor::Imu {
        sets, lever_arm, ..
    } = &mut data.sensor
    {
        *lever_arm = Some([
            [0.004, -0.003, 0.004],
            [0.003, -0.004, 0.004],
            [-0.004, -0.004, 0.003],
        ]);
        for s in sets.as_mut_slice() {
            s.g_sensitivity = [
                [1.5e-3, 1e-3, -1e-3],
                [-1e-3, 1e-3, 1e-3],
                [-1e-3, 1e-3, 1e-3],
            ];
        }
    }
    let cal = Calibration::new(data).expect("bounded at the rates a unit runs at");
    let top = cal.max_sample_rate_hz();
    assert!(
        (1000.0..spincal::correct::MAX_SAMPLE_RATE_HZ).contains(&top),
        "{top}"
    );
    assert!(AnyImuCorrector::new(&cal, 1000.0).is_ok());
    assert!(AnyImuCorrector::new(&cal, 0.98 * top).is_ok(), "{top}");
    match AnyImuCorrector::new(&cal, 1.02 * top).err() {
        Some(e @ spincal::Error::CorrectorUnboundedFeedback { max_rate_hz, .. }) => {
            assert_eq!(max_rate_hz, top as u32);
            assert!(
                e.to_string().contains(&format!("up to {max_rate_hz} Hz")),
                "{e}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn batch_equals_sample_by_sample() {
    let data = CalibrationData::example_imu();
    let cal = Calibration::new(data).unwrap();
    let mut one = AnyImuCorrector::new(&cal, 800.0).unwrap();
    let mut many = one.clone();
    one.set_environment(12.0, 3.2);
    many.set_environment(12.0, 3.2);
    let raw: Vec<[i32; 6]> = (0..500)
        .map(|i| std::array::from_fn(|a| 30_000 + ((i * 7919 + a * 104_729) % 6_000) as i32))
        .collect();
    let mut out = vec![Default::default(); 500];
    assert_eq!(many.correct_batch(&raw, &mut out), 500);
    for (r, o) in raw.iter().zip(&out) {
        assert_eq!(one.correct(*r), *o);
    }
    // A shorter output buffer corrects only what fits.
    assert_eq!(many.correct_batch(&raw, &mut out[..10]), 10);
}

#[test]
fn lever_arm_first_sample_is_flagged_and_reset_flags_again() {
    let cal = Calibration::new(CalibrationData::example_imu()).unwrap();
    let mut c = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    c.set_environment(25.0, 3.3);
    let raw = [33_109, 33_329, 36_427, 34_000, 32_430, 32_517];
    assert_eq!(c.correct(raw).flags, Flags::RATE_DERIVATIVE_UNKNOWN);
    assert!(c.correct(raw).flags.is_clean());
    c.reset();
    assert_eq!(c.correct(raw).flags, Flags::RATE_DERIVATIVE_UNKNOWN);
    assert!(c.correct(raw).flags.is_clean());
    // Linear IMUs have no lever arm and never need priming.
    let lin = Calibration::new(CalibrationData::example_imu_linear()).unwrap();
    let mut c = AnyImuCorrector::new(&lin, 1000.0).unwrap();
    c.set_environment(25.0, 3.3);
    assert!(c.correct(raw).flags.is_clean());
}

#[test]
fn a_rate_step_beyond_the_airframe_is_flagged_only_with_a_lever_arm() {
    let cal = Calibration::new(CalibrationData::example_imu()).unwrap();
    let mut c = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    c.set_environment(25.0, 3.3);
    let still = [33_109, 33_329, 36_427, 34_000, 32_430, 32_517];
    let mut turned = still;
    turned[3] += 3_000;
    assert_eq!(c.correct(still).flags, Flags::RATE_DERIVATIVE_UNKNOWN);
    // The default (5e5 rad/s^2, 500 rad/s between samples at 1 kHz) is far beyond a step
    // inside this gyro's +-35 rad/s.
    assert!(c.correct(turned).flags.is_clean());
    assert!(c.correct(still).flags.is_clean());
    // An airframe that turns at most 1,000 rad/s^2: 1 rad/s between samples.
    c.set_max_angular_acceleration(1_000.0).unwrap();
    assert_eq!(c.correct(turned).flags, Flags::RATE_STEP);
    assert!(c.correct(turned).flags.is_clean(), "no step: the same rate");
    assert_eq!(c.correct(still).flags, Flags::RATE_STEP, "and back");
    // Refused values leave the setting as it was.
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            c.set_max_angular_acceleration(bad),
            Err(spincal::Error::CorrectorBadAngularAcceleration)
        );
    }
    assert_eq!(c.correct(turned).flags, Flags::RATE_STEP);
    // Without a lever arm no rate difference enters the correction: nothing to flag.
    let lin = Calibration::new(CalibrationData::example_imu_linear()).unwrap();
    let mut c = AnyImuCorrector::new(&lin, 1000.0).unwrap();
    c.set_environment(25.0, 3.3);
    c.set_max_angular_acceleration(1_000.0).unwrap();
    assert!(c.correct(still).flags.is_clean());
    assert!(c.correct(turned).flags.is_clean());
}

#[test]
fn lever_arm_removes_what_each_axis_senses_of_a_steady_spin() {
    // Spin about z at a steady rate: accelerometer axis i at r_i senses, along its own
    // direction n_i, w x (w x r_i) on top of the specific force at the reference point; the
    // corrected output must not, and the gyro's g-sensitivity must see the reference force.
    let data = CalibrationData::example_imu();
    let cal = Calibration::new(data.clone()).unwrap();
    let mut with = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    let mut without_data = data.clone();
    if let Sensor::Imu { lever_arm, .. } = &mut without_data.sensor {
        *lever_arm = None;
    }
    let without_cal = Calibration::new(without_data).unwrap();
    let mut without = AnyImuCorrector::new(&without_cal, 1000.0).unwrap();
    with.set_environment(30.0, 3.3); // a breakpoint: set 4 as stored
    without.set_environment(30.0, 3.3);
    let raw = [33_109, 33_329, 36_427, 32_786, 32_430, 32_517 + 20_000];
    let _ = with.correct(raw);
    let a = with.correct(raw);
    let b = without.correct(raw);
    let Sensor::Imu {
        lever_arm: Some(r),
        sets,
        ..
    } = &data.sensor
    else {
        unreachable!()
    };
    let set = &sets[4];
    let m = nalgebra::Matrix3::from_fn(|i, j| f64::from(set.accel.matrix[i][j]));
    let minv = m.try_inverse().unwrap();
    let n = nalgebra::Matrix3::from_fn(|i, j| minv[(i, j)] / minv[(i, i)]);
    let w: [f64; 3] = [a.values[3], a.values[4], a.values[5]].map(f64::from);
    let sensed = nalgebra::Vector3::from_fn(|i, _| {
        let c = spincal::model::rotation::force_at(&[0.0; 3], &w, &[0.0; 3], &r[i].map(f64::from));
        n.row(i).transpose().dot(&nalgebra::Vector3::from(c))
    });
    let e = n.try_inverse().unwrap() * sensed;
    for i in 0..3 {
        let got = f64::from(b.values[i]) - f64::from(a.values[i]);
        assert!(
            (got - e[i]).abs() < 1e-4 * (1.0 + e[i].abs()),
            "axis {i}: {got} vs {}",
            e[i]
        );
        // The rates differ by the g-sensitivity of the lever term: w = ws - G (a_s - e).
        let ge: f64 = (0..3)
            .map(|j| f64::from(set.g_sensitivity[i][j]) * e[j])
            .sum();
        let got = f64::from(a.values[i + 3]) - f64::from(b.values[i + 3]);
        assert!(
            (got - ge).abs() < 1e-5 * (1.0 + w[i].abs()),
            "rate {i}: {got} vs {ge}"
        );
    }
    assert!(w.iter().map(|x| x * x).sum::<f64>() > 400.0);
    // With misalignment the off-axis components matter: the own-component-only term is off.
    let own: f64 = (0..3)
        .map(|i| {
            let c =
                spincal::model::rotation::force_at(&[0.0; 3], &w, &[0.0; 3], &r[i].map(f64::from));
            (c[i] - e[i]).abs()
        })
        .fold(0.0, f64::max);
    assert!(own > 1e-3, "the example's misalignment must matter: {own}");
}

#[test]
fn sigma_is_the_quadratic_form_of_the_covariance_over_each_outputs_features() {
    let data = CalibrationData::example_imu();
    let cal = Calibration::new(data.clone()).unwrap();
    let mut c = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    c.set_environment(30.0, 3.3); // a breakpoint: the set is used as stored
    let Sensor::Imu {
        sets,
        lever_arm: Some(r),
        covariance: Some(cov),
        ..
    } = &data.sensor
    else {
        unreachable!()
    };
    let set = &sets[4];
    // A spinning sample (about 28 rad/s about z, the gyro's range).
    let raw = [34_000, 31_000, 36_000, 32_786, 32_430, 32_517 + 25_000];
    let _ = c.correct(raw);
    let out = c.correct(raw);
    let sigma = c.sigma(&out.values).unwrap();
    let v = out.values.map(f64::from);
    let (f, w) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
    assert!(w[2] > 20.0, "{w:?}");
    // Sensitive directions: rows of M^-1 over their diagonal.
    let dirs = |m: &[[f32; 3]; 3]| {
        let inv = nalgebra::Matrix3::from_fn(|i, j| f64::from(m[i][j]))
            .try_inverse()
            .unwrap();
        std::array::from_fn::<[f64; 3], 3, _>(|i| {
            std::array::from_fn(|j| inv[(i, j)] / inv[(i, i)])
        })
    };
    let (na, ng) = (dirs(&set.accel.matrix), dirs(&set.gyro.matrix));
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let quad = |packed: &[f32], phi: &[f64; 11]| -> f64 {
        // |L' phi| for packed row-major lower-triangular L.
        let l = |r: usize, k: usize| f64::from(packed[r * (r + 1) / 2 + k]);
        (0..11)
            .map(|k| (k..11).map(|r| l(r, k) * phi[r]).sum::<f64>().powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let gf: [f64; 3] = std::array::from_fn(|i| {
        (0..3)
            .map(|j| f64::from(set.g_sensitivity[i][j]) * f[j])
            .sum()
    });
    for i in 0..3 {
        let ri = r[i].map(f64::from);
        let at = spincal::model::rotation::force_at(&f, &w, &[0.0; 3], &ri);
        let g = spincal::model::rotation::lever_gradient(&na[i], &w, &[0.0; 3]);
        let x = dot(&na[i], &at);
        let phi = [
            1.0,
            at[0],
            at[1],
            at[2],
            g[0],
            g[1],
            g[2],
            x * x,
            x.abs(),
            x * x * x,
            x * x.abs(),
        ];
        let want = quad(cov[4].accel[i].as_flattened(), &phi);
        assert!(
            (f64::from(sigma[i]) - want).abs() < 1e-4 * want,
            "accel {i}: {} vs {want}",
            sigma[i]
        );
        let xg = dot(&ng[i], &[w[0] + gf[0], w[1] + gf[1], w[2] + gf[2]]);
        let phi = [
            1.0,
            w[0],
            w[1],
            w[2],
            f[0],
            f[1],
            f[2],
            xg * xg,
            xg.abs(),
            xg * xg * xg,
            xg * xg.abs(),
        ];
        let want = quad(cov[4].gyro[i].as_flattened(), &phi);
        assert!(
            (f64::from(sigma[i + 3]) - want).abs() < 1e-4 * want,
            "gyro {i}: {} vs {want}",
            sigma[i + 3]
        );
    }
    let no_cov = Calibration::new(CalibrationData::example_imu_linear()).unwrap();
    assert_eq!(
        AnyImuCorrector::new(&no_cov, 1000.0)
            .unwrap()
            .sigma(&out.values),
        None
    );
}

#[test]
fn an_imu_series_sigma_is_its_covariance_factors_summed_with_the_reference_weights() {
    // The device sums the series of covariance factors in place; the reference weights
    // (`cos(k acos x)`) give the same factors, which a table of one set holds as stored.
    let data = CalibrationData::example_imu_series();
    let cal = Calibration::new(data.clone()).unwrap();
    let mut series = AnyImuCorrector::new(&cal, 1000.0).unwrap();
    let Sensor::Imu {
        sets,
        covariance: Some(cov),
        ..
    } = &data.sensor
    else {
        unreachable!()
    };
    let raw = [34_000, 31_000, 36_000, 32_786, 32_430, 32_517 + 9_000];
    for t in [-40.0f32, -12.5, 3.0, 31.7, 66.0, 85.0, 100.0] {
        let w = reference::weights(&data.environment, f64::from(t), 3.3);
        let mut one_set = sets[0];
        let mut one_cov = cov[0];
        let floats = |c: &spincal::model::ImuCovariance| -> Vec<f32> {
            c.accel
                .iter()
                .chain(&c.gyro)
                .flat_map(|f| f.as_flattened().iter().copied())
                .collect()
        };
        let summed: Vec<f32> = (0..floats(&cov[0]).len())
            .map(|k| {
                w.iter()
                    .map(|(i, wi)| wi * f64::from(floats(&cov[*i])[k]))
                    .sum::<f64>() as f32
            })
            .collect();
        for (o, v) in one_cov
            .accel
            .iter_mut()
            .chain(one_cov.gyro.iter_mut())
            .flat_map(|f| f.as_flattened_mut().iter_mut())
            .zip(summed)
        {
            *o = v;
        }
        let blend = |f: &dyn Fn(&spincal::model::ImuSet) -> Vec<f32>| -> Vec<f32> {
            (0..f(&sets[0]).len())
                .map(|k| {
                    w.iter()
                        .map(|(i, wi)| wi * f64::from(f(&sets[*i])[k]))
                        .sum::<f64>() as f32
                })
                .collect()
        };
        let flat = |s: &spincal::model::ImuSet| -> Vec<f32> {
            let mut v = Vec::new();
            for t in [&s.accel, &s.gyro] {
                for a in &t.axes {
                    v.extend([
                        a.quadratic,
                        a.cubic,
                        a.odd_quadratic,
                        a.asymmetry,
                        a.asymmetry_break,
                    ]);
                }
                v.extend(t.matrix.as_flattened());
                v.extend(t.offset);
            }
            v.extend(s.g_sensitivity.as_flattened());
            v
        };
        let b = blend(&flat);
        let mut it = b.into_iter();
        for t in [&mut one_set.accel, &mut one_set.gyro] {
            for a in &mut t.axes {
                for x in [
                    &mut a.quadratic,
                    &mut a.cubic,
                    &mut a.odd_quadratic,
                    &mut a.asymmetry,
                    &mut a.asymmetry_break,
                ] {
                    *x = it.next().unwrap();
                }
            }
            for x in t
                .matrix
                .as_flattened_mut()
                .iter_mut()
                .chain(t.offset.iter_mut())
            {
                *x = it.next().unwrap();
            }
        }
        for x in one_set.g_sensitivity.as_flattened_mut() {
            *x = it.next().unwrap();
        }
        let mut table = data.clone();
        table.environment.temperature_model = spincal::model::TemperatureModel::Table;
        if let Sensor::Imu {
            sets, covariance, ..
        } = &mut table.sensor
        {
            *sets = spincal::model::BoundedVec::from_slice(&[one_set]).unwrap();
            *covariance = Some(spincal::model::BoundedVec::from_slice(&[one_cov]).unwrap());
        }
        let table = Calibration::new(table).unwrap();
        let mut one = AnyImuCorrector::new(&table, 1000.0).unwrap();
        series.set_environment(t, 3.3);
        one.set_environment(t, 3.3);
        let (a, b) = (series.correct(raw), one.correct(raw));
        let (sa, sb) = (
            series.sigma(&a.values).unwrap(),
            one.sigma(&a.values).unwrap(),
        );
        for i in 0..6 {
            let close = |x: f32, y: f32| (x - y).abs() <= 1e-4 * x.abs().max(y.abs()) + 1e-9;
            assert!(
                close(a.values[i], b.values[i]),
                "{t} C output {i}: {a:?} vs {b:?}"
            );
            assert!(close(sa[i], sb[i]), "{t} C sigma {i}: {sa:?} vs {sb:?}");
        }
        assert_eq!(
            a.flags.is_clean(),
            (-40.0..=85.0).contains(&t),
            "{t}: {}",
            a.flags
        );
    }
}

/// The device takes samples in the container the part delivers them in; a calibration states
/// which, and a corrector of another refuses it when it is built. The same motion read as
/// `u16`, `i16` and `i32` codes is corrected alike.
#[test]
fn each_sample_format_is_taken_as_the_part_delivers_it() {
    use host_tests::golden::in_format;
    use spincal::Error;
    use spincal::correct::ImuCorrector;
    use spincal::model::SampleFormat::{I16, I32, U16};
    let data = CalibrationData::example_imu_polynomial();
    let u = Calibration::new(data.clone()).unwrap();
    let s = Calibration::new(in_format(data.clone(), I16)).unwrap();
    let w = Calibration::new(in_format(data, I32)).unwrap();
    for (cal, format) in [(&u, U16), (&s, I16), (&w, I32)] {
        assert_eq!(cal.data().sensor.sample_format(), format);
    }
    let refused = |expected, found| Some(Error::CorrectorWrongFormat { expected, found });
    assert_eq!(ImuCorrector::<i16>::new(&u, 1e3).err(), refused(U16, I16));
    assert_eq!(ImuCorrector::<i32>::new(&u, 1e3).err(), refused(U16, I32));
    assert_eq!(ImuCorrector::<u16>::new(&s, 1e3).err(), refused(I16, U16));
    assert_eq!(ImuCorrector::<i16>::new(&w, 1e3).err(), refused(I32, I16));
    assert_eq!(
        spincal::correct::TriadCorrector::<i32>::new(
            &Calibration::new(CalibrationData::example_triad()).unwrap()
        )
        .err(),
        refused(U16, I32)
    );

    let mut cu = ImuCorrector::<u16>::new(&u, 1e3).unwrap();
    let mut cs = ImuCorrector::<i16>::new(&s, 1e3).unwrap();
    let mut cw = ImuCorrector::<i32>::new(&w, 1e3).unwrap();
    cu.set_environment(22.5, 3.3);
    cs.set_environment(22.5, 3.3);
    cw.set_environment(22.5, 3.3);
    let Sensor::Imu { accel, gyro, .. } = &u.data().sensor else {
        unreachable!()
    };
    let centers: Vec<f32> = accel.iter().chain(gyro).map(|c| c.center).collect();
    let mut batch_s = Vec::new();
    let mut outs = Vec::new();
    for k in 0..400u32 {
        let raw: [u16; 6] = std::array::from_fn(|a| {
            let wiggle = ((k * 7919 + a as u32 * 104_729) % 6_000) as f32 - 3_000.0;
            (centers[a] + wiggle).round() as u16
        });
        let signed = raw.map(|x| (i32::from(x) - 32_768) as i16);
        let (a, b, c) = (
            cu.correct(raw),
            cs.correct(signed),
            cw.correct(signed.map(i32::from)),
        );
        assert_eq!((a.flags, b.flags, c.flags), (a.flags, a.flags, a.flags));
        for ((x, y), z) in a.values.iter().zip(&b.values).zip(&c.values) {
            let tol = 1e-5 * x.abs().max(1.0);
            assert!(
                (x - y).abs() <= tol && (x - z).abs() <= tol,
                "{k}: {x} {y} {z}"
            );
        }
        batch_s.push(signed);
        outs.push(b);
    }
    // The batch path of the i16 corrector gives the bits of its one-at-a-time path.
    let mut cs = ImuCorrector::<i16>::new(&s, 1e3).unwrap();
    cs.set_environment(22.5, 3.3);
    let mut got = vec![spincal::correct::Corrected::<6>::default(); batch_s.len()];
    assert_eq!(cs.correct_batch(&batch_s, &mut got), batch_s.len());
    assert_eq!(got, outs);
    // Each format saturates at its own rails: the top code of 16 bits is a rail for `u16` and
    // `i16`, an ordinary code of the 18-bit converter delivered as `i32`.
    let top_u = cu.correct([u16::MAX; 6]).flags;
    let top_s = cs.correct([i16::MAX; 6]).flags;
    let top_w = cw.correct([i32::from(i16::MAX); 6]).flags;
    assert!(top_u.contains(Flags::SATURATED) && top_s.contains(Flags::SATURATED));
    assert!(!top_w.contains(Flags::SATURATED));
}
