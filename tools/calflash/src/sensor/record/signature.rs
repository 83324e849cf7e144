//! A record signed by the station that wrote it (red team four): the seal is a SHA-256 anyone
//! can recompute, so a record edited and re-sealed by hand passes it; the signature is an
//! Ed25519 signature of the seal by the station's private key (the key that signs its blobs),
//! which only that station can make. Stage two takes a stage-one record only when a key it
//! trusts signed it ([`Trust`]).

use ed25519_dalek::{Signer as _, SigningKey, Verifier as _, VerifyingKey};
use serde::{Deserialize, Serialize};
use spincal::signed::StationKey;

use super::{Record, Unsealed, hex, unhex};

/// What is signed: a fixed prefix (so that no signature of a blob, or of anything else, can
/// pass as a record's) and the seal's hex digits.
fn message(seal: &str) -> Vec<u8> {
    let mut m = b"calflash.calibration/1 record seal ".to_vec();
    m.extend_from_slice(seal.as_bytes());
    m
}

/// A record's signature.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RecordSignature {
    /// The signing station's key id (8 hex digits, as `calflash keygen` and a blob's trailer
    /// name it).
    pub key_id: String,
    /// Its public key, hex: what the signature is checked with; trusted only when it is one of
    /// the keys the reader trusts.
    pub public_key: String,
    /// The Ed25519 signature of the seal, hex.
    pub signature: String,
}

/// The keys a reader trusts to sign records, and whether it takes an unsigned one.
#[derive(Debug, Clone, Default)]
pub struct Trust {
    /// The trusted station keys.
    pub keys: Vec<StationKey>,
    /// Take a record without a signature (`--unsigned-stage-one`; and records this process
    /// made itself, as a design's simulation does).
    pub unsigned: bool,
}

impl Trust {
    /// Trusts every record, signed or not: for records this process wrote itself.
    #[must_use]
    pub fn own() -> Self {
        Self {
            keys: Vec::new(),
            unsigned: true,
        }
    }

    /// The trusted keys' ids, for a message.
    fn ids(&self) -> String {
        if self.keys.is_empty() {
            return "none".into();
        }
        self.keys
            .iter()
            .map(|k| hex(&k.id()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Why a record's signature is not taken.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Untrusted {
    /// No signature, and none is taken without one.
    #[error(
        "the record is not signed, and a seal alone can be recomputed by anyone who edits the record; trusted station keys: {trusted}. Calibrate stage one with --sign-key (or $CALFLASH_SIGN_KEY), give stage two that station's public key with --trust-key, or take the record from the history (history:SERIAL)"
    )]
    Unsigned {
        /// The trusted keys' ids.
        trusted: String,
    },
    /// A signature that does not match the record.
    #[error(
        "its signature by station key {key_id} does not match its content: the record was changed (and perhaps re-sealed) after that station signed it"
    )]
    Forged {
        /// The key id the record names.
        key_id: String,
    },
    /// A valid signature by a key not trusted here.
    #[error(
        "signed by station key {key_id}, which is not among the keys trusted here ({trusted}); give its public key with --trust-key if that station is yours"
    )]
    Stranger {
        /// The key id.
        key_id: String,
        /// The trusted keys' ids.
        trusted: String,
    },
}

impl Record {
    /// This record, sealed, signed by `key`. Any earlier signature is replaced.
    #[must_use]
    pub fn signed(self, key: &SigningKey) -> Self {
        let mut rec = self.sealed();
        let public = StationKey {
            public: key.verifying_key().to_bytes(),
        };
        rec.signature = Some(RecordSignature {
            key_id: hex(&public.id()),
            public_key: hex(&public.public),
            signature: hex(&key.sign(&message(&rec.seal)).to_bytes()),
        });
        rec
    }

    /// Who signed this record, when `trust` takes it. The seal is checked first
    /// ([`Record::check_seal`]); a signature that does not match is refused whatever `trust`
    /// takes, for it shows the record was changed after it was signed.
    ///
    /// # Errors
    /// The seal's failure, or why the signature is not taken.
    pub fn check_trusted(&self, trust: &Trust) -> Result<Signer, TrustError> {
        self.check_sealed()?;
        let signer = self.check_signature(trust)?;
        self.check_blob()?;
        Ok(signer)
    }

    /// [`Record::check_trusted`]'s signature, the seal already checked.
    fn check_signature(&self, trust: &Trust) -> Result<Signer, TrustError> {
        let Some(sig) = &self.signature else {
            return if trust.unsigned {
                Ok(Signer::Nobody)
            } else {
                Err(Untrusted::Unsigned {
                    trusted: trust.ids(),
                }
                .into())
            };
        };
        let forged = || Untrusted::Forged {
            key_id: sig.key_id.clone(),
        };
        let public: [u8; 32] = unhex(&sig.public_key)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(forged)?;
        let signature: [u8; 64] = unhex(&sig.signature)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(forged)?;
        let station = StationKey { public };
        if hex(&station.id()) != sig.key_id {
            return Err(forged().into());
        }
        let key = VerifyingKey::from_bytes(&public).map_err(|_| forged())?;
        key.verify(
            &message(&self.seal),
            &ed25519_dalek::Signature::from_bytes(&signature),
        )
        .map_err(|_| forged())?;
        if trust.keys.contains(&station) {
            Ok(Signer::Trusted(sig.key_id.clone()))
        } else if trust.unsigned {
            Ok(Signer::Stranger(sig.key_id.clone()))
        } else {
            Err(Untrusted::Stranger {
                key_id: sig.key_id.clone(),
                trusted: trust.ids(),
            }
            .into())
        }
    }
}

/// Who signed a record that was taken.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Signer {
    /// A trusted station key, by id.
    Trusted(String),
    /// A key not trusted here, whose signature matches; taken because unsigned records are.
    Stranger(String),
    /// Nobody; taken because unsigned records are.
    Nobody,
}

impl std::fmt::Display for Signer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Trusted(id) => write!(f, "signed by station key {id}"),
            Self::Stranger(id) => write!(
                f,
                "signed by station key {id}, which is not trusted here: taken as unsigned on --unsigned-stage-one"
            ),
            Self::Nobody => f.write_str("UNSIGNED, taken on --unsigned-stage-one"),
        }
    }
}

/// A record not taken: its seal, or its signature.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TrustError {
    /// The seal does not match.
    #[error(transparent)]
    Unsealed(#[from] Unsealed),
    /// The signature is not taken.
    #[error(transparent)]
    Untrusted(#[from] Untrusted),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> Record {
        serde_json::from_value(serde_json::json!({
            "schema": super::super::SCHEMA, "serial": "S-1", "sensor": "single",
            "created_unix_s": 1, "data_file": "d.csv", "data_hash": "00", "tool_version": "0.1.0",
            "verdict": "accept", "findings": [], "notes": [], "decisions": [], "points": [],
            "device_error": 0.0, "blob": ""
        }))
        .unwrap()
    }

    #[test]
    fn a_signed_record_is_taken_only_from_a_trusted_key_and_only_as_signed() {
        let key = SigningKey::from_bytes(&[7; 32]);
        let other = SigningKey::from_bytes(&[9; 32]);
        let trusted = Trust {
            keys: vec![StationKey {
                public: key.verifying_key().to_bytes(),
            }],
            unsigned: false,
        };
        let rec = record().signed(&key);
        let Signer::Trusted(id) = rec.check_trusted(&trusted).unwrap() else {
            panic!("not trusted")
        };
        assert_eq!(id.len(), 8);
        // Edited and re-sealed by hand: the seal passes, the signature does not.
        let mut forged = rec.clone();
        forged.created_unix_s = 2;
        let forged = Record {
            signature: rec.signature.clone(),
            ..forged.sealed()
        };
        let e = forged.check_trusted(&trusted).unwrap_err();
        assert!(
            matches!(&e, TrustError::Untrusted(Untrusted::Forged { key_id }) if *key_id == id),
            "{e:?}"
        );
        assert!(e.to_string().contains(&id), "{e}");
        // Signed by a station not trusted here.
        let stranger = record().signed(&other);
        let e = stranger.check_trusted(&trusted).unwrap_err();
        assert!(
            matches!(e, TrustError::Untrusted(Untrusted::Stranger { .. })),
            "{e:?}"
        );
        // Unsigned: refused unless unsigned records are taken.
        let bare = record().sealed();
        assert!(matches!(
            bare.check_trusted(&trusted),
            Err(TrustError::Untrusted(Untrusted::Unsigned { .. }))
        ));
        assert_eq!(bare.check_trusted(&Trust::own()), Ok(Signer::Nobody));
        assert_eq!(
            stranger.check_trusted(&Trust::own()),
            Ok(Signer::Stranger(stranger.signature.clone().unwrap().key_id))
        );
        // The signature is outside the seal: a signed record's seal is its unsigned seal.
        assert_eq!(rec.seal, bare.seal);
    }
}
