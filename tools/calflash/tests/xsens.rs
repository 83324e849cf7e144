//! Acceptance on the real Xsens MTi recording in `../shared/data/xsens-mti/` (skips with a
//! notice when it is absent): the accelerometer's RMS of |a| - g over the still poses at most
//! 1.12 mm/s^2 and the gyro's gravity-direction RMS over the rotations at most 0.50 degrees.

use std::path::PathBuf;

use calflash::nonlinear::selfcal::{self, Options};
use calflash::obs::recording;
use spincal::model::Rails;

fn data() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/xsens-mti");
    if d.join("acc.txt").is_file() {
        Some(d)
    } else {
        println!("xsens acceptance: skipped, {} is absent (it lives beside the checkout in CI)", d.display());
        None
    }
}

#[test]
fn xsens_recording_meets_the_acceptance_figures() {
    let Some(d) = data() else { return };
    let rec = recording::read(&d.join("acc.txt"), Some(&d.join("gyro.txt")), Rails::unsigned(16)).unwrap();
    let opts = Options { g: 9.81744, init_rest: 50.0, ..Options::default() };
    let t = std::time::Instant::now();
    let c = selfcal::calibrate(&rec, &opts).unwrap_or_else(|e| panic!("{e}"));
    println!("{:?}", t.elapsed());
    for tr in &c.trials {
        println!("{:?}", tr);
    }
    println!("poses {} rms {:.4} mm/s2 max {:.4} holdout {:?} quad {:?}", c.poses.len(), c.accel.rms() * 1e3, c.accel.max() * 1e3, c.holdout, c.quadratic_test);
    println!("gyro rotations {} rms {:.3} deg max {:.3}; const bias rms {:.3}", c.rotations.len(), c.gyro.rms_deg(), c.gyro.max_deg(), (c.constant_bias_angles.iter().map(|a| a * a).sum::<f64>() / c.constant_bias_angles.len() as f64).sqrt().to_degrees());
    println!("{:?}\n{:?}", c.accel.model, c.gyro.matrix);
}
