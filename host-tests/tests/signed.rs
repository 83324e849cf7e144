//! Signed calibrations (`spincal::signed`): what the unit's check refuses and accepts.

use ed25519_dalek::SigningKey;
use host_tests::golden;
use spincal::model::{CalibrationData, Serial};
use spincal::signed::{self, FLAG_DOWNGRADE, SignError, StationKey, TRAILER_LEN};

/// Signs `blob` as a station does (`calflash sign`).
fn sign(blob: &[u8], key: &SigningKey, counter: u32, flags: u8) -> Vec<u8> {
    calflash::signing::sign(blob, key, counter, flags & FLAG_DOWNGRADE != 0).unwrap()
}

fn station(seed: u8) -> (SigningKey, StationKey) {
    let k = SigningKey::from_bytes(&[seed; 32]);
    let public = StationKey {
        public: k.verifying_key().to_bytes(),
    };
    (k, public)
}

fn unit_serial(data: &CalibrationData) -> Serial {
    data.identity.serial.clone()
}

#[test]
fn a_signed_blob_verifies_and_every_changed_byte_is_refused() {
    let data = CalibrationData::example_imu();
    let blob = golden::encode(&data);
    let (key, public) = station(1);
    let bytes = sign(&blob, &key, 7, 0);
    assert_eq!(bytes.len(), blob.len() + TRAILER_LEN);
    const { assert!(TRAILER_LEN <= 80) };
    let unit = unit_serial(&data);
    let ok = signed::verify(&bytes, &[public], &unit, 6).unwrap();
    assert_eq!(
        (ok.counter, ok.key_id, ok.downgrade),
        (7, public.id(), false)
    );
    assert_eq!(ok.blob_len, blob.len());
    // Every single byte flipped, header to signature: refused.
    for i in 0..bytes.len() {
        let mut bad = bytes.clone();
        bad[i] ^= 0x01;
        assert!(
            signed::verify(&bad, &[public], &unit, 6).is_err(),
            "byte {i} of {} flipped and accepted",
            bytes.len()
        );
    }
}

#[test]
fn keys_serials_counters_and_unsigned_blobs() {
    let data = CalibrationData::example_imu();
    let blob = golden::encode(&data);
    let unit = unit_serial(&data);
    let (key, public) = station(1);
    let (other, other_public) = station(2);
    // A key the unit does not hold.
    let by_other = sign(&blob, &other, 7, 0);
    assert_eq!(
        signed::verify(&by_other, &[public], &unit, 0),
        Err(SignError::UnknownKey {
            key_id: other_public.id()
        })
    );
    // The held key's id over another key's signature.
    let mut forged = by_other.clone();
    let n = blob.len();
    forged[n + 3..n + 7].copy_from_slice(&public.id());
    assert_eq!(
        signed::verify(&forged, &[public], &unit, 0),
        Err(SignError::BadSignature)
    );
    // Either of two held keys.
    assert!(signed::verify(&by_other, &[public, other_public], &unit, 0).is_ok());
    // Replay: not above the unit's counter; a signed downgrade made for the unit's present
    // counter is accepted, one made for another counter is not.
    let old = sign(&blob, &key, 5, 0);
    assert_eq!(
        signed::verify(&old, &[public], &unit, 5),
        Err(SignError::Replay {
            counter: 5,
            held: 5
        })
    );
    let down = sign(&blob, &key, 5, FLAG_DOWNGRADE);
    assert!(
        signed::verify(&down, &[public], &unit, 5)
            .unwrap()
            .downgrade
    );
    let stale = sign(&blob, &key, 3, FLAG_DOWNGRADE);
    assert_eq!(
        signed::verify(&stale, &[public], &unit, 5),
        Err(SignError::Replay {
            counter: 3,
            held: 5
        })
    );
    assert!(signed::verify(&down, &[public], &unit, 6).is_err());
    // Another unit's calibration.
    let mut theirs = data.clone();
    theirs.identity.serial = Serial::new("OTHER-UNIT-7").unwrap();
    let signed_theirs = sign(&golden::encode(&theirs), &key, 9, 0);
    assert_eq!(
        signed::verify(&signed_theirs, &[public], &unit, 0),
        Err(SignError::WrongSerial)
    );
    // Unsigned, and a cut trailer.
    assert_eq!(
        signed::verify(&blob, &[public], &unit, 0),
        Err(SignError::Unsigned)
    );
    let good = sign(&blob, &key, 7, 0);
    assert_eq!(
        signed::verify(&good[..good.len() - 1], &[public], &unit, 0),
        Err(SignError::Malformed)
    );
    assert_eq!(
        signed::verify(&good[..20], &[public], &unit, 0),
        Err(SignError::Malformed)
    );
}
