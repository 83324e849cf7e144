//! `calflash flash` against a unit that misbehaves: stops answering mid-transfer, garbles an
//! answer, drops the link, loses the commit's answer, has another serial, is locked; and a
//! unit history database that cannot take the record. Each gives one clear message, the unit
//! keeps the calibration it had (checked on the flash after a reboot), and no record is lost.

use std::path::{Path, PathBuf};

use calflash::cmd::flash::{FlashArgs, run};
use calflash::db::Db;
use host_tests::golden;
use host_tests::tcp_unit::{self, Fault, Flash, TcpUnit};
use spincal::model::CalibrationData;
use spincal::protocol::{MAX_CHUNK, Request, Response};

const UNIT: &str = "IMU-FULL-0042";

fn old_blob() -> Vec<u8> {
    golden::encode(&CalibrationData::example_imu())
}

/// The same unit recalibrated: another centre code on the first accelerometer axis.
fn new_blob() -> Vec<u8> {
    let mut d = CalibrationData::example_imu();
    if let spincal::model::Sensor::Imu { accel, .. } = &mut d.sensor {
        accel[0].center += 3.0;
    }
    golden::encode(&d)
}

struct Bench {
    dir: tempfile::TempDir,
}

impl Bench {
    fn new() -> Self {
        Self {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn blob(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// Runs `calflash flash` against a unit over `flash` with `fault`; returns the result and
    /// the flash afterwards.
    fn flash(
        &self,
        flash: Flash,
        unit: &str,
        blob: &Path,
        fault: Fault,
        force: bool,
    ) -> (Result<(), String>, Flash) {
        let u = TcpUnit::serve(tcp_unit::device(flash, unit), fault);
        let args = FlashArgs {
            blob: blob.to_path_buf(),
            port: u.address(),
            force,
            force_rejected: false,
            timeout: 0.3,
            vectors: 4,
            db: Some(self.path("units.sqlite").into()),
            no_db: false,
            sign_key: None,
        };
        let r = run(&args).map_err(|e| e.to_string());
        (r, u.finish().into_store().into_inner())
    }

    /// A unit holding the old calibration.
    fn unit_with_old(&self) -> Flash {
        let (r, flash) = self.flash(
            tcp_unit::blank_flash(),
            UNIT,
            &self.blob("old.blob", &old_blob()),
            Fault::None,
            false,
        );
        r.unwrap();
        flash
    }

    fn history(&self) -> Vec<(String, String)> {
        Db::open(&self.path("units.sqlite"))
            .unwrap()
            .history(UNIT)
            .unwrap()
            .into_iter()
            .map(|e| (e.kind, e.outcome))
            .collect()
    }
}

/// What the unit holds after a power cycle.
fn held_after_reboot(mut flash: Flash) -> Option<Vec<u8>> {
    flash.reboot();
    let d = tcp_unit::device(flash, UNIT);
    d.calibration().map(|c| {
        let mut out = vec![0u8; spincal::blob::MAX_BLOB_LEN];
        let n = spincal::blob::encode(c, &mut out).unwrap();
        out.truncate(n);
        out
    })
}

fn chunks(blob: &[u8]) -> usize {
    blob.len().div_ceil(MAX_CHUNK)
}

#[test]
fn a_unit_that_stops_answering_mid_transfer_keeps_its_calibration() {
    let b = Bench::new();
    let flash = b.unit_with_old();
    assert_eq!(held_after_reboot(flash.clone()), Some(old_blob()));
    // Requests: 1 identify, 2 begin, 3 chunk at 0, 4 chunk at 256: silence from there on.
    let new = b.blob("new.blob", &new_blob());
    let (r, flash) = b.flash(flash, UNIT, &new, Fault::SilentFrom(4), false);
    let e = r.unwrap_err();
    assert_eq!(
        e,
        format!(
            "the unit did not answer the chunk at byte 256 within 0.3 s, at byte 256 of {} of the transfer; nothing was committed: the unit keeps its calibration {UNIT}",
            new_blob().len()
        )
    );
    assert_eq!(held_after_reboot(flash.clone()), Some(old_blob()));
    assert_eq!(
        b.history(),
        [
            ("flash".into(), "verified".into()),
            ("flash".into(), "failed".into())
        ]
    );
    // The abandoned transfer does not stand in the way of the next one.
    let (r, flash) = b.flash(flash, UNIT, &new, Fault::None, false);
    r.unwrap();
    assert_eq!(held_after_reboot(flash), Some(new_blob()));
}

#[test]
fn a_garbled_answer_or_a_dropped_link_changes_nothing() {
    let b = Bench::new();
    let new = b.blob("new.blob", &new_blob());
    for (fault, says) in [
        (
            Fault::GarbleAnswer(3),
            "the unit's answer to the chunk at byte 0 was garbled",
        ),
        (
            Fault::GarbleAnswer(2),
            "the unit's answer to the start of a",
        ),
        (
            Fault::CloseAt(5),
            "the link failed during the chunk at byte 512",
        ),
    ] {
        let (r, flash) = b.flash(b.unit_with_old(), UNIT, &new, fault, false);
        let e = r.unwrap_err();
        assert!(e.starts_with(says), "{fault:?}: {e}");
        assert!(
            e.ends_with(&format!(
                "nothing was committed: the unit keeps its calibration {UNIT}"
            )),
            "{e}"
        );
        assert_eq!(held_after_reboot(flash), Some(old_blob()), "{fault:?}");
    }
}

#[test]
fn a_lost_commit_answer_says_old_or_new_and_the_unit_holds_one_of_them() {
    let b = Bench::new();
    let new = b.blob("new.blob", &new_blob());
    let commit = 3 + chunks(&new_blob());
    for fault in [Fault::SilentFrom(commit), Fault::GarbleAnswer(commit)] {
        let (r, flash) = b.flash(b.unit_with_old(), UNIT, &new, fault, false);
        let e = r.unwrap_err();
        assert!(
            e.contains("the commit was sent but its answer was lost"),
            "{e}"
        );
        assert!(
            e.contains(&format!(
                "either its previous calibration {UNIT} or the new one"
            )),
            "{e}"
        );
        let held = held_after_reboot(flash);
        match fault {
            // Silence from the commit on: the unit never handled it.
            Fault::SilentFrom(_) => assert_eq!(held, Some(old_blob())),
            _ => assert_eq!(held, Some(new_blob())),
        }
    }
    // A lost answer after the commit: committed but not verified, and said so.
    let (r, flash) = b.flash(
        b.unit_with_old(),
        UNIT,
        &new,
        Fault::SilentFrom(commit + 1),
        false,
    );
    let e = r.unwrap_err();
    assert!(e.ends_with("after the commit: the unit holds the new calibration (slot sequence 2) but it is NOT verified; flash again to verify it"), "{e}");
    assert_eq!(held_after_reboot(flash), Some(new_blob()));
}

#[test]
fn a_wrong_serial_is_refused_unless_forced() {
    let b = Bench::new();
    let blob = b.blob("old.blob", &old_blob());
    let blank = tcp_unit::blank_flash();
    let (r, flash) = b.flash(blank.clone(), "OTHER-9", &blob, Fault::None, false);
    assert_eq!(
        r.unwrap_err(),
        format!(
            "the blob is for unit {UNIT} but the unit is OTHER-9; nothing was written (use --force to write it anyway)"
        )
    );
    assert_eq!(flash.mem, blank.mem, "nothing written");
    let (r, flash) = b.flash(blank, "OTHER-9", &blob, Fault::None, true);
    r.unwrap();
    assert_eq!(held_after_reboot(flash), Some(old_blob()));
}

#[test]
fn a_locked_unit_refuses_and_keeps_its_calibration() {
    let b = Bench::new();
    let mut d = tcp_unit::device(b.unit_with_old(), UNIT);
    assert_eq!(d.handle(Request::Lock), Response::LockedOk);
    let locked = d.into_store().into_inner();
    let (r, flash) = b.flash(
        locked.clone(),
        UNIT,
        &b.blob("new.blob", &new_blob()),
        Fault::None,
        false,
    );
    assert_eq!(
        r.unwrap_err(),
        format!("unit {UNIT} is locked against writes; it keeps its calibration {UNIT}")
    );
    assert_eq!(flash.mem, locked.mem, "nothing written");
}

#[test]
fn an_unwritable_database_loses_no_record() {
    let b = Bench::new();
    let blob = b.blob("old.blob", &old_blob());
    // A database that cannot be written, even by root: its rollback journal cannot be created.
    Db::open(&b.path("units.sqlite")).unwrap();
    std::fs::create_dir(b.path("units.sqlite-journal")).unwrap();
    let (r, flash) = b.flash(tcp_unit::blank_flash(), UNIT, &blob, Fault::None, false);
    let e = r.unwrap_err();
    assert!(e.starts_with("the unit holds the new calibration, verified, but the flash is NOT recorded: the unit history database "), "{e}");
    let saved = e
        .rsplit_once("the record is saved in ")
        .map(|(_, p)| p.trim_end_matches(" instead"))
        .unwrap_or_else(|| panic!("{e}"));
    let record: serde_json::Value = serde_json::from_slice(&std::fs::read(saved).unwrap()).unwrap();
    assert_eq!(record["unit"], UNIT);
    assert_eq!(record["read_back_identical"], true);
    assert_eq!(held_after_reboot(flash), Some(old_blob()));
    // Nothing half-written: the database still opens and holds no row.
    std::fs::remove_dir(b.path("units.sqlite-journal")).unwrap();
    assert!(b.history().is_empty());
}

/// The old blob as `calflash calibrate --force-blob` writes it after a REJECT.
fn rejected_blob() -> Vec<u8> {
    let mut d = CalibrationData::example_imu();
    d.identity.fit_rejected = true;
    golden::encode(&d)
}

#[test]
fn a_blob_whose_fit_was_rejected_is_refused_unless_forced() {
    let b = Bench::new();
    let blob = b.blob("rejected.blob", &rejected_blob());
    let held = b.unit_with_old();
    let (r, flash) = b.flash(held.clone(), UNIT, &blob, Fault::None, false);
    assert_eq!(
        r.unwrap_err(),
        "the blob's fit was judged REJECT (it was written with --force-blob); nothing was written (use --force-rejected to write it anyway)"
    );
    assert_eq!(flash.mem, held.mem, "nothing written");
    // The refusal is recorded under the unit, beside the flash that put the old one there.
    assert_eq!(
        b.history(),
        [
            ("flash".into(), "verified".into()),
            ("flash".into(), "failed".into())
        ]
    );
    // Forced, it goes in.
    let u = TcpUnit::serve(tcp_unit::device(held, UNIT), Fault::None);
    let args = FlashArgs {
        blob: blob.clone(),
        port: u.address(),
        force: false,
        force_rejected: true,
        timeout: 0.3,
        vectors: 4,
        db: Some(b.path("units.sqlite").into()),
        no_db: false,
        sign_key: None,
    };
    run(&args).unwrap();
    assert_eq!(
        held_after_reboot(u.finish().into_store().into_inner()),
        Some(rejected_blob())
    );
}

#[test]
fn a_blob_for_another_sensor_is_refused_before_anything_is_written() {
    let b = Bench::new();
    // A single-axis calibration carrying the IMU unit's serial.
    let mut single = CalibrationData::example_single();
    single.identity.serial = spincal::model::Serial::new(UNIT).unwrap();
    let blob = b.blob("single.blob", &golden::encode(&single));
    let held = b.unit_with_old();
    for force in [false, true] {
        let (r, flash) = b.flash(held.clone(), UNIT, &blob, Fault::None, force);
        let e = r.unwrap_err();
        assert!(
            e.starts_with("the blob is for a single-axis")
                && e.contains(&format!("but unit {UNIT} carries an IMU"))
                && e.ends_with("nothing was written"),
            "{e}"
        );
        assert_eq!(flash.mem, held.mem, "nothing written, even with --force");
    }
}

#[test]
fn a_refused_flash_is_recorded_under_the_unit_that_answered() {
    let b = Bench::new();
    // The blob of another unit, and a blob that is not one at all.
    let other = {
        let mut d = CalibrationData::example_imu();
        d.identity.serial = spincal::model::Serial::new("IMU-OTHER-7").unwrap();
        golden::encode(&d)
    };
    let held = b.unit_with_old();
    for (name, bytes) in [("other.blob", other), ("garbage.blob", vec![0x55; 300])] {
        let (r, _) = b.flash(
            held.clone(),
            UNIT,
            &b.blob(name, &bytes),
            Fault::None,
            false,
        );
        assert!(r.is_err(), "{name}");
    }
    let mut db = Db::open(&b.path("units.sqlite")).unwrap();
    assert_eq!(db.history(UNIT).unwrap().len(), 3, "all three under {UNIT}");
    assert!(db.history("IMU-OTHER-7").unwrap().is_empty());
    assert!(db.history("?").unwrap().is_empty());
}
