//! What an IMU at rest is checked against: its noise terms and the allowances of the
//! in-use health check ([`crate::health`]).

use serde::{Deserialize, Serialize};

use super::Span;
use crate::Error;
use crate::error::Field;

/// The outputs of an IMU in the order of a corrected sample: `[ax, ay, az, wx, wy, wz]`.
pub const IMU_OUTPUTS: usize = 6;

/// The longest ageing allowance a calibration may state: 100 years of 365.25 days, in seconds.
/// Beyond it the allowance means nothing, and its variance (`K^2 t`) would leave the range in
/// which the health check's f32 arithmetic stays finite.
pub const MAX_AGEING_S: f32 = 3.155_76e9;

/// The noise terms of an IMU's six outputs (from `calflash allan`, or stated) and what the
/// unit at rest is held to. Optional in a calibration: without it the unit corrects as ever
/// and cannot judge its own calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoiseTerms {
    /// Per output, the white-noise density (velocity or angle random walk `N`): SI units per
    /// square root of hertz (m/s^2/sqrt(Hz), rad/s/sqrt(Hz)). One sample at rate `f` has the
    /// standard deviation `N sqrt(f)`.
    pub white: [f32; IMU_OUTPUTS],
    /// Per output, the bias random walk (rate random walk `K`): SI units per square root of
    /// second. Over `t` seconds a bias wanders by `K sqrt(t)` (1-sigma).
    pub bias_walk: [f32; IMU_OUTPUTS],
    /// The time, seconds, over which ageing may move the biases by their random walk: the
    /// allowance beyond which a drifted unit is SUSPECT rather than DRIFTED (its shelf life, or
    /// the interval between bench checks). At most [`MAX_AGEING_S`].
    pub ageing_s: f32,
    /// The magnitude of gravity wherever the unit may rest, m/s^2 (taken as uniform over it).
    pub gravity: Span,
    /// The probability that a unit whose calibration holds is called SUSPECT in one period at
    /// rest (the thresholds follow from it).
    pub false_alarm: f32,
}

impl NoiseTerms {
    /// Checks every term: densities positive, walks and ageing non-negative, all finite,
    /// gravity inside `[9.7, 9.9]` m/s^2 with `lo <= hi`, false-alarm rate in `(0, 0.5]`.
    ///
    /// # Errors
    /// [`Error::InvalidNonFinite`] for a NaN or infinite term, then
    /// [`Error::InvalidNoiseTerm`] naming the first term out of bounds.
    pub(crate) fn validate(&self) -> Result<(), Error> {
        let bad = |field: Field, index: Option<usize>| Error::InvalidNoiseTerm {
            field,
            index: index.map(|i| i as u8),
        };
        let terms = self.white.iter().map(|v| (Field::WhiteNoise, v));
        let terms = terms.chain(self.bias_walk.iter().map(|v| (Field::BiasWalk, v)));
        let rest = [
            (Field::Ageing, &self.ageing_s),
            (Field::Gravity, &self.gravity.lo),
            (Field::Gravity, &self.gravity.hi),
            (Field::FalseAlarm, &self.false_alarm),
        ];
        for (i, (field, v)) in terms.chain(rest).enumerate() {
            if !v.is_finite() {
                return Err(Error::InvalidNonFinite {
                    field,
                    part: None,
                    set: None,
                    index: Some((i % IMU_OUTPUTS) as u8),
                });
            }
        }
        for (i, n) in self.white.iter().enumerate() {
            if !(n.is_finite() && *n > 0.0) {
                return Err(bad(Field::WhiteNoise, Some(i)));
            }
        }
        for (i, k) in self.bias_walk.iter().enumerate() {
            if !(k.is_finite() && *k >= 0.0) {
                return Err(bad(Field::BiasWalk, Some(i)));
            }
        }
        if !(self.ageing_s.is_finite() && (0.0..=MAX_AGEING_S).contains(&self.ageing_s)) {
            return Err(bad(Field::Ageing, None));
        }
        let Span { lo, hi } = self.gravity;
        if !(lo >= 9.7 && lo <= hi && hi <= 9.9) {
            return Err(bad(Field::Gravity, None));
        }
        if !(self.false_alarm > 0.0 && self.false_alarm <= 0.5) {
            return Err(bad(Field::FalseAlarm, None));
        }
        Ok(())
    }
}

#[cfg(test)]
#[expect(
    clippy::expect_used,
    reason = "the example's noise terms are a fixture"
)]
mod tests {
    use super::*;

    #[test]
    fn an_ageing_beyond_a_century_or_not_finite_is_refused() {
        let mut n = crate::model::CalibrationData::example_imu()
            .noise
            .expect("the example IMU states noise terms");
        assert_eq!(n.validate(), Ok(()));
        n.ageing_s = MAX_AGEING_S;
        assert_eq!(n.validate(), Ok(()));
        for bad in [MAX_AGEING_S * 1.01, 8.64e34, -1.0] {
            n.ageing_s = bad;
            assert_eq!(
                n.validate(),
                Err(Error::InvalidNoiseTerm {
                    field: Field::Ageing,
                    index: None
                }),
                "{bad}"
            );
        }
    }
}
