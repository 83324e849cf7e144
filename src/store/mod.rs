//! The calibration store: two slots over an `embedded-storage` [`NorFlash`], so that a power
//! cut at any moment of an update leaves the old calibration or the new one, never neither and
//! never a mix.
//!
//! ```text
//! region:  [ slot 0 | slot 1 | lock sector ]        each slot a whole number of erase sectors
//! slot:    offset 0   commit marker (16 bytes)       written last
//!          offset 16  header: magic, sequence, length, CRC-32C of the blob (16 bytes)
//!          offset 32  the blob, padded to the write size with 0xFF
//! ```
//!
//! An update validates the blob, erases the idle slot (never the current one), writes the blob,
//! then the header with the next sequence number, reads both back and compares them, and only
//! then programs the commit marker. A slot counts only when its marker is exactly the commit
//! pattern (a torn program leaves extra 1 bits, so a half-written marker never matches), its
//! header is sound and the CRC over the blob matches. Boot ([`Store::load`]) takes the valid slot
//! with the highest sequence number whose blob also decodes and validates, reads it once into
//! RAM and hands out only that validated copy. Boot writes nothing, so a cut during it cannot
//! harm anything. NOR semantics are kept: erase sets 0xFF, programming only clears bits, and
//! every byte is programmed at most once per erase.
//!
//! Sequence numbers are `u32`: four billion updates of one unit before they wrap.

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};

use crate::Error;
use crate::blob;
use crate::model::{Calibration, CalibrationData};

/// Bytes of the commit region (the largest write size supported).
const COMMIT_SPAN: usize = 16;
/// Bytes of the header region.
const HEADER_SPAN: usize = 16;
/// Offset of the blob in a slot.
const BLOB_OFFSET: usize = COMMIT_SPAN + HEADER_SPAN;
/// The commit pattern: both 0 and 1 bits in every byte, so no partial program matches it.
const COMMIT: [u8; 4] = [0x5a, 0xa5, 0xc3, 0x3c];
/// The header magic, "SCSL".
const MAGIC: [u8; 4] = *b"SCSL";
/// The lock word: the store is locked when the lock sector starts with exactly this.
const LOCKED: [u8; 4] = *b"LOCK";

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
}

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
        }
    }
}

fn flash_err<E: NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}

/// A slot holding a valid calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlotInfo {
    /// Which slot, 0 or 1.
    pub index: u8,
    /// Its sequence number (higher is newer).
    pub seq: u32,
    /// Blob bytes.
    pub len: u32,
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

/// The calibration store over a flash region.
#[derive(Debug)]
pub struct Store<F> {
    flash: F,
    base: u32,
    slot_size: u32,
}

impl<F: NorFlash> Store<F> {
    /// A store of two slots of `slot_size` bytes from `base`, followed by one erase sector for
    /// the lock word.
    ///
    /// # Errors
    /// [`StoreError::Layout`] when the region is not sector-aligned or does not fit.
    pub fn new(flash: F, base: u32, slot_size: u32) -> Result<Self, StoreError> {
        let erase = F::ERASE_SIZE as u64;
        let end = u64::from(base) + 2 * u64::from(slot_size) + erase;
        let ok = erase > 0
            && F::WRITE_SIZE > 0
            && F::WRITE_SIZE <= COMMIT_SPAN
            && COMMIT_SPAN % F::WRITE_SIZE == 0
            && u64::from(base) % erase == 0
            && u64::from(slot_size) % erase == 0
            && slot_size as usize > BLOB_OFFSET
            && end <= flash.capacity() as u64;
        if !ok {
            return Err(StoreError::Layout);
        }
        Ok(Self {
            flash,
            base,
            slot_size,
        })
    }

    /// The flash back (for a reboot in tests, or another use).
    pub fn into_inner(self) -> F {
        self.flash
    }

    /// Blob bytes a slot holds.
    #[must_use]
    pub const fn capacity(&self) -> usize {
        self.slot_size as usize - BLOB_OFFSET
    }

    fn slot_start(&self, index: u8) -> u32 {
        self.base + u32::from(index) * self.slot_size
    }

    fn lock_offset(&self) -> u32 {
        self.base + 2 * self.slot_size
    }

    /// The header of a slot, if its commit marker and header are sound.
    fn committed(&mut self, index: u8) -> Result<Result<SlotInfo, SlotState>, StoreError> {
        let start = self.slot_start(index);
        let mut head = [0u8; BLOB_OFFSET];
        self.flash.read(start, &mut head).map_err(flash_err)?;
        if head.iter().all(|b| *b == 0xff) {
            return Ok(Err(SlotState::Empty));
        }
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
        // A length no valid blob can have (beyond the slot, or beyond the largest blob) makes
        // the slot invalid; it must never turn into an error that hides the other slot.
        let longest = self.capacity().min(blob::MAX_BLOB_LEN);
        if word(0) != COMMIT || magic != MAGIC || len == 0 || len as usize > longest {
            return Ok(Err(SlotState::Invalid));
        }
        Ok(Ok(SlotInfo { index, seq, len }))
    }

    /// Reads a committed slot's blob into `buf` and checks its CRC.
    fn read_blob<'b>(
        &mut self,
        info: &SlotInfo,
        buf: &'b mut [u8],
    ) -> Result<Option<&'b [u8]>, StoreError> {
        let len = info.len as usize;
        let Some(dst) = buf.get_mut(..len) else {
            return Err(StoreError::BufferTooSmall);
        };
        let start = self.slot_start(info.index);
        self.flash
            .read(start + BLOB_OFFSET as u32, dst)
            .map_err(flash_err)?;
        let mut crc = [0u8; 4];
        self.flash
            .read(start + (COMMIT_SPAN + 12) as u32, &mut crc)
            .map_err(flash_err)?;
        let ok = blob_crc(dst) == u32::from_le_bytes(crc);
        Ok(ok.then_some(&*dst))
    }

    /// The state of both slots, each fully checked (commit marker, header, CRC, and the blob
    /// decoding and validating into `scratch`). `buf` must hold a slot's blob.
    ///
    /// # Errors
    /// A flash error, or a buffer too small.
    pub fn scan(
        &mut self,
        buf: &mut [u8],
        scratch: &mut CalibrationData,
    ) -> Result<[SlotState; 2], StoreError> {
        let mut out = [SlotState::Empty; 2];
        for (index, state) in (0u8..).zip(out.iter_mut()) {
            *state = match self.committed(index)? {
                Err(s) => s,
                Ok(info) => match self.read_blob(&info, buf)? {
                    Some(bytes) if blob::decode_in(bytes, scratch).is_ok() => SlotState::Valid {
                        seq: info.seq,
                        len: info.len,
                    },
                    _ => SlotState::Invalid,
                },
            };
        }
        Ok(out)
    }

    /// Boot: the newest slot whose blob checks, decodes and validates, read once into `buf`
    /// and decoded into `slot`; the returned calibration is that RAM copy.
    ///
    /// # Errors
    /// [`StoreError::NoValidSlot`] when neither slot holds a valid calibration.
    pub fn load<'a>(
        &mut self,
        buf: &mut [u8],
        slot: &'a mut CalibrationData,
    ) -> Result<(&'a Calibration, SlotInfo), StoreError> {
        let mut candidates: [Option<SlotInfo>; 2] = [None, None];
        for (index, c) in (0u8..).zip(candidates.iter_mut()) {
            *c = self.committed(index)?.ok();
        }
        let [a, b] = candidates;
        let order = match (a, b) {
            (Some(a), Some(b)) if b.seq > a.seq => [Some(b), Some(a)],
            (a, b) => [a, b],
        };
        let mut found = None;
        for info in order.into_iter().flatten() {
            if let Some(bytes) = self.read_blob(&info, buf)?
                && blob::decode_in(bytes, slot).is_ok()
            {
                found = Some(info);
                break;
            }
        }
        let info = found.ok_or(StoreError::NoValidSlot)?;
        let cal = Calibration::validate_in_place(slot).map_err(|_| StoreError::NoValidSlot)?;
        Ok((cal, info))
    }

    /// True when the lock word has been programmed.
    ///
    /// # Errors
    /// A flash error.
    pub fn is_locked(&mut self) -> Result<bool, StoreError> {
        let mut w = [0u8; 4];
        self.flash
            .read(self.lock_offset(), &mut w)
            .map_err(flash_err)?;
        Ok(w == LOCKED)
    }

    /// Locks the store against further updates, for good: the store never erases the lock
    /// sector once the lock word is in it. (A torn lock leaves the unit unlocked; lock again.)
    ///
    /// # Errors
    /// A flash error.
    pub fn lock(&mut self) -> Result<(), StoreError> {
        if self.is_locked()? {
            return Ok(());
        }
        let at = self.lock_offset();
        let mut w = [0u8; 4];
        self.flash.read(at, &mut w).map_err(flash_err)?;
        if w != [0xff; 4] {
            // Never erased, or a torn lock: start from an erased sector.
            self.flash
                .erase(at, at + F::ERASE_SIZE as u32)
                .map_err(flash_err)?;
        }
        let mut w = [0xffu8; COMMIT_SPAN];
        if let Some(word) = w.get_mut(..4) {
            word.copy_from_slice(&LOCKED);
        }
        let span = w
            .get(..4usize.next_multiple_of(F::WRITE_SIZE))
            .unwrap_or_default();
        self.flash
            .write(self.lock_offset(), span)
            .map_err(flash_err)
    }

    /// Writes `blob` as the new current calibration. `buf` must hold the blob padded to the
    /// write size; `scratch` is used to validate it first. A cut at any point leaves the old or
    /// the new calibration; when this returns `Ok`, the new one is committed.
    ///
    /// # Errors
    /// [`StoreError::Locked`], [`StoreError::InvalidBlob`] (nothing is written),
    /// [`StoreError::BlobTooLarge`], [`StoreError::BufferTooSmall`],
    /// [`StoreError::VerifyFailed`] (the old calibration stays current), flash errors.
    pub fn update(
        &mut self,
        blob: &[u8],
        buf: &mut [u8],
        scratch: &mut CalibrationData,
    ) -> Result<SlotInfo, StoreError> {
        if self.is_locked()? {
            return Err(StoreError::Locked);
        }
        blob::decode_in(blob, scratch).map_err(StoreError::InvalidBlob)?;
        if blob.len() > self.capacity() {
            return Err(StoreError::BlobTooLarge {
                len: blob.len(),
                capacity: self.capacity(),
            });
        }
        let padded = blob.len().next_multiple_of(F::WRITE_SIZE);
        if buf.len() < padded {
            return Err(StoreError::BufferTooSmall);
        }
        // The current slot stays untouched; the idle one is the other, or the older.
        let slots = [self.committed(0)?.ok(), self.committed(1)?.ok()];
        let mut current: Option<SlotInfo> = None;
        for info in slots.into_iter().flatten() {
            let valid = self
                .read_blob(&info, buf)?
                .is_some_and(|b| blob::decode_in(b, scratch).is_ok());
            if valid && current.is_none_or(|c| info.seq > c.seq) {
                current = Some(info);
            }
        }
        let idle = current.map_or(0, |c| 1 - c.index);
        let seq = current.map_or(1, |c| c.seq.wrapping_add(1));
        let start = self.slot_start(idle);
        self.flash
            .erase(start, start + self.slot_size)
            .map_err(flash_err)?;

        let data = buf.get_mut(..padded).ok_or(StoreError::BufferTooSmall)?;
        if let Some(d) = data.get_mut(..blob.len()) {
            d.copy_from_slice(blob);
        }
        if let Some(pad) = data.get_mut(blob.len()..) {
            pad.fill(0xff);
        }
        self.flash
            .write(start + BLOB_OFFSET as u32, data)
            .map_err(flash_err)?;
        let mut header = [0u8; HEADER_SPAN];
        let fields = [
            MAGIC,
            seq.to_le_bytes(),
            (blob.len() as u32).to_le_bytes(),
            blob_crc(blob).to_le_bytes(),
        ];
        for (chunk, f) in header.chunks_exact_mut(4).zip(fields) {
            chunk.copy_from_slice(&f);
        }
        self.flash
            .write(start + COMMIT_SPAN as u32, &header)
            .map_err(flash_err)?;

        // Verify what is there before committing to it.
        let mut back = [0u8; HEADER_SPAN];
        self.flash
            .read(start + COMMIT_SPAN as u32, &mut back)
            .map_err(flash_err)?;
        if back != header {
            return Err(StoreError::VerifyFailed);
        }
        let info = SlotInfo {
            index: idle,
            seq,
            len: blob.len() as u32,
        };
        match self.read_blob(&info, buf)? {
            Some(b) if b == blob => {}
            _ => return Err(StoreError::VerifyFailed),
        }
        let mut commit = [0xffu8; COMMIT_SPAN];
        if let Some(c) = commit.get_mut(..4) {
            c.copy_from_slice(&COMMIT);
        }
        self.flash.write(start, &commit).map_err(flash_err)?;
        match self.committed(idle)? {
            Ok(i) if i == info => Ok(info),
            _ => Err(StoreError::VerifyFailed),
        }
    }

    /// Reads `len` bytes of the current slot's blob from `offset` (for the update protocol's
    /// read-back).
    ///
    /// # Errors
    /// A flash error.
    pub fn read_slot(
        &mut self,
        info: &SlotInfo,
        offset: u32,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let start = self.slot_start(info.index) + BLOB_OFFSET as u32;
        self.flash.read(start + offset, out).map_err(flash_err)
    }
}

/// The bytes a slot holds after a committed update of `blob` with sequence number `seq`, for
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
    blob::decode_in(blob, scratch).map_err(StoreError::InvalidBlob)?;
    let capacity = out.len().saturating_sub(BLOB_OFFSET);
    if blob.len() > capacity {
        return Err(StoreError::BlobTooLarge {
            len: blob.len(),
            capacity,
        });
    }
    out.fill(0xff);
    let fields = [
        COMMIT,
        [0xff; 4],
        [0xff; 4],
        [0xff; 4],
        MAGIC,
        seq.to_le_bytes(),
        (blob.len() as u32).to_le_bytes(),
        blob_crc(blob).to_le_bytes(),
    ];
    for (chunk, f) in out.chunks_exact_mut(4).zip(fields) {
        chunk.copy_from_slice(&f);
    }
    if let Some(dst) = out.get_mut(BLOB_OFFSET..BLOB_OFFSET + blob.len()) {
        dst.copy_from_slice(blob);
    }
    Ok(BLOB_OFFSET + blob.len())
}

fn blob_crc(bytes: &[u8]) -> u32 {
    crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(bytes)
}
