//! The full regression (coefficients, inference, every diagnostic) for n = 10^4, 10^5 and 10^6
//! observations by 10 terms. `crosscheck/bench_statsmodels.py` times statsmodels on the same
//! data; `cargo xtask bench-fit` runs both.

use std::hint::black_box;

use calflash::stats::{Options, fit};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;

/// The benchmark's design: an intercept and nine columns built from five inputs (squares, a
/// product and an odd form among them), and a response with noise. Deterministic.
pub fn data(n: usize) -> (DMatrix<f64>, Vec<f64>, Vec<String>) {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut x = DMatrix::zeros(n, 10);
    let mut y = vec![0.0; n];
    for i in 0..n {
        let v: [f64; 5] = std::array::from_fn(|_| uniform());
        let row = [
            1.0,
            v[0],
            v[1],
            v[2],
            v[3],
            v[4],
            v[0] * v[0],
            v[1] * v[1],
            v[0] * v[1],
            v[2] * v[2].abs(),
        ];
        for (j, r) in row.iter().enumerate() {
            x[(i, j)] = *r;
        }
        y[i] = 2.5 + 0.4 * v[0] - 0.3 * v[1] + 0.05 * v[2] + 0.01 * v[0] * v[0] + 1e-3 * uniform();
    }
    let names = [
        "1", "a", "b", "c", "d", "e", "a^2", "b^2", "a:b", "c:abs(c)",
    ]
    .map(String::from)
    .to_vec();
    (x, y, names)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("fit_10_terms");
    group.sample_size(10);
    for n in [10_000, 100_000, 1_000_000] {
        let (x, y, names) = data(n);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                fit(
                    black_box(&x),
                    black_box(&y),
                    names.clone(),
                    true,
                    &Options::default(),
                )
                .unwrap()
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
