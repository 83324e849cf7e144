//! Instruction counts of the flight filter on the Cortex-M4F (QEMU `-icount shift=10`, as
//! `bench.rs`): the golden flight's events through `FlightFilter<f32>`, each call timed, the
//! samples that only navigate apart from those that also step the covariance and take the
//! updates; and the filter's parts on their own (the navigation of one sample, one covariance
//! step, one GNSS position update of three scalars). Prints `bench` and `size`/`stack` lines as
//! `bench.rs` does.
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use nalgebra::Vector3;
use spincal::correct::AnyImuCorrector;
use spincal::flight::{DelayedFlight, FlightFilter, FlightLines, LaunchChange, Phase};
use spincal::nav::ErrorFilter;
use spincal_firmware::flight_golden::{BLOB, Input, RATE, flight_config, inputs, rails};
use spincal_firmware::{stack, timer};

fn report(name: &str, ticks: u64, ops: u64) {
    let total = (ticks * 40 + 512) / 1024;
    let tenths = (total * 10 + ops / 2) / ops.max(1);
    hprintln!(
        "bench {} {}.{} {} {}",
        name,
        tenths / 10,
        tenths % 10,
        ops,
        total
    );
}

/// Ticks of `f`, less the cost of reading the timer twice.
#[inline(always)]
fn timed<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let t0 = timer::now();
    let r = f();
    let t1 = timer::now();
    (r, u64::from(t0.wrapping_sub(t1)))
}

fn fail(what: &str) -> ! {
    hprintln!("FAIL {}", what);
    spincal_firmware::exit(false);
}

#[entry]
fn main() -> ! {
    timer::start();
    let Ok(cal) = spincal::blob::decode(BLOB) else {
        fail("imu_spin.blob")
    };
    let Some(rails) = rails(&cal) else {
        fail("not an IMU")
    };
    let Ok(mut imu) = AnyImuCorrector::new(&cal, RATE) else {
        fail("corrector")
    };
    let Ok(features_of) = AnyImuCorrector::new(&cal, RATE) else {
        fail("corrector")
    };
    let (_, overhead) = timed(|| black_box(0));
    let mut filter = FlightFilter::new(flight_config());
    // Per kind of call: ticks and count.
    let mut navigate = (0u64, 0u64);
    let mut epoch = (0u64, 0u64);
    let mut fixes = (0u64, 0u64);
    let mut pressures = (0u64, 0u64);
    let mut all = 0u64;
    let mut last_t = 0u64;
    let mut first_flight_t = None;
    let mut epoch_stack = 0usize;
    for e in inputs(&mut imu, rails) {
        match e {
            Input::Sample(t, f, w, doubt) => {
                let before = filter.stats().epochs;
                let flying = filter.phase() == Phase::Flight;
                let (_, ticks) = timed(|| filter.sample(t, &f, &w, doubt));
                let ticks = ticks.saturating_sub(overhead);
                all += ticks;
                last_t = t;
                if flying {
                    first_flight_t.get_or_insert(t);
                    let slot = if filter.stats().epochs > before {
                        &mut epoch
                    } else {
                        &mut navigate
                    };
                    slot.0 += ticks;
                    slot.1 += 1;
                }
            }
            Input::Fix(fix) => {
                let (_, ticks) = timed(|| filter.gnss(&fix));
                fixes.0 += ticks.saturating_sub(overhead);
                fixes.1 += 1;
                all += ticks.saturating_sub(overhead);
            }
            Input::Pressure(t, p) => {
                let (_, ticks) = timed(|| filter.pressure(t, p));
                pressures.0 += ticks.saturating_sub(overhead);
                pressures.1 += 1;
                all += ticks.saturating_sub(overhead);
            }
        }
    }
    report("flight_sample_navigate", navigate.0, navigate.1);
    report("flight_sample_with_epoch", epoch.0, epoch.1);
    report("flight_gnss_receive", fixes.0, fixes.1);
    report("flight_pressure_receive", pressures.0, pressures.1);
    // The whole golden flight (pad and flight), per second of it.
    report(
        "flight_golden_per_second",
        all * 1_000_000 / last_t.max(1),
        1,
    );
    let _ = first_flight_t;
    // The round's verdict at the end of the flight: a few 12 x 12 decompositions in software
    // double precision, once when it is read.
    let (verdict, ticks) = timed(|| filter.verdict());
    report("flight_verdict", ticks.saturating_sub(overhead), 1);
    if verdict.word != spincal::flight::Word::Shifted {
        fail("the golden flight's verdict");
    }
    let (_, used) = stack::high_water(|| black_box(filter.verdict()));
    hprintln!("stack flight_verdict {}", used);

    // The parts: an error filter in flight, from the golden flight's state at its end.
    let estimate = *filter.estimate();
    let covariance = *filter.covariance();
    let config = flight_config();
    let mut parts = ErrorFilter::new(
        estimate,
        &spincal::nav::Prior { covariance },
        spincal::nav::Earth::new(0.687_f32, 0.0),
        config.noise,
    );
    let f = Vector3::new(-8.0f32, 0.3, -0.2);
    let w = Vector3::new(1800.0f32, 2.0, -1.5);
    let step = spincal::nav::Interval::micros(500.0f32);
    parts.sample(&f, &w, step, None);
    let n = 200u64;
    let (_, ticks) = timed(|| {
        for _ in 0..n {
            parts.sample(black_box(&f), black_box(&w), black_box(step), None);
        }
    });
    report("nav_sample", ticks, n);
    let (_, ticks) = timed(|| black_box(parts.covariance_step()));
    report("covariance_step", ticks.saturating_sub(overhead), 1);
    let lever = Vector3::zeros();
    let (_, ticks) = timed(|| {
        for axis in 0..3 {
            let (h, at) = parts.antenna_row(&lever, axis);
            black_box(parts.update(&h, black_box(at + 1.0), 6.25));
        }
    });
    report("gnss_position_update_3", ticks.saturating_sub(overhead), 1);
    let (_, ticks) = timed(|| {
        for axis in 0..3 {
            let h = ErrorFilter::<f32>::velocity_row(axis);
            black_box(parts.update(&h, black_box(0.1), 0.04));
        }
    });
    report("gnss_velocity_update_3", ticks.saturating_sub(overhead), 1);
    let (_, ticks) = timed(|| parts.feedback());
    report("feedback", ticks.saturating_sub(overhead), 1);

    // Stack of a sample that steps the covariance and takes a fix.
    let mut again = FlightFilter::new(flight_config());
    let Ok(mut imu) = AnyImuCorrector::new(&cal, RATE) else {
        fail("corrector")
    };
    for e in inputs(&mut imu, rails) {
        match e {
            Input::Sample(t, f, w, doubt) => {
                let (_, used) = stack::high_water(|| again.sample(t, &f, &w, doubt));
                epoch_stack = epoch_stack.max(used);
            }
            Input::Fix(fix) => again.gnss(&fix),
            Input::Pressure(t, p) => again.pressure(t, p),
        }
    }
    hprintln!("stack flight_sample {}", epoch_stack);

    // The same flight on a delayed horizon of 256 samples (128 ms at 2 kHz): every sample
    // goes through the buffer, in and out. The golden flight's fixes come at their instant,
    // so the horizon is zero and the filter inside must end where `again` ended, bit for bit;
    // a longer horizon moves each sample through the buffer the same way.
    let mut delayed = DelayedFlight::<f32, 256>::new(flight_config());
    let Ok(mut imu) = AnyImuCorrector::new(&cal, RATE) else {
        fail("corrector")
    };
    let (mut delayed_all, mut samples) = (0u64, 0u64);
    for e in inputs(&mut imu, rails) {
        let (_, ticks) = timed(|| match e {
            Input::Sample(t, f, w, doubt) => delayed.sample(t, &f, &w, doubt),
            Input::Fix(fix) => delayed.gnss(&fix),
            Input::Pressure(t, p) => delayed.pressure(t, p),
        });
        delayed_all += ticks.saturating_sub(overhead);
        samples += u64::from(matches!(e, Input::Sample(..)));
    }
    delayed.flush();
    if delayed.filter().estimate() != again.estimate()
        || delayed.filter().covariance() != again.covariance()
    {
        fail("the delayed horizon of zero changed the golden flight");
    }
    report(
        "flight_delayed_golden_per_second",
        delayed_all * 1_000_000 / last_t.max(1),
        1,
    );
    report(
        "flight_delayed_overhead_per_sample",
        delayed_all.saturating_sub(all),
        samples,
    );
    // The round's lines beside the filter (every flight sample after the setback: the
    // corrector's error features and the single-precision sums), and the change of line and
    // the verdict it carries, once at the end.
    let Some(setback_end) = again.setback_end_us() else {
        fail("the golden flight's setback")
    };
    let Ok(mut imu) = AnyImuCorrector::new(&cal, RATE) else {
        fail("corrector")
    };
    let mut lines = FlightLines::default();
    let (mut line_ticks, mut line_samples, mut feature_ticks) = (0u64, 0u64, 0u64);
    for e in inputs(&mut imu, rails) {
        if let Input::Sample(t, f, w, doubt) = e
            && t >= setback_end
        {
            let v = [f.x, f.y, f.z, w.x, w.y, w.z];
            let (_, ticks) = timed(|| {
                let features = features_of.error_features(black_box(&v));
                lines.add(&v, &features, doubt);
            });
            line_ticks += ticks.saturating_sub(overhead);
            line_samples += 1;
            let (_, ticks) = timed(|| black_box(features_of.error_features(black_box(&v))));
            feature_ticks += ticks.saturating_sub(overhead);
        }
    }
    report("flight_lines_per_sample", line_ticks, line_samples);
    report("flight_lines_features_alone", feature_ticks, line_samples);
    let Some(factors) = features_of.covariance_factors() else {
        fail("the golden calibration's covariance")
    };
    let (change, ticks) = timed(|| LaunchChange::of(factors, &lines));
    report("flight_launch_change", ticks.saturating_sub(overhead), 1);
    let (_, ticks) = timed(|| black_box(again.verdict_given(Some(&change))));
    report(
        "flight_verdict_with_change",
        ticks.saturating_sub(overhead),
        1,
    );
    hprintln!(
        "size delayed_flight_256 {}",
        core::mem::size_of::<DelayedFlight<f32, 256>>()
    );
    hprintln!(
        "size flight_filter {}",
        core::mem::size_of::<FlightFilter<f32>>()
    );
    hprintln!("size flight_lines {}", core::mem::size_of::<FlightLines>());
    spincal_firmware::exit(true);
}
