//! The store over random flash contents: the input is either the whole region (first byte
//! even) or a list of (offset, xor) corruptions of a region holding two valid slots (first byte
//! odd; with bit 1 set, a provisioned unit whose slots hold signed records), so the fuzzer
//! reaches both garbage and nearly valid states. Scanning, loading and the lock check never
//! panic; what loads is a valid calibration equal to one of the slots'; and an update on an
//! unlocked store whose keys are sound returns Ok and is then exactly what loads.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::blob;
use spincal::model::{CalibrationData, Serial};
use spincal::store::{Policy, Provisioning, SlotState, Store, StoreError};
use spincal_fuzz::RamNor;

const SLOT: u32 = 16 * 1024;
const REGION: usize = Store::<RamNor>::region_len(SLOT, 1024) as usize;

fn encode(data: CalibrationData) -> Vec<u8> {
    let cal = spincal::model::Calibration::new(data).expect("example validates");
    let mut out = vec![0u8; blob::MAX_BLOB_LEN];
    let n = blob::encode(&cal, &mut out).expect("encodes");
    out.truncate(n);
    out
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let signed = mode & 3 == 3;
    let (key, public) = spincal_fuzz::station();
    let unit = Serial::new("FUZZ-1").expect("serial");
    let for_unit = |mut d: CalibrationData| {
        d.identity.serial = unit.clone();
        encode(d)
    };
    let (a, b) = (
        for_unit(CalibrationData::example_imu()),
        for_unit(CalibrationData::example_triad()),
    );
    // Signed: a and b committed at counters 1 and 2; the last update offers a at 3.
    let (a, b, a_again) = if signed {
        (
            spincal_fuzz::sign(&a, &key, 1, false),
            spincal_fuzz::sign(&b, &key, 2, false),
            spincal_fuzz::sign(&a, &key, 3, false),
        )
    } else {
        (a.clone(), b, a)
    };
    let blob_of = |r: &[u8]| {
        blob::decode(spincal::signed::parts(r).0)
            .expect("blob")
            .data()
            .clone()
    };
    let mut buf = vec![0u8; spincal::protocol::SLOT_BUFFER];
    let mut scratch = CalibrationData::empty();
    let mem = if mode & 1 == 0 {
        let mut m: Vec<u8> = rest.iter().copied().cycle().take(REGION).collect();
        m.resize(REGION, 0xff);
        m
    } else {
        let mut s = Store::new(
            RamNor {
                mem: vec![0xff; REGION],
            },
            0,
            SLOT,
        )
        .expect("layout");
        let keys = [public];
        let policy = if signed {
            s.provision(&keys).expect("provisions");
            Policy::Signed {
                keys: &keys,
                unit: &unit,
            }
        } else {
            Policy::Open
        };
        s.update(&a, &mut buf, &mut scratch, policy)
            .expect("first update");
        s.update(&b, &mut buf, &mut scratch, policy)
            .expect("second update");
        let mut m = s.into_inner().mem;
        for c in rest.chunks_exact(3) {
            let at = usize::from(u16::from_le_bytes([c[0], c[1]])) % REGION;
            m[at] ^= c[2];
        }
        m
    };
    let mut store = Store::new(RamNor { mem }, 0, SLOT).expect("layout");
    let provisioning = store.provisioning().expect("a RAM flash does not fail");
    let policy = provisioning.policy(&unit);
    let slots = store
        .scan(&mut buf, &mut scratch, policy)
        .expect("a RAM flash does not fail");
    let locked = store.is_locked().expect("a RAM flash does not fail");
    let mut slot = CalibrationData::empty();
    let loaded = match store.load(&mut buf, &mut slot, policy) {
        Ok((cal, info)) => {
            assert!(
                matches!(slots[usize::from(info.index)], SlotState::Valid { seq, .. } if seq == info.seq)
            );
            Some(cal.data().clone())
        }
        Err(StoreError::NoValidSlot | StoreError::Refused(_)) => {
            assert!(
                slots.iter().all(|s| !matches!(s, SlotState::Valid { .. })),
                "{slots:?}"
            );
            None
        }
        Err(e) => panic!("load failed on a RAM flash: {e:?}"),
    };
    if mode & 1 == 1 && rest.is_empty() {
        assert_eq!(loaded.as_ref(), Some(&blob_of(&b)));
    }
    match store.update(&a_again, &mut buf, &mut scratch, policy) {
        Ok(_) => {
            assert!(!locked);
            let mut slot = CalibrationData::empty();
            let (cal, _) = store
                .load(&mut buf, &mut slot, policy)
                .expect("an update that returned Ok loads");
            assert_eq!(cal.data(), &blob_of(&a_again));
        }
        Err(StoreError::Locked) => assert!(locked),
        // Keys damaged by the corruption (or garbage keys), or signed slots corrupted into a
        // higher counter than the record offered: refused, nothing written.
        Err(StoreError::Refused(_)) => {
            assert!(!matches!(provisioning, Provisioning::Unprovisioned))
        }
        Err(e) => panic!("update failed on a RAM flash: {e:?}"),
    }
});
