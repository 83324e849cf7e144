//! Host timings of the correction (criterion): nanoseconds per corrected sample on this
//! machine, for the same calibrations the Cortex-M4F benchmark uses.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use spincal::blob;
use spincal::correct::{Corrected, ImuCorrector};
use spincal::model::{Calibration, CalibrationData};

fn samples() -> Vec<[u16; 6]> {
    let centers = [33_109, 33_329, 36_427, 32_786, 32_430, 32_517];
    (0..1024)
        .map(|i| {
            std::array::from_fn(|a| centers[a] + ((i * 7919 + a * 104_729) % 4_000) as u16 - 2_000)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let raw = samples();
    let mut out = vec![Corrected::<6>::default(); raw.len()];
    let cases = [
        ("imu_linear", CalibrationData::example_imu_linear()),
        ("imu_full", CalibrationData::example_imu_polynomial()),
        ("imu_full_asym", CalibrationData::example_imu()),
    ];
    let mut group = c.benchmark_group("correct");
    group.throughput(Throughput::Elements(raw.len() as u64));
    for (name, data) in &cases {
        let cal = Calibration::new(data.clone()).unwrap();
        let mut imu = ImuCorrector::new(&cal, 1000.0).unwrap();
        imu.set_environment(22.5, 3.3);
        group.bench_function(format!("{name}_batch"), |b| {
            b.iter(|| imu.correct_batch(black_box(&raw), &mut out));
        });
        group.bench_function(format!("{name}_call"), |b| {
            b.iter(|| {
                for (r, o) in raw.iter().zip(out.iter_mut()) {
                    *o = imu.correct(black_box(*r));
                }
            });
        });
    }
    group.finish();

    let full = Calibration::new(CalibrationData::example_imu()).unwrap();
    let mut imu = ImuCorrector::<u16>::new(&full, 1000.0).unwrap();
    c.bench_function("set_environment_8pt", |b| {
        let mut t = -40.0f32;
        b.iter(|| {
            t = if t > 85.0 { -40.0 } else { t + 3.7 };
            imu.set_environment(black_box(t), 3.3);
        });
    });
    let bytes = std::fs::read(host_tests::golden::dir().join("imu.blob")).unwrap();
    let mut slot = CalibrationData::empty();
    c.bench_function("decode_validate_imu_blob", |b| {
        b.iter(|| blob::decode_in(black_box(&bytes), &mut slot).is_ok());
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
