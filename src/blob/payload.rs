//! Reads the postcard payload piece by piece into a caller's slot.
//!
//! The payload is the postcard encoding of `CalibrationData` (written by serde's derive in
//! `encode`). Deserialising it in one call would build the whole calibration on the stack
//! and move it through every visitor, several times over (53 KB of stack for the largest IMU
//! table on the Cortex-M4F); here each small piece (identity, environment, sensor head, one
//! coefficient set) is decoded with postcard on its own and stored in place. The byte format
//! is the same: postcard writes a struct as its fields in order, an enum as its variant index
//! (varint) and the variant's fields, an `Option` as a 0/1 byte and the value, a sequence as
//! its length (varint) and the elements. The round-trip tests hold the two sides together.

use serde::de::DeserializeOwned;

use crate::Error;
use crate::model::{
    BoundedVec, CalibrationData, Channel, ImuCovariance, ImuSet, Quantity, Rails, Sensor,
    SingleCovariance, SingleSet, TriadCovariance, TriadSet,
};

/// Decodes one value from the front of `rest` and advances it.
fn take<T: DeserializeOwned>(rest: &mut &[u8]) -> Result<T, Error> {
    let (value, tail) = postcard::take_from_bytes(rest).map_err(|_| Error::PayloadMalformed)?;
    *rest = tail;
    Ok(value)
}

/// A sequence into `vec`: the first `N` elements kept, the rest read, dropped and marked.
fn take_seq<T: DeserializeOwned, const N: usize>(
    rest: &mut &[u8],
    vec: &mut BoundedVec<T, N>,
) -> Result<(), Error> {
    vec.clear();
    let len: u32 = take(rest)?;
    for _ in 0..len {
        // Every element is at least one byte, so a lying length runs out of payload quickly.
        vec.push_or_mark(take(rest)?);
    }
    Ok(())
}

/// An optional sequence.
fn take_option_seq<T: DeserializeOwned, const N: usize>(
    rest: &mut &[u8],
    slot: &mut Option<BoundedVec<T, N>>,
) -> Result<(), Error> {
    match take::<u8>(rest)? {
        0 => *slot = None,
        1 => take_seq(rest, slot.get_or_insert_with(BoundedVec::new))?,
        _ => return Err(Error::PayloadMalformed),
    }
    Ok(())
}

/// Reads `payload` into `slot`.
pub(super) fn read_into(payload: &[u8], slot: &mut CalibrationData) -> Result<(), Error> {
    let mut rest = payload;
    slot.identity = take(&mut rest)?;
    slot.environment = take(&mut rest)?;
    match take::<u32>(&mut rest)? {
        0 => {
            let (quantity, rails, channel): (Quantity, Rails, Channel) = take(&mut rest)?;
            if !matches!(slot.sensor, Sensor::Single { .. }) {
                slot.sensor = Sensor::Single {
                    quantity,
                    rails,
                    channel,
                    sets: BoundedVec::new(),
                    covariance: None,
                };
            }
            let Sensor::Single {
                quantity: q,
                rails: r,
                channel: c,
                sets,
                covariance,
            } = &mut slot.sensor
            else {
                return Err(Error::PayloadMalformed);
            };
            (*q, *r, *c) = (quantity, rails, channel);
            take_seq::<SingleSet, _>(&mut rest, sets)?;
            take_option_seq::<SingleCovariance, _>(&mut rest, covariance)?;
        }
        1 => {
            let (quantity, rails, channels): (Quantity, Rails, [Channel; 3]) = take(&mut rest)?;
            if !matches!(slot.sensor, Sensor::Triad { .. }) {
                slot.sensor = Sensor::Triad {
                    quantity,
                    rails,
                    channels,
                    sets: BoundedVec::new(),
                    covariance: None,
                };
            }
            let Sensor::Triad {
                quantity: q,
                rails: r,
                channels: c,
                sets,
                covariance,
            } = &mut slot.sensor
            else {
                return Err(Error::PayloadMalformed);
            };
            (*q, *r, *c) = (quantity, rails, channels);
            take_seq::<TriadSet, _>(&mut rest, sets)?;
            take_option_seq::<TriadCovariance, _>(&mut rest, covariance)?;
        }
        2 => {
            type Head = (
                Rails,
                Rails,
                [Channel; 3],
                [Channel; 3],
                Option<[[f32; 3]; 3]>,
            );
            let (accel_rails, gyro_rails, accel, gyro, lever_arm): Head = take(&mut rest)?;
            if !matches!(slot.sensor, Sensor::Imu { .. }) {
                slot.sensor = Sensor::Imu {
                    accel_rails,
                    gyro_rails,
                    accel,
                    gyro,
                    lever_arm,
                    sets: BoundedVec::new(),
                    covariance: None,
                };
            }
            let Sensor::Imu {
                accel_rails: ar,
                gyro_rails: gr,
                accel: a,
                gyro: g,
                lever_arm: l,
                sets,
                covariance,
            } = &mut slot.sensor
            else {
                return Err(Error::PayloadMalformed);
            };
            (*ar, *gr, *a, *g, *l) = (accel_rails, gyro_rails, accel, gyro, lever_arm);
            take_seq::<ImuSet, _>(&mut rest, sets)?;
            take_option_seq::<ImuCovariance, _>(&mut rest, covariance)?;
        }
        _ => return Err(Error::PayloadMalformed),
    }
    slot.noise = take(&mut rest)?;
    if rest.is_empty() {
        Ok(())
    } else {
        Err(Error::PayloadTrailingBytes { unread: rest.len() })
    }
}
