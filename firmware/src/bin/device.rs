//! The example device on QEMU mps2-an386 with 16-bit unsigned converters (the main job's
//! unit); the body is `spincal_firmware::device`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use spincal::model::Rails;
use spincal::protocol::UnitSensor;

/// The unit's serial number, fixed at build time.
const UNIT_SERIAL: &str = match option_env!("SPINCAL_UNIT_SERIAL") {
    Some(s) => s,
    None => "QEMU-0001",
};

#[entry]
fn main() -> ! {
    spincal_firmware::device::run(
        UNIT_SERIAL,
        UnitSensor::Imu {
            accel_rails: Rails::unsigned(16),
            gyro_rails: Rails::unsigned(16),
        },
    )
}
