//! Which of a corrected IMU sample's sensors the flight filter should doubt: both when the
//! corrector says the sample is outside the calibration (or there is none), one when its own
//! codes sit at their converter's rails (a round's accelerometers saturate at setback while
//! its gyros keep counting the spin).

use crate::correct::Flags;
use crate::model::Rails;

/// `[accelerometer, gyro]` in doubt, for the raw codes `raw` (`ax ay az gx gy gz`) whose
/// correction carried `flags`, the converters' rails being `accel` and `gyro`.
#[must_use]
pub fn doubted(raw: &[i32; 6], flags: Flags, accel: Rails, gyro: Rails) -> [bool; 2] {
    let both = flags.contains(Flags::OUT_OF_RANGE) || flags.contains(Flags::NO_CALIBRATION);
    let at = |codes: &[i32], r: Rails| codes.iter().any(|c| *c <= r.lo || *c >= r.hi);
    let (a, g) = raw.split_at(3);
    [both || at(a, accel), both || at(g, gyro)]
}
