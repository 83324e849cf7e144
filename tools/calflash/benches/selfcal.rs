//! Calibration without equipment on the Xsens MTi recording (reading both files, finding the
//! poses, both fits: what `calflash selfcal` does before writing its outputs), and the
//! overlapping Allan deviation with the noise-term fit of 10^7 samples.
//! Run with `cargo bench -p calflash --bench selfcal`.

use std::hint::black_box;
use std::path::PathBuf;

use calflash::noise::allan;
use calflash::nonlinear::selfcal::{self, Options};
use calflash::obs::recording;
use criterion::{Criterion, criterion_group, criterion_main};
use spincal::model::Rails;

fn xsens(c: &mut Criterion) {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/xsens-mti");
    if !d.join("acc.txt").is_file() {
        println!(
            "selfcal bench: the Xsens recording is absent ({}); skipped",
            d.display()
        );
        return;
    }
    let opts = Options {
        g: 9.81744,
        init_rest: 50.0,
        ..Options::default()
    };
    let mut g = c.benchmark_group("selfcal");
    g.sample_size(20);
    g.bench_function("xsens: read + poses + accelerometer + gyro", |b| {
        b.iter(|| {
            let rec = recording::read(
                &d.join("acc.txt"),
                Some(&d.join("gyro.txt")),
                Rails::unsigned(16),
            )
            .unwrap();
            black_box(selfcal::calibrate(&rec, &opts).unwrap())
        });
    });
    g.finish();
}

fn allan_1e7(c: &mut Criterion) {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let y: Vec<f64> = (0..10_000_000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let mut g = c.benchmark_group("allan");
    g.sample_size(10);
    g.bench_function("10^7 samples, 2 taus per octave, with noise terms", |b| {
        b.iter(|| {
            let curve = allan::overlapping(black_box(&y), 0.01, 2);
            black_box(allan::noise_terms(&curve))
        });
    });
    g.finish();
}

criterion_group!(benches, xsens, allan_1e7);
criterion_main!(benches);
