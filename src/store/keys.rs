//! The keys sector: the station public keys a unit is provisioned with at manufacture, written
//! once by a flasher (`calflash image --station-key`) or [`super::Store::provision`]; the store
//! never erases or writes a sound keys record.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "SKEY"
//!      4     1  number of keys, 1 to MAX_KEYS
//!      5     3  0xFF
//!      8  32*n  the Ed25519 public keys
//!   8+32n    4  CRC-32C of bytes 0..8+32n, little-endian
//! ```
//!
//! An erased sector (all 0xFF where the record would be), or one never erased (all 0x00), is an
//! unprovisioned unit; anything else that is not a sound record is a damaged one, which trusts
//! no key (fails closed).

use crate::signed::StationKey;

/// The most station keys a unit holds.
pub const MAX_KEYS: usize = 4;
/// Bytes of the largest keys record.
pub const KEYS_SPAN: usize = 8 + 32 * MAX_KEYS + 4;
const MAGIC: [u8; 4] = *b"SKEY";

/// The station keys a unit holds.
pub type StationKeys = heapless::Vec<StationKey, MAX_KEYS>;

/// What the keys sector says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Provisioning {
    /// Erased: a developer's board, which takes unsigned calibrations.
    Unprovisioned,
    /// Provisioned with these keys: it takes only calibrations signed by one of them.
    Provisioned(StationKeys),
    /// Written but not a sound record (a torn provisioning, or damage): the unit trusts no key
    /// and takes nothing until it is provisioned again by a flasher.
    Damaged,
}

impl Provisioning {
    /// Reads a keys record (the sector's first [`KEYS_SPAN`] bytes).
    #[must_use]
    pub fn read(bytes: &[u8; KEYS_SPAN]) -> Self {
        // Erased, or never erased (all zeros, as the RAM standing in for flash powers up): no
        // record was ever written. A torn or damaged record is neither (it keeps both 0 and 1
        // bits of the magic and the padding).
        if bytes.iter().all(|b| *b == 0xff) || bytes.iter().all(|b| *b == 0) {
            return Self::Unprovisioned;
        }
        let [m0, m1, m2, m3, count, p0, p1, p2, ..] = *bytes;
        let n = usize::from(count);
        if [m0, m1, m2, m3] != MAGIC || n == 0 || n > MAX_KEYS || [p0, p1, p2] != [0xff; 3] {
            return Self::Damaged;
        }
        let end = 8 + 32 * n;
        let (Some(body), Some(crc)) = (bytes.get(..end), bytes.get(end..end + 4)) else {
            return Self::Damaged;
        };
        let stored = crc.try_into().ok().map(u32::from_le_bytes);
        if stored != Some(super::blob_crc(body)) {
            return Self::Damaged;
        }
        let mut keys = StationKeys::new();
        for k in body.get(8..).unwrap_or_default().chunks_exact(32) {
            let mut public = [0u8; 32];
            public.copy_from_slice(k);
            // At most MAX_KEYS chunks: the push cannot fail.
            let _ = keys.push(StationKey { public });
        }
        Self::Provisioned(keys)
    }

    /// The keys trusted: none when unprovisioned or damaged.
    #[must_use]
    pub fn keys(&self) -> &[StationKey] {
        match self {
            Self::Provisioned(k) => k,
            Self::Unprovisioned | Self::Damaged => &[],
        }
    }
}

/// The keys record a flasher writes at the start of the keys sector; `out` is filled with 0xFF
/// first. Returns the bytes used.
///
/// # Errors
/// `None` when `keys` is empty, holds more than [`MAX_KEYS`], or `out` is too short.
pub fn keys_record(keys: &[StationKey], out: &mut [u8]) -> Option<usize> {
    if keys.is_empty() || keys.len() > MAX_KEYS {
        return None;
    }
    let end = 8 + 32 * keys.len();
    if out.len() < end + 4 {
        return None;
    }
    out.fill(0xff);
    let (head, rest) = out.split_at_mut(8);
    head.copy_from_slice(&[
        MAGIC[0],
        MAGIC[1],
        MAGIC[2],
        MAGIC[3],
        keys.len() as u8,
        0xff,
        0xff,
        0xff,
    ]);
    for (dst, k) in rest.chunks_exact_mut(32).zip(keys) {
        dst.copy_from_slice(&k.public);
    }
    let crc = super::blob_crc(out.get(..end)?);
    out.get_mut(end..end + 4)?
        .copy_from_slice(&crc.to_le_bytes());
    Some(end + 4)
}
