//! `calflash calibrate` over a batch (issue 18): 16 IMUs, each from a 26-position tumble and
//! rate-table steps at one temperature (as `examples/data/imu_bench.csv`), calibrated with the
//! blob, record and history entry, with and without the HTML report, on one and on two threads.
//! Units per second are 16 / the time. The history is a SQLite file, and (without the
//! report) a PostgreSQL database on a server the bench starts as the tests do
//! (`host-tests/src/postgres.rs`; skipped with a notice where PostgreSQL is not installed). Run
//! with `cargo bench -p calflash --bench batch`. The group `batch_check` times the batch's
//! file check alone at 100 and 10^4 units.

#[path = "../../../host-tests/src/postgres.rs"]
mod pg_server;

use std::path::PathBuf;

use calflash::cmd::calibrate::CalibrateArgs;
use calflash::cmd::calibrate::batch::{calibrate_all, unit_files};
use calflash::sim::{self, Sensor, plan};
use clap::Parser;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const UNITS: usize = 16;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    args: CalibrateArgs,
}

/// The units' observation files, written once.
fn units() -> Vec<(String, PathBuf)> {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("batch-imu");
    std::fs::create_dir_all(&dir).unwrap();
    let conds = plan::plan(
        &["tumble:26".into(), "rate:-6:6:7".into()],
        &[25.0],
        &[3.3],
        1,
        false,
    )
    .unwrap();
    (0..UNITS)
        .map(|i| {
            let serial = format!("IMU-B-{i:03}");
            let path = dir.join(format!("{serial}.csv"));
            if !path.is_file() {
                let unit = Sensor::Imu(Box::default());
                let obs = sim::simulate(&unit, &conds, i as u64 + 1, false);
                obs.write_csv(std::fs::File::create(&path).unwrap())
                    .unwrap();
            }
            (serial, path)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let units = units();
    let out = tempfile::tempdir().unwrap();
    let server =
        pg_server::Server::start("batch into PostgreSQL").unwrap_or_else(|e| panic!("{e}"));
    let mut histories = vec![(
        "",
        out.path().join("units.sqlite").display().to_string(),
        [false, true].as_slice(),
    )];
    if let Some(s) = &server {
        s.execute("postgres", "CREATE DATABASE batch");
        histories.push(("_postgres", s.url("batch"), [false].as_slice()));
    }
    let mut g = c.benchmark_group("batch");
    g.sample_size(10);
    g.throughput(Throughput::Elements(UNITS as u64));
    for (backend, db, reports) in histories {
        for &report in reports {
            let mut argv = vec![
                "x".to_string(),
                "unused.csv".into(),
                "--sensor".into(),
                "imu".into(),
                "--out-dir".into(),
                out.path().display().to_string(),
                "--db".into(),
                db.clone(),
            ];
            if report {
                argv.push("--reports".into());
            }
            let args = Cli::parse_from(&argv).args;
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let name = format!(
                    "imu_{}_{threads}_thread{}{backend}",
                    if report { "with_report" } else { "no_report" },
                    if threads == 1 { "" } else { "s" }
                );
                g.bench_function(name, |b| {
                    b.iter(|| {
                        let outcomes = pool
                            .install(|| calibrate_all(&args, &units, out.path()))
                            .expect("the units' files can be written");
                        assert!(outcomes.iter().all(|o| o.result.is_ok()), "{outcomes:?}");
                    });
                });
            }
        }
    }
    g.finish();
}

/// The check that no unit's file is an input or another unit's (`batch::unit_files`, run before
/// any unit is calibrated) at 100 and at 10^4 units: its cost per unit must not grow with the
/// batch (issue 50: it compared every pair of paths, 12,600 `readlink` a unit at 300 units).
fn check(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("in"), dir.path().join("out"));
    std::fs::create_dir_all(&input).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let args = Cli::parse_from([
        "x",
        input.to_str().unwrap(),
        "--sensor",
        "imu",
        "--out-dir",
        out.to_str().unwrap(),
        "--reports",
    ])
    .args;
    let mut g = c.benchmark_group("batch_check");
    for n in [100usize, 10_000] {
        let units: Vec<(String, PathBuf)> = (0..n)
            .map(|i| {
                let serial = format!("U{i:05}");
                let f = input.join(format!("{serial}.csv"));
                if !f.exists() {
                    std::fs::write(&f, "").unwrap();
                }
                (serial, f)
            })
            .collect();
        g.throughput(Throughput::Elements(n as u64));
        g.sample_size(10);
        g.bench_function(format!("units_{n}"), |b| {
            b.iter(|| unit_files(&args, &units, &out).expect("no file is another's"));
        });
    }
    g.finish();
}

criterion_group!(benches, bench, check);
criterion_main!(benches);
