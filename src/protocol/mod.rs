//! The update protocol over a serial link, shared by the device and `calflash`.
//!
//! A frame is `COBS(body ++ CRC-32C(body), little-endian) ++ 0x00`, the body
//! `postcard(message)`, or `postcard(message) ++ postcard(id: u16)` for a tagged frame
//! ([`encode_tagged`]). The host sends a [`Request`], the device answers with one [`Reply`]: a
//! [`Response`] and whether the unit checks signatures ([`Trust`]). The reply to a tagged
//! request carries the request's id, so that a client tells its own answer from a late one
//! meant for an earlier connection. A frame that does not decode, fails its CRC or carries an
//! unknown request gets [`Response::Error`] (untagged: its id could not be read) and changes
//! nothing. [`Device`] is the device's side, over any [`NorFlash`](embedded_storage::nor_flash::NorFlash).
//!
//! ```
//! use spincal::protocol::{self, Request, MAX_FRAME};
//!
//! let mut frame = [0u8; MAX_FRAME];
//! let n = protocol::encode(&Request::Identify, &mut frame).unwrap();
//! assert_eq!(frame[n - 1], 0, "frames end with 0x00");
//! let mut scratch = [0u8; MAX_FRAME];
//! let back: Request = protocol::decode(&frame[..n - 1], &mut scratch).unwrap();
//! assert_eq!(back, Request::Identify);
//! ```

mod device;

pub use device::{Device, SLOT_BUFFER, vector_rate_hz};

use serde::{Deserialize, Serialize};

use crate::model::{CalibrationData, Quantity, Rails, Sensor, Serial};
use crate::signed::SignError;
use crate::store::{MAX_KEYS, SlotState};

/// The sensor a unit carries, fixed in its firmware: the only kind of calibration it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UnitSensor {
    /// One axis.
    Single {
        /// What it measures.
        quantity: Quantity,
        /// Its converter's code range.
        rails: Rails,
    },
    /// A triad.
    Triad {
        /// What it measures.
        quantity: Quantity,
        /// Its converters' code range.
        rails: Rails,
    },
    /// An accelerometer and a gyro triad.
    Imu {
        /// The accelerometer converters' code range.
        accel_rails: Rails,
        /// The gyro converters' code range.
        gyro_rails: Rails,
    },
}

impl UnitSensor {
    /// The sensor a calibration is for.
    #[must_use]
    pub fn of(data: &CalibrationData) -> Self {
        match &data.sensor {
            Sensor::Single {
                quantity, rails, ..
            } => Self::Single {
                quantity: *quantity,
                rails: *rails,
            },
            Sensor::Triad {
                quantity, rails, ..
            } => Self::Triad {
                quantity: *quantity,
                rails: *rails,
            },
            Sensor::Imu {
                accel_rails,
                gyro_rails,
                ..
            } => Self::Imu {
                accel_rails: *accel_rails,
                gyro_rails: *gyro_rails,
            },
        }
    }
}

impl core::fmt::Display for UnitSensor {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let what = |q: &Quantity| match q {
            Quantity::Acceleration => "accelerometer",
            Quantity::AngularRate => "gyro",
        };
        match self {
            Self::Single { quantity, rails } => write!(
                f,
                "a single-axis {} (codes {} to {})",
                what(quantity),
                rails.lo,
                rails.hi
            ),
            Self::Triad { quantity, rails } => write!(
                f,
                "a {} triad (codes {} to {})",
                what(quantity),
                rails.lo,
                rails.hi
            ),
            Self::Imu {
                accel_rails,
                gyro_rails,
            } => write!(
                f,
                "an IMU (accelerometer codes {} to {}, gyro codes {} to {})",
                accel_rails.lo, accel_rails.hi, gyro_rails.lo, gyro_rails.hi
            ),
        }
    }
}

/// Bytes of blob per chunk.
pub const MAX_CHUNK: usize = 256;
/// Samples per test-vector request.
pub const MAX_VECTORS: usize = 16;
/// Largest encoded frame, terminator included.
pub const MAX_FRAME: usize = 640;
/// The protocol's version (in [`Identity`]); 2 added the unit's [`UnitSensor`], 3 the health
/// check at rest ([`Request::ObserveRest`], [`Request::ReadHealth`]), 4 signed calibrations
/// (every answer a [`Reply`] saying whether the unit checks signatures; [`Status::Refused`];
/// the station keys, counter and signer in [`Identity`]), 5 the flight filter's state
/// ([`Request::ReadFlight`]).
pub const PROTOCOL_VERSION: u8 = 6;

/// What the host asks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// Who are you, and what do you hold?
    Identify,
    /// `len` bytes of the current blob from `offset`.
    ReadBlob {
        /// Offset.
        offset: u32,
        /// Bytes (at most [`MAX_CHUNK`]).
        len: u16,
    },
    /// A new blob of `len` bytes with CRC-32C `crc` follows in chunks.
    WriteBegin {
        /// Blob bytes.
        len: u32,
        /// CRC-32C of the whole blob.
        crc: u32,
    },
    /// The next chunk of the blob (chunks come in order).
    WriteChunk {
        /// Its offset in the blob.
        offset: u32,
        /// The bytes.
        data: heapless::Vec<u8, MAX_CHUNK>,
    },
    /// Check the whole blob and make it the current calibration.
    Commit,
    /// Correct raw samples with the current calibration at a temperature and voltage (each
    /// sample is 6 codes; a single axis uses the first, a triad the first three).
    RunVectors {
        /// Temperature, C.
        temperature: f32,
        /// Supply voltage, V.
        voltage: f32,
        /// Raw samples.
        raw: heapless::Vec<[i32; 6], MAX_VECTORS>,
    },
    /// Refuse all further writes, for good.
    Lock,
    /// Correct raw samples of an IMU as [`Request::RunVectors`] does, with the health
    /// check's overlay and flag, and give them to the health check at rest, whose state is kept
    /// from one request to the next (the lever-arm state is not: each request's first sample
    /// has no rate derivative): a unit whose own sensor stream is not running (the example
    /// device) takes its stream this way.
    ObserveRest {
        /// Temperature, C.
        temperature: f32,
        /// Supply voltage, V.
        voltage: f32,
        /// Raw samples, in order.
        raw: heapless::Vec<[i32; 6], MAX_VECTORS>,
    },
    /// The unit's health: its verdict on its calibration, the refined terms and their
    /// covariance, and its time at rest ([`crate::health`]).
    ReadHealth,
    /// The flight filter's last snapshot ([`crate::flight`]): estimate, 1-sigma, counts.
    ReadFlight,
}

/// Why the device refused a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// The frame was not COBS, or too long, or its CRC did not match.
    BadFrame,
    /// The frame's message did not decode.
    Malformed,
    /// A request this firmware does not know.
    UnknownRequest,
    /// The unit is locked against writes.
    Locked,
    /// A chunk or commit without a transfer begun.
    NoTransfer,
    /// A chunk at another offset than the next expected, or past the declared length.
    OutOfOrder,
    /// A blob longer than a slot holds.
    TooLarge,
    /// The received blob's CRC differs from the one declared.
    CrcMismatch,
    /// The received blob is not a valid calibration (the blob error follows).
    InvalidBlob(crate::Error),
    /// The store failed to commit; the previous calibration stays current.
    StoreFailed,
    /// No valid calibration is stored.
    NoCalibration,
    /// The requested range is outside the blob.
    OutOfRange,
    /// The blob is for another kind of sensor (or other code ranges) than the unit carries;
    /// nothing was committed.
    WrongSensor {
        /// What the blob is for.
        blob: UnitSensor,
    },
    /// The calibration gives the health check nothing to run on (no noise terms, no
    /// covariance, not an IMU: the error says which); the unit still corrects.
    HealthUnavailable(crate::Error),
    /// A provisioned unit refuses the record: unsigned, signed by a key it does not hold,
    /// changed after signing, made for another unit, or not above its counter. Nothing was
    /// committed; the previous calibration stays current.
    Refused(SignError),
}

/// Whether a unit checks the signatures of calibrations: every answer says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Trust {
    /// No station keys (a developer's board): it takes unsigned calibrations from anyone with
    /// the cable, and keeps no counter.
    Unprovisioned,
    /// Provisioned with station keys: it takes only calibrations signed for it by one of them,
    /// with a counter above the one it holds.
    Provisioned,
    /// Its keys sector is written but damaged: it trusts no key and takes nothing until a
    /// flasher provisions it again.
    KeysDamaged,
}

/// A response frame's message: the response and the unit's [`Trust`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reply {
    /// Whether the unit checks signatures.
    pub trust: Trust,
    /// The answer.
    pub response: Response,
}

/// The device's answer to [`Request::Identify`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identity {
    /// The unit's serial number (fixed in the unit).
    pub unit: Serial,
    /// The sensor it carries (fixed in the unit): the only kind of calibration it takes.
    pub sensor: UnitSensor,
    /// Firmware version (major, minor, patch).
    pub firmware: [u16; 3],
    /// Blob format version the firmware reads.
    pub format: u8,
    /// Protocol version.
    pub protocol: u8,
    /// Both slots.
    pub slots: [SlotState; 2],
    /// The current calibration's serial, if one is loaded.
    pub calibration: Option<Serial>,
    /// Its blob length.
    pub blob_len: u32,
    /// Whether writes are refused.
    pub locked: bool,
    /// Bytes a slot holds.
    pub capacity: u32,
    /// Whether it checks signatures.
    pub trust: Trust,
    /// The ids of the station keys it holds.
    pub station_keys: heapless::Vec<[u8; 4], MAX_KEYS>,
    /// The current calibration's counter (0 for none or unsigned): a new one must be above it.
    pub counter: u32,
    /// The id of the key that signed the current calibration, when signed.
    pub signed_by: Option<[u8; 4]>,
    /// Why the unit runs with no calibration although a slot holds one, when it was refused
    /// for its signature at boot.
    pub refused: Option<SignError>,
}

/// What the device answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Response {
    /// To [`Request::Identify`].
    Identity(Identity),
    /// To [`Request::ReadBlob`].
    Blob {
        /// Offset.
        offset: u32,
        /// Bytes.
        data: heapless::Vec<u8, MAX_CHUNK>,
    },
    /// To [`Request::WriteBegin`]: send the chunks.
    Ready,
    /// To [`Request::WriteChunk`]: received up to `next`.
    ChunkOk {
        /// The next offset expected.
        next: u32,
    },
    /// To [`Request::Commit`]: the new calibration is current.
    Committed {
        /// Its slot's sequence number.
        seq: u32,
        /// Its counter (0 when unsigned).
        counter: u32,
    },
    /// To [`Request::RunVectors`]: outputs (as many as the sensor has, then zeros) and flag
    /// bits per sample.
    Vectors {
        /// Corrected samples.
        out: heapless::Vec<([f32; 6], u8), MAX_VECTORS>,
    },
    /// To [`Request::Lock`].
    LockedOk,
    /// To [`Request::ReadHealth`].
    Health(crate::health::Health),
    /// A refusal; nothing changed.
    Error(Status),
    /// To [`Request::ReadFlight`]: the snapshot the firmware's flight loop last published
    /// ([`Device::publish_flight`]), `None` when it has published none since power-on.
    Flight(Option<crate::flight::FlightReport>),
}

/// A frame that cannot be made or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The output buffer is too small.
    TooLong,
    /// Not COBS.
    Cobs,
    /// Shorter than a CRC.
    Truncated,
    /// The CRC does not match.
    Crc,
    /// The message does not decode (or has trailing bytes).
    Message,
}

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// The CRC-32C a [`Request::WriteBegin`] declares for a blob.
#[must_use]
pub fn checksum(bytes: &[u8]) -> u32 {
    CRC.checksum(bytes)
}

/// Encodes `msg` as a frame into `out`, terminator included; returns its length.
///
/// # Errors
/// [`FrameError::TooLong`] when `out` cannot hold it.
pub fn encode<T: Serialize>(msg: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    encode_with(msg, None, out)
}

/// Encodes `msg` tagged with `id` into `out` (see the [module docs](self)); returns the frame
/// length including the terminator.
///
/// # Errors
/// [`FrameError::TooLong`] when the frame does not fit `out` or [`MAX_FRAME`].
pub fn encode_tagged<T: Serialize>(msg: &T, id: u16, out: &mut [u8]) -> Result<usize, FrameError> {
    encode_with(msg, Some(id), out)
}

/// [`encode`] or [`encode_tagged`]: the body (`msg`, then `id` when given), its CRC, COBS and
/// the terminator.
fn encode_with<T: Serialize>(
    msg: &T,
    id: Option<u16>,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_FRAME];
    let mut body = postcard::to_slice(msg, &mut raw)
        .map_err(|_| FrameError::TooLong)?
        .len();
    if let Some(id) = id {
        body += postcard::to_slice(&id, raw.get_mut(body..).unwrap_or_default())
            .map_err(|_| FrameError::TooLong)?
            .len();
    }
    let crc = CRC
        .checksum(raw.get(..body).unwrap_or_default())
        .to_le_bytes();
    raw.get_mut(body..body + 4)
        .ok_or(FrameError::TooLong)?
        .copy_from_slice(&crc);
    let n = cobs::try_encode(raw.get(..body + 4).unwrap_or_default(), out)
        .map_err(|_| FrameError::TooLong)?;
    *out.get_mut(n).ok_or(FrameError::TooLong)? = 0;
    Ok(n + 1)
}

/// Decodes a frame, tagged or not: the message and its id (`None` for an untagged frame).
///
/// # Errors
/// As [`decode`]; anything after the message but one id is [`FrameError::Message`].
pub fn decode_tagged<'a, T: Deserialize<'a>>(
    frame: &[u8],
    scratch: &'a mut [u8],
) -> Result<(T, Option<u16>), FrameError> {
    let body = checked_body(frame, scratch)?;
    let (msg, rest) = postcard::take_from_bytes(body).map_err(|_| FrameError::Message)?;
    if rest.is_empty() {
        return Ok((msg, None));
    }
    match postcard::take_from_bytes::<u16>(rest) {
        Ok((id, [])) => Ok((msg, Some(id))),
        _ => Err(FrameError::Message),
    }
}

/// Decodes a frame (without its 0x00 terminator), using `scratch` for the COBS decoding.
///
/// # Errors
/// The [`FrameError`] of the first check that fails.
pub fn decode<'a, T: Deserialize<'a>>(
    frame: &[u8],
    scratch: &'a mut [u8],
) -> Result<T, FrameError> {
    let body = checked_body(frame, scratch)?;
    let (msg, rest) = postcard::take_from_bytes(body).map_err(|_| FrameError::Message)?;
    if !rest.is_empty() {
        return Err(FrameError::Message);
    }
    Ok(msg)
}

/// A frame's body, COBS-decoded into `scratch`, its CRC checked and removed.
fn checked_body<'a>(frame: &[u8], scratch: &'a mut [u8]) -> Result<&'a [u8], FrameError> {
    if frame.len() > scratch.len() {
        return Err(FrameError::TooLong);
    }
    let n = cobs::decode(frame, scratch).map_err(|_| FrameError::Cobs)?;
    let data = scratch.get(..n).ok_or(FrameError::Cobs)?;
    let Some(body_len) = n.checked_sub(4) else {
        return Err(FrameError::Truncated);
    };
    let (body, crc) = data.split_at(body_len);
    let stored = u32::from_le_bytes(crc.try_into().map_err(|_| FrameError::Truncated)?);
    if CRC.checksum(body) != stored {
        return Err(FrameError::Crc);
    }
    Ok(body)
}

/// Number of request kinds (the largest known postcard variant index plus one).
const REQUEST_KINDS: u32 = 9;

/// Whether a body that failed to decode names a request this firmware does not know.
fn unknown_request(frame: &[u8], scratch: &mut [u8]) -> bool {
    let Ok(n) = cobs::decode(frame, scratch) else {
        return false;
    };
    let body = scratch.get(..n.saturating_sub(4)).unwrap_or_default();
    matches!(postcard::take_from_bytes::<u32>(body), Ok((tag, _)) if tag >= REQUEST_KINDS)
}
