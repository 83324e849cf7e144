//! The MPU-6050 driver against the transactions of the part's register map (rev. 4.2), on a
//! mocked I2C bus: identity check, wake-up and set-up, the 14-byte burst decoded into the
//! corrector's sample order, errors, and a block read going straight into `correct_batch`.

use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use host_tests::golden;
use spincal::correct::{Corrected, ImuCorrector};
use spincal::driver::mpu6050::{
    ADDRESS, AccelRange, Config, Error, GyroRange, Mpu6050, temperature_c,
};
use spincal::model::{Calibration, CalibrationData, SampleFormat};

/// The set-up the register map asks for, after `WHO_AM_I` (0x75) reads 0x68: `PWR_MGMT_1`
/// (0x6B) = 0x01 (awake, PLL on the x gyro), `SMPLRT_DIV` (0x19), `CONFIG` (0x1A) = DLPF,
/// `GYRO_CONFIG` (0x1B) = `FS_SEL << 3`, `ACCEL_CONFIG` (0x1C) = `AFS_SEL << 3`.
fn init_transactions(who_am_i: u8, divider: u8, dlpf: u8, fs: u8, afs: u8) -> Vec<Transaction> {
    vec![
        Transaction::write_read(ADDRESS, vec![0x75], vec![who_am_i]),
        Transaction::write(ADDRESS, vec![0x6B, 0x01]),
        Transaction::write(ADDRESS, vec![0x19, divider]),
        Transaction::write(ADDRESS, vec![0x1A, dlpf]),
        Transaction::write(ADDRESS, vec![0x1B, fs << 3]),
        Transaction::write(ADDRESS, vec![0x1C, afs << 3]),
    ]
}

/// The burst from `ACCEL_XOUT_H` (0x3B): `ax ay az temp gx gy gz`, big-endian.
fn burst(words: [i16; 7]) -> Transaction {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    Transaction::write_read(ADDRESS, vec![0x3B], bytes)
}

#[test]
fn init_sets_the_part_up_as_the_register_map_says_and_a_burst_decodes() {
    let config = Config {
        gyro: GyroRange::Dps1000,
        accel: AccelRange::G8,
        dlpf: 3,
        divider: 4,
    };
    let mut expected = init_transactions(0x68, 4, 3, 2, 2);
    // 1 g on z at +-8 g (4096 codes), -5 on x, 300 on y; 36.53 C - 521/340; gyro -1, 2, -32768.
    expected.push(burst([-5, 300, 4096, -521, -1, 2, i16::MIN]));
    let mut bus = Mock::new(&expected);
    let mut imu = Mpu6050::new(bus.clone(), ADDRESS, config);
    imu.init().unwrap();
    assert_eq!(imu.config().sample_rate_hz(), 200.0);
    let s = imu.read().unwrap();
    assert_eq!(s.raw, [-5, 300, 4096, -1, 2, i16::MIN]);
    assert!((s.temperature_c - (36.53 - 521.0 / 340.0)).abs() < 1e-5);
    bus.done();
}

#[test]
fn another_part_a_reserved_filter_and_a_failing_bus_are_errors() {
    // An MPU-6500 answers 0x70: nothing is written to it.
    let mut bus = Mock::new(&[Transaction::write_read(ADDRESS, vec![0x75], vec![0x70])]);
    let mut imu = Mpu6050::new(bus.clone(), ADDRESS, Config::default());
    assert_eq!(imu.init(), Err(Error::NotMpu6050 { who_am_i: 0x70 }));
    bus.done();
    let mut bus = Mock::new(&[]);
    let reserved = Config {
        dlpf: 7,
        ..Config::default()
    };
    assert_eq!(
        Mpu6050::new(bus.clone(), ADDRESS, reserved).init(),
        Err(Error::InvalidFilter)
    );
    bus.done();
    let mut bus = Mock::new(&[
        Transaction::write_read(ADDRESS, vec![0x3B], vec![0; 14]).with_error(ErrorKind::Other)
    ]);
    let mut imu = Mpu6050::new(bus.clone(), ADDRESS, Config::default());
    assert_eq!(imu.read(), Err(Error::Bus(ErrorKind::Other)));
    bus.done();
    assert_eq!(Config::default().sample_rate_hz(), 1000.0);
    assert!((temperature_c(0) - 36.53).abs() < 1e-6);
}

#[test]
fn a_block_read_from_the_part_goes_straight_into_correct_batch() {
    // An IMU calibration for a part with two's complement 16-bit codes.
    let data = golden::in_format(CalibrationData::example_imu_linear(), SampleFormat::I16);
    let cal = Calibration::new(data).unwrap();
    let words: Vec<[i16; 7]> = (0..16i16)
        .map(|k| [100 + k, -200 + 3 * k, 981 - k, 340 * k, -15 + k, 40, 7 * k])
        .collect();
    let mut expected = init_transactions(0x68, 0, 1, 3, 3);
    expected.extend(words.iter().map(|w| burst(*w)));
    let mut bus = Mock::new(&expected);
    let mut imu = Mpu6050::new(bus.clone(), ADDRESS, Config::default());
    imu.init().unwrap();
    let mut block = [[0i16; 6]; 16];
    let temperature = imu.read_block(&mut block).unwrap();
    bus.done();
    let mean = words.iter().map(|w| temperature_c(w[3])).sum::<f32>() / 16.0;
    assert!((temperature - mean).abs() < 1e-4);
    let mut batch = ImuCorrector::<i16>::new(&cal, imu.config().sample_rate_hz()).unwrap();
    let mut one = ImuCorrector::<i16>::new(&cal, 1000.0).unwrap();
    batch.set_environment(25.0, 3.3);
    one.set_environment(25.0, 3.3);
    let mut out = [Corrected::<6>::default(); 16];
    assert_eq!(batch.correct_batch(&block, &mut out), 16);
    for (k, (raw, got)) in block.iter().zip(&out).enumerate() {
        let w = words[k];
        assert_eq!(*raw, [w[0], w[1], w[2], w[4], w[5], w[6]]);
        assert_eq!(*got, one.correct(*raw), "sample {k}");
    }
}
