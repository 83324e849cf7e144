//! The example round on QEMU mps2-an386: the example device (`spincal_firmware::device`) that,
//! with its calibration loaded, flies the recorded flight in its flash through its flight loop
//! before serving the update protocol, so that `calflash flight --port` reads the round's own
//! filter. Its converters are the recorded flight's (the spinning round's IMU).
#![no_std]
#![no_main]

use spincal::protocol::UnitSensor;
use spincal_firmware::flight_golden::BLOB;

#[cortex_m_rt::entry]
fn main() -> ! {
    // The unit's sensor is fixed in its firmware: the recorded round's.
    let Ok(round) = spincal::blob::decode(BLOB) else {
        cortex_m_semihosting::hprintln!("round: the recorded round's calibration does not decode");
        spincal_firmware::exit(false)
    };
    let sensor = UnitSensor::of(round.data());
    drop(round);
    spincal_firmware::device::run_round("ROUND-0001", sensor)
}
