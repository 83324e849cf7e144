//! One slot's format: the commit marker, the header (magic, sequence, length, CRC-32C of the
//! record) and the record, as [`Store::update`](super::Store::update) writes it and
//! [`slot_image`] lays it out for a flasher.

use crate::blob;
use crate::model::CalibrationData;
use crate::signed;

use super::StoreError;

/// Bytes of the commit region (the largest write size supported).
pub(super) const COMMIT_SPAN: usize = 16;
/// Bytes of the header region.
pub(super) const HEADER_SPAN: usize = 16;
/// Offset of the blob in a slot.
pub(super) const BLOB_OFFSET: usize = COMMIT_SPAN + HEADER_SPAN;
/// The commit pattern: both 0 and 1 bits in every byte, so no partial program matches it.
pub(super) const COMMIT: [u8; 4] = [0x5a, 0xa5, 0xc3, 0x3c];
/// The header magic, "SCSL".
pub(super) const MAGIC: [u8; 4] = *b"SCSL";

/// A slot holding a valid calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlotInfo {
    /// Which slot, 0 or 1.
    pub index: u8,
    /// Its sequence number (higher is newer).
    pub seq: u32,
    /// Record bytes (the blob, and its trailer when signed).
    pub len: u32,
    /// The record's counter (0 when unsigned).
    pub counter: u32,
    /// The id of the key that signed it, when signed.
    pub signed_by: Option<[u8; 4]>,
}

/// What a slot holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotState {
    /// Never written since its last erase (or never erased).
    Empty,
    /// Written but not committed, torn or damaged.
    Invalid,
    /// A committed, checked calibration.
    Valid {
        /// Sequence number.
        seq: u32,
        /// Blob bytes.
        len: u32,
    },
}

/// The header of a record with sequence number `seq`: magic, sequence, length and CRC-32C,
/// little-endian words.
pub(super) fn header(seq: u32, record: &[u8]) -> [u8; HEADER_SPAN] {
    let mut header = [0u8; HEADER_SPAN];
    let fields = [
        MAGIC,
        seq.to_le_bytes(),
        (record.len() as u32).to_le_bytes(),
        blob_crc(record).to_le_bytes(),
    ];
    for (chunk, f) in header.chunks_exact_mut(4).zip(fields) {
        chunk.copy_from_slice(&f);
    }
    header
}

/// The sequence number and record length of a slot whose first `BLOB_OFFSET` bytes are
/// `head`, when its commit marker is exactly the pattern, its magic is right and its length is
/// 1 to `longest`; `None` otherwise.
pub(super) fn sound_head(head: &[u8; BLOB_OFFSET], longest: usize) -> Option<(u32, u32)> {
    let word = |at: usize| -> [u8; 4] {
        let mut w = [0u8; 4];
        if let Some(s) = head.get(at..at + 4) {
            w.copy_from_slice(s);
        }
        w
    };
    let magic = word(COMMIT_SPAN);
    let seq = u32::from_le_bytes(word(COMMIT_SPAN + 4));
    let len = u32::from_le_bytes(word(COMMIT_SPAN + 8));
    (word(0) == COMMIT && magic == MAGIC && len != 0 && len as usize <= longest)
        .then_some((seq, len))
}

/// The bytes a slot holds after a committed update of `blob` (a record: signed or not) with
/// sequence number `seq`, for
/// programming a unit by other means (a debug probe, a production flasher) with exactly what an
/// update would write. `out` is the slot: it is filled with 0xFF first. Returns the bytes used.
///
/// # Errors
/// [`StoreError::InvalidBlob`] when the blob does not decode and validate (it is checked with
/// `scratch`), [`StoreError::BlobTooLarge`] when it does not fit `out`.
pub fn slot_image(
    blob: &[u8],
    seq: u32,
    out: &mut [u8],
    scratch: &mut CalibrationData,
) -> Result<usize, StoreError> {
    blob::decode_in(signed::parts(blob).0, scratch).map_err(StoreError::InvalidBlob)?;
    let capacity = out.len().saturating_sub(BLOB_OFFSET);
    if blob.len() > capacity {
        return Err(StoreError::BlobTooLarge {
            len: blob.len(),
            capacity,
        });
    }
    out.fill(0xff);
    if let Some(marker) = out.get_mut(..COMMIT.len()) {
        marker.copy_from_slice(&COMMIT);
    }
    if let Some(head) = out.get_mut(COMMIT_SPAN..BLOB_OFFSET) {
        head.copy_from_slice(&header(seq, blob));
    }
    if let Some(dst) = out.get_mut(BLOB_OFFSET..BLOB_OFFSET + blob.len()) {
        dst.copy_from_slice(blob);
    }
    Ok(BLOB_OFFSET + blob.len())
}

/// CRC-32C (Castagnoli) of a record.
pub(super) fn blob_crc(bytes: &[u8]) -> u32 {
    crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(bytes)
}
