//! The checks of an IMU's rotation terms: the lever arms, the axes' sensing directions, and
//! the g-sensitivity's feedback of the lever term into the rates, bounded at every sample rate.

use super::{OUTPUT_LIMIT, finite_all, triad_output_bound};
use crate::Error;
use crate::error::{Field, Part};
use crate::model::interval::Bound;
use crate::model::rotation::LeverTerms;
use crate::model::sets::ImuSet;
use crate::model::{Channel, MAX_LEVER_ARM_M, Rails};

/// With a lever arm the device feeds the previous sample's lever term into the g-sensitivity
/// ([`crate::model::rotation`]); for every code inside the rails the rate must stay bounded
/// through that feedback at the corrector's sample rate: the smallest `W` with
/// `W = W_s + |G| (A + E(W))` must exist below the output limit, where `W_s` and `A` bound the
/// triads' outputs over the rails (doubled for the blends between sets), `|G|` is the
/// g-sensitivity's largest row sum and `E(W)` bounds the lever term for rates up to `W` and
/// rate differences up to `2 W` (the tangential term takes the difference times the sample
/// rate), all maxima over the sets.
///
/// The tangential term's gain grows with the sample rate: with g-sensitivity rows of 6.6e-4
/// rad/s per m/s^2 and arms of 4 mm the loop's gain through it reaches one at 100 kHz (the
/// recurrence `w_k = c - G T (w_(k-1) - w_(k-2))` has a root at -1 there), and such a unit is
/// bounded at any rate below about 50 kHz. So the bound is the corrector's, at its rate
/// ([`Feedback::bounded_at`]); validation only refuses a calibration bounded at no rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Feedback {
    /// Bound of the accelerometer outputs, doubled.
    a: f64,
    /// Bound of the gyro outputs, doubled.
    ws: f64,
    /// The g-sensitivity's largest row sum.
    g: f64,
    /// The lever term's largest row sum of its quadratic coefficients.
    pq: f64,
    /// The lever term's largest row sum of its tangential coefficients, per Hz.
    pt: f64,
    /// The set with the largest loop gain, which names a failure.
    worst: u8,
}

impl Feedback {
    /// The loop's terms of an IMU's `sets` with lever arms `lever`.
    ///
    /// # Errors
    /// [`Error::InvalidSensingDirection`] when the lever term has no directions.
    pub(crate) fn of(
        sets: &[ImuSet],
        lever: &[[f32; 3]; 3],
        (accel, accel_rails): (&[Channel; 3], &Rails),
        (gyro, gyro_rails): (&[Channel; 3], &Rails),
    ) -> Result<Self, Error> {
        let big = |b: &[Bound; 3]| {
            b.iter()
                .map(|b| f64::from(libm::fmaxf(libm::fabsf(b.lo), libm::fabsf(b.hi))))
                .fold(0.0, f64::max)
        };
        let row_sum = |rows: &[[f32; 3]]| {
            rows.iter()
                .map(|r| r.iter().map(|x| f64::from(libm::fabsf(*x))).sum::<f64>())
                .fold(0.0, f64::max)
        };
        let mut f = Self {
            a: 0.0,
            ws: 0.0,
            g: 0.0,
            pq: 0.0,
            pt: 0.0,
            worst: 0,
        };
        let mut worst_gain = -1.0f64;
        for (i, set) in sets.iter().enumerate() {
            let Some(terms) = LeverTerms::new(&set.accel.matrix, lever, 1.0) else {
                return Err(Error::InvalidSensingDirection {
                    set: i as u8,
                    axis: 0,
                });
            };
            f.a =
                f.a.max(big(&triad_output_bound(&set.accel, accel, accel_rails)));
            f.ws =
                f.ws.max(big(&triad_output_bound(&set.gyro, gyro, gyro_rails)));
            f.g = f.g.max(row_sum(&set.g_sensitivity));
            let sums = |rows: &[[f32; 6]]| {
                rows.iter()
                    .map(|r| r.iter().map(|x| f64::from(libm::fabsf(*x))).sum::<f64>())
                    .fold(0.0, f64::max)
            };
            let (q, t) = (sums(&terms.quad), row_sum(&terms.tangential));
            let gain = row_sum(&set.g_sensitivity) * (q + t);
            if gain > worst_gain {
                (f.worst, worst_gain) = (i as u8, gain);
            }
            f.pq = f.pq.max(q);
            f.pt = f.pt.max(t);
        }
        f.a *= 2.0;
        f.ws *= 2.0;
        Ok(f)
    }

    /// Whether the rate stays bounded through the feedback at `rate_hz`.
    pub(crate) fn bounded_at(&self, rate_hz: f32) -> bool {
        let limit = f64::from(OUTPUT_LIMIT);
        let (pt, mut w) = (self.pt * f64::from(rate_hz), self.ws);
        for _ in 0..200 {
            let next = self.ws + self.g * (self.a + self.pq * w * w + pt * 2.0 * w);
            if next.is_nan() || next > limit {
                return false;
            }
            if next - w <= 1e-9 * w {
                return true;
            }
            w = next;
        }
        false
    }

    /// The highest sample rate (Hz, to 1 %) at which the feedback is bounded, at most
    /// [`MAX_SAMPLE_RATE_HZ`](crate::model::MAX_SAMPLE_RATE_HZ); 0 when it is bounded at none.
    pub(crate) fn max_rate(&self) -> f32 {
        let top = crate::model::MAX_SAMPLE_RATE_HZ;
        if self.bounded_at(top) {
            return top;
        }
        let (mut lo, mut hi) = (0.0f32, top);
        if !self.bounded_at(1e-6) {
            return 0.0;
        }
        while hi - lo > 0.01 * hi {
            let mid = 0.5 * (lo + hi);
            if self.bounded_at(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The error a corrector at a rate the feedback is not bounded at gets.
    pub(crate) fn error(&self) -> Error {
        Error::CorrectorUnboundedFeedback {
            set: self.worst,
            max_rate_hz: self.max_rate() as u32,
        }
    }
}

/// Refuses a calibration whose feedback is bounded at no sample rate (the tangential term
/// aside: the quadratic term and the triads' bounds alone).
pub(super) fn validate_lever_feedback(
    sets: &[ImuSet],
    lever: &[[f32; 3]; 3],
    accel: (&[Channel; 3], &Rails),
    gyro: (&[Channel; 3], &Rails),
) -> Result<(), Error> {
    let f = Feedback::of(sets, lever, accel, gyro)?;
    if f.bounded_at(0.0) {
        Ok(())
    } else {
        Err(Error::InvalidUnboundedOutput {
            part: Part::Gyro,
            set: f.worst,
        })
    }
}

/// Each accelerometer axis senses mainly along itself: in the inverse of the device matrix
/// (rows: the sensitive directions up to scale) the diagonal dominates every other element of
/// its row, so the lever term's normalised directions exist ([`crate::model::rotation::LeverTerms`]).
pub(super) fn validate_sensing_directions(m: &[[f32; 3]; 3], set: u8) -> Result<(), Error> {
    let Some(inv) = crate::model::rotation::inverse3(m) else {
        return Err(Error::InvalidSingularMatrix {
            part: Part::Accelerometer,
            set,
        });
    };
    for (i, row) in inv.iter().enumerate() {
        let own = row.get(i).map_or(0.0, |x| libm::fabsf(*x));
        let dominant = row
            .iter()
            .enumerate()
            .all(|(j, x)| j == i || libm::fabsf(*x) < own);
        if !dominant {
            return Err(Error::InvalidSensingDirection { set, axis: i as u8 });
        }
    }
    Ok(())
}

pub(super) fn validate_lever_arm(arm: &[[f32; 3]; 3]) -> Result<(), Error> {
    for (i, row) in arm.iter().enumerate() {
        finite_all(row.iter(), Field::LeverArm, Some(Part::Accelerometer), None)?;
        let len = libm::sqrtf(row.iter().map(|x| x * x).sum());
        if len > MAX_LEVER_ARM_M {
            return Err(Error::InvalidLeverArm { axis: i as u8 });
        }
    }
    Ok(())
}
