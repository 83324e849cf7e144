//! The example device on QEMU mps2-an386 with 16-bit signed (two's-complement) converters,
//! as nearly every digital IMU has; the body is `spincal_firmware::device`.
#![no_std]
#![no_main]

use spincal::model::Rails;
use spincal::protocol::UnitSensor;

#[cortex_m_rt::entry]
fn main() -> ! {
    spincal_firmware::device::run(
        spincal_firmware::device::UNIT_SERIAL,
        UnitSensor::Imu {
            accel_rails: Rails::signed(16),
            gyro_rails: Rails::signed(16),
        },
    )
}
