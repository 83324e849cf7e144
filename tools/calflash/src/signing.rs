//! The station's keys and signed calibrations (issue 17): an Ed25519 key pair in two files,
//! and the signed blob a provisioned unit checks (`spincal::signed`).
//!
//! Key files are text: a header line that says which half the file holds, then 64 hex digits.
//! The private one ([`PRIVATE_HEADER`]) holds the 32-byte seed and must be readable by its owner
//! only; the public one ([`PUBLIC_HEADER`]) the 32-byte public key. The two are not
//! interchangeable: a private key given where a public one is expected (`image --station-key`)
//! is refused before a byte of it is used, and so is a public key given to sign with. A public
//! key that is not a point of the curve, or one of small order (which any signature would
//! match), is refused; so is one key given twice.

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
    /// A key file too long to be one, or unreadable.
    #[error(transparent)]
    Read(#[from] crate::files::Error),
    /// A key file that is not a header line and 64 hex digits.
    #[error(
        "{}: expected a key written by `calflash keygen` (a header line, then 64 hex digits)",
        .0.display()
    )]
    Malformed(PathBuf),
    /// A key file of 64 hex digits without the header that says which half it holds (written
    /// by a calflash before the two halves were labelled).
    #[error(
        "{}: 64 hex digits without a header, so it cannot be told whether this is the private \
         or the public half; if it is the public key, put the line `{PUBLIC_HEADER}` above the \
         digits, if it is the private key the line `{PRIVATE_HEADER}` (or make a new pair with \
         `calflash keygen`)",
        .0.display()
    )]
    Unlabelled(PathBuf),
    /// The other half of the pair than the one asked for.
    #[error("{}: {}", .path.display(), match .held {
        Half::Private => "this is a station's PRIVATE key; a unit is provisioned with the public \
            half (PREFIX.pub): the private key never leaves the station",
        Half::Public => "this is a station's public key; signing needs the private half \
            (PREFIX.key)",
    })]
    WrongHalf {
        /// The file.
        path: PathBuf,
        /// What it holds.
        held: Half,
    },
    /// A public key no signature check can trust: not a point of the curve, or of small order.
    #[error(
        "{}: not a usable Ed25519 public key ({why}): a unit provisioned with it would accept \
         forgeries or nothing",
        .path.display()
    )]
    Weak {
        /// The file.
        path: PathBuf,
        /// Not a point, or small order.
        why: &'static str,
    },
    /// One public key given twice.
    #[error(
        "{} and {}: the same station key twice; give each key once",
        .first.display(),
        .second.display()
    )]
    Twice {
        /// The first file.
        first: PathBuf,
        /// The second.
        second: PathBuf,
    },
    /// A `keygen` prefix that already ends in a key file's extension.
    #[error(
        "{}: give the files' path without extension (keygen writes PREFIX.key and PREFIX.pub)",
        .0.display()
    )]
    Prefix(PathBuf),
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

/// The first line of a private key file.
pub const PRIVATE_HEADER: &str =
    "calflash station PRIVATE key (Ed25519 seed): keep it on the station, mode 600";
/// The first line of a public key file.
pub const PUBLIC_HEADER: &str =
    "calflash station public key (Ed25519): give it to `calflash image --station-key`";

/// Which half a key file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Half {
    /// The private seed.
    Private,
    /// The public key.
    Public,
}

/// The longest key file read: a header and a key, with room to spare.
const MAX_KEY_FILE: u64 = 4096;

/// The 32 bytes of key file `path`, which must hold the `half` asked for.
fn read_key(path: &Path, half: Half) -> Result<[u8; 32], KeyError> {
    let bytes = crate::files::read_bounded(path, MAX_KEY_FILE, "a calflash key file")?;
    let text = std::str::from_utf8(&bytes).map_err(|_| KeyError::Malformed(path.to_path_buf()))?;
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or_default();
    let held = if first == PRIVATE_HEADER {
        Half::Private
    } else if first == PUBLIC_HEADER {
        Half::Public
    } else if first.len() == 64 && first.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(KeyError::Unlabelled(path.to_path_buf()));
    } else {
        return Err(KeyError::Malformed(path.to_path_buf()));
    };
    if held != half {
        return Err(KeyError::WrongHalf {
            path: path.to_path_buf(),
            held,
        });
    }
    let key = unhex32(lines.next().unwrap_or_default(), path)?;
    if lines.next().is_some() {
        return Err(KeyError::Malformed(path.to_path_buf()));
    }
    Ok(key)
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

/// The two files of key pair `prefix`: `PREFIX.key` (private) and `PREFIX.pub` (public). The
/// extensions are appended, so `station.v1` gives `station.v1.key`; a prefix that already
/// ends in `.key` or `.pub` is refused.
///
/// # Errors
/// [`KeyError::Prefix`].
pub fn pair_paths(prefix: &Path) -> Result<(PathBuf, PathBuf), KeyError> {
    if prefix
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("key") || e.eq_ignore_ascii_case("pub"))
    {
        return Err(KeyError::Prefix(prefix.to_path_buf()));
    }
    let with = |ext: &str| {
        let mut p = prefix.as_os_str().to_owned();
        p.push(ext);
        PathBuf::from(p)
    };
    Ok((with(".key"), with(".pub")))
}

/// Writes a new key pair: `private` (mode 0600) and `public`; returns the key id. Neither file
/// may exist. Both are written or neither: the public half is staged first, the private one
/// written beside it, and the public one renamed into place last; a failure removes what was
/// written, so a rerun starts clean.
///
/// # Errors
/// A file that exists or cannot be written, named.
pub fn keygen(private: &Path, public: &Path) -> Result<[u8; 4], KeyError> {
    for p in [private, public] {
        if p.exists() || std::fs::symlink_metadata(p).is_ok() {
            return Err(KeyError::Exists(p.to_path_buf()));
        }
    }
    let seed: [u8; 32] = rand::random();
    let key = SigningKey::from_bytes(&seed);
    let station = StationKey {
        public: key.verifying_key().to_bytes(),
    };
    let mut staged = crate::files::Staged::new();
    staged.write(public, |w| {
        writeln!(w, "{PUBLIC_HEADER}")?;
        writeln!(w, "{}", hex(&station.public))
    })?;
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut opts, 0o600);
    let mut f = opts.open(private).map_err(io(private))?;
    let written = writeln!(f, "{PRIVATE_HEADER}")
        .and_then(|()| writeln!(f, "{}", hex(&seed)))
        .and_then(|()| f.sync_all());
    let committed = written
        .map_err(io(private))
        .and_then(|()| staged.commit().map_err(KeyError::from));
    if let Err(e) = committed {
        let _ = std::fs::remove_file(private);
        return Err(e);
    }
    Ok(station.id())
}

/// The station's private key from `path`, refused when the file holds the public half, or
/// when others may read it.
///
/// # Errors
/// A missing or malformed file, the public half, or a file readable by group or others.
pub fn load_private(path: &Path) -> Result<SigningKey, KeyError> {
    // What the file is comes first: a public key readable by all is no exposure.
    let seed = read_key(path, Half::Private)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path)
            .map_err(io(path))?
            .permissions()
            .mode();
        if mode & 0o077 != 0 {
            return Err(KeyError::Exposed {
                path: path.to_path_buf(),
                mode: mode & 0o777,
            });
        }
    }
    Ok(SigningKey::from_bytes(&seed))
}

/// A station's public key from `path`: refused when the file holds the private half, or when
/// the key is not a point of the curve or is of small order.
///
/// # Errors
/// A missing or malformed file, the private half, or a weak key.
pub fn load_public(path: &Path) -> Result<StationKey, KeyError> {
    let public = read_key(path, Half::Public)?;
    let weak = |why| KeyError::Weak {
        path: path.to_path_buf(),
        why,
    };
    let key = ed25519_dalek::VerifyingKey::from_bytes(&public)
        .map_err(|_| weak("not a point of the curve"))?;
    if key.is_weak() {
        return Err(weak("a point of small order"));
    }
    Ok(StationKey { public })
}

/// The station public keys of `paths`, each loaded as [`load_public`], none twice.
///
/// # Errors
/// As [`load_public`], or one key given twice.
pub fn load_publics(paths: &[PathBuf]) -> Result<Vec<StationKey>, KeyError> {
    let mut keys: Vec<StationKey> = Vec::with_capacity(paths.len());
    for (i, p) in paths.iter().enumerate() {
        let k = load_public(p)?;
        if let Some(j) = keys.iter().position(|h| h.public == k.public) {
            return Err(KeyError::Twice {
                first: paths[j].clone(),
                second: paths[i].clone(),
            });
        }
        keys.push(k);
    }
    Ok(keys)
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
            // A public key readable by all is the public key, never 'chmod 600' and sign.
            let e = load_private(&pk).unwrap_err();
            assert!(
                matches!(
                    e,
                    KeyError::WrongHalf {
                        held: Half::Public,
                        ..
                    }
                ),
                "{e:?}"
            );
            assert!(!e.to_string().contains("chmod"), "{e}");
            std::fs::set_permissions(&pk, std::fs::Permissions::from_mode(0o600)).unwrap();
            assert!(load_private(&pk).is_err(), "a public key never signs");
            std::fs::set_permissions(&sk, std::fs::Permissions::from_mode(0o600)).unwrap();
            // The private key is never taken as the public one.
            let e = load_public(&sk).unwrap_err();
            assert!(
                matches!(
                    e,
                    KeyError::WrongHalf {
                        held: Half::Private,
                        ..
                    }
                ),
                "{e:?}"
            );
        }
        assert!(matches!(
            load_publics(&[pk.clone(), pk.clone()]),
            Err(KeyError::Twice { .. })
        ));
        // Unlabelled hex (the old format) is refused with the way out.
        let bare = dir.path().join("bare.pub");
        std::fs::write(&bare, format!("{}\n", hex(&public.public))).unwrap();
        let e = load_public(&bare).unwrap_err();
        assert!(matches!(e, KeyError::Unlabelled(_)), "{e:?}");
        // Small-order points and non-points are refused.
        let identity = {
            let mut b = [0u8; 32];
            b[0] = 1;
            b
        };
        std::fs::write(&bare, format!("{PUBLIC_HEADER}\n{}\n", hex(&identity))).unwrap();
        let e = load_public(&bare).unwrap_err();
        assert!(e.to_string().contains("small order"), "{e}");
        std::fs::write(&pk, format!("{PUBLIC_HEADER}\nzz\n")).unwrap();
        assert!(
            load_public(&pk)
                .unwrap_err()
                .to_string()
                .contains("64 hex digits")
        );
    }
}
