//! The golden flight on the Cortex-M4F: the simulated shell's raw codes through the round's
//! correction, then with the GNSS fixes and pressures through
//! `spincal::flight::FlightFilter<f32>`, the state at every checkpoint compared bit for bit
//! with the same code's on the host. Exits 0 when all match.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::correct::AnyImuCorrector;
use spincal::flight::FlightFilter;
use spincal_firmware::flight_golden::{
    BLOB, EVERY, EXPECTED, Input, RATE, VALUES, feed, flight_config, inputs, rails,
};

/// A checkpoint's values: position, velocity, attitude, sensor errors, variances.
fn values(filter: &FlightFilter<f32>) -> [f32; VALUES] {
    let e = filter.estimate();
    let s = &e.sensors;
    let q = e.nav.attitude();
    let quaternion = [q.w, q.i, q.j, q.k];
    let variances = filter.covariance().diagonal();
    let mut out = [0.0; VALUES];
    let all = e
        .nav
        .p
        .iter()
        .chain(e.nav.v.iter())
        .chain(quaternion.iter())
        .chain(s.accel_bias.iter())
        .chain(s.gyro_bias.iter())
        .chain(s.accel_scale.iter())
        .chain(s.gyro_scale.iter())
        .chain(core::iter::once(&s.baro_bias))
        .chain(variances.iter());
    for (o, v) in out.iter_mut().zip(all) {
        *o = *v;
    }
    out
}

#[entry]
fn main() -> ! {
    let Ok(cal) = spincal::blob::decode(BLOB) else {
        hprintln!("FAIL: imu_spin.blob does not decode");
        spincal_firmware::exit(false);
    };
    let (Some(rails), Ok(mut imu)) = (rails(&cal), AnyImuCorrector::new(&cal, RATE)) else {
        hprintln!("FAIL: imu_spin.blob is not an IMU's");
        spincal_firmware::exit(false);
    };
    let mut filter = match FlightFilter::try_new(flight_config()) {
        Ok(filter) => filter,
        Err(fault) => {
            hprintln!("FAIL: {}", fault.field);
            spincal_firmware::exit(false);
        }
    };
    let mut expected = EXPECTED
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let (mut samples, mut checkpoints, mut mismatches) = (0usize, 0usize, 0usize);
    let mut check = |filter: &FlightFilter<f32>, checkpoints: &mut usize| {
        *checkpoints += 1;
        for (i, v) in values(filter).iter().enumerate() {
            let want = expected.next();
            if want != Some(v.to_bits()) {
                mismatches += 1;
                if mismatches <= 20 {
                    hprintln!(
                        "FAIL checkpoint {} value {}: got {:08x}, expected {:08x?}",
                        checkpoints,
                        i,
                        v.to_bits(),
                        want
                    );
                }
            }
        }
    };
    for e in inputs(&mut imu, rails) {
        let sample = matches!(e, Input::Sample(..));
        feed(&mut filter, e);
        if sample {
            samples += 1;
            if samples % EVERY == 0 {
                check(&filter, &mut checkpoints);
            }
        }
    }
    check(&filter, &mut checkpoints);
    let s = filter.stats();
    hprintln!(
        "flight: {} samples, {} epochs, {} checkpoints, {} values differ; fixes taken {} refused {}",
        samples,
        s.epochs,
        checkpoints,
        mismatches,
        s.taken[1],
        s.refused[1]
    );
    spincal_firmware::exit(mismatches == 0 && checkpoints > 40);
}
