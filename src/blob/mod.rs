//! The calibration blob: the one wire format, used by the device and the host tool alike.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "SCAL"
//!      4     1  format version (5; 4 had no noise terms, 3 no temperature series, 2 did
//!                 not state the sample format, 1 also had the IMU covariance over [1, u] and
//!                 the own-axis lever term)
//!      5     2  payload length, little-endian
//!      7     4  CRC-32C (Castagnoli), little-endian, over bytes 0..7 and the payload
//!     11     n  payload: postcard encoding of `CalibrationData`
//! ```
//!
//! [`decode`] is the checking gate: it checks the header, then that exactly the declared number
//! of bytes is present, then the CRC over them, and only then decodes the payload; then it
//! validates every value ([`Calibration::new`]). Every refusal is its own [`Error`] variant.
//! Nothing in it can panic for any input.
//!
//! ```
//! use spincal::{blob, model::{Calibration, CalibrationData}};
//!
//! let cal = Calibration::new(CalibrationData::example_triad())?;
//! let mut buf = [0u8; blob::MAX_BLOB_LEN];
//! let n = blob::encode(&cal, &mut buf)?;
//! assert_eq!(&buf[..5], b"SCAL\x06");
//! assert_eq!(blob::decode(&buf[..n])?, cal);
//! // One flipped bit anywhere is caught before decoding.
//! buf[20] ^= 0x10;
//! assert!(matches!(blob::decode(&buf[..n]), Err(spincal::Error::ChecksumMismatch { .. })));
//! # Ok::<(), spincal::Error>(())
//! ```

mod payload;

use crate::Error;
use crate::model::{Calibration, CalibrationData};

/// The first four bytes of every blob.
pub const MAGIC: [u8; 4] = *b"SCAL";
pub use crate::limits::FORMAT_VERSION;
/// Bytes in the fixed header.
pub const HEADER_LEN: usize = 11;
/// Upper bound on the encoded length of any valid calibration (the largest IMU table with
/// covariance factors and a full-length serial fits; a test checks it).
pub const MAX_BLOB_LEN: usize = 30_720;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// A view of a blob's fixed header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Format version.
    pub version: u8,
    /// Payload bytes after the header.
    pub payload_len: u16,
    /// Stored CRC-32C.
    pub crc: u32,
}

impl Header {
    /// Reads the header at the start of `bytes`, checking magic and version.
    ///
    /// # Errors
    /// [`Error::HeaderTruncated`], [`Error::HeaderBadMagic`],
    /// [`Error::HeaderUnsupportedVersion`].
    pub fn parse(bytes: &[u8]) -> Result<Self, Error> {
        let Some(&[m0, m1, m2, m3, version, l0, l1, c0, c1, c2, c3]) =
            bytes.first_chunk::<HEADER_LEN>()
        else {
            return Err(Error::HeaderTruncated { found: bytes.len() });
        };
        if [m0, m1, m2, m3] != MAGIC {
            return Err(Error::HeaderBadMagic {
                found: [m0, m1, m2, m3],
            });
        }
        if version != FORMAT_VERSION {
            return Err(Error::HeaderUnsupportedVersion { found: version });
        }
        Ok(Self {
            version,
            payload_len: u16::from_le_bytes([l0, l1]),
            crc: u32::from_le_bytes([c0, c1, c2, c3]),
        })
    }

    /// Total blob length, header included.
    #[must_use]
    pub const fn blob_len(&self) -> usize {
        HEADER_LEN + self.payload_len as usize
    }
}

fn crc_of(header_prefix: &[u8], payload: &[u8]) -> u32 {
    let mut digest = CRC.digest();
    digest.update(header_prefix);
    digest.update(payload);
    digest.finalize()
}

/// Writes `cal` as a blob into `out` and returns its length.
///
/// # Errors
/// [`Error::EncodeBufferTooSmall`], [`Error::EncodePayloadTooLong`].
pub fn encode(cal: &Calibration, out: &mut [u8]) -> Result<usize, Error> {
    let available = out.len();
    let too_small = Error::EncodeBufferTooSmall { available };
    let (header, payload) = out.split_at_mut_checked(HEADER_LEN).ok_or(too_small)?;
    let payload_len = postcard::to_slice(cal.data(), payload)
        .map_err(|_| too_small)?
        .len();
    let len = u16::try_from(payload_len).map_err(|_| Error::EncodePayloadTooLong)?;
    let [l0, l1] = len.to_le_bytes();
    let [m0, m1, m2, m3] = MAGIC;
    let prefix = [m0, m1, m2, m3, FORMAT_VERSION, l0, l1];
    let crc = crc_of(&prefix, payload.get(..payload_len).unwrap_or_default());
    let [c0, c1, c2, c3] = crc.to_le_bytes();
    header.copy_from_slice(&[m0, m1, m2, m3, FORMAT_VERSION, l0, l1, c0, c1, c2, c3]);
    Ok(HEADER_LEN + payload_len)
}

/// Checks the header, the length and the CRC of `bytes` and returns the payload.
fn checked_payload(bytes: &[u8]) -> Result<&[u8], Error> {
    let header = Header::parse(bytes)?;
    let declared = header.blob_len();
    if bytes.len() < declared {
        return Err(Error::LengthTruncated {
            declared,
            found: bytes.len(),
        });
    }
    if bytes.len() > declared {
        return Err(Error::LengthTrailingBytes {
            declared,
            found: bytes.len(),
        });
    }
    let prefix = bytes.get(..HEADER_LEN - 4).unwrap_or_default();
    let payload = bytes.get(HEADER_LEN..).unwrap_or_default();
    let computed = crc_of(prefix, payload);
    if computed != header.crc {
        return Err(Error::ChecksumMismatch {
            stored: header.crc,
            computed,
        });
    }
    Ok(payload)
}

/// Checks, decodes and validates a blob into `slot` and returns the validated calibration,
/// which borrows the slot. This is the device's way in: the slot is typically a `static`, and
/// decoding reads the payload piece by piece straight into it, so the stack never holds a copy
/// of the whole calibration. On error the slot holds unspecified (unvalidated) data.
///
/// # Errors
/// In the order checked: `Header*`, `Length*`, [`Error::ChecksumMismatch`], `Payload*`, then
/// the `Invalid*` errors of [`Calibration::new`].
pub fn decode_in<'a>(
    bytes: &[u8],
    slot: &'a mut CalibrationData,
) -> Result<&'a Calibration, Error> {
    let payload = checked_payload(bytes)?;
    payload::read_into(payload, slot)?;
    Calibration::validate_in_place(slot)
}

/// Checks, decodes and validates a blob. `bytes` must be exactly one blob. Returns the
/// calibration by value, which costs stack for a few copies of it; on the device prefer
/// [`decode_in`].
///
/// # Errors
/// As [`decode_in`].
pub fn decode(bytes: &[u8]) -> Result<Calibration, Error> {
    let mut slot = CalibrationData::empty();
    decode_in(bytes, &mut slot)?;
    Ok(Calibration::validated(slot))
}
