//! The store over random flash contents: the input is either the whole region (first byte
//! even) or a list of (offset, xor) corruptions of a region holding two valid slots (first byte
//! odd), so the fuzzer reaches both garbage and nearly valid states. Scanning, loading and the
//! lock check never panic; what loads is a valid calibration equal to one of the slots'; and an
//! update on an unlocked store returns Ok and is then exactly what loads.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::blob;
use spincal::model::CalibrationData;
use spincal::store::{SlotState, Store, StoreError};
use spincal_fuzz::RamNor;

const SLOT: u32 = 12 * 1024;
const REGION: usize = 2 * SLOT as usize + 1024;

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
    let (a, b) = (
        encode(CalibrationData::example_imu()),
        encode(CalibrationData::example_triad()),
    );
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
        s.update(&a, &mut buf, &mut scratch).expect("first update");
        s.update(&b, &mut buf, &mut scratch).expect("second update");
        let mut m = s.into_inner().mem;
        for c in rest.chunks_exact(3) {
            let at = usize::from(u16::from_le_bytes([c[0], c[1]])) % REGION;
            m[at] ^= c[2];
        }
        m
    };
    let mut store = Store::new(RamNor { mem }, 0, SLOT).expect("layout");
    let slots = store
        .scan(&mut buf, &mut scratch)
        .expect("a RAM flash does not fail");
    let locked = store.is_locked().expect("a RAM flash does not fail");
    let mut slot = CalibrationData::empty();
    let loaded = match store.load(&mut buf, &mut slot) {
        Ok((cal, info)) => {
            assert!(
                matches!(slots[usize::from(info.index)], SlotState::Valid { seq, .. } if seq == info.seq)
            );
            Some(cal.data().clone())
        }
        Err(StoreError::NoValidSlot) => {
            assert!(
                slots.iter().all(|s| !matches!(s, SlotState::Valid { .. })),
                "{slots:?}"
            );
            None
        }
        Err(e) => panic!("load failed on a RAM flash: {e:?}"),
    };
    if mode & 1 == 1 && rest.is_empty() {
        assert_eq!(loaded.as_ref(), Some(blob::decode(&b).expect("b").data()));
    }
    match store.update(&a, &mut buf, &mut scratch) {
        Ok(_) => {
            assert!(!locked);
            let mut slot = CalibrationData::empty();
            let (cal, _) = store
                .load(&mut buf, &mut slot)
                .expect("an update that returned Ok loads");
            assert_eq!(cal.data(), blob::decode(&a).expect("a").data());
        }
        Err(StoreError::Locked) => assert!(locked),
        Err(e) => panic!("update failed on a RAM flash: {e:?}"),
    }
});
