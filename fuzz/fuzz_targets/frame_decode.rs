//! The update protocol: any bytes decode as a request or response frame or give an error; any
//! sequence of frames (split at the zero delimiter, so valid requests can be built by the fuzzer
//! from its corpus) sent to the device's handler gets a decodable response each, never a panic,
//! and leaves a store that loads either nothing or a valid calibration.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::model::{CalibrationData, Serial};
use spincal::protocol::{self, Device, MAX_FRAME, Reply, Request, Response};
use spincal::store::Store;
use spincal_fuzz::RamNor;

/// The unit's sensor: the IMU examples' (the single-axis and triad blobs are refused).
const IMU: protocol::UnitSensor = protocol::UnitSensor::Imu {
    accel_rails: spincal::model::Rails::unsigned(16),
    gyro_rails: spincal::model::Rails::unsigned(16),
};

const SLOT: u32 = 16 * 1024;

fuzz_target!(|data: &[u8]| {
    let mut scratch = [0u8; MAX_FRAME];
    let _ = protocol::decode::<Request>(data, &mut scratch);
    let _ = protocol::decode::<Response>(data, &mut scratch);

    let flash = RamNor {
        mem: vec![0xff; Store::<RamNor>::region_len(SLOT, 1024) as usize],
    };
    let mut store = Store::new(flash, 0, SLOT).expect("layout");
    // Half the inputs drive a provisioned unit (the first byte odd).
    if data.first().is_some_and(|b| b & 1 == 1) {
        store
            .provision(&[spincal_fuzz::station().1])
            .expect("a RAM flash provisions");
    }
    let mut device = Box::new(Device::new(
        store,
        Serial::new("FUZZ-1").expect("serial"),
        IMU,
        [0, 1, 0],
    ));
    for frame in data.split(|b| *b == 0).take(64) {
        let mut out = [0u8; MAX_FRAME];
        let n = device.handle_frame(frame, &mut out);
        assert!(
            n > 0 && out[n - 1] == 0,
            "every frame gets a response frame"
        );
        let mut s = [0u8; MAX_FRAME];
        let reply =
            protocol::decode::<Reply>(&out[..n - 1], &mut s).expect("the device's reply decodes");
        assert_eq!(reply.trust, device.trust());
    }
    let loaded = device.calibration().map(|c| c.data().clone());
    let unit = device.unit().clone();
    let provisioning = device.provisioning().clone();
    let mut flash = device.into_store().into_inner();
    // After a reboot the store holds what the device said it held.
    let mut store = Store::new(
        core::mem::replace(&mut flash, RamNor { mem: Vec::new() }),
        0,
        SLOT,
    )
    .expect("layout");
    let mut buf = vec![0u8; spincal::protocol::SLOT_BUFFER];
    let mut slot = CalibrationData::empty();
    let reloaded = store
        .load(&mut buf, &mut slot, provisioning.policy(&unit))
        .ok()
        .map(|(c, _)| c.data().clone());
    assert_eq!(reloaded, loaded);
});
