//! An exact D-optimal plan for a 10-term model (the full quadratic in three inputs) with 40
//! observations over 10^4 candidates, 5 restarts. Run with
//! `cargo bench -p calflash --bench design`.

use std::hint::black_box;

use calflash::design::exchange::{Criterion as Optimality, Options, optimize};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;

/// 10^4 candidates: a 22 x 22 x 21 grid over [-1, 1]^3 (10,164 points), full quadratic rows.
pub fn candidates() -> DMatrix<f64> {
    let level = |k: usize, m: usize| -1.0 + 2.0 * k as f64 / (m - 1) as f64;
    let mut rows = Vec::new();
    for a in 0..22 {
        for b in 0..22 {
            for c in 0..21 {
                let (x, y, z) = (level(a, 22), level(b, 22), level(c, 21));
                rows.extend([1.0, x, y, z, x * x, y * y, z * z, x * y, x * z, y * z]);
            }
        }
    }
    DMatrix::from_row_slice(rows.len() / 10, 10, &rows)
}

fn bench(c: &mut Criterion) {
    let f = candidates();
    let opts = Options {
        n: 40,
        restarts: 5,
        seed: 1,
    };
    let mut g = c.benchmark_group("design");
    g.sample_size(10);
    g.bench_function(
        "D-optimal, 10 terms, 40 points, 10,164 candidates, 5 restarts",
        |b| {
            b.iter(|| {
                black_box(optimize(black_box(&f), Optimality::D, None, &opts, |_, _| {}).unwrap())
            });
        },
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
