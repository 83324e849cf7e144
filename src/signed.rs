//! Signed calibrations: a blob, then a trailer that binds it to the station that made it and
//! to a counter that only grows per unit. The store ([`crate::store`]) keeps the whole signed
//! record in a slot; a unit provisioned with station keys commits and boots only records that
//! [`verify`] (at commit) and [`check`] (at boot) accept.
//!
//! ```text
//! offset  size  field
//!      0     n  the blob, exactly as `blob::encode` writes it (its header declares n)
//!      n     2  magic "SG"
//!    n+2     1  flags: bit 0 = a downgrade made for this unit at its present counter
//!    n+3     4  key id: the first 4 bytes of SHA-256 of the station's public key
//!    n+7     4  counter, little-endian: above the one the unit holds (equal to it for a
//!               downgrade)
//!   n+11    64  Ed25519 signature of the SHA-256 digest of DOMAIN then bytes 0..n+11
//!               (the blob carries the unit's serial, so the signature binds it)
//! ```
//!
//! 75 bytes over the blob. [`verify`] (at commit) checks, in order: the trailer's presence and
//! shape, that the counter is above the unit's (or the blob is a downgrade signed for this unit
//! at its counter), that the key is one the unit holds, the signature (strict: canonical
//! encodings only), and that the blob is for the unit's serial; [`check`] (at boot) all but
//! the counter. Neither decodes anything of the payload beyond the serial; the blob itself then
//! goes through [`crate::blob::decode`] as ever.

use ed25519_dalek::{Signature, VerifyingKey};
use sha2::{Digest, Sha256};

use crate::blob::{Header, MAX_BLOB_LEN};
use crate::model::{SERIAL_CAPACITY, Serial};

/// The first two bytes of the trailer.
pub const MAGIC: [u8; 2] = *b"SG";
/// Bytes of the trailer.
pub const TRAILER_LEN: usize = 2 + 1 + 4 + 4 + 64;
/// The signed message starts with this, so that a signature made for anything else never
/// verifies here.
pub const DOMAIN: &[u8] = b"spincal signed calibration v1\0";
/// Flag bit: a signed downgrade, made for the unit at its present counter.
pub const FLAG_DOWNGRADE: u8 = 1;
/// The longest record a slot or a transfer holds: the longest blob and a trailer.
pub const MAX_SIGNED_LEN: usize = MAX_BLOB_LEN + TRAILER_LEN;

/// A station's public key, with its id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct StationKey {
    /// The Ed25519 public key.
    pub public: [u8; 32],
}

impl StationKey {
    /// The key id: the first 4 bytes of SHA-256 of the public key.
    #[must_use]
    pub fn id(&self) -> [u8; 4] {
        let h = Sha256::digest(self.public);
        let mut id = [0; 4];
        id.copy_from_slice(h.get(..4).unwrap_or(&[0; 4]));
        id
    }
}

/// What a signed blob's trailer says, once checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Verified {
    /// The counter.
    pub counter: u32,
    /// The key that signed it.
    pub key_id: [u8; 4],
    /// A downgrade signed for this unit at its present counter.
    pub downgrade: bool,
    /// Bytes of the blob (without the trailer).
    pub blob_len: usize,
}

/// Why a signed blob is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SignError {
    /// The bytes are a blob with no trailer: the unit holds station keys and takes only
    /// signed calibrations (`calflash calibrate --sign-key`, or `calflash sign`).
    Unsigned,
    /// The blob's header or the trailer is cut or malformed.
    Malformed,
    /// Signed by a key the unit does not hold.
    UnknownKey {
        /// The trailer's key id.
        key_id: [u8; 4],
    },
    /// The signature does not verify: the blob or the trailer was changed after signing.
    BadSignature,
    /// Made for another unit.
    WrongSerial,
    /// Not above the counter the unit holds (an older calibration put back), or a downgrade
    /// made for another counter than the unit's.
    Replay {
        /// The blob's counter.
        counter: u32,
        /// The unit's.
        held: u32,
    },
}

impl core::fmt::Display for SignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Unsigned => f.write_str(
                "the calibration is not signed, and the unit takes only signed ones: sign it with \
                 the station's key (`calflash calibrate --sign-key KEY`, or `calflash sign`)",
            ),
            Self::Malformed => f.write_str("the signed calibration is cut or malformed"),
            Self::UnknownKey { key_id } => write!(
                f,
                "signed by key {:02x}{:02x}{:02x}{:02x}, which the unit does not hold",
                key_id[0], key_id[1], key_id[2], key_id[3]
            ),
            Self::BadSignature => f.write_str(
                "the signature does not verify: the calibration or its trailer was changed after \
                 signing",
            ),
            Self::WrongSerial => f.write_str("the calibration was signed for another unit"),
            // Above the held counter, only a downgrade is refused: it was made for another one.
            Self::Replay { counter, held } if counter > held => write!(
                f,
                "a downgrade signed at counter {counter}, but the unit holds counter {held}: a \
                 downgrade is made for the counter the unit holds; sign it again with --downgrade \
                 --counter {held}"
            ),
            Self::Replay { counter, held } => write!(
                f,
                "counter {counter} is not above the {held} the unit holds (an older calibration, \
                 or a downgrade made for another counter): sign it again with a counter above {held}"
            ),
        }
    }
}

/// A trailer's fields, read but not checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trailer {
    /// Flag bits ([`FLAG_DOWNGRADE`]).
    pub flags: u8,
    /// The signing key's id.
    pub key_id: [u8; 4],
    /// The counter.
    pub counter: u32,
    /// The Ed25519 signature.
    pub signature: [u8; 64],
}

impl Trailer {
    /// The fields of a trailer whose magic [`split`] has checked.
    #[must_use]
    pub fn read(trailer: &[u8; TRAILER_LEN]) -> Self {
        let [_, _, flags, k0, k1, k2, k3, c0, c1, c2, c3, signature @ ..] = *trailer;
        Self {
            flags,
            key_id: [k0, k1, k2, k3],
            counter: u32::from_le_bytes([c0, c1, c2, c3]),
            signature,
        }
    }

    /// Whether a unit holding the counter `held` may take this record: its counter above
    /// `held`, or a downgrade signed at `held`.
    ///
    /// # Errors
    /// [`SignError::Replay`].
    pub const fn fresh(&self, held: u32) -> Result<(), SignError> {
        let fresh = if self.flags & FLAG_DOWNGRADE != 0 {
            self.counter == held
        } else {
            self.counter > held
        };
        if fresh {
            Ok(())
        } else {
            Err(SignError::Replay {
                counter: self.counter,
                held,
            })
        }
    }
}

/// A record as a slot holds it: the blob, and the trailer's fields when a well-formed trailer
/// follows it. Anything else is returned whole as the blob, for [`crate::blob::decode`] to say
/// what is wrong with it.
#[must_use]
pub fn parts(bytes: &[u8]) -> (&[u8], Option<Trailer>) {
    match split(bytes) {
        Ok((blob, trailer)) => (blob, Some(Trailer::read(trailer))),
        Err(_) => (bytes, None),
    }
}

/// The message the station signs: SHA-256 of [`DOMAIN`] and the blob with the trailer's first
/// 11 bytes (so that a device hashes the blob once, in place, with no copy).
#[must_use]
pub fn digest(signed: &[u8]) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(DOMAIN);
    h.update(signed);
    h.finalize().into()
}

/// Writes `blob` signed by the station `key` into `out` (the blob, then the trailer), with
/// `sign` making the Ed25519 signature of the digest ([`digest`]) with the key's private half;
/// a downgrade made for the unit at `counter` when `downgrade`. Returns the bytes written, or
/// `None` when `out` is too short. The blob is not checked here.
pub fn seal(
    blob: &[u8],
    key: &StationKey,
    counter: u32,
    downgrade: bool,
    out: &mut [u8],
    sign: impl FnOnce(&[u8; 32]) -> [u8; 64],
) -> Option<usize> {
    let n = blob.len();
    let record = out.get_mut(..n + TRAILER_LEN)?;
    let (body, signature) = record.split_at_mut(n + 11);
    let (head, trailer) = body.split_at_mut(n);
    head.copy_from_slice(blob);
    let [k0, k1, k2, k3] = key.id();
    let [c0, c1, c2, c3] = counter.to_le_bytes();
    let flags = if downgrade { FLAG_DOWNGRADE } else { 0 };
    trailer.copy_from_slice(&[MAGIC[0], MAGIC[1], flags, k0, k1, k2, k3, c0, c1, c2, c3]);
    signature.copy_from_slice(&sign(&digest(body)));
    Some(n + TRAILER_LEN)
}

/// The serial a blob's payload starts with (postcard: the identity's serial string first).
fn blob_serial(blob: &[u8]) -> Option<&str> {
    let payload = blob.get(crate::blob::HEADER_LEN..)?;
    let (&len, rest) = payload.split_first()?;
    let len = usize::from(len);
    if len > SERIAL_CAPACITY {
        return None;
    }
    core::str::from_utf8(rest.get(..len)?).ok()
}

/// The blob and the trailer of `bytes`.
///
/// # Errors
/// [`SignError::Malformed`] for a header that does not parse or bytes shorter than it declares;
/// [`SignError::Unsigned`] when nothing or something else follows the blob.
pub fn split(bytes: &[u8]) -> Result<(&[u8], &[u8; TRAILER_LEN]), SignError> {
    let header = Header::parse(bytes).map_err(|_| SignError::Malformed)?;
    let n = header.blob_len();
    let blob = bytes.get(..n).ok_or(SignError::Malformed)?;
    let rest = bytes.get(n..).unwrap_or_default();
    if rest.is_empty() || rest.get(..2) != Some(MAGIC.as_slice()) {
        return Err(SignError::Unsigned);
    }
    let trailer: &[u8; TRAILER_LEN] = rest.try_into().map_err(|_| SignError::Malformed)?;
    Ok((blob, trailer))
}

/// Checks a signed record's key, signature and serial for the unit `unit` holding `keys`,
/// whatever its counter (at boot: the counter was checked when it was committed).
///
/// # Errors
/// The first [`SignError`] found, in the order of the module docs (all but the counter).
pub fn check(bytes: &[u8], keys: &[StationKey], unit: &Serial) -> Result<Verified, SignError> {
    let (blob, trailer) = split(bytes)?;
    let t = Trailer::read(trailer);
    let key_id = t.key_id;
    let key = keys
        .iter()
        .find(|k| k.id() == key_id)
        .ok_or(SignError::UnknownKey { key_id })?;
    let public =
        VerifyingKey::from_bytes(&key.public).map_err(|_| SignError::UnknownKey { key_id })?;
    let serial = blob_serial(blob).ok_or(SignError::Malformed)?;
    let signed = bytes.get(..blob.len() + 11).ok_or(SignError::Malformed)?;
    public
        .verify_strict(&digest(signed), &Signature::from_bytes(&t.signature))
        .map_err(|_| SignError::BadSignature)?;
    if serial != unit.as_str() {
        return Err(SignError::WrongSerial);
    }
    Ok(Verified {
        counter: t.counter,
        key_id,
        downgrade: t.flags & FLAG_DOWNGRADE != 0,
        blob_len: blob.len(),
    })
}

/// Checks a signed blob offered to the unit `unit` holding `keys` and the counter `held`: its
/// counter is above `held` (or it is a downgrade signed at `held`), then as [`check`].
///
/// # Errors
/// The first [`SignError`] found, in the order of the module docs.
pub fn verify(
    bytes: &[u8],
    keys: &[StationKey],
    unit: &Serial,
    held: u32,
) -> Result<Verified, SignError> {
    // The counter first: a replay is refused without the cost of a signature check (refusing
    // on a trailer not yet authenticated is safe; accepting waits for the signature).
    let (_, trailer) = split(bytes)?;
    Trailer::read(trailer).fresh(held)?;
    check(bytes, keys, unit)
}
