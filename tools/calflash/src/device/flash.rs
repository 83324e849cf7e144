//! `calflash flash`: write a blob into a unit, commit it, read it back byte for byte, and run
//! test vectors through the unit's own correction against the host's.

use std::io::{Read, Write};

use spincal::blob;
use spincal::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector};
use spincal::model::{Calibration, Sensor};
use spincal::protocol::{self, MAX_CHUNK, MAX_VECTORS, Request, Response, Trust};
use spincal::signed::{self, SignError};

use super::client::{Client, DeviceError};

/// How to flash.
#[derive(Debug, Clone)]
pub struct FlashOptions {
    /// Write even when the blob's serial differs from the unit's.
    pub force: bool,
    /// Write a blob whose fit was judged REJECT (written with `--force-blob`).
    pub rejected_fit: bool,
    /// Test-vector batches of 16 samples (each batch at another temperature and voltage).
    pub vector_batches: usize,
}

impl Default for FlashOptions {
    fn default() -> Self {
        Self {
            force: false,
            rejected_fit: false,
            vector_batches: 4,
        }
    }
}

/// What a flash did and found.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FlashReport {
    /// The unit's serial.
    pub unit: String,
    /// The calibration the unit held before.
    pub previous: Option<String>,
    /// The new calibration's serial.
    pub calibration: String,
    /// Its slot sequence number.
    pub seq: u32,
    /// Blob bytes.
    pub bytes: usize,
    /// Read back and identical.
    pub read_back_identical: bool,
    /// Samples run through the unit's correction.
    pub vectors: usize,
    /// Largest difference between the unit's and the host's outputs, in units in the last place
    /// of f32.
    pub max_ulp: u32,
    /// Samples whose flags differ.
    pub flag_mismatches: usize,
    /// Whether the unit checks signatures: `provisioned`, `unprovisioned` (it takes unsigned
    /// calibrations from anyone with the cable) or `keys damaged`.
    pub trust: String,
    /// The id of the station key that signed the calibration (hex), when signed.
    pub signed_by: Option<String>,
    /// The calibration's counter (0 when unsigned).
    pub counter: u32,
}

/// A key id as hex.
#[must_use]
pub fn key_hex(id: [u8; 4]) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}

/// A unit's trust in words.
#[must_use]
pub const fn trust_name(t: Trust) -> &'static str {
    match t {
        Trust::Unprovisioned => "unprovisioned",
        Trust::Provisioned => "provisioned",
        Trust::KeysDamaged => "keys damaged",
    }
}

/// Why a flash failed; the unit keeps its previous calibration unless the message says
/// otherwise.
#[derive(Debug, thiserror::Error)]
pub enum FlashError {
    /// The blob given is not valid.
    #[error("the blob is not a valid calibration: {0}")]
    Blob(spincal::Error),
    /// The unit's serial differs.
    #[error(
        "the blob is for unit {blob} but the unit is {unit}; nothing was written (use --force to write it anyway)"
    )]
    WrongSerial {
        /// Blob serial.
        blob: String,
        /// Unit serial.
        unit: String,
    },
    /// The blob's fit was judged REJECT.
    #[error(
        "the blob's fit was judged REJECT (it was written with --force-blob); nothing was written (use --force-rejected to write it anyway)"
    )]
    RejectedFit,
    /// The blob is for another sensor than the unit carries.
    #[error("the blob is for {blob} but unit {unit} carries {carries}; nothing was written")]
    WrongSensor {
        /// The unit.
        unit: String,
        /// What it carries.
        carries: protocol::UnitSensor,
        /// What the blob is for.
        blob: protocol::UnitSensor,
    },
    /// A provisioned unit would refuse the calibration's signature (checked before sending
    /// anything, from what the unit says it holds; the unit checks again itself).
    #[error(
        "unit {unit} takes only calibrations signed for it by a key it holds: {why}; nothing was written"
    )]
    Signature {
        /// The unit.
        unit: String,
        /// Why.
        why: SignError,
    },
    /// The unit's keys sector is damaged: it trusts no key.
    #[error(
        "unit {unit} has a damaged keys sector and trusts no station key; it takes nothing until a flasher provisions it again (`calflash image --station-key`); nothing was written"
    )]
    KeysDamaged {
        /// The unit.
        unit: String,
    },
    /// The unit is locked.
    #[error("unit {unit} is locked against writes; it keeps its calibration {current}")]
    Locked {
        /// Unit.
        unit: String,
        /// What it holds.
        current: String,
    },
    /// The link or the unit failed during the transfer, before the commit.
    #[error(
        "{source}, at byte {at} of {total} of the transfer; nothing was committed: the unit keeps its calibration {current}"
    )]
    Transfer {
        /// Bytes sent.
        at: usize,
        /// Blob bytes.
        total: usize,
        /// What the unit holds.
        current: String,
        /// The cause.
        source: DeviceError,
    },
    /// The commit was sent but its answer was lost: the unit holds either its previous
    /// calibration or the new one, never a mix.
    #[error(
        "{source}: the commit was sent but its answer was lost, so the unit holds either its previous calibration {current} or the new one (never a mix); run `calflash flash` again to finish and verify"
    )]
    CommitUnknown {
        /// What the unit held before.
        current: String,
        /// The cause.
        source: DeviceError,
    },
    /// The link failed after the commit, during verification.
    #[error(
        "{source}, after the commit: the unit holds the new calibration (slot sequence {seq}) but it is NOT verified; flash again to verify it"
    )]
    Unverified {
        /// The committed sequence number.
        seq: u32,
        /// The cause.
        source: DeviceError,
    },
    /// Something failed before or after the transfer.
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// The read-back differs.
    #[error(
        "the blob read back from the unit differs from the one written (first difference at byte {at}); the unit is not verified: flash it again before use"
    )]
    ReadBack {
        /// First differing byte.
        at: usize,
    },
    /// The unit's outputs differ from the host's.
    #[error(
        "the unit's correction differs from the host's by {max_ulp} ulp (at most 2 are allowed) on {count} of {total} values; the unit is not verified"
    )]
    Vectors {
        /// Largest difference.
        max_ulp: u32,
        /// Values beyond 2 ulp.
        count: usize,
        /// Values compared.
        total: usize,
    },
}

/// Distance between two floats in units in the last place (0 for equal bits).
#[must_use]
pub fn ulp_distance(a: f32, b: f32) -> u32 {
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 { i32::MIN - i } else { i }
    };
    key(a).abs_diff(key(b))
}

/// Raw samples spanning each channel's calibrated neighbourhood, with a few at and beyond the
/// rails to exercise the flags.
fn samples(cal: &Calibration, batch: usize) -> Vec<[i32; 6]> {
    let (centers, rails): (Vec<f32>, Vec<spincal::model::Rails>) = match &cal.data().sensor {
        Sensor::Single { channel, rails, .. } => (vec![channel.center], vec![*rails]),
        Sensor::Triad {
            channels, rails, ..
        } => (channels.iter().map(|c| c.center).collect(), vec![*rails; 3]),
        Sensor::Imu {
            accel,
            gyro,
            accel_rails,
            gyro_rails,
            ..
        } => (
            accel.iter().chain(gyro.iter()).map(|c| c.center).collect(),
            [*accel_rails; 3]
                .into_iter()
                .chain([*gyro_rails; 3])
                .collect(),
        ),
    };
    (0..MAX_VECTORS)
        .map(|k| {
            std::array::from_fn(|a| {
                let Some(c) = centers.get(a) else { return 0 };
                let r = rails[a];
                let x = ((k * 7919 + a * 104_729 + batch * 31) % 12_001) as i64 - 6_000;
                let code = match (k + batch) % 16 {
                    14 => i64::from(r.hi),
                    15 => i64::from(r.lo) - 3,
                    _ => (f64::from(*c) as i64) + x,
                };
                code.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
            })
        })
        .collect()
}

/// The host's correction of `raw`, as the unit computes it (a fresh corrector per batch).
fn host_vectors(cal: &Calibration, t: f32, v: f32, raw: &[[i32; 6]]) -> Vec<([f32; 6], u8)> {
    match &cal.data().sensor {
        Sensor::Single { .. } => {
            let mut c = AnyAxisCorrector::new(cal).expect("single");
            c.set_environment(t, v);
            raw.iter()
                .map(|r| {
                    let o = c.correct(r[0]);
                    ([o.values[0], 0.0, 0.0, 0.0, 0.0, 0.0], o.flags.bits())
                })
                .collect()
        }
        Sensor::Triad { .. } => {
            let mut c = AnyTriadCorrector::new(cal).expect("triad");
            c.set_environment(t, v);
            raw.iter()
                .map(|r| {
                    let o = c.correct([r[0], r[1], r[2]]);
                    let [a, b, d] = o.values;
                    ([a, b, d, 0.0, 0.0, 0.0], o.flags.bits())
                })
                .collect()
        }
        Sensor::Imu { .. } => {
            let mut c = AnyImuCorrector::new(cal, protocol::vector_rate_hz()).expect("imu");
            c.set_environment(t, v);
            raw.iter()
                .map(|r| {
                    let o = c.correct(*r);
                    (o.values, o.flags.bits())
                })
                .collect()
        }
    }
}

fn crc(b: &[u8]) -> u32 {
    protocol::checksum(b)
}

/// Writes `bytes` into the unit behind `client`, which answered `id` to Identify, and
/// verifies it. Nothing is written when the blob is not valid, its fit was rejected (unless
/// `opts.rejected_fit`), it is for another sensor than the unit carries, or for another unit
/// (unless `opts.force`). `progress(done, total)` is called as the transfer goes.
///
/// # Errors
/// A [`FlashError`] that says what the unit holds afterwards.
pub fn flash<L: Read + Write>(
    client: &mut Client<L>,
    id: &protocol::Identity,
    bytes: &[u8],
    opts: &FlashOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<FlashReport, FlashError> {
    let (blob_part, trailer) = signed::parts(bytes);
    let cal = blob::decode(blob_part).map_err(FlashError::Blob)?;
    let serial = cal.data().identity.serial.as_str().to_string();
    let unit = id.unit.as_str().to_string();
    let previous = id.calibration.as_ref().map(|s| s.as_str().to_string());
    let current = previous.clone().unwrap_or_else(|| "(none)".into());
    if id.locked {
        return Err(FlashError::Locked { unit, current });
    }
    match id.trust {
        Trust::Unprovisioned => {}
        Trust::KeysDamaged => return Err(FlashError::KeysDamaged { unit }),
        Trust::Provisioned => {
            if let Err(why) = signature_precheck(trailer, id, &serial) {
                return Err(FlashError::Signature { unit, why });
            }
        }
    }
    if crate::approval::refused(&cal.data().identity, opts.rejected_fit) {
        return Err(FlashError::RejectedFit);
    }
    let kind = protocol::UnitSensor::of(cal.data());
    if kind != id.sensor {
        return Err(FlashError::WrongSensor {
            unit,
            carries: id.sensor,
            blob: kind,
        });
    }
    if serial != unit && !opts.force {
        return Err(FlashError::WrongSerial { blob: serial, unit });
    }
    let total = bytes.len();
    let transfer = |at: usize, current: &str, source: DeviceError| FlashError::Transfer {
        at,
        total,
        current: current.to_string(),
        source,
    };
    client
        .ask(&Request::WriteBegin {
            len: total as u32,
            crc: crc(bytes),
        })
        .map_err(|e| transfer(0, &current, e))?;
    for (k, chunk) in bytes.chunks(MAX_CHUNK).enumerate() {
        let offset = k * MAX_CHUNK;
        let data = heapless::Vec::from_slice(chunk).expect("a chunk fits");
        client
            .ask(&Request::WriteChunk {
                offset: offset as u32,
                data,
            })
            .map_err(|e| transfer(offset, &current, e))?;
        progress(offset + chunk.len(), total);
    }
    let seq = match client.ask(&Request::Commit) {
        Ok(Response::Committed { seq, .. }) => seq,
        Ok(other) => {
            return Err(FlashError::Device(DeviceError::Unexpected {
                what: "Commit".into(),
                got: format!("{other:?}"),
            }));
        }
        Err(DeviceError::Refused { status, what }) => {
            return Err(transfer(
                total,
                &current,
                DeviceError::Refused { what, status },
            ));
        }
        // The commit was sent but no answer came: the unit holds the old or the new one.
        Err(source) => return Err(FlashError::CommitUnknown { current, source }),
    };
    // Read back byte for byte.
    let back = client
        .read_blob(total)
        .map_err(|source| FlashError::Unverified { seq, source })?;
    if let Some(at) = back.iter().zip(bytes).position(|(a, b)| a != b) {
        return Err(FlashError::ReadBack { at });
    }
    // Test vectors through the unit's correction against the host's.
    let env = &cal.data().environment;
    let (t0, t1) = (env.temperature_span.lo, env.temperature_span.hi);
    let (v0, v1) = (env.voltage_span.lo, env.voltage_span.hi);
    let points = [
        ((t0 + t1) / 2.0, (v0 + v1) / 2.0),
        (t0, v1),
        (t1, v0),
        (t1 + 10.0, (v0 + v1) / 2.0),
    ];
    let mut max_ulp = 0;
    let mut beyond = 0;
    let mut compared = 0;
    let mut flag_mismatches = 0;
    let mut vectors = 0;
    for b in 0..opts.vector_batches {
        let (t, v) = points[b % points.len()];
        let raw = samples(&cal, b);
        let resp = client
            .ask(&Request::RunVectors {
                temperature: t,
                voltage: v,
                raw: heapless::Vec::from_slice(&raw).expect("16 samples"),
            })
            .map_err(|source| FlashError::Unverified { seq, source })?;
        let Response::Vectors { out } = resp else {
            return Err(FlashError::Device(DeviceError::Unexpected {
                what: "RunVectors".into(),
                got: format!("{resp:?}"),
            }));
        };
        let host = host_vectors(&cal, t, v, &raw);
        for ((dv, df), (hv, hf)) in out.iter().zip(&host) {
            vectors += 1;
            flag_mismatches += usize::from(df != hf);
            for (a, h) in dv.iter().zip(hv) {
                let d = ulp_distance(*a, *h);
                max_ulp = max_ulp.max(d);
                beyond += usize::from(d > 2);
                compared += 1;
            }
        }
    }
    if beyond > 0 || flag_mismatches > 0 {
        return Err(FlashError::Vectors {
            max_ulp,
            count: beyond + flag_mismatches,
            total: compared,
        });
    }
    Ok(FlashReport {
        unit,
        previous,
        calibration: serial,
        seq,
        bytes: total,
        read_back_identical: true,
        vectors,
        max_ulp,
        flag_mismatches,
        trust: trust_name(id.trust).into(),
        signed_by: trailer.map(|t| key_hex(t.key_id)),
        counter: trailer.map_or(0, |t| t.counter),
    })
}

/// What a provisioned unit that answered `id` would refuse in a record with `trailer` for the
/// unit `serial`, short of the signature itself (only the unit holds the keys' public halves
/// here by id): unsigned, an unknown key, another serial, a counter not above the unit's.
fn signature_precheck(
    trailer: Option<signed::Trailer>,
    id: &protocol::Identity,
    serial: &str,
) -> Result<(), SignError> {
    let t = trailer.ok_or(SignError::Unsigned)?;
    if !id.station_keys.contains(&t.key_id) {
        return Err(SignError::UnknownKey { key_id: t.key_id });
    }
    if serial != id.unit.as_str() {
        return Err(SignError::WrongSerial);
    }
    t.fresh(id.counter)
}

#[cfg(test)]
mod tests {
    use super::ulp_distance;

    #[test]
    fn ulps() {
        assert_eq!(ulp_distance(1.0, 1.0), 0);
        assert_eq!(ulp_distance(1.0, f32::from_bits(1.0f32.to_bits() + 2)), 2);
        assert_eq!(ulp_distance(0.0, -0.0), 0);
        assert_eq!(ulp_distance(f32::from_bits(1), -f32::from_bits(1)), 2);
    }
}
