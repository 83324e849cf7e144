//! Writing one output into a folder that already holds many files (a batch of units writes
//! four files a unit into one `--out-dir`): `files::write_atomically` stages the file beside
//! its destination and renames it, and removes killed runs' staging files from the folder.
//! Issue 30: that cleanup read the whole folder for every file written, so a batch's cost per
//! unit grew with its size (1,000 units 3.5 ms of CPU each, 6,000 units 10 ms); it now reads
//! each folder once per process. Run with `cargo bench -p calflash --bench outputs`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("write_into_a_folder");
    g.sample_size(30);
    for files in [1_000usize, 6_000] {
        let dir = tempfile::tempdir().unwrap();
        for k in 0..files {
            std::fs::write(dir.path().join(format!("UNIT-{k:05}.json")), b"{}").unwrap();
        }
        let out = dir.path().join("UNIT-NEW.json");
        g.bench_function(format!("holding_{files}_files"), |b| {
            b.iter(|| {
                calflash::files::write_atomically(&out, |w| w.write_all(black_box(b"{\"v\":1}")))
                    .unwrap();
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
