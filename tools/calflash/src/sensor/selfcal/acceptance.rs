//! Whether a calibration without equipment can be used: REJECT when a fit cannot observe its
//! parameters or does not explain the recording, REVIEW with what to look at, else ACCEPT.

use super::DeviceCheck;
use crate::nonlinear::selfcal::SelfCal;
use crate::sensor::Verdict;

/// The gyro fit's RMS angle error above which it explains the rotations too badly to be
/// trusted, degrees (good hand tumbles leave a few tenths).
pub const GYRO_REJECT_DEG: f64 = 3.0;

/// The accelerometer fit's RMS of |a| - g above which it cannot be trusted, as a fraction of g
/// (good tumbles leave a few parts in 10^4).
pub const ACCEL_REJECT: f64 = 0.01;

/// Why the calibration cannot be trusted (empty when it can): parameters a fit cannot observe,
/// or fits that do not explain the recording. Such a calibration is judged REJECT and writes no
/// blob unless `--force-blob`.
#[must_use]
pub fn rejected(c: &SelfCal) -> Vec<String> {
    let mut why = Vec::new();
    if c.accel.covariance.is_none() {
        why.push("the accelerometer's parameters are not all observable from these poses: turn the unit through more directions".to_string());
    }
    if c.gyro.covariance.is_none() {
        why.push("the gyro's parameters are not all observable from these rotations: rotate about all three axes".to_string());
    }
    if c.accel.rms() > ACCEL_REJECT * c.options.g {
        why.push(format!(
            "the accelerometer fit leaves |a| - g of {:.4} m/s^2 RMS ({:.2} % of g, more than {} %): poses that moved, or a --g far from the site's",
            c.accel.rms(),
            100.0 * c.accel.rms() / c.options.g,
            100.0 * ACCEL_REJECT
        ));
    }
    if c.gyro.rms_deg() > GYRO_REJECT_DEG {
        why.push(format!(
            "the gyro fit predicts the gravity direction after each rotation {:.1} degrees RMS off (more than {GYRO_REJECT_DEG}): the rotations are not what the gyro measured (a wrong --sample-rate, a gyro file of another recording, poses that moved)",
            c.gyro.rms_deg()
        ));
    }
    why
}

/// Whether the result can be used as it is: REJECT with the reasons of [`rejected`], else
/// REVIEW with what to look at, else ACCEPT.
#[must_use]
pub fn verdict(c: &SelfCal, check: Option<&DeviceCheck>) -> (Verdict, Vec<String>) {
    let why = rejected(c);
    if !why.is_empty() {
        return (Verdict::Reject, why);
    }
    let mut notes = Vec::new();
    if c.holdout.rms > 2.0 * c.accel.rms() {
        notes.push(format!(
            "poses left out are predicted {:.1} times worse than the fit: too few poses for the model, or a pose that moved",
            c.holdout.rms / c.accel.rms()
        ));
    }
    if c.holdout.unfitted > 0 {
        notes.push(format!(
            "{} of {} hold-out folds could not fit the accelerometer model on the poses left to them: too few poses for it{}",
            c.holdout.unfitted,
            c.holdout.folds,
            if c.accel.params.len() == 12 {
                " (the quadratic terms; --quadratic off leaves them out)"
            } else {
                ""
            }
        ));
    }
    if !c.skipped.is_empty() {
        notes.push(format!(
            "{} rotations left out of the gyro fit",
            c.skipped.len()
        ));
    }
    let limit = 1e-3 * c.accel.sigma();
    if let Some(check) = check
        && check.accel > limit.max(1e-5)
    {
        notes.push(format!(
            "the device's f32 correction differs from the fit by {:.2e} m/s^2",
            check.accel
        ));
    }
    let v = if notes.is_empty() {
        Verdict::Accept
    } else {
        Verdict::Review
    };
    (v, notes)
}
