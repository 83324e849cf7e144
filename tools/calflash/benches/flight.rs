//! Issue 32's speed goal: a 60 s flight at 2 kHz (about 120,000 samples) filtered and smoothed
//! in under 2 s on one core. The README's 62 s shell (124,001 samples, GNSS at 10 Hz, a
//! barometer) is simulated once with this build's `calflash`; then, each iteration, the unit's
//! correction of its codes (`nav::input::corrected`, reading the CSV included) and the check
//! (`nav::check::check`: the strapdown navigation, the filter, the roll search, the smoother,
//! the verdict). Run with `cargo bench -p calflash --bench flight` (`taskset -c 0` for one core).

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::path::Path;

use calflash::nav::check::{self, Walks};
use calflash::nav::input;
use calflash::nav::prior::{self, PriorSource};
use calflash::nav::run::Options;
use criterion::{Criterion, criterion_group, criterion_main};

/// `calflash` with `args` in `dir`, which exits 0 or 3 (a verdict other than ACCEPT).
fn ok(dir: &Path, args: &[&str]) {
    let (code, _, err) = common::calflash(dir, args);
    assert!(code == 0 || code == 3, "{args:?}: {err}");
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/data/spinning_round.truth.json"
    );
    common::simulate_rig(d, truth, &[]);
    ok(
        d,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "ROUND-0300",
            "--blob",
            "round.blob",
            "--no-db",
            "--quiet",
        ],
    );
    ok(
        d,
        &[
            "simulate",
            "--sensor",
            "imu",
            "--truth",
            truth,
            "--flight",
            "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2",
            "--sample-rate",
            "2000",
            "-o",
            "shell.csv",
            "--gnss",
            "gnss.csv",
            "--baro",
            "baro.csv",
        ],
    );
    let bytes = std::fs::read(d.join("round.blob")).unwrap();
    let cal = spincal::blob::decode(&bytes).unwrap();
    let (fixes, _) = input::gnss(&d.join("gnss.csv"), input::MAX_ROWS).unwrap();
    let baro = input::baro(&d.join("baro.csv"), input::MAX_ROWS).unwrap();
    let walks = Walks::default();
    let opts = Options::default();
    let mut g = c.benchmark_group("flight");
    g.sample_size(10);
    g.bench_function("shell_62_s_at_2_khz_corrected", |b| {
        b.iter(|| {
            input::corrected(black_box(&d.join("shell.csv")), &cal, input::MAX_ROWS).unwrap()
        });
    });
    let imu = input::corrected(&d.join("shell.csv"), &cal, input::MAX_ROWS).unwrap();
    g.bench_function("shell_62_s_at_2_khz_filtered_smoothed_judged", |b| {
        b.iter(|| {
            // The prior over the flight's rates is part of the check's cost.
            let from = calflash::nav::launch::launch(&imu, opts.launch_force)
                .unwrap()
                .1;
            let prior = prior::calibration_prior(&cal, &imu, from)
                .expect("the rig's blob carries covariance");
            let checked = check::check(
                black_box(&imu),
                (&fixes, &baro),
                (prior, PriorSource::Factors),
                &walks,
                &opts,
                0.01,
            )
            .unwrap();
            black_box(checked.pass.said.len())
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
