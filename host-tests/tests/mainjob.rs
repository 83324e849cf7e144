//! The main job, end to end on the QEMU device: simulate, calibrate, report, blob, boot the
//! example firmware, flash over the emulated UART, verify on the device, record. Skips with a
//! notice without QEMU (unless SPINCAL_REQUIRE_QEMU=1, as in CI).

use host_tests::mainjob::{self, Job};
use host_tests::qemu;

#[test]
fn the_main_job_runs_end_to_end() {
    if !qemu::available_or_skip("the_main_job_runs_end_to_end") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let job = Job {
        data: None,
        workdir: dir.path().join("job"),
        db: dir.path().join("units.sqlite"),
        seed: 43,
        codes: mainjob::DEFAULT_CODES,
    };
    let s = mainjob::run(&job, |l| println!("{l}")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.flash.unit, mainjob::UNIT);
    assert!(s.flash.read_back_identical);
    assert!(s.flash.max_ulp <= 2, "{} ulp", s.flash.max_ulp);
    assert_eq!(s.flash.vectors, 64);
    let mut db = calflash::db::Db::open(&job.db).unwrap();
    let h = db.history(mainjob::UNIT).unwrap();
    assert_eq!(h.len(), 2);
    assert_eq!((h[0].kind.as_str(), h[1].kind.as_str()), ("fit", "flash"));
    let html = std::fs::read_to_string(job.workdir.join("report.html")).unwrap();
    assert!(html.matches("<svg").count() >= 10);
    let log = std::fs::read_to_string(job.workdir.join("qemu.log")).unwrap();
    assert!(log.contains("device: unit QEMU-0001 up"), "{log}");
    let reboot = std::fs::read_to_string(job.workdir.join("qemu-reboot.log")).unwrap();
    assert!(
        reboot.contains("device: calibration QEMU-0001 loaded"),
        "{reboot}"
    );
    assert_eq!(s.flash.seq, 1);
    // Signed with the station key the job made, verified by the unit at commit and at boot.
    let station = calflash::signing::load_public(&job.workdir.join("station.pub")).unwrap();
    let key = calflash::device::key_hex(station.id());
    assert_eq!(s.flash.trust, "provisioned");
    assert_eq!(s.flash.signed_by.as_deref(), Some(key.as_str()));
    assert_eq!(s.flash.counter, 1);
    assert!(
        reboot.contains(&format!(
            "device: the calibration verified at boot: signed by {key}, counter 1"
        )),
        "{reboot}"
    );

    // The unit's flash persists between runs: the second calibration goes to the other slot
    // with the next sequence number, and the history holds both.
    let again = mainjob::run(&job, |l| println!("{l}")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.flash.seq, 2);
    assert_eq!(again.flash.counter, 2, "the counter grows per unit");
    let flash = std::fs::read(job.workdir.join("unit-flash.bin")).unwrap();
    assert_eq!(flash.len(), host_tests::unit::region().1 as usize);
    assert_eq!(db.history(mainjob::UNIT).unwrap().len(), 4);
}

/// A unit whose converter gives signed two's-complement codes (as nearly every digital IMU
/// does) goes through the same job: simulated in signed codes, calibrated with them, flashed
/// and verified on the device by its test vectors.
#[test]
fn a_signed_code_imu_runs_the_main_job() {
    if !qemu::available_or_skip("a_signed_code_imu_runs_the_main_job") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let job = Job {
        data: None,
        workdir: dir.path().join("job"),
        db: dir.path().join("units.sqlite"),
        seed: 44,
        codes: mainjob::codes("signed16").unwrap(),
    };
    let mut said = Vec::new();
    let s = mainjob::run(&job, |l| said.push(l.to_string())).unwrap_or_else(|e| panic!("{e}"));
    let said = said.join("\n");
    println!("{said}");
    assert!(
        said.contains("1. simulated an IMU (signed16 codes)"),
        "{said}"
    );
    // The observations are signed: gravity on a negative-biased axis reads below zero.
    let obs = std::fs::read_to_string(job.workdir.join("observations.csv")).unwrap();
    assert!(
        obs.lines()
            .skip(1)
            .any(|l| l.split(',').any(|f| f.starts_with('-') && f.len() > 6))
    );
    assert_eq!(s.verdict, calflash::sensor::Verdict::Accept, "{said}");
    assert!(s.flash.read_back_identical);
    assert!(s.flash.max_ulp <= 2, "{} ulp", s.flash.max_ulp);
    assert_eq!(s.flash.vectors, 64);
    let cal =
        spincal::blob::decode(&std::fs::read(job.workdir.join("unit.blob")).unwrap()).unwrap();
    let spincal::model::Sensor::Imu {
        accel_rails,
        gyro_rails,
        ..
    } = &cal.data().sensor
    else {
        panic!("an IMU calibration");
    };
    assert_eq!(*accel_rails, spincal::model::Rails::signed(16));
    assert_eq!(*gyro_rails, spincal::model::Rails::signed(16));
}
