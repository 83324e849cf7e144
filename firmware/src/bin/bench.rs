//! Instruction counts of the correction on the Cortex-M4F. Run under QEMU with
//! `-icount shift=10` (`cargo xtask bench` does): every instruction then advances the CMSDK
//! timer by exactly 25.6 ticks, so the counts are exact and repeat from run to run.
//!
//! Prints one line per benchmark: `bench <name> <instructions per operation> <operations>`,
//! and `size <name> <bytes>` for the RAM the device keeps.
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::blob;
use spincal::correct::{AxisCorrector, Corrected, ImuCorrector, Sample};
use spincal::model::{Calibration, CalibrationData, Sensor};
use spincal_firmware::{stack, timer};

const N: usize = 256;

static IMU_BLOB: &[u8] = include_bytes!("../../../host-tests/golden/imu.blob");

/// The linear and the full (polynomial) example for samples delivered as `i16` and as `i32`
/// (the golden cases of those formats: the unsigned examples moved to two's complement).
static FORMAT_BLOBS: [([&str; 2], &[u8]); 4] = [
    (
        ["imu_linear_i16_batch", "imu_linear_i16_call"],
        include_bytes!("../../../host-tests/golden/imu_linear_i16.blob"),
    ),
    (
        ["imu_linear_i32_batch", "imu_linear_i32_call"],
        include_bytes!("../../../host-tests/golden/imu_linear_i32.blob"),
    ),
    (
        ["imu_full_i16_batch", "imu_full_i16_call"],
        include_bytes!("../../../host-tests/golden/imu_polynomial_i16.blob"),
    ),
    (
        ["imu_full_i32_batch", "imu_full_i32_call"],
        include_bytes!("../../../host-tests/golden/imu_polynomial_i32.blob"),
    ),
];

/// Raw unsigned 16-bit samples around the zero-input codes (well inside the calibrated range),
/// or all at the rails when `saturated`.
fn samples(saturated: bool) -> [[u16; 6]; N] {
    let mut state: u32 = 0x1234_5678;
    core::array::from_fn(|i| {
        core::array::from_fn(|a| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            if saturated {
                if (i + a) % 2 == 0 { 0 } else { 65_535 }
            } else {
                let center = [33_109, 33_329, 36_427, 32_786, 32_430, 32_517][a];
                center + ((state >> 16) as u16 % 4_000) - 2_000
            }
        })
    })
}

/// The same samples in two's complement (`u - 32768`).
fn signed<S: Sample>(raw: &[[u16; 6]; N], convert: impl Fn(i32) -> S) -> [[S; 6]; N] {
    core::array::from_fn(|i| core::array::from_fn(|a| convert(i32::from(raw[i][a]) - 32_768)))
}

fn instructions_per(ticks: u32, ops: usize) -> (u64, u64) {
    let total = timer::instructions(ticks);
    let ops = ops as u64;
    // Tenths of an instruction.
    ((total * 10 + ops / 2) / ops, total)
}

fn report(name: &str, ticks: u32, ops: usize) {
    let (tenths, total) = instructions_per(ticks, ops);
    hprintln!(
        "bench {} {}.{} {} {}",
        name,
        tenths / 10,
        tenths % 10,
        ops,
        total
    );
}

#[inline(never)]
fn batch<S: Sample>(
    c: &mut ImuCorrector<'_, S>,
    raw: &[[S; 6]],
    out: &mut [Corrected<6>],
) -> usize {
    c.correct_batch(raw, out)
}

#[inline(never)]
fn one<S: Sample>(c: &mut ImuCorrector<'_, S>, raw: [S; 6]) -> Corrected<6> {
    c.correct(raw)
}

fn bench_batch<S: Sample>(name: &str, c: &mut ImuCorrector<'_, S>, raw: &[[S; 6]; N]) {
    let mut out = [Corrected::<6>::default(); N];
    // Warm up (the first lever-arm sample primes the rate derivative).
    batch(c, black_box(raw), &mut out);
    let t0 = timer::now();
    let n = batch(c, black_box(raw), &mut out);
    let t1 = timer::now();
    black_box(&out);
    report(name, t0.wrapping_sub(t1), n);
}

fn bench_one<S: Sample>(name: &str, c: &mut ImuCorrector<'_, S>, raw: &[[S; 6]; N]) {
    let mut out = [Corrected::<6>::default(); N];
    let t0 = timer::now();
    for (r, o) in raw.iter().zip(out.iter_mut()) {
        *o = one(c, black_box(*r));
    }
    let t1 = timer::now();
    black_box(&out);
    report(name, t0.wrapping_sub(t1), N);
}

#[entry]
fn main() -> ! {
    timer::start();
    let Ok(linear) = Calibration::new(CalibrationData::example_imu_linear()) else {
        fail("linear example invalid")
    };
    let Ok(full) = Calibration::new(CalibrationData::example_imu()) else {
        fail("full example invalid")
    };
    // The "full model": polynomial, misalignment, g-sensitivity, lever arm (the
    // example without its asymmetry terms).
    let Ok(poly) = Calibration::new(CalibrationData::example_imu_polynomial()) else {
        fail("polynomial example invalid")
    };
    let inside = samples(false);
    let railed = samples(true);

    let Ok(mut c) = ImuCorrector::new(&linear, 1000.0) else {
        fail("linear corrector")
    };
    c.set_environment(25.0, 3.3);
    bench_batch("imu_linear_batch", &mut c, &inside);
    bench_one("imu_linear_call", &mut c, &inside);
    bench_batch("imu_linear_batch_saturated", &mut c, &railed);

    let Ok(mut c) = ImuCorrector::new(&poly, 1000.0) else {
        fail("polynomial corrector")
    };
    c.set_environment(22.5, 3.3);
    bench_batch("imu_full_batch", &mut c, &inside);
    bench_one("imu_full_call", &mut c, &inside);
    bench_batch("imu_full_batch_saturated", &mut c, &railed);
    let mut block_out = [Corrected::<6>::default(); 16];
    let (_, batch_stack) = stack::high_water(|| {
        batch(
            &mut c,
            black_box(inside.get(..16).unwrap_or_default()),
            &mut block_out,
        )
    });
    black_box(&block_out);

    // The same without the lever arm (the accelerometer at the reference point).
    let mut no_lever = CalibrationData::example_imu_polynomial();
    if let Sensor::Imu { lever_arm, .. } = &mut no_lever.sensor {
        *lever_arm = None;
    }
    let Ok(no_lever) = Calibration::new(no_lever) else {
        fail("no-lever example invalid")
    };
    let Ok(mut c) = ImuCorrector::new(&no_lever, 1000.0) else {
        fail("no-lever corrector")
    };
    c.set_environment(22.5, 3.3);
    bench_batch("imu_poly_no_lever_batch", &mut c, &inside);
    bench_one("imu_poly_no_lever_call", &mut c, &inside);

    let Ok(mut c) = ImuCorrector::new(&full, 1000.0) else {
        fail("full corrector")
    };
    c.set_environment(22.5, 3.3);
    bench_batch("imu_full_asym_batch", &mut c, &inside);
    bench_one("imu_full_asym_call", &mut c, &inside);

    // The six 1-sigmas of a corrected sample: the blob's covariance factors (66 values an
    // output) over the output's 11 error features (`ImuCorrector::sigma`).
    let mut corrected = [Corrected::<6>::default(); N];
    batch(&mut c, &inside, &mut corrected);
    let mut stated = [[0.0f32; 6]; N];
    let t0 = timer::now();
    for (o, s) in corrected.iter().zip(stated.iter_mut()) {
        if let Some(x) = c.sigma(black_box(&o.values)) {
            *s = x;
        }
    }
    let t1 = timer::now();
    black_box(&stated);
    report("imu_sigma", t0.wrapping_sub(t1), N);
    let probe = corrected.first().map_or([0.0; 6], |o| o.values);
    let (_, sigma_stack) = stack::high_water(|| black_box(c.sigma(black_box(&probe))));

    // set_environment over the 8-point temperature table, at points spread over the table.
    let temps = [-37.0f32, -12.5, 3.0, 16.0, 29.9, 44.0, 61.0, 84.0];
    let t0 = timer::now();
    for t in temps {
        c.set_environment(black_box(t), black_box(3.3));
    }
    let t1 = timer::now();
    black_box(&c);
    report("set_environment_8pt", t0.wrapping_sub(t1), temps.len());

    // An IMU's temperature dependence as a 5-term Chebyshev series (no lever arm), over the
    // same temperatures.
    let Ok(series) = Calibration::new(CalibrationData::example_imu_series()) else {
        fail("IMU series example invalid")
    };
    let Ok(mut s) = ImuCorrector::<u16>::new(&series, 1000.0) else {
        fail("IMU series corrector")
    };
    let t0 = timer::now();
    for t in temps {
        s.set_environment(black_box(t), black_box(3.3));
    }
    let t1 = timer::now();
    black_box(&s);
    report(
        "set_environment_imu_series5",
        t0.wrapping_sub(t1),
        temps.len(),
    );
    let (_, series_env_stack) = stack::high_water(|| s.set_environment(black_box(41.0), 3.3));

    // A single axis' temperature dependence as a 3-point table and as a 6-term Chebyshev
    // series, each at 2 supply voltages, over the same temperatures.
    for (name, data) in [
        (
            "set_environment_single_table3",
            CalibrationData::example_single(),
        ),
        (
            "set_environment_single_series6",
            CalibrationData::example_single_series(),
        ),
    ] {
        let Ok(cal) = Calibration::new(data) else {
            fail(name)
        };
        let Ok(mut a) = AxisCorrector::<u16>::new(&cal) else {
            fail(name)
        };
        let t0 = timer::now();
        for t in temps {
            a.set_environment(black_box(t), black_box(5.0));
        }
        let t1 = timer::now();
        black_box(&a);
        report(name, t0.wrapping_sub(t1), temps.len());
    }

    // Decode + validate the full IMU blob into a slot, as the device does at boot.
    let mut slot = CalibrationData::empty();
    let t0 = timer::now();
    let decoded = blob::decode_in(black_box(IMU_BLOB), &mut slot).is_ok();
    let t1 = timer::now();
    if !decoded || slot != *full.data() {
        fail("golden IMU blob does not decode to the example");
    }
    report("decode_validate_imu_blob", t0.wrapping_sub(t1), 1);
    let (_, decode_stack) =
        stack::high_water(|| black_box(blob::decode_in(black_box(IMU_BLOB), &mut slot)).is_ok());

    let mut one_out = Corrected::<6>::default();
    let (_, correct_stack) = stack::high_water(|| {
        one_out = one(&mut c, black_box(inside[3]));
    });
    let (_, env_stack) = stack::high_water(|| c.set_environment(black_box(41.0), 3.3));
    black_box(&one_out);
    // The linear and the full kernel for samples delivered as `i16` and `i32`.
    let inside_i16 = signed(&inside, |x| x as i16);
    let inside_i32 = signed(&inside, |x| x);
    for (names, bytes) in FORMAT_BLOBS {
        let Ok(cal) = blob::decode(bytes) else {
            fail(names[0])
        };
        let env = if names[0].starts_with("imu_linear") {
            25.0
        } else {
            22.5
        };
        if names[0].contains("i16") {
            bench_format(names, &cal, env, &inside_i16);
        } else {
            bench_format(names, &cal, env, &inside_i32);
        }
    }
    // A fresh corrector's first sample takes the slow path (it primes the lever-arm state).
    let Ok(mut fresh) = ImuCorrector::<u16>::new(&full, 1000.0) else {
        fail("full corrector")
    };
    fresh.set_environment(22.5, 3.3);
    let (_, first_stack) = stack::high_water(|| {
        one_out = one(&mut fresh, black_box(inside[3]));
    });
    black_box(&one_out);
    let health_stack = bench_health();
    let signed_stack = bench_signed();
    let [commit_stack, boot_stack] = bench_signed_store();
    hprintln!("stack correct {}", correct_stack);
    hprintln!("stack sigma {}", sigma_stack);
    hprintln!("stack store_commit_signed {}", commit_stack);
    hprintln!("stack store_boot_signed {}", boot_stack);
    hprintln!("stack health_observe_rest {}", health_stack);
    hprintln!("stack signed_verify {}", signed_stack);
    hprintln!(
        "size rest_monitor {}",
        core::mem::size_of::<spincal::health::RestMonitor>()
    );
    hprintln!("stack correct_first_sample {}", first_stack);
    hprintln!("stack correct_batch {}", batch_stack);
    hprintln!("stack set_environment {}", env_stack);
    hprintln!("stack set_environment_imu_series5 {}", series_env_stack);
    hprintln!("stack decode {}", decode_stack);
    hprintln!("size calibration {}", core::mem::size_of::<Calibration>());
    hprintln!(
        "size imu_corrector {}",
        core::mem::size_of::<ImuCorrector<'_, u16>>()
    );
    hprintln!("size imu_blob {}", IMU_BLOB.len());
    spincal_firmware::exit(true)
}

/// `correct_batch` and `correct` of `cal` (samples `[S; 6]`) at `temperature`, under the
/// names `[batch, call]`.
fn bench_format<S: Sample>(
    [batch_name, call_name]: [&str; 2],
    cal: &Calibration,
    temperature: f32,
    raw: &[[S; 6]; N],
) {
    let Ok(mut c) = ImuCorrector::<S>::new(cal, 1000.0) else {
        fail(batch_name)
    };
    c.set_environment(temperature, 3.3);
    bench_batch(batch_name, &mut c, raw);
    bench_one(call_name, &mut c, raw);
}

fn fail(what: &str) -> ! {
    hprintln!("FAIL {}", what);
    spincal_firmware::exit(false)
}

#[inline(never)]
fn observe(
    m: &mut spincal::health::RestMonitor,
    c: &mut ImuCorrector<'_, u16>,
    out: &Corrected<6>,
) -> spincal::health::Verdict {
    m.observe_rest(c, out)
}

/// The health check on the `health_drifted` golden samples (rest, a turn, rest; DRIFTED with
/// the overlay refreshed at each checkpoint): the samples corrected alone, then corrected and
/// observed; the difference per sample is the detector's and the filter's cost, window ends
/// and checkpoints amortised. Returns the stack high-water of one window-ending observation.
fn bench_health() -> usize {
    let Some(case) = spincal_firmware::HEALTH_CASES
        .iter()
        .find(|c| c.name == "health_drifted")
    else {
        fail("no health_drifted case")
    };
    let Ok(cal) = blob::decode(case.blob) else {
        fail("health blob")
    };
    let fresh = || {
        let Ok(mut c) = ImuCorrector::<u16>::new(&cal, case.rate) else {
            fail("health corrector")
        };
        c.set_environment(25.0, 3.3);
        c
    };
    let Ok(monitor) = spincal::health::RestMonitor::new(&cal, case.rate) else {
        fail("health monitor")
    };
    let mut c = fresh();
    let t0 = timer::now();
    for r in case.raw {
        black_box(one(&mut c, black_box(*r)));
    }
    let t1 = timer::now();
    let alone = t0.wrapping_sub(t1);
    let mut c = fresh();
    let mut m = monitor.clone();
    let t0 = timer::now();
    for r in case.raw {
        let out = one(&mut c, black_box(*r));
        black_box(observe(&mut m, &mut c, &out));
    }
    let t1 = timer::now();
    let both = t0.wrapping_sub(t1);
    if m.health().verdict != spincal::health::Verdict::Drifted {
        fail("health_drifted is not DRIFTED");
    }
    report(
        "health_observe_rest",
        both.wrapping_sub(alone),
        case.raw.len(),
    );
    // One window's end: the last sample of a window at rest.
    let mut c = fresh();
    let mut m = monitor;
    let len = usize::from(spincal::health::WINDOW);
    let mut stack = 0;
    for (i, r) in case.raw.iter().take(4 * len).enumerate() {
        let out = one(&mut c, *r);
        if i + 1 == 4 * len {
            let (_, s) = stack::high_water(|| black_box(observe(&mut m, &mut c, &out)));
            stack = s;
        } else {
            observe(&mut m, &mut c, &out);
        }
    }
    stack
}

/// Verifies the signed example IMU blob (9,292 bytes: SHA-256 over the blob and the trailer's
/// head, then Ed25519 `verify_strict`), as a unit does at commit and at boot. Returns its stack
/// high-water.
fn bench_signed() -> usize {
    static SIGNED: &[u8] = include_bytes!("../../../host-tests/golden/imu.signed");
    static PUBLIC: &[u8; 32] = include_bytes!("../../../host-tests/golden/station.pub");
    let keys = [spincal::signed::StationKey { public: *PUBLIC }];
    let Some(serial) = spincal::model::Serial::new("IMU-FULL-0042") else {
        fail("serial")
    };
    let t0 = timer::now();
    let ok = spincal::signed::verify(black_box(SIGNED), &keys, &serial, 0).is_ok();
    let t1 = timer::now();
    if !ok {
        fail("the signed example does not verify");
    }
    report("signed_verify_imu_blob", t0.wrapping_sub(t1), 1);
    let t0 = timer::now();
    black_box(spincal::signed::digest(black_box(SIGNED)));
    let t1 = timer::now();
    report("signed_digest_imu_blob", t0.wrapping_sub(t1), 1);
    let (_, stack) = stack::high_water(|| {
        black_box(spincal::signed::verify(
            black_box(SIGNED),
            &keys,
            &serial,
            0,
        ))
        .is_ok()
    });
    stack
}

/// A provisioned unit's store on the calibration region: commits the signed example at
/// counter 1 into an empty store (one verification), then at counter 2 over it (the current
/// record's and the new one's), and boots (the newest record verified and decoded). Returns
/// the stack high-water of a commit and of a boot.
fn bench_signed_store() -> [usize; 2] {
    use spincal::protocol::SLOT_BUFFER;
    use spincal::store::{Policy, Store};
    use spincal_firmware::RamFlash;
    static FIRST: &[u8] = include_bytes!("../../../host-tests/golden/imu.signed");
    static SECOND: &[u8] = include_bytes!("../../../host-tests/golden/imu2.signed");
    static PUBLIC: &[u8; 32] = include_bytes!("../../../host-tests/golden/station.pub");
    let keys = [spincal::signed::StationKey { public: *PUBLIC }];
    let Some(serial) = spincal::model::Serial::new("IMU-FULL-0042") else {
        fail("serial")
    };
    let policy = Policy::Signed {
        keys: &keys,
        unit: &serial,
    };
    let Some((buf, scratch)) = cortex_m::singleton!(: ([u8; SLOT_BUFFER], CalibrationData) =
        ([0; SLOT_BUFFER], CalibrationData::empty()))
    else {
        fail("buffers")
    };
    let Ok(mut store) = Store::new(RamFlash::calibration_region(), 0, RamFlash::SLOT_SIZE) else {
        fail("store layout")
    };
    if store.provision(&keys).is_err() {
        fail("provision");
    }
    let t0 = timer::now();
    let first = store.update(black_box(FIRST), buf, scratch, policy);
    let t1 = timer::now();
    if first.is_err() {
        fail("commit of the first signed record");
    }
    report("store_commit_signed_first", t0.wrapping_sub(t1), 1);
    let t0 = timer::now();
    let second = store.update(black_box(SECOND), buf, scratch, policy);
    let t1 = timer::now();
    if !matches!(second, Ok(i) if i.counter == 2) {
        fail("commit of the second signed record");
    }
    report("store_commit_signed", t0.wrapping_sub(t1), 1);
    let t0 = timer::now();
    let booted = store.load(buf, scratch, policy).is_ok();
    let t1 = timer::now();
    if !booted {
        fail("boot from the signed record");
    }
    report("store_boot_signed", t0.wrapping_sub(t1), 1);
    // A replay costs the same checks and writes nothing.
    let t0 = timer::now();
    let replay = store.update(black_box(FIRST), buf, scratch, policy);
    let t1 = timer::now();
    if replay.is_ok() {
        fail("a replay was committed");
    }
    report("store_refuse_replay", t0.wrapping_sub(t1), 1);
    let (_, commit) = stack::high_water(|| {
        black_box(store.update(black_box(FIRST), buf, scratch, policy)).is_ok()
    });
    let (_, boot) = stack::high_water(|| black_box(store.load(buf, scratch, policy)).is_ok());
    [commit, boot]
}
