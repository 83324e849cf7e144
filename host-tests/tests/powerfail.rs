//! The store's promise, tested by cutting the power: after any cut during an update, or during
//! the recovery that follows it, the store yields exactly the old or exactly the new
//! calibration, never an error and never a mix; an update that returned Ok survives any later
//! cut. On a simulated NOR flash with write sizes 1, 4, 8 and 16 bytes, for an unprovisioned
//! unit (unsigned blobs) and a provisioned one (signed blobs, whose counter never goes back);
//! every count printed is recorded in RELIABILITY.md.

use std::sync::LazyLock;

use ed25519_dalek::SigningKey;
use host_tests::golden;
use host_tests::nor::{SimFlash, Tear};
use spincal::model::{CalibrationData, Serial};
use spincal::signed::StationKey;
use spincal::store::{Policy, SlotState, Store, StoreError};

const ERASE: usize = 1024;
const SLOT: u32 = 4 * ERASE as u32;
const SIZE: usize = Store::<SimFlash<4, ERASE>>::region_len(SLOT, ERASE as u32) as usize;

/// How the unit under test takes records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Unprovisioned: unsigned blobs.
    Open,
    /// Provisioned with [`STATION`]'s key: blobs signed for [`UNIT`] with growing counters.
    Signed,
}

/// The station that signs in [`Mode::Signed`].
static STATION: LazyLock<SigningKey> = LazyLock::new(|| SigningKey::from_bytes(&[7; 32]));
static KEYS: LazyLock<[StationKey; 1]> = LazyLock::new(|| {
    [StationKey {
        public: STATION.verifying_key().to_bytes(),
    }]
});
static UNIT: LazyLock<Serial> = LazyLock::new(|| Serial::new("UNIT-S").unwrap());

fn policy(mode: Mode) -> Policy<'static> {
    match mode {
        Mode::Open => Policy::Open,
        Mode::Signed => Policy::Signed {
            keys: &KEYS[..],
            unit: &UNIT,
        },
    }
}

/// A new unit's flash (never erased), provisioned in [`Mode::Signed`].
fn fresh<const W: usize>(mode: Mode) -> SimFlash<W, ERASE> {
    let flash = SimFlash::<W, ERASE>::new(SIZE);
    if mode == Mode::Open {
        return flash;
    }
    let mut store = Store::new(flash, 0, SLOT).unwrap();
    store.provision(&KEYS[..]).unwrap();
    let mut flash = store.into_inner();
    flash.reboot();
    flash
}

/// Calibrations to write: the golden triad and single axis, under several serials (signed for
/// the unit with counters 1, 2, 3, 4 in [`Mode::Signed`]).
fn blobs(mode: Mode) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for (i, serial) in ["OLD-1", "NEW-2", "NEWER-3", "X-4"].iter().enumerate() {
        let mut d = if i % 2 == 0 {
            CalibrationData::example_triad()
        } else {
            CalibrationData::example_single()
        };
        d.identity.serial = match mode {
            Mode::Open => Serial::new(serial).unwrap(),
            Mode::Signed => UNIT.clone(),
        };
        let blob = golden::encode(&d);
        out.push(match mode {
            Mode::Open => blob,
            Mode::Signed => calflash::signing::sign(&blob, &STATION, i as u32 + 1, false).unwrap(),
        });
    }
    out
}

fn update<const W: usize>(
    flash: SimFlash<W, ERASE>,
    blob: &[u8],
    mode: Mode,
) -> (SimFlash<W, ERASE>, Result<u32, StoreError>) {
    let mut store = Store::new(flash, 0, SLOT).unwrap();
    let mut buf = vec![0u8; SLOT as usize];
    let mut scratch = CalibrationData::empty();
    let r = store
        .update(blob, &mut buf, &mut scratch, policy(mode))
        .map(|i| i.seq);
    (store.into_inner(), r)
}

/// Reboot and load: the record bytes of the calibration the store yields.
fn boot<const W: usize>(
    flash: SimFlash<W, ERASE>,
    mode: Mode,
) -> (SimFlash<W, ERASE>, Result<Vec<u8>, StoreError>) {
    let (flash, r) = boot_counter(flash, mode);
    (flash, r.map(|(b, _)| b))
}

/// As [`boot`], with the loaded record's counter.
fn boot_counter<const W: usize>(
    mut flash: SimFlash<W, ERASE>,
    mode: Mode,
) -> (SimFlash<W, ERASE>, Result<(Vec<u8>, u32), StoreError>) {
    flash.reboot();
    let before = flash.mem.clone();
    let mut store = Store::new(flash, 0, SLOT).unwrap();
    let mut buf = vec![0u8; SLOT as usize];
    let mut slot = CalibrationData::empty();
    let r = store
        .load(&mut buf, &mut slot, policy(mode))
        .map(|(_, info)| (buf[..info.len as usize].to_vec(), info.counter));
    let flash = store.into_inner();
    assert_eq!(flash.ops, 0, "boot must not write or erase");
    assert_eq!(flash.mem, before, "boot changed the flash");
    (flash, r)
}

fn tears(op_len: usize, erase: bool) -> Vec<Tear> {
    let mut t = vec![Tear::Skip, Tear::Complete];
    if erase {
        t.extend((1..=4).map(Tear::RandomZeros));
    } else {
        t.extend((0..op_len).map(Tear::Partial));
        t.extend((1..=4).map(Tear::RandomBits));
    }
    t
}

/// The operations of an update from `flash`: (is erase, bytes written).
fn operations<const W: usize>(
    flash: &SimFlash<W, ERASE>,
    blob: &[u8],
    mode: Mode,
) -> Vec<(bool, usize)> {
    // Dry run on a copy with a spy: count ops and their sizes by cutting "complete" at each.
    let mut out = Vec::new();
    let (done, r) = update(flash.clone(), blob, mode);
    r.unwrap();
    for i in 0..done.ops - flash.ops {
        let mut f = flash.clone();
        let before = f.mem.clone();
        f.cut_at(i, Tear::Complete);
        let (f, _) = update(f, blob, mode);
        // An erase touches a whole slot; a write touches at most its own bytes.
        let changed = f.mem.iter().zip(&before).filter(|(a, b)| a != b).count();
        let is_erase = i == 0;
        out.push((
            is_erase,
            if is_erase {
                0
            } else {
                changed.max(16).min(blob.len() + 16)
            },
        ));
    }
    out
}

/// Cuts every operation of an update of `new` from `start` in every way; returns the cases run.
fn every_cut<const W: usize>(
    start: &SimFlash<W, ERASE>,
    old: Option<&[u8]>,
    new: &[u8],
    mode: Mode,
) -> usize {
    let ops = operations(start, new, mode);
    let mut cases = 0;
    for (i, (is_erase, len)) in ops.iter().enumerate() {
        for tear in tears(*len, *is_erase) {
            let mut f = start.clone();
            f.cut_at(i, tear);
            let (f, r) = update(f, new, mode);
            assert!(
                r.is_err(),
                "op {i} {tear:?}: the update cannot succeed without power"
            );
            assert!(f.violations.is_empty(), "{:?}", f.violations);
            let (_, got) = boot(f, mode);
            match (got, old) {
                (Ok(b), Some(old)) => assert!(b == old || b == new, "W={W} op {i} {tear:?}: a mix"),
                (Ok(b), None) => assert_eq!(b, new, "W={W} op {i} {tear:?}"),
                (Err(StoreError::NoValidSlot), None) => {}
                (Err(e), _) => panic!("W={W} op {i} {tear:?}: {e}"),
            }
            cases += 1;
        }
    }
    cases
}

fn cut_every_operation<const W: usize>(mode: Mode) -> usize {
    let b = blobs(mode);
    let mut cases = 0;
    // A new unit: flash never erased.
    let fresh = fresh::<W>(mode);
    cases += every_cut(&fresh, None, &b[0], mode);
    // One valid slot.
    let (one, r) = update(fresh.clone(), &b[0], mode);
    r.unwrap();
    cases += every_cut(&one, Some(&b[0]), &b[1], mode);
    // Both slots valid (the idle one older).
    let (two, r) = update(one.clone(), &b[1], mode);
    r.unwrap();
    cases += every_cut(&two, Some(&b[1]), &b[2], mode);
    // The idle slot left half-written by an earlier cut.
    let mut torn = one.clone();
    torn.cut_at(1, Tear::Partial(37));
    let (torn, _) = update(torn, &b[3], mode);
    let (torn, got) = boot(torn, mode);
    assert_eq!(got.unwrap(), b[0]);
    cases += every_cut(&torn, Some(&b[0]), &b[1], mode);
    cases
}

fn all_write_sizes(mode: Mode) -> usize {
    cut_every_operation::<1>(mode)
        + cut_every_operation::<4>(mode)
        + cut_every_operation::<8>(mode)
        + cut_every_operation::<16>(mode)
}

#[test]
fn a_cut_at_every_operation_leaves_old_or_new() {
    let cases = all_write_sizes(Mode::Open);
    println!("powerfail: {cases} single-cut cases (write sizes 1, 4, 8, 16)");
    assert!(cases > 4_000);
}

#[test]
fn a_cut_at_every_operation_of_a_signed_update_leaves_old_or_new() {
    let cases = all_write_sizes(Mode::Signed);
    println!("powerfail: {cases} single-cut cases with signed blobs (write sizes 1, 4, 8, 16)");
    assert!(cases > 4_000);
}

fn nested<const W: usize>(mode: Mode) -> usize {
    let b = blobs(mode);
    let (start, r) = update(fresh::<W>(mode), &b[0], mode);
    r.unwrap();
    let ops = operations(&start, &b[1], mode);
    let mut cases = 0;
    let kinds = |len: usize, erase: bool| -> Vec<Tear> {
        if erase {
            vec![Tear::Skip, Tear::Complete, Tear::RandomZeros(9)]
        } else {
            vec![
                Tear::Skip,
                Tear::Complete,
                Tear::Partial(len / 2),
                Tear::RandomBits(5),
            ]
        }
    };
    for (i, (ei, li)) in ops.iter().enumerate() {
        for t1 in kinds(*li, *ei) {
            let mut f = start.clone();
            f.cut_at(i, t1);
            let (f, _) = update(f, &b[1], mode);
            // Recovery: boot (which writes nothing), then the host retries the update and the
            // power is cut again, at every operation of the retry.
            let (f, got) = boot(f, mode);
            let first = got.unwrap();
            assert!(first == b[0] || first == b[1]);
            let (done, r) = update(f.clone(), &b[1], mode);
            r.unwrap();
            for j in 0..done.ops - f.ops {
                for t2 in kinds(16, j == 0) {
                    let mut g = f.clone();
                    g.cut_at(j, t2);
                    let (g, _) = update(g, &b[1], mode);
                    assert!(g.violations.is_empty(), "{:?}", g.violations);
                    let (_, got) = boot(g, mode);
                    let got = got
                        .unwrap_or_else(|e| panic!("W={W} cuts {i} {t1:?} then {j} {t2:?}: {e}"));
                    assert!(
                        got == b[0] || got == b[1],
                        "W={W} cuts {i} {t1:?} then {j} {t2:?}: a mix"
                    );
                    cases += 1;
                }
            }
        }
    }
    cases
}

#[test]
fn every_pair_of_nested_cuts_during_recovery() {
    let mut cases = 0;
    for mode in [Mode::Open, Mode::Signed] {
        cases += nested::<1>(mode) + nested::<4>(mode) + nested::<8>(mode) + nested::<16>(mode);
    }
    println!("powerfail: {cases} nested-cut cases (unsigned and signed)");
    assert!(cases > 1_000);
}

#[test]
fn an_update_that_returned_ok_survives_any_later_cut() {
    for mode in [Mode::Open, Mode::Signed] {
        let b = blobs(mode);
        let (f, r) = update(fresh::<4>(mode), &b[0], mode);
        r.unwrap();
        let (f, r) = update(f, &b[1], mode);
        r.unwrap();
        // Every cut of the next update keeps b[1] (or the newer).
        let ops = operations(&f, &b[2], mode);
        for (i, (e, len)) in ops.iter().enumerate() {
            for tear in tears(*len, *e) {
                let mut g = f.clone();
                g.cut_at(i, tear);
                let (g, _) = update(g, &b[2], mode);
                let (_, got) = boot(g, mode);
                let got = got.unwrap();
                assert!(got == b[1] || got == b[2], "{mode:?}");
            }
        }
    }
}

/// A small deterministic generator for the campaign.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

fn campaign<const W: usize>(sequences: usize, seed: u64, mode: Mode) -> usize {
    let b = blobs(mode);
    let mut rng = Rng(seed);
    let mut cuts = 0;
    for _ in 0..sequences {
        let mut flash = fresh::<W>(mode);
        let mut current: Option<Vec<u8>> = None;
        let mut held = 0u32;
        for _ in 0..(1 + rng.below(4)) {
            let new = &b[rng.below(b.len() as u64) as usize];
            let cut = rng.below(3) != 0;
            if cut {
                let at = rng.below(5) as usize;
                let tear = match rng.below(5) {
                    0 => Tear::Skip,
                    1 => Tear::Complete,
                    2 => Tear::Partial(rng.below(400) as usize),
                    3 => Tear::RandomBits(rng.next()),
                    _ => Tear::RandomZeros(rng.next()),
                };
                flash.cut_at(at, tear);
                cuts += 1;
            }
            let (f, r) = update(flash, new, mode);
            let (f, got) = boot(f, mode);
            assert!(f.violations.is_empty(), "{:?}", f.violations);
            match (r, got) {
                (Ok(_), Ok(g)) => assert_eq!(&g, new, "an update that returned Ok is not current"),
                (Err(_), Ok(g)) => assert!(
                    Some(&g) == current.as_ref() || &g == new,
                    "a mix or a stale calibration"
                ),
                (Err(_), Err(StoreError::NoValidSlot)) => {
                    assert!(current.is_none(), "a committed calibration was lost")
                }
                (r, g) => panic!("update {r:?}, boot {g:?}"),
            }
            let (_, now) = boot_counter(f.clone(), mode);
            if let Ok((_, counter)) = &now {
                assert!(
                    *counter >= held,
                    "the counter went back from {held} to {counter}"
                );
                held = *counter;
            }
            current = now.ok().map(|(b, _)| b);
            flash = f;
        }
    }
    cuts
}

#[test]
fn a_random_campaign_of_multi_cut_sequences() {
    let n = 25_000;
    let cuts = campaign::<1>(n, 1, Mode::Open)
        + campaign::<4>(n, 2, Mode::Open)
        + campaign::<8>(n, 3, Mode::Open)
        + campaign::<16>(n, 4, Mode::Open);
    println!("powerfail: {} random sequences with {cuts} cuts", 4 * n);
    assert!(cuts > 100_000);
}

#[test]
fn a_random_campaign_of_signed_updates_never_moves_the_counter_back() {
    // Blobs picked at random: older counters are refused (replays), newer ones committed, with
    // cuts anywhere; fewer sequences than unsigned, each boot and commit verifying signatures.
    let n = 2_500;
    let cuts = campaign::<1>(n, 5, Mode::Signed)
        + campaign::<4>(n, 6, Mode::Signed)
        + campaign::<8>(n, 7, Mode::Signed)
        + campaign::<16>(n, 8, Mode::Signed);
    println!(
        "powerfail: {} random signed sequences with {cuts} cuts",
        4 * n
    );
    assert!(cuts > 10_000);
}

#[test]
fn a_locked_store_refuses_updates_and_keeps_its_calibration() {
    let b = blobs(Mode::Open);
    let (f, r) = update(fresh::<4>(Mode::Open), &b[0], Mode::Open);
    r.unwrap();
    let mut store = Store::new(f, 0, SLOT).unwrap();
    assert!(!store.is_locked().unwrap());
    store.lock().unwrap();
    assert!(store.is_locked().unwrap());
    let mut buf = vec![0u8; SLOT as usize];
    let mut scratch = CalibrationData::empty();
    assert_eq!(
        store.update(&b[1], &mut buf, &mut scratch, Policy::Open),
        Err(StoreError::Locked)
    );
    let (_, got) = boot(store.into_inner(), Mode::Open);
    assert_eq!(got.unwrap(), b[0]);
}

#[test]
fn invalid_blobs_and_bad_layouts_are_refused_before_writing() {
    let b = blobs(Mode::Open);
    let (f, r) = update(fresh::<4>(Mode::Open), &b[0], Mode::Open);
    r.unwrap();
    let before = f.mem.clone();
    let mut bad = b[1].clone();
    bad[20] ^= 1;
    let (f, r) = update(f, &bad, Mode::Open);
    assert!(matches!(
        r,
        Err(StoreError::InvalidBlob(
            spincal::Error::ChecksumMismatch { .. }
        ))
    ));
    assert_eq!(f.mem, before, "nothing written");
    assert!(matches!(
        Store::new(f.clone(), 100, SLOT),
        Err(StoreError::Layout)
    ));
    assert!(matches!(
        Store::new(f, 0, 100 * SLOT),
        Err(StoreError::Layout)
    ));
}

#[test]
fn a_slot_image_is_what_an_update_writes() {
    let b = blobs(Mode::Open);
    let (f, r) = update(fresh::<4>(Mode::Open), &b[2], Mode::Open);
    r.unwrap();
    let mut image = vec![0u8; SLOT as usize];
    let mut scratch = CalibrationData::empty();
    let n = spincal::store::slot_image(&b[2], 1, &mut image, &mut scratch).unwrap();
    assert_eq!(n, 32 + b[2].len());
    assert_eq!(&f.mem[..SLOT as usize], &image[..], "byte for byte");
    // And a flash programmed with it boots with that calibration.
    let mut g = SimFlash::<4, ERASE>::new(SIZE);
    g.mem[..SLOT as usize].copy_from_slice(&image);
    g.mem[SLOT as usize..].fill(0xff);
    assert_eq!(boot(g, Mode::Open).1.unwrap(), b[2]);
}

/// Found by `cargo fuzz` (store_flash): a newer slot whose header claims a blob longer than any
/// valid blob (but within the slot) must count as invalid, so boot falls back to the older
/// slot; it once made `scan` and `load` fail with `BufferTooSmall` instead, losing both.
#[test]
fn a_header_claiming_an_impossible_length_is_an_invalid_slot() {
    // A slot with room for a length beyond the boot buffer.
    const BIG_SLOT: u32 = ((spincal::protocol::SLOT_BUFFER / ERASE + 2) * ERASE) as u32;
    let region = Store::<SimFlash<4, ERASE>>::region_len(BIG_SLOT, ERASE as u32) as usize;
    let [old, new, ..] = &blobs(Mode::Open)[..] else {
        unreachable!()
    };
    let mut store = Store::new(SimFlash::<4, ERASE>::new(region), 0, BIG_SLOT).unwrap();
    let mut buf = vec![0u8; spincal::protocol::SLOT_BUFFER];
    let mut scratch = CalibrationData::empty();
    store
        .update(old, &mut buf, &mut scratch, Policy::Open)
        .unwrap();
    let newer = store
        .update(new, &mut buf, &mut scratch, Policy::Open)
        .unwrap();
    let mut flash = store.into_inner();
    // The slot header's length field (slot offset 16 + 8, `store` module docs), set beyond the
    // largest blob and the boot buffer but within the slot; the commit marker and magic stay
    // sound.
    let at = newer.index as usize * BIG_SLOT as usize + 24;
    let len = u32::try_from(spincal::protocol::SLOT_BUFFER + 1).unwrap();
    assert!(len < BIG_SLOT - 32);
    flash.mem[at..at + 4].copy_from_slice(&len.to_le_bytes());
    let mut store = Store::new(flash, 0, BIG_SLOT).unwrap();
    let slots = store.scan(&mut buf, &mut scratch, Policy::Open).unwrap();
    assert_eq!(slots[usize::from(newer.index)], SlotState::Invalid);
    let mut slot = CalibrationData::empty();
    let (cal, info) = store.load(&mut buf, &mut slot, Policy::Open).unwrap();
    assert_ne!(info.index, newer.index);
    assert_eq!(
        cal.data(),
        spincal::blob::decode(old).unwrap().data(),
        "boot falls back to the older calibration"
    );
}
