//! The device demo: decodes and validates a calibration blob on the Cortex-M4F, then corrects
//! a stream of raw IMU samples of a unit that rests, spins up, warms and takes a set-back shock,
//! printing the corrected values and the flags every so often and a summary at the end.
//!
//! The raw codes are synthesised with nominal sensitivities (no misalignment, no nonlinearity),
//! so the corrected values differ from the synthetic truth by what the calibration knows and
//! the nominal synthesis does not: a few tenths of a percent, growing with the temperature.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::blob;
use spincal::correct::{Flags, ImuCorrector};
use spincal::model::Sensor;

static BLOB: &[u8] = include_bytes!("../../../host-tests/golden/imu.blob");

const RATE_HZ: f32 = 1000.0;
/// Nominal sensitivities used to synthesise raw codes from the true motion.
const ACCEL_COUNTS_PER_MS2: f32 = 412.0;
const GYRO_COUNTS_PER_RADS: f32 = 900.0;

#[entry]
fn main() -> ! {
    let cal = match blob::decode(BLOB) {
        Ok(cal) => cal,
        Err(e) => {
            hprintln!("calibration refused: {}", e);
            spincal_firmware::exit(false)
        }
    };
    let id = &cal.data().identity;
    hprintln!(
        "calibration: serial {}, {} bytes, made {} (unix s) by tool {}.{}.{}",
        id.serial,
        BLOB.len(),
        id.created_unix_s,
        id.tool_version[0],
        id.tool_version[1],
        id.tool_version[2]
    );
    let Sensor::Imu {
        accel,
        gyro,
        lever_arm,
        ..
    } = &cal.data().sensor
    else {
        hprintln!("not an IMU calibration");
        spincal_firmware::exit(false)
    };
    let centers: [f32; 6] = core::array::from_fn(|i| {
        if i < 3 {
            accel[i].center
        } else {
            gyro[i - 3].center
        }
    });
    let Ok(mut imu) = ImuCorrector::<u16>::new(&cal, RATE_HZ) else {
        hprintln!("not an IMU calibration of unsigned 16-bit samples");
        spincal_firmware::exit(false)
    };

    hprintln!("   t [s]  temp   ax      ay      az   [m/s^2]   gx      gy      gz  [rad/s]  flags");
    let mut counts = [0u32; 8];
    let mut clean = 0u32;
    let n = 6_000u32;
    for k in 0..n {
        let t = k as f32 / RATE_HZ;
        // Temperature ramps from 20 C to 95 C (beyond the 85 C table edge) over the run.
        let temp = 20.0 + 75.0 * t / 6.0;
        if k % 100 == 0 {
            imu.set_environment(temp, 3.3);
        }
        // Rest, spin-up about z to 25 rad/s, steady spin, a 40 ms set-back shock at 4.5 s.
        let spin = if t < 1.0 {
            0.0
        } else {
            25.0 * libm::fminf(1.0, t - 1.0)
        };
        let setback = if (4.5..4.54).contains(&t) { 900.0 } else { 0.0 };
        let truth = [0.0, 0.0, 9.81 + setback, 0.0, 0.0, spin];
        // Each accelerometer axis sits at its lever arm r_i and also feels w x (w x r_i).
        let r = lever_arm.unwrap_or([[0.0; 3]; 3]);
        let sensed: [f32; 6] = core::array::from_fn(|i| match r.get(i) {
            Some(ri) => {
                let w = [0.0, 0.0, spin];
                let dot = w[0] * ri[0] + w[1] * ri[1] + w[2] * ri[2];
                let ww = spin * spin;
                truth[i] + w[i] * dot - ri[i] * ww
            }
            None => truth[i],
        });
        let raw: [u16; 6] = core::array::from_fn(|i| {
            let counts = if i < 3 {
                ACCEL_COUNTS_PER_MS2
            } else {
                GYRO_COUNTS_PER_RADS
            };
            let code = centers[i] + sensed[i] * counts;
            libm::roundf(libm::fminf(libm::fmaxf(code, 0.0), 65_535.0)) as u16
        });
        let out = imu.correct(raw);
        for (bit, c) in counts.iter_mut().enumerate() {
            *c += u32::from(out.flags.bits() & (1 << bit) != 0);
        }
        clean += u32::from(out.flags.is_clean());
        if k % 500 == 0 || k == 4_510 {
            let v = out.values;
            hprintln!(
                "{:8.3} {:5.1} {:7.3} {:7.3} {:7.3}         {:7.3} {:7.3} {:7.3}          {}",
                t,
                temp,
                v[0],
                v[1],
                v[2],
                v[3],
                v[4],
                v[5],
                out.flags
            );
        }
    }
    hprintln!(
        "\n{} samples corrected on the Cortex-M4F, {} clean",
        n,
        clean
    );
    for (bit, name) in [
        (Flags::SATURATED, "saturated"),
        (Flags::OUT_OF_RANGE, "out of range"),
        (Flags::TEMPERATURE_CLAMPED, "temperature clamped"),
        (Flags::VOLTAGE_CLAMPED, "voltage clamped"),
        (Flags::NO_CALIBRATION, "no calibration"),
        (Flags::RATE_DERIVATIVE_UNKNOWN, "rate derivative unknown"),
        (Flags::CALIBRATION_SUSPECT, "calibration suspect"),
        (Flags::RATE_STEP, "rate step"),
    ] {
        let i = bit.bits().trailing_zeros() as usize;
        hprintln!("  {:<24} {}", name, counts.get(i).copied().unwrap_or(0));
    }
    spincal_firmware::exit(true)
}
