//! Why the store cannot do what was asked.

use embedded_storage::nor_flash::{NorFlashError, NorFlashErrorKind};

use crate::Error;
use crate::signed::SignError;

/// Why the store cannot do what was asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// The flash driver failed.
    Flash(NorFlashErrorKind),
    /// The region does not fit the flash, or is not a whole number of erase sectors, or the
    /// write size is above 16 bytes.
    Layout,
    /// No slot holds a valid calibration (a new unit, or both slots damaged).
    NoValidSlot,
    /// The blob is larger than a slot holds.
    BlobTooLarge {
        /// Blob bytes.
        len: usize,
        /// What a slot holds.
        capacity: usize,
    },
    /// The buffer given is smaller than the blob (padded to the write size) needs.
    BufferTooSmall,
    /// The blob offered for an update does not decode and validate.
    InvalidBlob(Error),
    /// What was read back after writing differs from what was written.
    VerifyFailed,
    /// The unit is locked against writes.
    Locked,
    /// The record's signature, key, serial or counter is refused by a provisioned unit; or,
    /// at boot, no slot holds a record it trusts and this is why the newest was refused.
    Refused(SignError),
}

impl core::error::Error for StoreError {}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Flash(k) => write!(f, "flash error: {k:?}"),
            Self::Layout => f.write_str("the store's region does not fit the flash's sectors"),
            Self::NoValidSlot => f.write_str("no slot holds a valid calibration"),
            Self::BlobTooLarge { len, capacity } => {
                write!(f, "a blob of {len} bytes does not fit a slot of {capacity}")
            }
            Self::BufferTooSmall => f.write_str("the buffer is too small for the blob"),
            Self::InvalidBlob(e) => write!(f, "the blob is not a valid calibration: {e}"),
            Self::VerifyFailed => f.write_str("the slot read back differs from what was written"),
            Self::Locked => f.write_str("the unit is locked against writes"),
            Self::Refused(e) => write!(f, "refused: {e}"),
        }
    }
}

// `NorFlashErrorKind` has no `defmt::Format`: the flash error is logged by its name.
#[cfg(feature = "defmt")]
impl defmt::Format for StoreError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Self::Flash(k) => {
                let kind = match k {
                    NorFlashErrorKind::NotAligned => "not aligned",
                    NorFlashErrorKind::OutOfBounds => "out of bounds",
                    _ => "other",
                };
                defmt::write!(f, "flash error: {=str}", kind);
            }
            Self::Layout => defmt::write!(f, "Layout"),
            Self::NoValidSlot => defmt::write!(f, "NoValidSlot"),
            Self::BlobTooLarge { len, capacity } => {
                defmt::write!(
                    f,
                    "BlobTooLarge {{ len: {=usize}, capacity: {=usize} }}",
                    len,
                    capacity
                );
            }
            Self::BufferTooSmall => defmt::write!(f, "BufferTooSmall"),
            Self::InvalidBlob(e) => defmt::write!(f, "InvalidBlob({})", e),
            Self::VerifyFailed => defmt::write!(f, "VerifyFailed"),
            Self::Locked => defmt::write!(f, "Locked"),
            Self::Refused(e) => defmt::write!(f, "Refused({})", e),
        }
    }
}

pub(super) fn flash_err<E: NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}
