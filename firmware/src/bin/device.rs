//! The example device on QEMU mps2-an386 with 16-bit unsigned converters (the main job's
//! unit); the body is `spincal_firmware::device`.
#![no_std]
#![no_main]

use spincal::model::Rails;
use spincal::protocol::UnitSensor;

#[cortex_m_rt::entry]
fn main() -> ! {
    spincal_firmware::device::run(
        spincal_firmware::device::UNIT_SERIAL,
        UnitSensor::Imu {
            accel_rails: Rails::unsigned(16),
            gyro_rails: Rails::unsigned(16),
        },
    )
}
