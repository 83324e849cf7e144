//! The README's firmware example ("The firmware crate in one example") as a program: the
//! store's load at boot gives the calibration the corrector runs on. If a call of the example
//! changes, this stops compiling or failing, and the README is to be changed with it.

use host_tests::golden;
use host_tests::tcp_unit::{SLOT, blank_flash};
use spincal::correct::{Flags, ImuCorrector};
use spincal::model::{CalibrationData, Serial};
use spincal::protocol;
use spincal::store::{Policy, Store};

#[test]
fn the_readme_firmware_example_loads_and_corrects() {
    // The factory: a blob committed into the unit's store (what `calflash flash` does).
    let blob = golden::encode(&CalibrationData::example_imu());
    let mut store = Store::new(blank_flash(), 0, SLOT).unwrap();
    let mut buf = [0u8; protocol::SLOT_BUFFER];
    let mut scratch = CalibrationData::empty();
    store
        .update(&blob, &mut buf, &mut scratch, Policy::Open)
        .unwrap();
    let flash = store.into_inner();

    // The README's lines, at boot.
    let mut store = Store::new(flash, 0, SLOT).unwrap();
    let provisioning = store.provisioning().unwrap();
    let unit = Serial::new("IMU-0042")
        .ok_or("a serial of at most its length")
        .unwrap();
    let mut buf = [0u8; protocol::SLOT_BUFFER];
    let mut slot = CalibrationData::empty();
    let (cal, _slot_info) = store
        .load(&mut buf, &mut slot, provisioning.policy(&unit))
        .unwrap();
    let mut imu = ImuCorrector::<u16>::new(cal, 1000.0).unwrap();
    imu.set_environment(25.0, 3.3);
    let raw = [33_109, 33_329, 36_427, 34_000, 32_430, 32_517];
    let out = imu.correct(raw);
    assert_eq!(
        out.flags,
        Flags::RATE_DERIVATIVE_UNKNOWN,
        "the first sample"
    );
    let out = imu.correct(raw);
    assert!(out.flags.is_clean());
    assert!(out.values.iter().all(|v| v.is_finite()));
    let sigma = imu
        .sigma(&out.values)
        .expect("the example stores covariance factors");
    assert!(sigma.iter().all(|s| *s > 0.0));
}
