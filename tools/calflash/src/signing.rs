//! The station's keys and signed calibrations (issue 17): an Ed25519 key pair in two files,
//! and the signed blob a provisioned unit checks (`spincal::signed`).
//!
//! Key files are hex text: the private one holds the 32-byte seed and must be readable by its
//! owner only; the public one the 32-byte public key.

use std::io::Write;
use std::path::{Path, PathBuf};

use ed25519_dalek::{Signer, SigningKey};
use spincal::signed::{self, StationKey};

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Why a key file cannot be written or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum KeyError {
    /// A key file to write that exists already.
    #[error("{}: exists; a key is never overwritten (move it away first)", .0.display())]
    Exists(PathBuf),
    /// A key file that cannot be read or written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The public key cannot be written.
    #[error(transparent)]
    Write(#[from] crate::files::Error),
    /// A key file that is not 64 hex digits.
    #[error("{}: expected 64 hex digits (a key written by `calflash keygen`)", .0.display())]
    Malformed(PathBuf),
    /// A private key that group or others may read.
    #[error(
        "{}: the private key is readable by others (mode {mode:o}); it signs every unit's \
         calibration: `chmod 600 {}` and keep it so",
        .path.display(),
        .path.display()
    )]
    Exposed {
        /// The file.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
}

/// An I/O failure on key file `path`.
fn io(path: &Path) -> impl Fn(std::io::Error) -> KeyError + '_ {
    move |source| KeyError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn unhex32(text: &str, path: &Path) -> Result<[u8; 32], KeyError> {
    let t = text.trim();
    let bad = || KeyError::Malformed(path.to_path_buf());
    if t.len() != 64 {
        return Err(bad());
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(t.get(2 * i..2 * i + 2).ok_or_else(bad)?, 16).map_err(|_| bad())?;
    }
    Ok(out)
}

/// Writes a new key pair: `private` (mode 0600) and `public`; returns the key id. Neither file
/// may exist.
///
/// # Errors
/// A file that exists or cannot be written, named.
pub fn keygen(private: &Path, public: &Path) -> Result<[u8; 4], KeyError> {
    for p in [private, public] {
        if p.exists() {
            return Err(KeyError::Exists(p.to_path_buf()));
        }
    }
    let seed: [u8; 32] = rand::random();
    let key = SigningKey::from_bytes(&seed);
    let station = StationKey {
        public: key.verifying_key().to_bytes(),
    };
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut opts, 0o600);
    let mut f = opts.open(private).map_err(io(private))?;
    writeln!(f, "{}", hex(&seed)).map_err(io(private))?;
    f.sync_all().map_err(io(private))?;
    crate::files::write_atomically(public, |w| writeln!(w, "{}", hex(&station.public)))?;
    Ok(station.id())
}

/// The station's private key from `path`, refused when others may read the file.
///
/// # Errors
/// A missing or malformed file, or one readable by group or others.
pub fn load_private(path: &Path) -> Result<SigningKey, KeyError> {
    let meta = std::fs::metadata(path).map_err(io(path))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = meta.permissions().mode();
        if mode & 0o077 != 0 {
            return Err(KeyError::Exposed {
                path: path.to_path_buf(),
                mode: mode & 0o777,
            });
        }
    }
    #[cfg(not(unix))]
    let _ = meta;
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    Ok(SigningKey::from_bytes(&unhex32(&text, path)?))
}

/// A station's public key from `path`.
///
/// # Errors
/// A missing or malformed file.
pub fn load_public(path: &Path) -> Result<StationKey, KeyError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    Ok(StationKey {
        public: unhex32(&text, path)?,
    })
}

/// The station key to sign with: `given`, else `$CALFLASH_SIGN_KEY` when set.
#[must_use]
pub fn key_path(given: Option<&Path>) -> Option<std::path::PathBuf> {
    given
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os("CALFLASH_SIGN_KEY").map(std::path::PathBuf::from))
}

/// The calibration a blob file or a unit's record holds, signed or not (a signed blob's
/// trailer is set aside; only a unit can check it against its keys).
///
/// # Errors
/// What is wrong with the blob.
pub fn calibration(bytes: &[u8]) -> Result<spincal::model::Calibration, spincal::Error> {
    spincal::blob::decode(signed::parts(bytes).0)
}

/// The signer's key id (hex) and counter of a signed record; `None` when unsigned.
#[must_use]
pub fn signer(bytes: &[u8]) -> Option<(String, u32)> {
    signed::parts(bytes).1.map(|t| (hex(&t.key_id), t.counter))
}
/// Why a blob cannot be signed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SealError {
    /// It carries a trailer already.
    #[error("the blob is signed already")]
    SignedAlready,
    /// It does not decode.
    #[error("not a calibration blob: {0}")]
    NotBlob(spincal::Error),
    /// Blob and trailer are longer than a slot holds.
    #[error("the signed blob does not fit its buffer")]
    TooLong,
}

/// `blob` signed with `key` at `counter` (a downgrade made for the unit at that counter when
/// `downgrade`).
///
/// # Errors
/// A blob that does not decode, or one already signed.
pub fn sign(
    blob: &[u8],
    key: &SigningKey,
    counter: u32,
    downgrade: bool,
) -> Result<Vec<u8>, SealError> {
    spincal::blob::decode(blob).map_err(|e| {
        if signed::split(blob).is_ok() {
            SealError::SignedAlready
        } else {
            SealError::NotBlob(e)
        }
    })?;
    let station = StationKey {
        public: key.verifying_key().to_bytes(),
    };
    let mut out = vec![0u8; blob.len() + signed::TRAILER_LEN];
    let n = signed::seal(blob, &station, counter, downgrade, &mut out, |digest| {
        key.sign(digest).to_bytes()
    })
    .ok_or(SealError::TooLong)?;
    out.truncate(n);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_sign_and_the_unit_check_accepts() {
        let dir = tempfile::tempdir().unwrap();
        let (sk, pk) = (dir.path().join("s.key"), dir.path().join("s.pub"));
        let id = keygen(&sk, &pk).unwrap();
        assert!(matches!(keygen(&sk, &pk), Err(KeyError::Exists(p)) if p == sk));
        let key = load_private(&sk).unwrap();
        let public = load_public(&pk).unwrap();
        assert_eq!(public.id(), id);
        let data = spincal::model::CalibrationData::example_imu();
        let cal = spincal::model::Calibration::new(data.clone()).unwrap();
        let mut buf = vec![0u8; spincal::blob::MAX_BLOB_LEN];
        let n = spincal::blob::encode(&cal, &mut buf).unwrap();
        let bytes = sign(&buf[..n], &key, 4, false).unwrap();
        let v = signed::verify(&bytes, &[public], &data.identity.serial, 3).unwrap();
        assert_eq!((v.counter, v.key_id), (4, id));
        assert_eq!(sign(&bytes, &key, 5, false), Err(SealError::SignedAlready));
        assert!(matches!(
            sign(&[1, 2, 3], &key, 5, false),
            Err(SealError::NotBlob(_))
        ));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(
                std::fs::metadata(&sk).unwrap().permissions().mode() & 0o777,
                0o600
            );
            std::fs::set_permissions(&sk, std::fs::Permissions::from_mode(0o644)).unwrap();
            let e = load_private(&sk).unwrap_err();
            assert!(matches!(e, KeyError::Exposed { mode: 0o644, .. }), "{e:?}");
            let e = e.to_string();
            assert!(
                e.contains("readable by others") && e.contains("chmod 600"),
                "{e}"
            );
        }
        std::fs::write(&pk, "zz\n").unwrap();
        assert!(
            load_public(&pk)
                .unwrap_err()
                .to_string()
                .contains("64 hex digits")
        );
    }
}
