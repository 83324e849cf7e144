//! Is each sensor error the flight filter estimates within its stated uncertainty? Simulated
//! shells, each with its own calibration (a spin rig simulated and calibrated at its own
//! seed), against the truth of what the unit's correction got wrong in that flight.
//!
//! The truth of a flight: the unit's noise-free codes along the simulated flight (the truth
//! model's outputs with the launch shift after launch, dithered by a uniform draw before
//! rounding so that the rounding averages out, held at the converter's rails), corrected by
//! the device's own correction of the flight's blob, less what the unit truly felt; per axis
//! the straight line `error = bias + scale * input` fitted to the flight's unflagged samples
//! after launch. That is the filter's own model of a sensor error, over the same flight.
//!
//! The statistic is the normalised estimation error squared (NEES) of each term the flight
//! observes (the verdict tests it): `((estimate - truth) /
//! sigma)^2`, whose average over `n` independent flights lies inside the chi-square(n) / n
//! band at 95 % when the stated 1-sigma is right. The Monte Carlo (50 flights of each kind)
//! is `cargo test --release -p calflash --test flight_nees -- --ignored --nocapture`
//! (`BENCHMARKS.md`); CI runs two flights and holds the shifted bias within 4 of its sigmas.

mod common;

use std::path::Path;

use calflash::sim::flight::receivers::LaunchShift;
use calflash::sim::truth::ImuTruth;
use common::calflash;
use rand::{RngExt, SeedableRng};
use spincal::correct::AnyImuCorrector;

const TRUTH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/data/spinning_round.truth.json"
);

fn ok(dir: &Path, args: &[&str]) {
    let (code, out, err) = calflash(dir, args);
    // 3: SHIFTED; 4: the filter does not fit (counted by the Monte Carlo).
    assert!(matches!(code, 0 | 3 | 4), "{args:?}: {out}{err}");
}

/// One term as the flight reported it, with its truth.
#[derive(Debug, Clone)]
struct Term {
    name: String,
    estimate: f64,
    sigma: f64,
    /// The calibration's own 1-sigma of it in flight.
    calibration: f64,
    /// Tested by the verdict (the flight determines it).
    observed: bool,
    truth: f64,
    shifted: bool,
}

impl Term {
    fn nees(&self) -> f64 {
        ((self.estimate - self.truth) / self.sigma).powi(2)
    }
}

/// Per output (ax ay az wx wy wz) the bias and scale factor of the correction's error over the
/// flight in `dir/s.csv` with `blob`, as the filter models them.
fn truth_of_flight(dir: &Path, shift: &LaunchShift) -> [(f64, f64); 6] {
    let truth: ImuTruth = serde_json::from_str(&std::fs::read_to_string(TRUTH).unwrap()).unwrap();
    let bytes = std::fs::read(dir.join("round.blob")).unwrap();
    let cal = spincal::blob::decode(&bytes).unwrap();
    let mut imu = AnyImuCorrector::new(&cal, 2000.0).unwrap();
    let mut reader = csv::Reader::from_path(dir.join("s.csv")).unwrap();
    let head = reader.headers().unwrap().clone();
    let at = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (t, temp, volt) = (at("t"), at("temp"), at("volt"));
    let cols = |names: [&str; 3]| names.map(&at);
    let (fc, wc, dwc) = (
        cols(["f_x", "f_y", "f_z"]),
        cols(["w_x", "w_y", "w_z"]),
        cols(["dw_x", "dw_y", "dw_z"]),
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    // Sums for the six straight lines: n, x, y, xx, xy.
    let mut sums = [[0.0f64; 5]; 6];
    let mut environment = None;
    for row in reader.records() {
        let row = row.unwrap();
        let v = |c: usize| row[c].parse::<f64>().unwrap();
        let get = |c: [usize; 3]| c.map(v);
        let (f, w, dw) = (get(fc), get(wc), get(dwc));
        let (tc, vc) = (v(temp), v(volt));
        if environment != Some((tc, vc)) {
            imu.set_environment(tc as f32, vc as f32);
            environment = Some((tc, vc));
        }
        let (fs, ws) = if v(t) > 0.0 {
            shift.apply(f, w)
        } else {
            (f, w)
        };
        let a = truth.accel.accel_output(fs, ws, dw, tc, vc);
        let g = truth.gyro.gyro_output(ws, fs, tc, vc);
        let raw: [i32; 6] = std::array::from_fn(|i| {
            let x = if i < 3 { a[i] } else { g[i - 3] };
            (x + rng.random::<f64>() - 0.5).round().clamp(0.0, 65_535.0) as i32
        });
        let out = imu.correct(raw);
        // The samples the filter navigates on doubt (a rail, out of range, a rate step) are
        // not the sensor's error; a temperature held at the calibrated span's end is.
        let rails = spincal::model::Rails::unsigned(16);
        if v(t) <= 0.0 || spincal::flight::doubted(&raw, out.flags, rails, rails) != [false; 2] {
            continue;
        }
        for i in 0..6 {
            let x = if i < 3 { f[i] } else { w[i - 3] };
            let y = f64::from(out.values[i]) - x;
            let s = &mut sums[i];
            s[0] += 1.0;
            s[1] += x;
            s[2] += y;
            s[3] += x * x;
            s[4] += x * y;
        }
    }
    sums.map(|[n, x, y, xx, xy]| {
        let det = n * xx - x * x;
        if det.abs() <= 1e-12 * n * xx.max(1.0) {
            // No spread of the input: the mean error is the bias.
            return (y / n, 0.0);
        }
        let scale = (n * xy - x * y) / det;
        ((y - scale * x) / n, scale)
    })
}

/// Which prior the flight takes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Prior {
    /// The calibration's record (`--record`): its whole model.
    Record,
    /// The blob's covariance factors.
    Factors,
}

/// A spin rig and a shell at `seed`: the rig calibrated, the shell flown with `shift` and
/// checked by `calflash flight` with `prior`; each term with its truth.
fn fly(seed: u64, shift: &str, prior: Prior) -> Flight {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let seed = seed.to_string();
    common::simulate_rig(dir, TRUTH, &["--seed", &seed]);
    ok(
        dir,
        &[
            "calibrate",
            "rig.csv",
            "--sensor",
            "imu",
            "--nonlinear",
            "--serial",
            "ROUND-NEES",
            "--blob",
            "round.blob",
            "--json",
            "rig.json",
            "--no-db",
            "--quiet",
        ],
    );
    let mut extra = vec![
        "--baro",
        "b.csv",
        "--seed",
        &seed,
        "--flight-truth",
        "truth.csv",
    ];
    if !shift.is_empty() {
        extra.extend(["--launch-shift", shift]);
    }
    // The Monte Carlo's receiver or flight varied from the command line (NEES_SIMULATE).
    let varied = std::env::var("NEES_SIMULATE").unwrap_or_default();
    extra.extend(varied.split_whitespace());
    common::simulate_flight(
        dir,
        TRUTH,
        (
            "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=22",
            "2000",
        ),
        "s.csv",
        &extra,
    );
    let mut check = vec![
        "flight",
        "s.csv",
        "--blob",
        "round.blob",
        "--gnss",
        "g.csv",
        "--baro",
        "b.csv",
        "--json",
        "f.json",
        "--track",
        "track.csv",
        "--no-db",
    ];
    if prior == Prior::Record {
        check.extend(["--record", "rig.json"]);
    }
    ok(dir, &check);
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("f.json")).unwrap()).unwrap();
    let share = track_within_three_sigma(dir);
    let word = record["verdict"].as_str().unwrap_or_default().to_string();
    let truth = truth_of_flight(dir, &LaunchShift::parse(shift).unwrap());
    // A term named SHIFTED is estimated again with its prior opened (the flight alone): that
    // is the estimate the check reports of it.
    let shifts = record["shifts"].as_array().cloned().unwrap_or_default();
    let terms = record["terms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let again = shifts.iter().find(|s| s["term"] == t["name"]);
            let (estimate, sigma) = match again {
                Some(s) => (
                    s["estimate"].as_f64().unwrap(),
                    s["sigma"].as_f64().unwrap(),
                ),
                None => (
                    t["estimate"].as_f64().unwrap(),
                    t["sigma"].as_f64().unwrap(),
                ),
            };
            let name = t["name"].as_str().unwrap().to_string();
            let axis = match name.chars().last() {
                Some('x') => 0,
                Some('y') => 1,
                _ => 2,
            };
            let output = if name.starts_with("gyro") {
                3 + axis
            } else {
                axis
            };
            let truth = if name.contains("bias") {
                truth[output].0
            } else {
                truth[output].1
            };
            Term {
                estimate,
                sigma,
                calibration: t["prior_sigma"].as_f64().unwrap(),
                observed: !t["z"].is_null(),
                shifted: t["shifted"].as_bool().unwrap(),
                truth,
                name,
            }
        })
        .collect();
    let unseen = record["unseen"]
        .as_array()
        .map(|u| {
            u.iter()
                .map(|u| {
                    (
                        u["term"].as_str().unwrap_or_default().to_string(),
                        u["smallest"].as_f64().unwrap_or(f64::NAN),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    Flight {
        terms,
        track_share: share,
        verdict: word,
        unseen,
    }
}

/// A flight's terms, the share of its smoothed track's epochs within 3 of their 1-sigma of
/// the truth, and its verdict.
#[derive(Debug)]
struct Flight {
    terms: Vec<Term>,
    track_share: f64,
    verdict: String,
    /// Each term not named, with the smallest change at launch the flight says it names.
    unseen: Vec<(String, f64)>,
}

/// The share of the smoothed track's epochs (`dir/track.csv`) from launch on within 3 of
/// their 1-sigma of the flight's truth (`dir/truth.csv`, the flight frame of the site the
/// flights are launched from).
fn track_within_three_sigma(dir: &Path) -> f64 {
    use calflash::sim::flight::site::Site;
    let site = Site {
        latitude: 39.4,
        longitude: -8.3,
        height: 0.0,
        azimuth: 60.0,
    };
    let rows = |f: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(dir.join(f))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let (truth, track) = (rows("truth.csv"), rows("track.csv"));
    let (mut inside, mut n) = (0usize, 0usize);
    for r in track.iter().filter(|r| r[0] >= 0.0) {
        let Some(k) = truth.iter().position(|x| x[0] >= r[0]).filter(|&k| k > 0) else {
            continue;
        };
        let (a, b) = (&truth[k - 1], &truth[k]);
        let u = (r[0] - a[0]) / (b[0] - a[0]);
        let flight = nalgebra::Vector3::from_fn(|i, _| a[1 + i] * (1.0 - u) + b[1 + i] * u);
        let (lat, lon, h) = site.geodetic(&flight);
        let e = calflash::nav::frame::level_position(
            &calflash::nav::input::Fix {
                t: r[0],
                lat_lon: (r[1], r[2]),
                height: Some(r[3]),
                velocity: None,
                satellites: None,
            },
            (lat, lon, h),
        );
        n += 1;
        let ok = (0..3).all(|i| e[i].abs() <= 3.0 * r[4 + i]);
        inside += usize::from(ok);
        if !ok && std::env::var("NEES_DEBUG").is_ok() && n % 50 == 0 {
            println!("t {:.2}: error {e:?}, 1-sigma {:?}", r[0], &r[4..7]);
        }
    }
    inside as f64 / n.max(1) as f64
}

/// Two flights with a 4-sigma axial bias shift (0.8 m/s^2: at the round's spin the axial bias
/// is known to 0.19): the shifted bias and the roll gyro's scale factor are observed and
/// estimated within 4 of their sigmas of the truth.
#[test]
fn a_shifted_bias_is_estimated_within_its_stated_uncertainty() {
    for seed in [201, 202] {
        let flight = fly(seed, "ax=0.8", Prior::Record);
        let terms = &flight.terms;
        println!(
            "seed {seed}: {}, track within 3 sigma on {:.1} % of the epochs",
            flight.verdict,
            100.0 * flight.track_share
        );
        assert!(flight.track_share >= 0.9, "seed {seed}: {flight:?}");
        let observed: Vec<&Term> = terms.iter().filter(|t| t.observed).collect();
        println!("seed {seed}: {observed:?}");
        let ax = observed
            .iter()
            .find(|t| t.name == "accel bias x")
            .unwrap_or_else(|| panic!("accel bias x not observed: {terms:?}"));
        assert!(ax.nees() < 16.0, "seed {seed}: {ax:?}, NEES {}", ax.nees());
        // The truth holds the shift and the calibration's own error of that bias (its stated
        // 1-sigma 0.19 m/s^2 at the spin).
        assert!((ax.truth - 0.8).abs() < 0.6, "{ax:?}");
        let wx = observed
            .iter()
            .find(|t| t.name == "gyro scale x")
            .unwrap_or_else(|| panic!("gyro scale x not observed: {terms:?}"));
        assert!(wx.nees() < 16.0, "seed {seed}: {wx:?}, NEES {}", wx.nees());
    }
}

/// Unshifted shells whose pass with the calibration's prior found the observed terms moved
/// together, no term named (the overall chi-square rests on the directions the flight barely
/// informs): no term's change, opened on its own, fits the flight better by the bar, so each is
/// HELD. Each was SHIFTED before that was asked (3 of the first 15 seeds).
#[test]
fn an_unshifted_shell_is_held_where_only_the_overall_chi_square_moved() {
    for seed in [302, 303, 312] {
        let flight = fly(seed, "", Prior::Record);
        assert_eq!(flight.verdict, "HELD", "seed {seed}: {flight:?}");
    }
}

/// The chi-square(n) / n band at 95 % (Wilson-Hilferty).
fn band(n: f64) -> (f64, f64) {
    let q = |z: f64| (1.0 - 2.0 / (9.0 * n) + z * (2.0 / (9.0 * n)).sqrt()).powi(3);
    (q(-1.959_964), q(1.959_964))
}

/// The Monte Carlo of `BENCHMARKS.md`: 50 flights of each kind, with each prior, the average
/// NEES of each term the flights observe, over those flights, against its band, and how often
/// a term is called SHIFTED. A term a flight does not observe keeps the calibration's estimate,
/// and is left out.
#[test]
#[ignore = "50 flights of each of three kinds, twice: run with --release -- --ignored --nocapture"]
fn average_nees_over_fifty_flights_of_each_kind() {
    // NEES_FLIGHTS flights of each kind (50), NEES_ONLY a kind's shift (`ax=0.8`, `none`).
    let n: u64 = std::env::var("NEES_FLIGHTS").map_or(50, |v| v.parse().unwrap());
    let only = std::env::var("NEES_ONLY").ok();
    for prior in [Prior::Record, Prior::Factors] {
        for (shift, term) in [
            ("", ""),
            ("ax=0.8", "accel bias x"),
            ("swx=0.003", "gyro scale x"),
        ] {
            let kind = if shift.is_empty() { "none" } else { shift };
            if only.as_deref().is_some_and(|o| o != kind) {
                continue;
            }
            // NEES_FIRST: the first seed (300).
            let first: u64 = std::env::var("NEES_FIRST").map_or(300, |v| v.parse().unwrap());
            let flown: Vec<Flight> = (0..n).map(|k| fly(first + k, shift, prior)).collect();
            let worst = (0..flown.len())
                .min_by(|&a, &b| flown[a].track_share.total_cmp(&flown[b].track_share))
                .map_or(0, |k| first + k as u64);
            println!("the track's worst flight: seed {worst}");
            let shares: Vec<f64> = flown.iter().map(|f| f.track_share).collect();
            let not_fit = flown
                .iter()
                .filter(|f| f.verdict == "FILTER DOES NOT FIT")
                .count();
            println!(
                "prior {prior:?}, launch shift `{shift}`: the track within 3 sigma on {:.1} % of the epochs on average, {:.1} % at worst; {not_fit} flights the filter does not fit",
                100.0 * shares.iter().sum::<f64>() / n as f64,
                100.0 * shares.iter().copied().fold(1.0, f64::min)
            );
            // Every verdict counts: an unshifted flight called SHIFTED with no term named
            // (the observed terms together moved) is a false SHIFTED too.
            let words: std::collections::BTreeMap<&str, usize> =
                flown.iter().fold(Default::default(), |mut m, f| {
                    *m.entry(f.verdict.as_str()).or_default() += 1;
                    m
                });
            let called: Vec<u64> = (0..n)
                .filter(|&k| flown[k as usize].verdict == "SHIFTED")
                .map(|k| first + k)
                .collect();
            println!(
                "prior {prior:?}, launch shift `{kind}`: verdicts {words:?}; SHIFTED at seeds {called:?}"
            );
            // The stated smallest change named, held against the truth: a flight that leaves
            // the shifted term unnamed though its shift is beyond that figure.
            let beyond: Vec<u64> = (0..n)
                .filter(|&k| {
                    let f = &flown[k as usize];
                    let truth = f.terms.iter().find(|t| t.name == term).map(|t| t.truth);
                    f.unseen.iter().any(|(u, smallest)| {
                        u == term && truth.is_some_and(|x| x.abs() > *smallest)
                    })
                })
                .map(|k| first + k)
                .collect();
            if !term.is_empty() {
                println!(
                    "prior {prior:?}, launch shift `{kind}`: not named though beyond the smallest change the flight says it names: {} ({beyond:?})",
                    beyond.len()
                );
            }
            let flights: Vec<Vec<Term>> = flown.into_iter().map(|f| f.terms).collect();
            let others: Vec<String> = flights
                .iter()
                .flat_map(|f| f.iter().filter(|t| t.shifted && t.name != term))
                .map(|t| t.name.clone())
                .collect();
            let alarmed: Vec<u64> = (0..n)
                .filter(|&k| {
                    flights[k as usize]
                        .iter()
                        .any(|t| t.shifted && t.name != term)
                })
                .map(|k| first + k)
                .collect();
            let alarms = alarmed.len();
            let found = flights
                .iter()
                .filter(|f| f.iter().any(|t| t.shifted && t.name == term))
                .count();
            println!(
                "prior {prior:?}, launch shift `{}` ({n} flights, each its own calibration): the shifted term called SHIFTED in {found}, another term in {alarms} ({others:?}; seeds {alarmed:?})",
                if shift.is_empty() { "none" } else { shift }
            );
            println!(
                "| term | flights observing it | average NEES | 95 % band | largest | mean and spread of (estimate - truth) / sigma | median stated 1-sigma | median calibration 1-sigma in flight |"
            );
            for name in flights[0].iter().map(|t| t.name.clone()) {
                print_nees(&flights, &name);
            }
        }
    }
}

/// One row of the Monte Carlo's table: term `name` over the flights that observe it.
fn print_nees(flights: &[Vec<Term>], name: &str) {
    let seen: Vec<&Term> = flights
        .iter()
        .filter_map(|f| f.iter().find(|t| t.name == name))
        .filter(|t| t.observed)
        .collect();
    if seen.is_empty() {
        return;
    }
    let m = seen.len() as f64;
    let avg = seen.iter().map(|t| t.nees()).sum::<f64>() / m;
    let largest = seen.iter().map(|t| t.nees()).fold(0.0, f64::max);
    let z: Vec<f64> = seen
        .iter()
        .map(|t| (t.estimate - t.truth) / t.sigma)
        .collect();
    let mean = z.iter().sum::<f64>() / m;
    let spread = (z.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
    let (lo, hi) = band(m);
    let mut sigmas: Vec<f64> = seen.iter().map(|t| t.sigma).collect();
    sigmas.sort_by(f64::total_cmp);
    let median = sigmas[sigmas.len() / 2];
    let mut cal: Vec<f64> = seen.iter().map(|t| t.calibration).collect();
    cal.sort_by(f64::total_cmp);
    let cal = cal[cal.len() / 2];
    println!(
        "| {name} | {} of {} | {avg:.2} | {lo:.2} to {hi:.2} | {largest:.1} | {mean:+.2}, {spread:.2} | {median:.3e} | {cal:.3e} |",
        seen.len(),
        flights.len()
    );
}
