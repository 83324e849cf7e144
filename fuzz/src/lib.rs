//! Shared by the fuzz targets: a RAM NOR flash with NOR rules, blob sealing, and running a
//! decoded calibration through the correction.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use spincal::blob::{FORMAT_VERSION, HEADER_LEN, MAGIC};
use spincal::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector};
use spincal::model::{Calibration, Sensor};

/// A NOR flash in RAM: erase sets 0xFF, programming clears bits (AND), 4-byte writes, 1 KiB
/// sectors. Out-of-bounds or misaligned access is an error, as on a real part.
#[derive(Debug, Clone)]
pub struct RamNor {
    /// The contents.
    pub mem: Vec<u8>,
}

/// The flash's error kind.
#[derive(Debug)]
pub struct RamNorError(NorFlashErrorKind);

impl NorFlashError for RamNorError {
    fn kind(&self) -> NorFlashErrorKind {
        self.0
    }
}

impl ErrorType for RamNor {
    type Error = RamNorError;
}

impl RamNor {
    fn range(
        &self,
        offset: u32,
        len: usize,
        align: usize,
    ) -> Result<core::ops::Range<usize>, RamNorError> {
        let o = offset as usize;
        if !o.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(RamNorError(NorFlashErrorKind::NotAligned));
        }
        match o.checked_add(len) {
            Some(end) if end <= self.mem.len() => Ok(o..end),
            _ => Err(RamNorError(NorFlashErrorKind::OutOfBounds)),
        }
    }
}

impl ReadNorFlash for RamNor {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamNorError> {
        let r = self.range(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.mem[r]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for RamNor {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 1024;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamNorError> {
        let len = to
            .checked_sub(from)
            .ok_or(RamNorError(NorFlashErrorKind::OutOfBounds))? as usize;
        let r = self.range(from, len, Self::ERASE_SIZE)?;
        self.mem[r].fill(0xff);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamNorError> {
        let r = self.range(offset, bytes.len(), Self::WRITE_SIZE)?;
        for (m, b) in self.mem[r].iter_mut().zip(bytes) {
            *m &= b;
        }
        Ok(())
    }
}

/// `payload` behind a valid header (magic, version, length, CRC-32C), so that the fuzzer reaches
/// the payload decoder and validation instead of stopping at the checksum.
#[must_use]
pub fn seal(payload: &[u8]) -> Vec<u8> {
    let len = u16::try_from(payload.len()).unwrap_or(u16::MAX);
    let payload = &payload[..usize::from(len)];
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&MAGIC);
    out.push(FORMAT_VERSION);
    out.extend_from_slice(&len.to_le_bytes());
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
    let mut d = crc.digest();
    d.update(&out);
    d.update(payload);
    out.extend_from_slice(&d.finalize().to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// Runs raw samples derived from `seed` (as `i32`, clamped to the calibration's sample format)
/// through the correction `cal` builds; every output must be finite or flagged.
pub fn exercise(cal: &Calibration, seed: &[u8]) {
    let raw = |k: usize, a: usize| -> i32 {
        let b = |i: usize| {
            seed.get((k * 6 + a + i) % seed.len().max(1))
                .copied()
                .unwrap_or(0)
        };
        i32::from_le_bytes([b(0), b(1), b(2), b(3)]) >> (b(4) % 24)
    };
    let env = |k: usize| (f32::from(seed.get(k).copied().unwrap_or(25)) - 100.0, 3.3);
    match &cal.data().sensor {
        Sensor::Single { .. } => {
            let mut c = AnyAxisCorrector::new(cal).expect("a valid calibration's corrector");
            let (t, v) = env(0);
            c.set_environment(t, v);
            for k in 0..8 {
                let o = c.correct(raw(k, 0));
                assert!(o.values[0].is_finite() || !o.flags.is_clean(), "{o:?}");
            }
        }
        Sensor::Triad { .. } => {
            let mut c = AnyTriadCorrector::new(cal).expect("a valid calibration's corrector");
            let (t, v) = env(1);
            c.set_environment(t, v);
            for k in 0..8 {
                let o = c.correct(core::array::from_fn(|a| raw(k, a)));
                assert!(
                    o.values.iter().all(|x| x.is_finite()) || !o.flags.is_clean(),
                    "{o:?}"
                );
            }
        }
        Sensor::Imu { .. } => {
            let mut c = AnyImuCorrector::new(cal, 1000.0).expect("a valid calibration's corrector");
            let (t, v) = env(2);
            c.set_environment(t, v);
            for k in 0..8 {
                let o = c.correct(core::array::from_fn(|a| raw(k, a)));
                assert!(
                    o.values.iter().all(|x| x.is_finite()) || !o.flags.is_clean(),
                    "{o:?}"
                );
            }
        }
    }
}

/// The station of the fuzz targets' provisioned units: its signing key and public key.
#[must_use]
pub fn station() -> (ed25519_dalek::SigningKey, spincal::signed::StationKey) {
    let key = ed25519_dalek::SigningKey::from_bytes(&[9; 32]);
    let public = spincal::signed::StationKey {
        public: key.verifying_key().to_bytes(),
    };
    (key, public)
}

/// `blob` signed by `key` at `counter` (a downgrade when `downgrade`).
///
/// # Panics
/// Never: the buffer holds the blob and its trailer.
#[must_use]
pub fn sign(
    blob: &[u8],
    key: &ed25519_dalek::SigningKey,
    counter: u32,
    downgrade: bool,
) -> Vec<u8> {
    use ed25519_dalek::Signer;
    let public = spincal::signed::StationKey {
        public: key.verifying_key().to_bytes(),
    };
    let mut out = vec![0u8; blob.len() + spincal::signed::TRAILER_LEN];
    let n = spincal::signed::seal(blob, &public, counter, downgrade, &mut out, |d| {
        key.sign(d).to_bytes()
    })
    .expect("room for the trailer");
    out.truncate(n);
    out
}
