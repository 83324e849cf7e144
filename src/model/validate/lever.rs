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
/// ([`crate::model::rotation`]); for every code inside the rails the rate must stay bounded through
/// that feedback, at every sample rate up to [`MAX_SAMPLE_RATE_HZ`](crate::model::MAX_SAMPLE_RATE_HZ):
/// the smallest `W` with `W = W_s + |G| (A + E(W))` must exist below the output limit, where
/// `W_s` and `A` bound the triads' outputs over the rails (doubled for the blends between
/// sets), `|G|` is the g-sensitivity's largest row sum and `E(W)` bounds the lever term for
/// rates up to `W` and rate differences up to `2 W`, all maxima over the sets.
pub(super) fn validate_lever_feedback(
    sets: &[ImuSet],
    lever: &[[f32; 3]; 3],
    (accel, accel_rails): (&[Channel; 3], &Rails),
    (gyro, gyro_rails): (&[Channel; 3], &Rails),
) -> Result<(), Error> {
    let rate = crate::model::MAX_SAMPLE_RATE_HZ;
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
    let (mut a, mut ws, mut g, mut pq, mut pt) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    // The set with the largest loop gain names the failure.
    let (mut worst, mut worst_gain) = (0u8, -1.0f64);
    for (i, set) in sets.iter().enumerate() {
        let Some(terms) = LeverTerms::new(&set.accel.matrix, lever, rate) else {
            return Err(Error::InvalidSensingDirection {
                set: i as u8,
                axis: 0,
            });
        };
        a = a.max(big(&triad_output_bound(&set.accel, accel, accel_rails)));
        ws = ws.max(big(&triad_output_bound(&set.gyro, gyro, gyro_rails)));
        g = g.max(row_sum(&set.g_sensitivity));
        let sums = |rows: &[[f32; 6]]| {
            rows.iter()
                .map(|r| r.iter().map(|x| f64::from(libm::fabsf(*x))).sum::<f64>())
                .fold(0.0, f64::max)
        };
        let (q, t) = (sums(&terms.quad), row_sum(&terms.tangential));
        let gain = row_sum(&set.g_sensitivity) * (q + t);
        if gain > worst_gain {
            (worst, worst_gain) = (i as u8, gain);
        }
        pq = pq.max(q);
        pt = pt.max(t);
    }
    let (a, ws) = (2.0 * a, 2.0 * ws);
    let limit = f64::from(OUTPUT_LIMIT);
    let mut w = ws;
    for _ in 0..200 {
        let next = ws + g * (a + pq * w * w + pt * 2.0 * w);
        if next.is_nan() || next > limit {
            break;
        }
        if next - w <= 1e-9 * w {
            return Ok(());
        }
        w = next;
    }
    Err(Error::InvalidUnboundedOutput {
        part: Part::Gyro,
        set: worst,
    })
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
