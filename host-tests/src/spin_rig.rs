//! The spinning round, as the tests calibrate and fly it: a high-g IMU with lever arms of 0.5
//! to 3 mm (`ImuTruth::spinning_round`), calibrated at one temperature from a 24-position
//! tumble, rate-table steps to +-1900 rad/s about the six axis directions and the twelve
//! 45-degree diagonals, and centrifuge levels to 1500 g; then spun about its roll axis with
//! gravity transverse and a little coning.
//!
//! Shared by the golden vectors (the case `imu_spin`, checked bit for bit on the Cortex-M4F)
//! and the host tests of the model under rotation (`tests/rotation.rs`).

use calflash::sensor::{Calibrated, Options, triad};
use calflash::sim::{self, Sensor, plan, spin, truth::ImuTruth};

/// The calibration plan.
pub const PLAN: [&str; 4] = [
    "tumble:24",
    "rate:-1900:1900:9",
    "diagonal:-1900:1900:9",
    "centrifuge:1:1500:6",
];

/// Sample rate of the flights, Hz.
pub const SAMPLE_RATE: f64 = 2000.0;

/// Coning half-angle (degrees) and rate (Hz) of the flights.
pub const CONING: (f64, f64) = (1.0, 10.0);

/// Simulates the calibration plan through `truth` with `seed` and calibrates it with
/// `calflash` (an IMU with nonlinear terms, every term kept when `keep_all`), as of a fixed
/// creation time.
///
/// # Panics
/// When the workflow fails (a test failure).
#[must_use]
pub fn calibrate(truth: &ImuTruth, seed: u64, keep_all: bool) -> Calibrated {
    let dir = tempfile::tempdir().expect("temporary directory");
    let items: Vec<String> = PLAN.iter().map(|s| (*s).to_string()).collect();
    let conds = plan::plan(&items, &[25.0], &[3.3], 1, false).expect("plan");
    let obs = sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &conds, seed, false);
    let path = dir.path().join("spin_rig.csv");
    obs.write_csv(std::fs::File::create(&path).expect("create"))
        .expect("write");
    let mut opts = Options::new(&path, "ROUND-0300");
    opts.created = Some(1_795_000_000);
    opts.keep_all_terms = keep_all;
    triad::calibrate(&opts, triad::Kind::Imu, true).expect("the spin-rig calibration")
}

/// A flight of `profile` (see `calflash::sim::spin::profile`) through `truth` with coning,
/// sampled at [`SAMPLE_RATE`].
///
/// # Panics
/// On a bad profile.
#[must_use]
pub fn fly(truth: &ImuTruth, profile: &str, seed: u64) -> Vec<spin::Sample> {
    fly_about(truth, profile, [1.0, 0.0, 0.0], seed)
}

/// [`fly`] about another axis of the unit.
///
/// # Panics
/// On a bad profile.
#[must_use]
pub fn fly_about(truth: &ImuTruth, profile: &str, axis: [f64; 3], seed: u64) -> Vec<spin::Sample> {
    let run = spin::SpinRun {
        segments: spin::profile(profile).expect("profile"),
        axis,
        sample_rate: SAMPLE_RATE,
        cone_angle: CONING.0.to_radians(),
        cone_hz: CONING.1,
        temp: 25.0,
        volt: 3.3,
        seed,
    };
    spin::run(truth, &run)
}

/// The golden case's flight: a steady 300 Hz roll for 80 samples, then a spin-down to 290 Hz
/// over 70 (1,800 rad/s^2), continuous, then 10 samples at 290 Hz of which one
/// ([`GOLDEN_GLITCH`]) has its roll gyro's code 8,000 lower (about 490 rad/s): a rate step
/// no airframe makes, into the glitch and out of it, which the device flags.
#[must_use]
pub fn golden_flight() -> Vec<spin::Sample> {
    let mut flight = fly(
        &ImuTruth::spinning_round(),
        "300:0.04,300-290:0.035,290:0.005",
        0x5eed,
    );
    flight[GOLDEN_GLITCH].raw[3] -= 8_000.0;
    flight
}

/// The sample of [`golden_flight`] whose roll rate glitches.
pub const GOLDEN_GLITCH: usize = 155;
