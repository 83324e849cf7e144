//! The example device boots from what a flasher wrote: the region image `calflash image --bin`
//! makes is loaded at `_calib_start` on QEMU, and the unit comes up with that calibration (read
//! back byte for byte over its UART); a corrupted image gives a unit that holds nothing and flags
//! every sample. Skips without QEMU unless SPINCAL_REQUIRE_QEMU=1 (as in CI).

use std::time::Duration;

use calflash::device::image::{Region, region_image};
use host_tests::unit::QemuUnit;
use host_tests::{golden, qemu};
use spincal::model::CalibrationData;
use spincal::protocol::{MAX_CHUNK, Request, Response};
use spincal::store::SlotState;

fn boot_with(
    image: &[u8],
    dir: &std::path::Path,
) -> (spincal::protocol::Identity, Vec<u8>, String) {
    boot_unit("device", image, dir)
}

/// Boots the example device binary `name` with the region `image` loaded.
fn boot_unit(
    name: &str,
    image: &[u8],
    dir: &std::path::Path,
) -> (spincal::protocol::Identity, Vec<u8>, String) {
    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let (flash, log) = (dir.join("flash.bin"), dir.join("qemu.log"));
    std::fs::write(&flash, image).unwrap();
    let unit = QemuUnit::power_on(&bin.join(name), Some(&flash), &log).unwrap();
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    let id = client.identify().unwrap();
    let mut back = Vec::new();
    while back.len() < id.blob_len as usize {
        let len = (id.blob_len as usize - back.len()).min(MAX_CHUNK) as u16;
        match client
            .call(&Request::ReadBlob {
                offset: back.len() as u32,
                len,
            })
            .unwrap()
        {
            Response::Blob { data, .. } => back.extend_from_slice(&data),
            r => panic!("{r:?}"),
        }
    }
    drop(client);
    drop(unit);
    (id, back, std::fs::read_to_string(&log).unwrap())
}

#[test]
fn the_unit_boots_with_the_image_a_flasher_wrote() {
    if !qemu::available_or_skip("the_unit_boots_with_the_image_a_flasher_wrote") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let blob = golden::encode(&CalibrationData::example_imu());
    let image = region_image(&blob, Region::from_memory_x()).unwrap();
    let (id, back, log) = boot_with(&image, dir.path());
    assert_eq!(
        id.calibration.as_ref().map(|s| s.as_str()),
        Some("IMU-FULL-0042"),
        "{log}"
    );
    assert!(
        matches!(id.slots[0], SlotState::Valid { seq: 1, .. }),
        "{:?}",
        id.slots
    );
    assert_eq!(back, blob);
    assert!(
        log.contains("device: calibration IMU-FULL-0042 loaded; 1000 raw samples corrected"),
        "{log}"
    );

    // One flipped bit in the payload: the slot fails its CRC and the unit holds nothing.
    let mut bad = image.clone();
    bad[40] ^= 0x04;
    let (id, back, log) = boot_with(&bad, dir.path());
    assert_eq!(id.calibration, None, "{log}");
    assert!(back.is_empty());
    assert!(
        log.contains(
            "device: no valid calibration; 1000 samples passed through and flagged (1000 flagged)"
        ),
        "{log}"
    );
}

#[test]
fn a_unit_with_an_mpu6050_reads_its_samples_through_the_driver() {
    if !qemu::available_or_skip("a_unit_with_an_mpu6050_reads_its_samples_through_the_driver") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // The signed 16-bit unit: an IMU whose codes come as the MPU-6050 delivers them.
    let data = golden::in_format(
        CalibrationData::example_imu(),
        spincal::model::SampleFormat::I16,
    );
    let blob = golden::encode(&data);
    let image = region_image(&blob, Region::from_memory_x()).unwrap();
    let (id, _, log) = boot_unit("device_signed16", &image, dir.path());
    assert_eq!(
        id.calibration.as_ref().map(|s| s.as_str()),
        Some("IMU-FULL-0042"),
        "{log}"
    );
    assert!(
        log.contains(
            "device: 1000 samples read from the MPU-6050 over I2C (spincal::driver) and corrected in blocks"
        ),
        "{log}"
    );
    assert!(
        log.contains("device: calibration IMU-FULL-0042 loaded; 1000 raw samples corrected"),
        "{log}"
    );
}

/// An idle unit sleeps (`wfi` until its UART receives): over 3 s without a client it uses
/// under a tenth of a host core (it used a whole core spinning on the UART's status), and it
/// still answers when spoken to. The figure is printed for BENCHMARKS.
#[test]
fn an_idle_unit_sleeps_and_still_answers() {
    if !qemu::available_or_skip("an_idle_unit_sleeps_and_still_answers") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let log = dir.path().join("qemu.log");
    let unit = QemuUnit::power_on(&bin.join("device"), None, &log).unwrap();
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    client.identify().unwrap();
    // Booted and served once; now idle with the client connected and silent.
    std::thread::sleep(Duration::from_secs(1));
    let (t0, c0) = (std::time::Instant::now(), unit.cpu_time().unwrap());
    std::thread::sleep(Duration::from_secs(3));
    let share = (unit.cpu_time().unwrap() - c0).as_secs_f64() / t0.elapsed().as_secs_f64();
    println!("idle unit: {:.1} % of a host core over 3 s", 100.0 * share);
    assert!(
        share < 0.10,
        "the idle unit uses {:.0} % of a host core",
        100.0 * share
    );
    let id = client.identify().unwrap();
    assert_eq!(id.calibration, None);
}

/// Sends `record` to the unit over its UART and commits it; the commit's answer.
fn commit_over_uart<L: std::io::Read + std::io::Write>(
    client: &mut calflash::device::Client<L>,
    record: &[u8],
) -> Response {
    let r = client
        .call(&Request::WriteBegin {
            len: record.len() as u32,
            crc: spincal::protocol::checksum(record),
        })
        .unwrap();
    assert_eq!(r, Response::Ready);
    for (k, chunk) in record.chunks(MAX_CHUNK).enumerate() {
        let r = client
            .call(&Request::WriteChunk {
                offset: (k * MAX_CHUNK) as u32,
                data: heapless::Vec::from_slice(chunk).unwrap(),
            })
            .unwrap();
        assert!(matches!(r, Response::ChunkOk { .. }), "{r:?}");
    }
    client.call(&Request::Commit).unwrap()
}

/// A unit provisioned by the flasher (`calflash image --station-key`) boots a calibration
/// signed for it by its station and verifies it on the Cortex-M4F; one signed by another key
/// is refused at boot (the unit flags every sample and says why) and at commit, as is an
/// unsigned one; an unprovisioned unit takes either and says that it is unprovisioned.
#[test]
fn a_provisioned_unit_verifies_at_boot_and_at_commit() {
    use calflash::device::image::unit_image;
    use spincal::protocol::{Status, Trust};
    use spincal::signed::{SignError, StationKey};
    if !qemu::available_or_skip("a_provisioned_unit_verifies_at_boot_and_at_commit") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let station = |seed: u8| {
        let k = ed25519_dalek::SigningKey::from_bytes(&[seed; 32]);
        let public = StationKey {
            public: k.verifying_key().to_bytes(),
        };
        (k, public)
    };
    let ((key, public), (other, other_public)) = (station(1), station(2));
    let mut data = CalibrationData::example_imu();
    data.identity.serial = spincal::model::Serial::new("QEMU-0001").unwrap();
    let blob = golden::encode(&data);
    let signed = calflash::signing::sign(&blob, &key, 4, false).unwrap();
    let region = Region::from_memory_x();

    let image = unit_image(Some(&signed), &[public], region).unwrap();
    let (id, back, log) = boot_with(&image, dir.path());
    assert_eq!(id.trust, Trust::Provisioned, "{log}");
    assert_eq!((id.counter, id.signed_by), (4, Some(public.id())), "{log}");
    assert_eq!(back, signed);
    let hex = calflash::device::key_hex(public.id());
    assert!(
        log.contains(&format!(
            "device: the calibration verified at boot: signed by {hex}, counter 4"
        )),
        "{log}"
    );

    // Signed by a key the unit does not hold: refused at boot.
    let theirs = calflash::signing::sign(&blob, &other, 9, false).unwrap();
    let image = unit_image(Some(&theirs), &[public], region).unwrap();
    let (id, back, log) = boot_with(&image, dir.path());
    assert_eq!(id.calibration, None, "{log}");
    assert!(back.is_empty());
    assert_eq!(
        id.refused,
        Some(SignError::UnknownKey {
            key_id: other_public.id()
        })
    );
    assert!(log.contains("REFUSED at boot"), "{log}");
    assert!(
        log.contains("1000 samples passed through and flagged"),
        "{log}"
    );

    // At commit, over the UART: unsigned and foreign records refused, the signed one taken.
    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let (flash, log_path) = (dir.path().join("flash.bin"), dir.path().join("commit.log"));
    std::fs::write(&flash, unit_image(None, &[public], region).unwrap()).unwrap();
    let unit = QemuUnit::power_on(&bin.join("device"), Some(&flash), &log_path).unwrap();
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    assert_eq!(
        commit_over_uart(&mut client, &blob),
        Response::Error(Status::Refused(SignError::Unsigned))
    );
    assert_eq!(client.trust(), Some(Trust::Provisioned));
    assert_eq!(
        commit_over_uart(&mut client, &theirs),
        Response::Error(Status::Refused(SignError::UnknownKey {
            key_id: other_public.id()
        }))
    );
    assert_eq!(
        commit_over_uart(&mut client, &signed),
        Response::Committed { seq: 1, counter: 4 }
    );
    let older = calflash::signing::sign(&blob, &key, 3, false).unwrap();
    assert_eq!(
        commit_over_uart(&mut client, &older),
        Response::Error(Status::Refused(SignError::Replay {
            counter: 3,
            held: 4
        }))
    );
    drop(client);
    drop(unit);

    // Unprovisioned: takes the signed blob as a blob, and says it checks nothing.
    let image = unit_image(Some(&signed), &[], region).unwrap();
    let (id, _, log) = boot_with(&image, dir.path());
    assert_eq!(id.trust, Trust::Unprovisioned);
    assert!(id.calibration.is_some(), "{log}");
    assert!(log.contains("device: UNPROVISIONED"), "{log}");
}
