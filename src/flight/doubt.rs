//! Which of a corrected IMU sample's sensors the flight filter should doubt: both when the
//! corrector has no calibration or says the rate stepped beyond what the airframe can turn (a
//! glitch or a gap, which neither the rate nor the lever-arm correction of the specific force
//! survives); one when its own codes sit at their converter's rails (a round's accelerometers
//! saturate at setback while its gyros keep counting the spin); both when the sample is outside
//! the calibration and neither sensor is at its rails, since the flag does not say which.
//!
//! A gyro whose accelerometer is doubted is still read: its g-sensitivity correction used the
//! doubted force, and the filter widens the rate for it (`FlightRun::sample`), but a spinning
//! round's roll rate frozen at its last trusted value through a setback would lose the
//! thousands of radians it turns.

use crate::correct::Flags;
use crate::model::Rails;

/// `[accelerometer, gyro]` in doubt, for the raw codes `raw` (`ax ay az gx gy gz`) whose
/// correction carried `flags`, the converters' rails being `accel` and `gyro`.
#[must_use]
pub fn doubted(raw: &[i32; 6], flags: Flags, accel: Rails, gyro: Rails) -> [bool; 2] {
    let at = |codes: &[i32], r: Rails| codes.iter().any(|c| *c <= r.lo || *c >= r.hi);
    let (a, g) = raw.split_at(3);
    let railed = [at(a, accel), at(g, gyro)];
    let both = flags.contains(Flags::NO_CALIBRATION)
        || flags.contains(Flags::RATE_STEP)
        || (flags.contains(Flags::OUT_OF_RANGE) && railed == [false, false]);
    [both || railed[0], both || railed[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rate_step_puts_both_sensors_in_doubt_and_a_rail_only_its_own() {
        let rails = Rails::unsigned(16);
        let mid = [32_768; 6];
        assert_eq!(doubted(&mid, Flags::NONE, rails, rails), [false, false]);
        assert_eq!(doubted(&mid, Flags::RATE_STEP, rails, rails), [true, true]);
        assert_eq!(
            doubted(&mid, Flags::TEMPERATURE_CLAMPED, rails, rails),
            [false, false]
        );
        let mut railed = mid;
        railed[0] = 65_535;
        assert_eq!(
            doubted(&railed, Flags::SATURATED, rails, rails),
            [true, false]
        );
        // Setback: the accelerometer at its rails puts the sample outside the calibration;
        // the gyro, inside its own, is still read.
        assert_eq!(
            doubted(
                &railed,
                Flags::SATURATED | Flags::OUT_OF_RANGE,
                rails,
                rails
            ),
            [true, false]
        );
        // Outside the calibration with no sensor at its rails: which is unknown, both.
        assert_eq!(
            doubted(&mid, Flags::OUT_OF_RANGE, rails, rails),
            [true, true]
        );
    }
}
