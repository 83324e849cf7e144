//! The example unit a newcomer leaves running (`cargo xtask unit`): QEMU on a port of its own,
//! up at once, taking one client after another on its UART as a unit on a bench does, its flash
//! saved while it runs and at power-off, and its calibration still there after a power cycle.
//! Skips without QEMU unless SPINCAL_REQUIRE_QEMU=1 (as in CI).

use std::net::TcpListener;
use std::time::Duration;

use calflash::device::{self, FlashOptions};
use host_tests::unit::{QemuUnit, region};
use host_tests::{golden, qemu};
use spincal::model::CalibrationData;

#[test]
fn a_unit_on_its_own_port_takes_one_client_after_another_and_keeps_its_flash() {
    if !qemu::available_or_skip(
        "a_unit_on_its_own_port_takes_one_client_after_another_and_keeps_its_flash",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let elf = qemu::build_firmware().unwrap().join("device");
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let flash = dir.path().join("flash.bin");
    let log = dir.path().join("qemu.log");
    let mut unit = QemuUnit::power_on_at(&elf, Some(&flash), &log, Some(port)).unwrap();
    assert_eq!(unit.port, port);

    // The first client: an empty unit, flashed.
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    let id = client.identify().unwrap();
    assert!(id.calibration.is_none(), "{id:?}");
    let blob = golden::encode(&CalibrationData::example_imu());
    let opts = FlashOptions {
        force: true,
        ..FlashOptions::default()
    };
    let report = device::flash(&mut client, &id, &blob, &opts, |_, _| {}).unwrap();
    assert!(report.read_back_identical);
    // What it holds, read without writing (`calflash read --port`): the blob as flashed.
    let (holding, back) = calflash::cmd::read::holding(&mut client).unwrap();
    assert_eq!(back, blob);
    assert_eq!(holding.calibration.as_deref(), Some("IMU-FULL-0042"));
    assert_eq!(holding.blob_len as usize, blob.len());
    assert_eq!(client.stale_replies(), 0);
    drop(client);

    // A client that leaves half a frame (two stray bytes: a cable pulled, a terminal probe):
    // the next one still identifies the unit at once (red team four: "the unit refused
    // Identify: BadFrame" until a retry by hand).
    {
        use std::io::Write as _;
        let mut stray = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
        stray.write_all(&[0x41, 0x42]).unwrap();
        stray.flush().unwrap();
        std::thread::sleep(Duration::from_millis(200));
    }

    // Another on the same port, later: the unit still runs and holds it.
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    let id = client.identify().unwrap();
    assert_eq!(
        id.calibration.as_ref().map(|s| s.as_str()),
        Some("IMU-FULL-0042")
    );
    drop(client);

    // Its port is its own: a second unit there is refused, naming it.
    let taken = QemuUnit::power_on_at(&elf, None, &dir.path().join("other.log"), Some(port));
    let Err(err) = taken else {
        panic!("a second unit started on the taken port {port}");
    };
    assert!(err.contains(&port.to_string()), "{err}");

    // Its monitor is no TCP port any local user could reach (red team four: `quit`,
    // `pmemsave` to any path, a gdbserver): a Unix socket in a folder of mode 0700.
    {
        use std::os::unix::fs::{FileTypeExt as _, PermissionsExt as _};
        let socket = unit.monitor_socket();
        assert!(std::fs::metadata(socket).unwrap().file_type().is_socket());
        let folder = std::fs::metadata(socket.parent().unwrap()).unwrap();
        assert_eq!(folder.permissions().mode() & 0o777, 0o700);
    }

    // Saved while it runs (what a power cut would leave), then at power-off.
    unit.save_flash().unwrap();
    assert_eq!(
        std::fs::metadata(&flash).unwrap().len(),
        u64::from(region().1)
    );
    assert!(unit.running());
    unit.power_off().unwrap();

    // Powered on again from its file: the calibration is there.
    let unit = QemuUnit::power_on(&elf, Some(&flash), &dir.path().join("again.log")).unwrap();
    let mut client = unit.connect(Duration::from_secs(30)).unwrap();
    let id = client.identify().unwrap();
    assert_eq!(
        id.calibration.as_ref().map(|s| s.as_str()),
        Some("IMU-FULL-0042")
    );
}
