//! A unit provisioned with station keys takes only calibrations signed for it, with a counter
//! above the one it holds, and keeps its calibration through every refusal; an unprovisioned
//! one says so on every answer. Over the device's protocol handler and the store on a simulated
//! NOR flash, and through `calflash flash` over a TCP link.

use ed25519_dalek::SigningKey;
use host_tests::golden;
use host_tests::tcp_unit::{self, Fault, Flash, TcpUnit};
use spincal::model::{CalibrationData, Serial};
use spincal::protocol::{Device, MAX_CHUNK, Request, Response, Status, Trust};
use spincal::signed::{SignError, StationKey};

const UNIT: &str = "SIGNED-0007";

fn station(seed: u8) -> (SigningKey, StationKey) {
    let k = SigningKey::from_bytes(&[seed; 32]);
    let public = StationKey {
        public: k.verifying_key().to_bytes(),
    };
    (k, public)
}

/// The example IMU's blob for unit `serial`, its bias shifted by `shift` (so that records
/// differ).
fn blob_for(serial: &str, shift: f32) -> Vec<u8> {
    let mut d = CalibrationData::example_imu();
    d.identity.serial = Serial::new(serial).unwrap();
    if let spincal::model::Sensor::Imu { accel, .. } = &mut d.sensor {
        accel[0].center += shift;
    }
    golden::encode(&d)
}

fn sign(blob: &[u8], key: &SigningKey, counter: u32, downgrade: bool) -> Vec<u8> {
    calflash::signing::sign(blob, key, counter, downgrade).unwrap()
}

/// Sends `record` and commits it.
fn write(d: &mut Device<Flash>, record: &[u8]) -> Response {
    let crc = spincal::protocol::checksum(record);
    let r = d.handle(Request::WriteBegin {
        len: record.len() as u32,
        crc,
    });
    if r != Response::Ready {
        return r;
    }
    for (k, chunk) in record.chunks(MAX_CHUNK).enumerate() {
        let r = d.handle(Request::WriteChunk {
            offset: (k * MAX_CHUNK) as u32,
            data: heapless::Vec::from_slice(chunk).unwrap(),
        });
        assert!(matches!(r, Response::ChunkOk { .. }), "{r:?}");
    }
    d.handle(Request::Commit)
}

fn identity(d: &mut Device<Flash>) -> spincal::protocol::Identity {
    match d.handle(Request::Identify) {
        Response::Identity(i) => i,
        r => panic!("{r:?}"),
    }
}

/// A provisioned unit holding the calibration signed at counter 1; the flash and that record.
fn unit_holding_one() -> (Flash, Vec<u8>) {
    let (key, public) = station(1);
    let mut d = tcp_unit::device(tcp_unit::provisioned_flash(&[public]), UNIT);
    assert_eq!(d.trust(), Trust::Provisioned);
    let one = sign(&blob_for(UNIT, 0.0), &key, 1, false);
    assert_eq!(
        write(&mut d, &one),
        Response::Committed { seq: 1, counter: 1 }
    );
    let mut flash = d.into_store().into_inner();
    flash.reboot();
    (flash, one)
}

#[test]
fn every_changed_byte_of_a_signed_blob_is_refused_and_the_unit_keeps_its_calibration() {
    let (key, _) = station(1);
    let (flash, one) = unit_holding_one();
    let two = sign(&blob_for(UNIT, 3.0), &key, 2, false);
    let mut refusals = [0usize; 2];
    for i in 0..two.len() {
        let mut bad = two.clone();
        bad[i] ^= 0x01;
        let mut d = tcp_unit::device(flash.clone(), UNIT);
        let r = write(&mut d, &bad);
        match r {
            // The blob's own CRC, header or payload: not a calibration at all.
            Response::Error(Status::InvalidBlob(_) | Status::TooLarge) => refusals[0] += 1,
            // The trailer: key id, counter, flags, signature.
            Response::Error(Status::Refused(_)) => refusals[1] += 1,
            r => panic!("byte {i} of {} flipped: {r:?}", two.len()),
        }
        let id = identity(&mut d);
        assert_eq!((id.counter, id.signed_by), (1, Some(station(1).1.id())));
        let mut after = d.into_store().into_inner();
        after.reboot();
        assert_eq!(after.mem, flash.mem, "byte {i}: the flash was written");
    }
    println!(
        "signed_unit: {} single-byte changes refused ({} as invalid blobs, {} by the signature check)",
        two.len(),
        refusals[0],
        refusals[1]
    );
    // All of the trailer but its magic, whose change leaves no trailer (trailing bytes).
    assert_eq!(refusals[1], spincal::signed::TRAILER_LEN - 2);
    // The record itself goes in.
    let mut d = tcp_unit::device(flash, UNIT);
    assert_eq!(
        write(&mut d, &two),
        Response::Committed { seq: 2, counter: 2 }
    );
    assert_ne!(one, two);
}

#[test]
fn unknown_keys_replays_other_units_and_unsigned_blobs_are_refused() {
    let (key, _) = station(1);
    let (other, other_public) = station(2);
    let (flash, one) = unit_holding_one();
    let mut d = tcp_unit::device(flash, UNIT);
    let refused = |r: Response| match r {
        Response::Error(Status::Refused(why)) => why,
        r => panic!("{r:?}"),
    };
    // Unsigned: refused with a message that says how to sign.
    let why = refused(write(&mut d, &blob_for(UNIT, 1.0)));
    assert_eq!(why, SignError::Unsigned);
    assert!(why.to_string().contains("--sign-key"), "{why}");
    // A valid signature by a key the unit does not hold.
    assert_eq!(
        refused(write(&mut d, &sign(&blob_for(UNIT, 1.0), &other, 5, false))),
        SignError::UnknownKey {
            key_id: other_public.id()
        }
    );
    // Made for another unit.
    assert_eq!(
        refused(write(
            &mut d,
            &sign(&blob_for("OTHER-1", 1.0), &key, 5, false)
        )),
        SignError::WrongSerial
    );
    // Newer, then the older one replayed.
    let three = sign(&blob_for(UNIT, 2.0), &key, 3, false);
    assert_eq!(
        write(&mut d, &three),
        Response::Committed { seq: 2, counter: 3 }
    );
    assert_eq!(
        refused(write(&mut d, &one)),
        SignError::Replay {
            counter: 1,
            held: 3
        }
    );
    // The same record again (a retry after a lost answer): current already, nothing written.
    assert_eq!(
        write(&mut d, &three),
        Response::Committed { seq: 2, counter: 3 }
    );
    // A downgrade signed for this unit at its present counter puts the old calibration back;
    // one signed at another counter does not.
    assert_eq!(
        refused(write(&mut d, &sign(&blob_for(UNIT, 0.0), &key, 2, true))),
        SignError::Replay {
            counter: 2,
            held: 3
        }
    );
    // One signed above the unit's counter says so, not that 4 is "not above" 3 (issue 30).
    let wrong = refused(write(&mut d, &sign(&blob_for(UNIT, 0.0), &key, 4, true)));
    assert_eq!(
        wrong,
        SignError::Replay {
            counter: 4,
            held: 3
        }
    );
    let said = wrong.to_string();
    assert!(
        said.starts_with("a downgrade signed at counter 4, but the unit holds counter 3")
            && said.contains("--downgrade --counter 3"),
        "{said}"
    );
    let down = sign(&blob_for(UNIT, 0.0), &key, 3, true);
    assert_eq!(
        write(&mut d, &down),
        Response::Committed { seq: 3, counter: 3 }
    );
    // The counter did not move back: a normal blob must still be above 3.
    assert_eq!(
        refused(write(&mut d, &sign(&blob_for(UNIT, 5.0), &key, 3, false))),
        SignError::Replay {
            counter: 3,
            held: 3
        }
    );
    let id = identity(&mut d);
    assert_eq!((id.trust, id.counter), (Trust::Provisioned, 3));
    assert_eq!(id.station_keys.as_slice(), &[station(1).1.id()]);
    // After a power cycle: the downgrade, verified at boot, counter 3.
    let mut flash = d.into_store().into_inner();
    flash.reboot();
    let mut d = tcp_unit::device(flash, UNIT);
    let id = identity(&mut d);
    assert_eq!((id.counter, id.blob_len as usize), (3, down.len()));
    assert!(d.calibration().is_some());
}

#[test]
fn a_provisioned_unit_boots_only_what_it_trusts() {
    let (key, public) = station(1);
    // A unit calibrated unsigned as a developer's board, then provisioned: it runs with no
    // calibration and says why, until a signed one is committed.
    let mut d = tcp_unit::device(tcp_unit::blank_flash(), UNIT);
    assert_eq!(d.trust(), Trust::Unprovisioned);
    assert!(matches!(
        write(&mut d, &blob_for(UNIT, 0.0)),
        Response::Committed { counter: 0, .. }
    ));
    let mut flash = d.into_store().into_inner();
    let mut store = spincal::store::Store::new(flash, 0, tcp_unit::SLOT).unwrap();
    store.provision(&[public]).unwrap();
    assert_eq!(
        store.provision(&[public]),
        Err(spincal::store::StoreError::Locked),
        "keys are written once"
    );
    flash = store.into_inner();
    flash.reboot();
    let mut d = tcp_unit::device(flash, UNIT);
    assert!(d.calibration().is_none());
    assert_eq!(d.refused(), Some(SignError::Unsigned));
    assert_eq!(identity(&mut d).refused, Some(SignError::Unsigned));
    let one = sign(&blob_for(UNIT, 0.0), &key, 1, false);
    assert!(matches!(
        write(&mut d, &one),
        Response::Committed { counter: 1, .. }
    ));
    assert_eq!(d.refused(), None);
    // A damaged keys sector trusts no key: nothing boots and nothing commits.
    let mut flash = d.into_store().into_inner();
    let keys_at = 2 * tcp_unit::SLOT as usize + 1024;
    flash.mem[keys_at + 9] ^= 0x10;
    flash.reboot();
    let mut d = tcp_unit::device(flash, UNIT);
    assert_eq!(d.trust(), Trust::KeysDamaged);
    assert!(d.calibration().is_none());
    assert!(matches!(
        write(&mut d, &sign(&blob_for(UNIT, 1.0), &key, 2, false)),
        Response::Error(Status::Refused(SignError::UnknownKey { .. }))
    ));
}

/// `calflash flash` to a provisioned unit: an unsigned blob is refused before anything is
/// sent, with the way to sign; `--sign-key` signs it for the unit at the counter above its
/// own, and the history records the key.
#[test]
fn calflash_flash_signs_for_the_unit_and_the_history_records_the_key() {
    use calflash::cmd::flash::{FlashArgs, run};
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let (key_file, pub_file) = (p("station.key"), p("station.pub"));
    let id = calflash::signing::keygen(&key_file, &pub_file).unwrap();
    let public = calflash::signing::load_public(&pub_file).unwrap();
    std::fs::write(p("unit.blob"), blob_for(UNIT, 0.0)).unwrap();
    let args = |port: String, sign_key: Option<std::path::PathBuf>| FlashArgs {
        blob: p("unit.blob"),
        port,
        force: false,
        force_rejected: false,
        timeout: 2.0,
        vectors: 1,
        db: Some(p("units.sqlite").into()),
        no_db: false,
        sign_key,
    };
    let flash = tcp_unit::provisioned_flash(&[public]);
    let unit = TcpUnit::serve(tcp_unit::device(flash.clone(), UNIT), Fault::None);
    let e = run(&args(unit.address(), None)).unwrap_err().to_string();
    assert!(
        e.contains("takes only calibrations signed") && e.contains("--sign-key"),
        "{e}"
    );
    let mut after = unit.finish().into_store().into_inner();
    after.reboot();
    assert_eq!(after.mem, flash.mem, "nothing written");
    // Signed at flash time, twice: counters 1 and 2.
    let mut flash = flash;
    for expected in 1..=2u32 {
        let unit = TcpUnit::serve(tcp_unit::device(flash, UNIT), Fault::None);
        run(&args(unit.address(), Some(key_file.clone()))).unwrap();
        flash = unit.finish().into_store().into_inner();
        flash.reboot();
        let mut d = tcp_unit::device(flash.clone(), UNIT);
        let i = identity(&mut d);
        assert_eq!((i.counter, i.signed_by), (expected, Some(id)));
    }
    let mut db = calflash::db::Db::open(&p("units.sqlite")).unwrap();
    let h = db.history(UNIT).unwrap();
    let signed: Vec<_> = h.iter().filter_map(|e| e.signed_by.clone()).collect();
    let hex = calflash::device::key_hex(id);
    assert_eq!(signed, vec![format!("{hex} #1"), format!("{hex} #2")]);
    assert_eq!(db.highest_counter(UNIT).unwrap(), 2);
}
