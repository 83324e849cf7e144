//! The example device on QEMU mps2-an386, shared by the device binaries (one per converter
//! format): boots, loads the current calibration from its two-slot store (or flags every
//! sample when there is none), corrects a stream of raw samples, and serves the update
//! protocol on UART0.

use cortex_m_semihosting::hprintln;
use spincal::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector, Flags};
use spincal::model::{Sensor, Serial};
use spincal::protocol::{Device, MAX_FRAME, UnitSensor};
use spincal::store::Store;

use crate::{RamFlash, Uart};

/// The unit's serial number, fixed at build time (`SPINCAL_UNIT_SERIAL`).
pub const UNIT_SERIAL: &str = match option_env!("SPINCAL_UNIT_SERIAL") {
    Some(s) => s,
    None => "QEMU-0001",
};

/// Corrects a stream of raw samples with whatever is loaded and reports how many were clean.
fn self_test(device: &Device<RamFlash>, mid: i32) {
    let mut clean = 0u32;
    let mut flagged = 0u32;
    let mut count = |f: Flags| {
        if f.is_clean() {
            clean += 1
        } else {
            flagged += 1
        }
    };
    let raw = |k: i32, a: i32| mid + ((k * 37 + a * 101) % 400) - 200;
    match device.calibration() {
        None => {
            let c = AnyImuCorrector::identity();
            let mut c = c;
            for k in 0..1000 {
                count(c.correct(core::array::from_fn(|a| raw(k, a as i32))).flags);
            }
            hprintln!(
                "device: no valid calibration; 1000 samples passed through and flagged ({} flagged)",
                flagged
            );
        }
        Some(cal) => {
            match &cal.data().sensor {
                Sensor::Single { .. } => {
                    if let Ok(mut c) = AnyAxisCorrector::new(cal) {
                        c.set_environment(25.0, 3.3);
                        (0..1000).for_each(|k| count(c.correct(raw(k, 0)).flags));
                    }
                }
                Sensor::Triad { .. } => {
                    if let Ok(mut c) = AnyTriadCorrector::new(cal) {
                        c.set_environment(25.0, 3.3);
                        (0..1000).for_each(|k| {
                            count(c.correct(core::array::from_fn(|a| raw(k, a as i32))).flags)
                        });
                    }
                }
                Sensor::Imu { .. } => {
                    if let Ok(mut c) = AnyImuCorrector::new(cal, 1000.0) {
                        c.set_environment(25.0, 3.3);
                        (0..1000).for_each(|k| {
                            count(c.correct(core::array::from_fn(|a| raw(k, a as i32))).flags)
                        });
                    }
                }
            }
            hprintln!(
                "device: calibration {} loaded; 1000 raw samples corrected, {} clean, {} flagged",
                cal.data().identity.serial,
                clean,
                flagged
            );
        }
    }
}

/// Runs the example device: unit `serial` carrying `sensor` (it commits no calibration of
/// another kind). Never returns: it serves the update protocol on UART0.
pub fn run(serial: &'static str, sensor: UnitSensor) -> ! {
    let flash = RamFlash::calibration_region();
    let Ok(store) = Store::new(flash, 0, RamFlash::SLOT_SIZE) else {
        hprintln!("device: the calibration region does not fit its sectors");
        crate::exit(false)
    };
    let unit = Serial::new(serial).unwrap_or_default();
    let device =
        cortex_m::singleton!(: Device<RamFlash> = Device::new(store, unit, sensor, [0, 1, 0]));
    let Some(device) = device else {
        crate::exit(false)
    };
    hprintln!(
        "device: unit {} up; serving the update protocol on UART0",
        serial
    );
    // Raw samples about the middle of the accelerometer's converter.
    let mid = match sensor {
        UnitSensor::Imu { accel_rails: r, .. }
        | UnitSensor::Triad { rails: r, .. }
        | UnitSensor::Single { rails: r, .. } => {
            ((i64::from(r.lo) + i64::from(r.hi) + 1) / 2) as i32
        }
    };
    self_test(device, mid);
    let uart = Uart::uart0();
    let mut frame = [0u8; MAX_FRAME];
    let mut len = 0usize;
    let mut overflow = false;
    let mut out = [0u8; MAX_FRAME];
    loop {
        let byte = uart.read();
        if byte != 0 {
            match frame.get_mut(len) {
                Some(slot) => {
                    *slot = byte;
                    len += 1;
                }
                None => overflow = true,
            }
            continue;
        }
        // A frame ends: handle it (an overlong one is answered as a bad frame).
        let input = if overflow { &frame[..0] } else { &frame[..len] };
        let n = device.handle_frame(input, &mut out);
        uart.write_all(&out[..n]);
        len = 0;
        overflow = false;
    }
}
