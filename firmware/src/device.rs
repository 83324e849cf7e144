//! The example device on QEMU mps2-an386, shared by the device binaries (one per converter
//! format): boots, loads the current calibration from its two-slot store (or flags every
//! sample when there is none), corrects a stream of raw samples, and serves the update
//! protocol on UART0.

use cortex_m_semihosting::hprintln;
use spincal::correct::{AnyCorrector, AnyImuCorrector, Corrected, Flags, ImuCorrector};
use spincal::driver::mpu6050::{ADDRESS, Config, Mpu6050};
use spincal::model::{Calibration, SampleFormat, Sensor, Serial};
use spincal::protocol::{Device, MAX_FRAME, UnitSensor};
use spincal::store::{Provisioning, Store};

use crate::simulated_mpu6050::SimulatedMpu6050;
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
    let raw = |k: i32, a: i32| raw(mid, k, a);
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
                Sensor::Imu { accel_rails, .. } if accel_rails.format == SampleFormat::I16 => {
                    // A unit with an MPU-6050: its samples come through the driver.
                    let (c, f) = mpu6050_self_test(cal);
                    clean += c;
                    flagged += f;
                    hprintln!(
                        "device: {} samples read from the MPU-6050 over I2C (spincal::driver) and corrected in blocks",
                        c + f
                    );
                }
                _ => {
                    if let Ok(mut c) = AnyCorrector::new(cal, 1000.0) {
                        c.set_environment(25.0, 3.3);
                        let n = c.outputs();
                        for k in 0..1000 {
                            let codes: [i32; 6] = core::array::from_fn(|a| raw(k, a as i32));
                            if let Some(o) = codes.get(..n).and_then(|r| c.correct(r)) {
                                count(o.flags);
                            }
                        }
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

/// The self-test's sample `k` on axis `a` about the converter's middle `mid`.
fn raw(mid: i32, k: i32, a: i32) -> i32 {
    mid + ((k * 37 + a * 101) % 400) - 200
}

/// The self-test of a unit whose IMU is an MPU-6050: the driver sets the (simulated) part up
/// and reads 1000 samples in blocks of 20, each block corrected by `correct_batch` at the die
/// temperature. Clean and flagged samples.
fn mpu6050_self_test(cal: &Calibration) -> (u32, u32) {
    const BLOCK: usize = 20;
    // The part's two's complement codes are about 0.
    let codes = |k: i32| core::array::from_fn(|a| raw(0, k, a as i32) as i16);
    let mut part = Mpu6050::new(SimulatedMpu6050::new(codes), ADDRESS, Config::default());
    let Ok(()) = part.init() else {
        hprintln!("device: the MPU-6050 does not answer");
        return (0, 0);
    };
    let Ok(mut c) = ImuCorrector::<i16>::new(cal, part.config().sample_rate_hz()) else {
        return (0, 0);
    };
    let (mut clean, mut flagged) = (0u32, 0u32);
    let mut block = [[0i16; 6]; BLOCK];
    let mut out = [Corrected::<6>::default(); BLOCK];
    for _ in 0..1000 / BLOCK {
        let Ok(temperature) = part.read_block(&mut block) else {
            hprintln!("device: an I2C read from the MPU-6050 failed");
            break;
        };
        c.set_environment(temperature, 3.3);
        let n = c.correct_batch(&block, &mut out);
        for o in out.iter().take(n) {
            if o.flags.is_clean() {
                clean += 1;
            } else {
                flagged += 1;
            }
        }
    }
    (clean, flagged)
}

/// Says at boot whether the unit checks signatures, and why it holds no calibration when a
/// slot's record was refused.
fn report_trust(device: &Device<RamFlash>) {
    match device.provisioning() {
        Provisioning::Unprovisioned => hprintln!(
            "device: UNPROVISIONED (no station keys): it takes unsigned calibrations from anyone with the cable"
        ),
        Provisioning::Damaged => hprintln!(
            "device: the keys sector is DAMAGED: it trusts no station key and takes no calibration until provisioned again"
        ),
        Provisioning::Provisioned(keys) => {
            hprintln!(
                "device: provisioned with {} station key(s); it takes only calibrations signed for it",
                keys.len()
            );
            for k in keys {
                let [a, b, c, d] = k.id();
                hprintln!("device:   station key {:02x}{:02x}{:02x}{:02x}", a, b, c, d);
            }
            if let Some(info) = device.loaded() {
                let [a, b, c, d] = info.signed_by.unwrap_or_default();
                hprintln!(
                    "device: the calibration verified at boot: signed by {:02x}{:02x}{:02x}{:02x}, counter {}",
                    a,
                    b,
                    c,
                    d,
                    info.counter
                );
            }
        }
    }
    if let Some(why) = device.refused() {
        hprintln!(
            "device: the stored calibration is REFUSED at boot: {:?}; every sample is flagged",
            why
        );
    }
}

/// Runs the example device: unit `serial` carrying `sensor` (it commits no calibration of
/// another kind). Never returns: it serves the update protocol on UART0.
pub fn run(serial: &'static str, sensor: UnitSensor) -> ! {
    serve(boot(serial, sensor))
}

/// Runs the example round: the example device that, before it serves the update protocol,
/// flies the recorded flight in its flash through its own calibration and the flight filter
/// ([`crate::flight_golden::fly`]) and publishes the filter's snapshot, which `calflash
/// flight --port` reads. Without a calibration (or with one that is not an IMU's) it flies
/// nothing and publishes nothing.
pub fn run_round(serial: &'static str, sensor: UnitSensor) -> ! {
    let device = boot(serial, sensor);
    let report = device.calibration().and_then(crate::flight_golden::fly);
    match report {
        Some(r) => {
            hprintln!(
                "round: flew the recorded flight: {} epochs, {} fixes taken, {} refused; published",
                r.stats.epochs,
                r.stats.taken[1],
                r.stats.refused[1]
            );
            device.publish_flight(r);
        }
        None => hprintln!("round: no IMU calibration loaded; no flight flown"),
    }
    serve(device)
}

/// Boots the example device: its store, its identity, the trust it reports, the self-test.
#[expect(
    clippy::mut_from_ref,
    reason = "the device is the `cortex_m::singleton!`'s, not borrowed from `serial`"
)]
fn boot(serial: &'static str, sensor: UnitSensor) -> &'static mut Device<RamFlash> {
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
    report_trust(device);
    // Raw samples about the middle of the accelerometer's converter.
    let mid = match sensor {
        UnitSensor::Imu { accel_rails: r, .. }
        | UnitSensor::Triad { rails: r, .. }
        | UnitSensor::Single { rails: r, .. } => {
            ((i64::from(r.lo) + i64::from(r.hi) + 1) / 2) as i32
        }
    };
    self_test(device, mid);
    device
}

/// Serves the update protocol on UART0, for ever.
fn serve(device: &mut Device<RamFlash>) -> ! {
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
