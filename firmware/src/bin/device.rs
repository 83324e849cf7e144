//! The example device on QEMU mps2-an386: boots, loads the current calibration from its
//! two-slot store (or flags every sample when there is none), corrects a stream of raw samples,
//! and serves the update protocol on UART0.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::correct::{AxisCorrector, Flags, ImuCorrector, TriadCorrector};
use spincal::model::{Rails, Sensor, Serial};
use spincal::protocol::{Device, MAX_FRAME, UnitSensor};
use spincal::store::Store;
use spincal_firmware::{RamFlash, Uart};

/// The unit's serial number, fixed at build time.
const UNIT_SERIAL: &str = match option_env!("SPINCAL_UNIT_SERIAL") {
    Some(s) => s,
    None => "QEMU-0001",
};

/// The sensor this unit carries: an IMU on 16-bit converters (the main job's). The unit commits
/// no calibration of another kind.
const SENSOR: UnitSensor = UnitSensor::Imu {
    accel_rails: Rails::unsigned(16),
    gyro_rails: Rails::unsigned(16),
};

/// Corrects a stream of raw samples with whatever is loaded and reports how many were clean.
fn self_test(device: &Device<RamFlash>) {
    let mut clean = 0u32;
    let mut flagged = 0u32;
    let mut count = |f: Flags| {
        if f.is_clean() {
            clean += 1
        } else {
            flagged += 1
        }
    };
    let raw = |k: i32, a: i32| 32_768 + ((k * 37 + a * 101) % 400) - 200;
    match device.calibration() {
        None => {
            let c = ImuCorrector::identity();
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
                    if let Ok(mut c) = AxisCorrector::new(cal) {
                        c.set_environment(25.0, 3.3);
                        (0..1000).for_each(|k| count(c.correct(raw(k, 0)).flags));
                    }
                }
                Sensor::Triad { .. } => {
                    if let Ok(mut c) = TriadCorrector::new(cal) {
                        c.set_environment(25.0, 3.3);
                        (0..1000).for_each(|k| {
                            count(c.correct(core::array::from_fn(|a| raw(k, a as i32))).flags)
                        });
                    }
                }
                Sensor::Imu { .. } => {
                    if let Ok(mut c) = ImuCorrector::new(cal, 1000.0) {
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

#[entry]
fn main() -> ! {
    let flash = RamFlash::calibration_region();
    let Ok(store) = Store::new(flash, 0, RamFlash::SLOT_SIZE) else {
        hprintln!("device: the calibration region does not fit its sectors");
        spincal_firmware::exit(false)
    };
    let unit = Serial::new(UNIT_SERIAL).unwrap_or_default();
    let device =
        cortex_m::singleton!(: Device<RamFlash> = Device::new(store, unit, SENSOR, [0, 1, 0]));
    let Some(device) = device else {
        spincal_firmware::exit(false)
    };
    hprintln!(
        "device: unit {} up; serving the update protocol on UART0",
        UNIT_SERIAL
    );
    self_test(device);
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
