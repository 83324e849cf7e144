//! The calibration store: two slots over an `embedded-storage` [`NorFlash`], so that a power
//! cut at any moment of an update leaves the old calibration or the new one, never neither and
//! never a mix.
//!
//! ```text
//! region:  [ slot 0 | slot 1 | lock sector | keys sector ]   slots: whole erase sectors
//! slot:    offset 0   commit marker (16 bytes)       written last
//!          offset 16  header: magic, sequence, length, CRC-32C of the record (16 bytes)
//!          offset 32  the record, padded to the write size with 0xFF
//! ```
//!
//! An update validates the record, erases the idle slot (never the current one), writes it,
//! then the header with the next sequence number, reads both back and compares them, and only
//! then programs the commit marker. A slot counts only when its marker is exactly the commit
//! pattern (a torn program leaves extra 1 bits, so a half-written marker never matches), its
//! header is sound and the CRC over the record matches. Boot ([`Store::load`]) takes the valid
//! slot with the highest sequence number whose blob also decodes and validates, reads it once into
//! RAM and hands out only that validated copy. Boot writes nothing, so a cut during it cannot
//! harm anything. NOR semantics are kept: erase sets 0xFF, programming only clears bits, and
//! every byte is programmed at most once per erase.
//!
//! Sequence numbers are `u32`: four billion updates of one unit before they wrap.
//!
//! A slot holds a record: a blob, or a blob and its signature trailer ([`crate::signed`]).
//! Under [`Policy::Signed`] (a unit provisioned with station keys, [`Provisioning`]) a slot counts only
//! when its record is signed by a held key for the unit, and an update is committed only when
//! it verifies and its counter is above the current slot's (or it is a downgrade signed at that
//! counter). The counter lives in the committed records, so the A/B slots keep it across cuts:
//! a cut leaves the old record (and its counter) or the new one.

mod error;
mod keys;
mod slot;

pub use error::StoreError;
use error::flash_err;
pub use keys::{KEYS_SPAN, MAX_KEYS, Provisioning, StationKeys, keys_record};
pub use slot::{SlotInfo, SlotState, slot_image};

use slot::{BLOB_OFFSET, COMMIT, COMMIT_SPAN, HEADER_SPAN, blob_crc};

use embedded_storage::nor_flash::NorFlash;

use crate::blob;
use crate::model::{Calibration, CalibrationData, Serial};
use crate::signed::{self, MAX_SIGNED_LEN, SignError, StationKey};

/// The lock word: the store is locked when the lock sector starts with exactly this.
const LOCKED: [u8; 4] = *b"LOCK";

/// What a slot's record must be to count.
#[derive(Debug, Clone, Copy)]
pub enum Policy<'a> {
    /// An unprovisioned unit: any valid blob, signed or not (a trailer is kept, not checked).
    Open,
    /// A provisioned unit: records signed by one of `keys` for `unit` only (no keys: nothing).
    Signed {
        /// The station keys held.
        keys: &'a [StationKey],
        /// The unit's serial.
        unit: &'a Serial,
    },
}

impl Provisioning {
    /// What the store takes on a unit so provisioned, whose serial is `unit`: anything valid
    /// when unprovisioned; records signed for `unit` by a held key when provisioned; nothing
    /// when the keys are damaged.
    #[must_use]
    pub fn policy<'a>(&'a self, unit: &'a Serial) -> Policy<'a> {
        match self {
            Self::Unprovisioned => Policy::Open,
            p => Policy::Signed {
                keys: p.keys(),
                unit,
            },
        }
    }
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
    /// the lock word and one for the station keys ([`Store::provisioning`]).
    ///
    /// # Errors
    /// [`StoreError::Layout`] when the region is not sector-aligned or does not fit.
    pub fn new(flash: F, base: u32, slot_size: u32) -> Result<Self, StoreError> {
        let erase = F::ERASE_SIZE as u64;
        let end = u64::from(base) + 2 * u64::from(slot_size) + 2 * erase;
        let ok = erase > 0
            && F::WRITE_SIZE > 0
            && F::WRITE_SIZE <= COMMIT_SPAN
            && COMMIT_SPAN % F::WRITE_SIZE == 0
            && F::ERASE_SIZE >= KEYS_SPAN
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

    /// Bytes of the whole region: two slots of `slot_size`, the lock sector and the keys sector
    /// of `erase` bytes each.
    #[must_use]
    pub const fn region_len(slot_size: u32, erase: u32) -> u32 {
        2 * slot_size + 2 * erase
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

    fn keys_offset(&self) -> u32 {
        self.lock_offset() + F::ERASE_SIZE as u32
    }

    /// What the keys sector says: unprovisioned, the station keys held, or damaged.
    ///
    /// # Errors
    /// A flash error.
    pub fn provisioning(&mut self) -> Result<Provisioning, StoreError> {
        let mut record = [0u8; KEYS_SPAN];
        self.flash
            .read(self.keys_offset(), &mut record)
            .map_err(flash_err)?;
        Ok(Provisioning::read(&record))
    }

    /// Provisions the unit with station `keys` (manufacture; a flasher may write the same
    /// record, [`keys_record`], instead). Once only: a unit that holds keys refuses, and the
    /// store never erases a sound keys record; a sector that is not erased (never erased, or a
    /// torn provisioning) is erased first. A cut while programming leaves
    /// the sector damaged, which trusts no key ([`Provisioning::Damaged`]) until provisioned.
    ///
    /// # Errors
    /// [`StoreError::Layout`] for no keys or more than [`MAX_KEYS`], [`StoreError::Locked`] when
    /// the unit holds keys already, a flash error, or [`StoreError::VerifyFailed`].
    pub fn provision(&mut self, keys: &[StationKey]) -> Result<(), StoreError> {
        let at = self.keys_offset();
        let mut sector = [0u8; KEYS_SPAN];
        self.flash.read(at, &mut sector).map_err(flash_err)?;
        if let Provisioning::Provisioned(_) = Provisioning::read(&sector) {
            return Err(StoreError::Locked);
        }
        if sector.iter().any(|b| *b != 0xff) {
            // Never erased, or a torn provisioning: start from an erased sector.
            self.flash
                .erase(at, at + F::ERASE_SIZE as u32)
                .map_err(flash_err)?;
        }
        // Room for the record padded to any write size.
        let mut record = [0u8; KEYS_SPAN + COMMIT_SPAN];
        let n = keys_record(keys, &mut record).ok_or(StoreError::Layout)?;
        let span = record
            .get(..n.next_multiple_of(F::WRITE_SIZE))
            .ok_or(StoreError::Layout)?;
        self.flash.write(at, span).map_err(flash_err)?;
        match self.provisioning()? {
            Provisioning::Provisioned(k) if k.as_slice() == keys => Ok(()),
            _ => Err(StoreError::VerifyFailed),
        }
    }

    /// The header of a slot, if its commit marker and header are sound.
    fn committed(&mut self, index: u8) -> Result<Result<SlotInfo, SlotState>, StoreError> {
        let start = self.slot_start(index);
        let mut head = [0u8; BLOB_OFFSET];
        self.flash.read(start, &mut head).map_err(flash_err)?;
        if head.iter().all(|b| *b == 0xff) {
            return Ok(Err(SlotState::Empty));
        }
        // A length no valid blob can have (beyond the slot, or beyond the largest blob) makes
        // the slot invalid; it must never turn into an error that hides the other slot.
        let longest = self.capacity().min(MAX_SIGNED_LEN);
        let Some((seq, len)) = slot::sound_head(&head, longest) else {
            return Ok(Err(SlotState::Invalid));
        };
        Ok(Ok(SlotInfo {
            index,
            seq,
            len,
            counter: 0,
            signed_by: None,
        }))
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

    /// Whether a committed slot's record counts under `policy`: its CRC; under a signed policy
    /// its signature, key and serial ([`signed::check`]); then the blob decoding and validating
    /// into `scratch`. `Err(Some(why))` for a record the policy refuses.
    fn trusted(
        &mut self,
        info: SlotInfo,
        buf: &mut [u8],
        scratch: &mut CalibrationData,
        policy: Policy<'_>,
    ) -> Result<Result<SlotInfo, Option<SignError>>, StoreError> {
        let Some(record) = self.read_blob(&info, buf)? else {
            return Ok(Err(None));
        };
        if let Policy::Signed { keys, unit } = policy
            && let Err(why) = signed::check(record, keys, unit)
        {
            return Ok(Err(Some(why)));
        }
        let (blob, trailer) = signed::parts(record);
        if blob::decode_in(blob, scratch).is_err() {
            return Ok(Err(None));
        }
        Ok(Ok(SlotInfo {
            counter: trailer.map_or(0, |t| t.counter),
            signed_by: trailer.map(|t| t.key_id),
            ..info
        }))
    }

    /// The committed slots, newest first.
    fn newest_first(&mut self) -> Result<[Option<SlotInfo>; 2], StoreError> {
        let a = self.committed(0)?.ok();
        let b = self.committed(1)?.ok();
        Ok(match (a, b) {
            (Some(a), Some(b)) if b.seq > a.seq => [Some(b), Some(a)],
            (a, b) => [a, b],
        })
    }

    /// The newest slot that counts under `policy`, and why the newest refused one was refused.
    fn current(
        &mut self,
        buf: &mut [u8],
        scratch: &mut CalibrationData,
        policy: Policy<'_>,
    ) -> Result<(Option<SlotInfo>, Option<SignError>), StoreError> {
        let mut refused = None;
        for info in self.newest_first()?.into_iter().flatten() {
            match self.trusted(info, buf, scratch, policy)? {
                Ok(found) => return Ok((Some(found), refused)),
                Err(why) => refused = refused.or(why),
            }
        }
        Ok((None, refused))
    }

    /// The state of both slots, each fully checked as boot checks it (commit marker, header,
    /// CRC, under a signed policy the signature, and the blob decoding and validating into
    /// `scratch`). `buf` must hold a slot's record.
    ///
    /// # Errors
    /// A flash error, or a buffer too small.
    pub fn scan(
        &mut self,
        buf: &mut [u8],
        scratch: &mut CalibrationData,
        policy: Policy<'_>,
    ) -> Result<[SlotState; 2], StoreError> {
        let mut out = [SlotState::Empty; 2];
        for (index, state) in (0u8..).zip(out.iter_mut()) {
            *state = match self.committed(index)? {
                Err(s) => s,
                Ok(info) => match self.trusted(info, buf, scratch, policy)? {
                    Ok(i) => SlotState::Valid {
                        seq: i.seq,
                        len: i.len,
                    },
                    Err(_) => SlotState::Invalid,
                },
            };
        }
        Ok(out)
    }

    /// Boot: the newest slot whose record checks under `policy`, decodes and validates, read
    /// once into `buf` and decoded into `slot`; the returned calibration is that RAM copy.
    ///
    /// # Errors
    /// [`StoreError::Refused`] when no slot holds a record the policy trusts and one was
    /// refused for its signature (the newest such reason); [`StoreError::NoValidSlot`] when
    /// neither slot holds a valid calibration at all.
    pub fn load<'a>(
        &mut self,
        buf: &mut [u8],
        slot: &'a mut CalibrationData,
        policy: Policy<'_>,
    ) -> Result<(&'a Calibration, SlotInfo), StoreError> {
        let (found, refused) = self.current(buf, slot, policy)?;
        let Some(info) = found else {
            return Err(refused.map_or(StoreError::NoValidSlot, StoreError::Refused));
        };
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

    /// Writes `record` (a blob, or a signed blob) as the new current calibration. `buf` must
    /// hold the record padded to the write size; `scratch` is used to validate it first. Under
    /// [`Policy::Signed`] the record must verify for the unit with a counter above the current
    /// slot's ([`signed::verify`]); the current record offered again is current already, and
    /// nothing is written. A cut at any point leaves the old or the new calibration;
    /// when this returns `Ok`, the new one is committed.
    ///
    /// # Errors
    /// [`StoreError::Locked`], [`StoreError::InvalidBlob`] and [`StoreError::Refused`] (nothing
    /// is written), [`StoreError::BlobTooLarge`], [`StoreError::BufferTooSmall`],
    /// [`StoreError::VerifyFailed`] (the old calibration stays current), flash errors.
    pub fn update(
        &mut self,
        record: &[u8],
        buf: &mut [u8],
        scratch: &mut CalibrationData,
        policy: Policy<'_>,
    ) -> Result<SlotInfo, StoreError> {
        if self.is_locked()? {
            return Err(StoreError::Locked);
        }
        let (blob_part, trailer) = signed::parts(record);
        blob::decode_in(blob_part, scratch).map_err(StoreError::InvalidBlob)?;
        if record.len() > self.capacity() {
            return Err(StoreError::BlobTooLarge {
                len: record.len(),
                capacity: self.capacity(),
            });
        }
        let padded = record.len().next_multiple_of(F::WRITE_SIZE);
        if buf.len() < padded {
            return Err(StoreError::BufferTooSmall);
        }
        // The current slot (the one boot takes) stays untouched; the idle one is the other.
        let (current, _) = self.current(buf, scratch, policy)?;
        if let Policy::Signed { keys, unit } = policy {
            // The very record that is current again (a retry after a commit whose answer was
            // lost): done, with nothing written; its counter would refuse it as a replay.
            if let Some(c) = current
                && buf.get(..c.len as usize) == Some(record)
            {
                return Ok(c);
            }
            let held = current.map_or(0, |c| c.counter);
            signed::verify(record, keys, unit, held).map_err(StoreError::Refused)?;
        }
        let idle = current.map_or(0, |c| 1 - c.index);
        let seq = current.map_or(1, |c| c.seq.wrapping_add(1));
        let start = self.slot_start(idle);
        self.flash
            .erase(start, start + self.slot_size)
            .map_err(flash_err)?;

        let data = buf.get_mut(..padded).ok_or(StoreError::BufferTooSmall)?;
        if let Some(d) = data.get_mut(..record.len()) {
            d.copy_from_slice(record);
        }
        if let Some(pad) = data.get_mut(record.len()..) {
            pad.fill(0xff);
        }
        self.flash
            .write(start + BLOB_OFFSET as u32, data)
            .map_err(flash_err)?;
        let header = slot::header(seq, record);
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
            len: record.len() as u32,
            counter: trailer.map_or(0, |t| t.counter),
            signed_by: trailer.map(|t| t.key_id),
        };
        match self.read_blob(&info, buf)? {
            Some(b) if b == record => {}
            _ => return Err(StoreError::VerifyFailed),
        }
        let mut commit = [0xffu8; COMMIT_SPAN];
        if let Some(c) = commit.get_mut(..4) {
            c.copy_from_slice(&COMMIT);
        }
        self.flash.write(start, &commit).map_err(flash_err)?;
        match self.committed(idle)? {
            Ok(i) if (i.index, i.seq, i.len) == (info.index, info.seq, info.len) => Ok(info),
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
