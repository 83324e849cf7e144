//! Issue 31's speed goals: a 60 s shell flight at 10 kHz simulated in under 2 s, and a
//! mission's moment matrix from 10^6 samples in under 0.2 s. Run with
//! `cargo bench -p calflash --bench mission`.

use std::hint::black_box;

use calflash::design::points::Unit;
use calflash::mission::Profile;
use calflash::mission::weight::{self, Lookup, Reach};
use calflash::sim::flight::shell::Shell;
use criterion::{Criterion, criterion_group, criterion_main};

/// The first million samples of the default shell at 20 kHz, as a profile.
fn shell_profile() -> Profile {
    let flight = Shell {
        seconds: 100.0,
        ..Shell::default()
    }
    .fire(5e-5);
    let s = &flight.samples[..1_000_000];
    Profile {
        source: "shell".into(),
        t: s.iter().map(|x| x.t).collect(),
        line: (2..).take(s.len()).collect(),
        f: Some(s.iter().map(|x| x.f).collect()),
        w: Some(s.iter().map(|x| x.w).collect()),
        dw: Some(s.iter().map(|x| x.dw).collect()),
        temp: Some(s.iter().map(|x| x.temp).collect()),
        volt: None,
        notes: Vec::new(),
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("mission");
    g.sample_size(10);
    g.bench_function("shell_60_s_at_10_khz", |b| {
        let shell = Shell::default();
        b.iter(|| black_box(shell.fire(black_box(1e-4))).samples.len());
    });
    let p = shell_profile();
    // A gyro's nonlinear model with g-sensitivity and temperature: 11 columns.
    let f = calflash::formula::parse(
        "g_x ~ 1 + w_x + w_y + w_z + w_x^2 + w_x^3 + w_x:abs(w_x) + f_x + f_y + f_z + temp",
    )
    .unwrap();
    let lookup = Lookup::new(&p, &f, Unit::Triad).unwrap();
    let reach = Reach {
        bounds: vec![
            ("w_x".into(), -2000.0, 2000.0),
            ("f_x".into(), -2000.0, 2000.0),
        ],
    };
    g.bench_function("moment_matrix_of_1e6_samples_11_columns", |b| {
        b.iter(|| black_box(weight::weight(&p, &f, &lookup, &reach)).share_inside);
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
