//! Region images for any flasher: the calibration region exactly as an update leaves it (slot 0
//! committed with the blob, slot 1 and the lock sector erased) and, for a unit provisioned at
//! manufacture, the keys sector holding the station public keys; as raw binary and as Intel
//! HEX at the region's address from `memory.x`.

use spincal::model::CalibrationData;
use spincal::signed::StationKey;
use spincal::store;

/// The example target's memory map, as the firmware links it.
const MEMORY_X: &str = include_str!("../../../../memory.x");

/// Where the calibration region is: its address, slot size and total size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// Address of slot 0.
    pub start: u32,
    /// Bytes per slot.
    pub slot_size: u32,
    /// Bytes of the lock sector after the two slots, and of the keys sector after it.
    pub lock_size: u32,
}

fn symbol(name: &str) -> Option<u32> {
    let line = MEMORY_X
        .lines()
        .find(|l| l.trim_start().starts_with(name))?;
    let value = line.split('=').nth(1)?.trim().trim_end_matches(';').trim();
    u32::from_str_radix(value.trim_start_matches("0x"), 16).ok()
}

impl Region {
    /// The region of `memory.x` (`_calib_start`, `_calib_slot_size`; a 4 KiB lock sector and a
    /// 4 KiB keys sector).
    ///
    /// # Panics
    /// When `memory.x` lacks the symbols (a build error of this repository).
    #[must_use]
    pub fn from_memory_x() -> Self {
        Self {
            start: symbol("_calib_start").expect("memory.x defines _calib_start"),
            slot_size: symbol("_calib_slot_size").expect("memory.x defines _calib_slot_size"),
            lock_size: 4096,
        }
    }

    /// Bytes of the whole region: two slots, the lock sector and the keys sector.
    #[must_use]
    pub const fn bytes(&self) -> u32 {
        2 * self.slot_size + 2 * self.lock_size
    }

    /// Offset of the keys sector in the region.
    #[must_use]
    pub const fn keys_offset(&self) -> u32 {
        2 * self.slot_size + self.lock_size
    }
}

/// Why a unit's image cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The blob is invalid or does not fit a slot.
    #[error(transparent)]
    Slot(#[from] store::StoreError),
    /// More station keys than a unit holds (or none where some are needed).
    #[error("{given} station keys; a unit holds 1 to {max}")]
    Keys {
        /// Keys given.
        given: usize,
        /// The most a unit holds.
        max: usize,
    },
    /// The Intel HEX writer's error.
    #[error(transparent)]
    Hex(#[from] ihex::WriterError),
}

/// The region's bytes after committing `blob` into slot 0 with sequence number 1 (a signed
/// blob keeps its trailer).
///
/// # Errors
/// When the blob is invalid or does not fit a slot.
pub fn region_image(blob: &[u8], region: Region) -> Result<Vec<u8>, Error> {
    unit_image(Some(blob), &[], region)
}

/// The region a flasher writes into a unit at manufacture: slot 0 committed with `blob` when
/// given (a provisioned unit boots only a blob signed by one of `keys` for it), the other
/// sectors erased, and the keys sector provisioned with `keys` when any.
///
/// # Errors
/// An invalid blob or one that does not fit a slot; more keys than a unit holds.
pub fn unit_image(
    blob: Option<&[u8]>,
    keys: &[StationKey],
    region: Region,
) -> Result<Vec<u8>, Error> {
    let mut out = vec![0xffu8; region.bytes() as usize];
    if let Some(blob) = blob {
        let mut scratch = CalibrationData::empty();
        store::slot_image(blob, 1, &mut out[..region.slot_size as usize], &mut scratch)?;
    }
    if !keys.is_empty() {
        let at = region.keys_offset() as usize;
        store::keys_record(keys, &mut out[at..at + region.lock_size as usize]).ok_or(
            Error::Keys {
                given: keys.len(),
                max: store::MAX_KEYS,
            },
        )?;
    }
    Ok(out)
}

/// Intel HEX of `bytes` at `address`, with extended linear address records.
///
/// # Errors
/// The writer's.
pub fn intel_hex(bytes: &[u8], address: u32) -> Result<String, Error> {
    let mut records = Vec::new();
    let mut upper = None;
    for (k, chunk) in bytes.chunks(16).enumerate() {
        let at = address + (k * 16) as u32;
        if upper != Some(at >> 16) {
            upper = Some(at >> 16);
            records.push(ihex::Record::ExtendedLinearAddress((at >> 16) as u16));
        }
        records.push(ihex::Record::Data {
            offset: (at & 0xffff) as u16,
            value: chunk.to_vec(),
        });
    }
    records.push(ihex::Record::EndOfFile);
    Ok(ihex::create_object_file_representation(&records)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_refuses_an_invalid_blob_and_too_many_keys() {
        let region = Region::from_memory_x();
        let e = region_image(&[0u8; 8], region).unwrap_err();
        assert!(matches!(e, Error::Slot(_)), "{e:?}");
        let keys = [StationKey { public: [7; 32] }; store::MAX_KEYS + 1];
        let e = unit_image(None, &keys, region).unwrap_err();
        assert!(matches!(e, Error::Keys { given: 5, max: 4 }), "{e:?}");
        assert_eq!(e.to_string(), "5 station keys; a unit holds 1 to 4");
        assert!(unit_image(None, &keys[..4], region).is_ok());
    }

    #[test]
    fn region_and_hex() {
        let r = Region::from_memory_x();
        assert_eq!(
            r,
            Region {
                start: 0x003e_e000,
                slot_size: 0x8000,
                lock_size: 4096
            }
        );
        let hex = intel_hex(&[1, 2, 3], 0x003f_fffe).unwrap();
        let lines: Vec<&str> = hex.lines().collect();
        assert_eq!(lines[0], ":02000004003FBB");
        assert!(lines.last().unwrap().starts_with(":00000001FF"));
        let back = ihex::Reader::new(&hex).count();
        assert_eq!(back, lines.len());
    }
}
