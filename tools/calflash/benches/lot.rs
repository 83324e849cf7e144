//! `calflash lot` on a lot of 10^5 units in the SQLite history (issue 18: under 2 s): reading
//! every unit's newest fit, the robust scatter and every unit's distance, and an individuals and
//! an EWMA chart. The history is written once into the target directory. Run with
//! `cargo bench -p calflash --bench lot`.

#[path = "../tests/common/lot_history.rs"]
mod lot_history;

use std::hint::black_box;
use std::path::PathBuf;

use calflash::stats::chart::Kind;
use criterion::{Criterion, criterion_group, criterion_main};

const UNITS: usize = 100_000;

fn history() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("lot-1e5.sqlite");
    if !path.is_file() {
        let partial = path.with_extension("partial");
        let _ = std::fs::remove_file(&partial);
        lot_history::write(&partial, "LOT-", UNITS, 1_795_478_400, 1, |i, b, _| {
            if i % 1000 == 7 {
                b[0] += 400.0;
            }
        });
        std::fs::rename(&partial, &path).unwrap();
    }
    path
}

fn bench(c: &mut Criterion) {
    let path = history();
    let mut g = c.benchmark_group("lot");
    g.sample_size(10);
    g.bench_function("lot_1e5_units_sqlite", |b| {
        b.iter(|| {
            let lot = calflash::cmd::lot::load(&path, "LOT-", None, None, None, 0.001).unwrap();
            assert_eq!(lot.units.len(), UNITS);
            let charts = [
                lot.chart("ax:1", Kind::Individuals, None).unwrap(),
                lot.chart("ax:input", Kind::Ewma, None).unwrap(),
            ];
            black_box((lot.outliers.len(), charts))
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
