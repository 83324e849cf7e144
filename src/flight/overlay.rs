//! The flight filter's sensor errors for the corrector: its bias estimates as an
//! [`Overlay`] (in RAM; the stored calibration is never changed in flight).

use super::run::{FlightFilter, Phase};
use crate::correct::Overlay;
use crate::nav::Real;
use crate::nav::filter::index;

impl<T: Real> FlightFilter<T> {
    /// The accelerometer and gyro biases the filter has estimated and their variances, for
    /// [`ImuCorrector::set_overlay`](crate::correct::ImuCorrector): `None` before the filter
    /// has levelled, or if any of them is not finite.
    ///
    /// The filter's own compensation takes the biases and the scale factors out of what it
    /// navigates; this hands the biases to the rest of the firmware. Samples the filter sees
    /// must then come from the corrector *without* this overlay (or the filter would take the
    /// biases out twice).
    #[must_use]
    pub fn overlay(&self) -> Option<Overlay> {
        if self.phase() == Phase::Levelling {
            return None;
        }
        let s = &self.estimate().sensors;
        let p = self.covariance();
        let mut overlay = Overlay {
            bias: [0.0; 6],
            variance: [0.0; 6],
        };
        let biases = s.accel_bias.iter().chain(s.gyro_bias.iter());
        let at = (index::ACCEL_BIAS..index::ACCEL_BIAS + 3)
            .chain(index::GYRO_BIAS..index::GYRO_BIAS + 3);
        for (((b, v), x), i) in overlay
            .bias
            .iter_mut()
            .zip(overlay.variance.iter_mut())
            .zip(biases)
            .zip(at)
        {
            *b = x.to_f64() as f32;
            *v = p.get((i, i)).map_or(f32::NAN, |d| d.to_f64() as f32);
        }
        let finite = overlay
            .bias
            .iter()
            .chain(overlay.variance.iter())
            .all(|x| x.is_finite());
        finite.then_some(overlay)
    }
}
