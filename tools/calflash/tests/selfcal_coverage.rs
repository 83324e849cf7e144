//! Do the stated errors of a calibration without equipment mean what they say? Simulated hand
//! tumbles with known truth (a 50 s rest, 36 poses of 3 s, smooth rotations, 3 counts of white
//! noise), many seeds: every pose is found on every seed, and the 95 % intervals of the
//! accelerometer's and the gyro's parameters cover the truth 95 % +- 3.5 % of the time.

use calflash::nonlinear::selfcal::{self, Options};
use calflash::sim::recording::Tumble;
use calflash::stats::dist::t_upper_quantile;

/// Seeds: 200 in CI (`SPINCAL_COVERAGE_SEEDS` may set another number).
fn seeds() -> u64 {
    std::env::var("SPINCAL_COVERAGE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
}

#[test]
fn stated_errors_cover_the_truth_over_many_tumbles() {
    let n = seeds();
    let opts = Options {
        g: 9.81,
        init_rest: 50.0,
        ..Options::default()
    };
    // The seeds are shared among the cores (each thread takes every k-th).
    let threads =
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get) as u64;
    let parts: Vec<Tally> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|w| {
                let opts = &opts;
                scope.spawn(move || {
                    let mut t = Tally::default();
                    for seed in (w..n).step_by(threads as usize) {
                        one(seed, opts, &mut t);
                    }
                    t
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut all = Tally::default();
    for p in parts {
        all.accel_in += p.accel_in;
        all.accel_all += p.accel_all;
        all.gyro_in += p.gyro_in;
        all.gyro_all += p.gyro_all;
        all.missed.extend(p.missed);
    }
    let Tally {
        accel_in,
        accel_all,
        gyro_in,
        gyro_all,
        missed,
    } = all;
    let a = accel_in as f64 / accel_all.max(1) as f64;
    let g = gyro_in as f64 / gyro_all.max(1) as f64;
    println!(
        "{n} tumbles: accelerometer 95 % intervals cover {:.1} % ({accel_all}), gyro {:.1} % ({gyro_all}); poses missed: {missed:?}",
        100.0 * a,
        100.0 * g
    );
    assert!(missed.is_empty(), "{missed:?}");
    assert!((a - 0.95).abs() <= 0.035, "accelerometer coverage {a}");
    assert!((g - 0.95).abs() <= 0.035, "gyro coverage {g}");
}

/// The intervals counted over some seeds.
#[derive(Default)]
struct Tally {
    accel_in: usize,
    accel_all: usize,
    gyro_in: usize,
    gyro_all: usize,
    missed: Vec<String>,
}

/// One simulated tumble: whether every pose is found and which intervals hold the truth.
fn one(seed: u64, opts: &Options, t: &mut Tally) {
    let truth = Tumble {
        rest: 50.0,
        poses: 36,
        hold: 3.0,
        seed,
        ..Tumble::default()
    };
    let rec = truth.record();
    let c = match selfcal::calibrate(&rec, opts) {
        Ok(c) => c,
        Err(e) => {
            t.missed.push(format!("seed {seed}: {e}"));
            return;
        }
    };
    if c.poses.len() != truth.poses + 1 {
        t.missed
            .push(format!("seed {seed}: {} poses", c.poses.len()));
        if std::env::var("SPINCAL_COVERAGE_DEBUG").is_ok() {
            println!("seed {seed}: {:?}", c.trials);
        }
    }
    let m = &c.accel.model;
    let want = truth.accel_parameters(m.center);
    // 95 % intervals: Student's t on the fits' residual degrees of freedom (each pose one;
    // each rotation two, its residual along gravity being second order).
    let np = c.accel.params.len();
    let ta = t_upper_quantile(0.025, (c.poses.len() - np) as f64);
    let tg = t_upper_quantile(0.025, (2 * c.rotations.len() - 9) as f64);
    if let Some(cov) = &c.accel.covariance {
        for (k, w) in want.iter().enumerate() {
            t.accel_all += 1;
            if ((c.accel.params[k] - w) / cov[(k, k)].sqrt()).abs() <= ta {
                t.accel_in += 1;
            }
        }
    }
    if let Some(cov) = &c.gyro.covariance {
        for i in 0..3 {
            for j in 0..3 {
                t.gyro_all += 1;
                let z = (c.gyro.matrix[i][j] - truth.gyro_matrix[(i, j)])
                    / cov[(3 * i + j, 3 * i + j)].sqrt();
                if z.abs() <= tg {
                    t.gyro_in += 1;
                }
            }
        }
    }
}
