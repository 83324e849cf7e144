//! The InvenSense MPU-6050 over I2C (the MPU-6000's I2C interface is the same), from the
//! *MPU-6000 and MPU-6050 Register Map and Descriptions*, revision 4.2.
//!
//! The part delivers two's complement 16-bit codes, big-endian, in one burst of 14 bytes from
//! `ACCEL_XOUT_H` (0x3B): accelerometer x, y, z, the die temperature, gyro x, y, z. The driver
//! wakes the part with the PLL on the x gyro as its clock (the register map's recommendation),
//! sets the digital low-pass filter, the sample-rate divider and both full-scale ranges, and
//! reads samples as `[i16; 6]`, the `i16` sample format of a calibration made for this part.
//! A calibration holds per-count coefficients: the full-scale ranges must be the ones the
//! calibration was made at.
//!
//! ```
//! # use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, Operation};
//! # struct Bus;
//! # impl ErrorType for Bus { type Error = ErrorKind; }
//! # impl I2c for Bus {
//! #     fn transaction(&mut self, _: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
//! #         for op in ops { if let Operation::Read(b) = op { b.fill(0); b[0] = 0x68; } }
//! #         Ok(())
//! #     }
//! # }
//! use spincal::driver::mpu6050::{Config, Mpu6050, ADDRESS};
//! let mut imu = Mpu6050::new(Bus, ADDRESS, Config::default());
//! imu.init()?;
//! let mut block = [[0i16; 6]; 16];
//! let temperature = imu.read_block(&mut block)?;
//! // corrector.set_environment(temperature, volts); corrector.correct_batch(&block, &mut out);
//! # let _ = temperature;
//! # Ok::<(), spincal::driver::mpu6050::Error<ErrorKind>>(())
//! ```

use embedded_hal::i2c::I2c;

/// The part's I2C address with its AD0 pin low.
pub const ADDRESS: u8 = 0x68;
/// With AD0 high.
pub const ADDRESS_AD0_HIGH: u8 = 0x69;

/// Register addresses (register map, section 3).
pub mod register {
    /// Sample-rate divider: rate = gyro output rate / (1 + divider).
    pub const SMPLRT_DIV: u8 = 0x19;
    /// External sync and the digital low-pass filter (`DLPF_CFG`, bits 2:0).
    pub const CONFIG: u8 = 0x1A;
    /// Gyro full scale (`FS_SEL`, bits 4:3).
    pub const GYRO_CONFIG: u8 = 0x1B;
    /// Accelerometer full scale (`AFS_SEL`, bits 4:3).
    pub const ACCEL_CONFIG: u8 = 0x1C;
    /// First of the 14 data bytes: accelerometer, temperature, gyro, high byte first.
    pub const ACCEL_XOUT_H: u8 = 0x3B;
    /// Power management: `SLEEP` (bit 6), clock source `CLKSEL` (bits 2:0).
    pub const PWR_MGMT_1: u8 = 0x6B;
    /// The part's identity, 0x68 (bits 6:1 hold 0b110100).
    pub const WHO_AM_I: u8 = 0x75;
}

/// What `WHO_AM_I` holds (whatever the AD0 pin).
pub const WHO_AM_I_VALUE: u8 = 0x68;
/// `PWR_MGMT_1`: awake, clock from the PLL with the x gyro as reference.
const WAKE_PLL_X: u8 = 0x01;

/// Gyro full-scale range (`FS_SEL`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroRange {
    /// +-250 deg/s, 131 codes per deg/s.
    Dps250 = 0,
    /// +-500 deg/s, 65.5.
    Dps500 = 1,
    /// +-1000 deg/s, 32.8.
    Dps1000 = 2,
    /// +-2000 deg/s, 16.4.
    Dps2000 = 3,
}

/// Accelerometer full-scale range (`AFS_SEL`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// +-2 g, 16384 codes per g.
    G2 = 0,
    /// +-4 g, 8192.
    G4 = 1,
    /// +-8 g, 4096.
    G8 = 2,
    /// +-16 g, 2048.
    G16 = 3,
}

/// How the part is set up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Gyro full scale.
    pub gyro: GyroRange,
    /// Accelerometer full scale.
    pub accel: AccelRange,
    /// `DLPF_CFG`, 0 to 6 (0: no filter, the gyro output at 8 kHz; 1 to 6: 188 Hz down to
    /// 5 Hz of bandwidth, the gyro output at 1 kHz).
    pub dlpf: u8,
    /// `SMPLRT_DIV`.
    pub divider: u8,
}

impl Default for Config {
    /// The widest ranges (a round's accelerations and rates), 188 Hz of bandwidth, 1 kHz.
    fn default() -> Self {
        Self {
            gyro: GyroRange::Dps2000,
            accel: AccelRange::G16,
            dlpf: 1,
            divider: 0,
        }
    }
}

impl Config {
    /// The sample rate, Hz (register map, `SMPLRT_DIV`).
    #[must_use]
    pub fn sample_rate_hz(&self) -> f32 {
        let gyro_rate = if self.dlpf == 0 { 8000.0 } else { 1000.0 };
        gyro_rate / (1.0 + f32::from(self.divider))
    }
}

/// A driver error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The bus failed.
    Bus(E),
    /// `WHO_AM_I` did not read 0x68: another part, or none, at the address.
    NotMpu6050 {
        /// What it read.
        who_am_i: u8,
    },
    /// A `DLPF_CFG` above 6 (7 is reserved).
    InvalidFilter,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Self::Bus(e)
    }
}

/// One sample: the six codes (accelerometer, then gyro) and the die temperature.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// `ax ay az gx gy gz`, codes.
    pub raw: [i16; 6],
    /// Die temperature, C (`TEMP_OUT / 340 + 36.53`).
    pub temperature_c: f32,
}

/// The temperature in C of a `TEMP_OUT` code.
#[must_use]
pub fn temperature_c(code: i16) -> f32 {
    f32::from(code) / 340.0 + 36.53
}

/// An MPU-6050 on an I2C bus.
#[derive(Debug)]
pub struct Mpu6050<I2C> {
    i2c: I2C,
    address: u8,
    config: Config,
}

impl<I2C: I2c> Mpu6050<I2C> {
    /// The part at `address` ([`ADDRESS`] or [`ADDRESS_AD0_HIGH`]), to be set up as `config`
    /// says by [`init`](Self::init).
    pub fn new(i2c: I2C, address: u8, config: Config) -> Self {
        Self {
            i2c,
            address,
            config,
        }
    }

    /// Checks the part's identity, wakes it and sets it up.
    ///
    /// # Errors
    /// The bus's, [`Error::NotMpu6050`], or [`Error::InvalidFilter`].
    pub fn init(&mut self) -> Result<(), Error<I2C::Error>> {
        if self.config.dlpf > 6 {
            return Err(Error::InvalidFilter);
        }
        let mut id = [0u8];
        self.i2c
            .write_read(self.address, &[register::WHO_AM_I], &mut id)?;
        if id[0] != WHO_AM_I_VALUE {
            return Err(Error::NotMpu6050 { who_am_i: id[0] });
        }
        let c = self.config;
        for (reg, value) in [
            (register::PWR_MGMT_1, WAKE_PLL_X),
            (register::SMPLRT_DIV, c.divider),
            (register::CONFIG, c.dlpf),
            (register::GYRO_CONFIG, (c.gyro as u8) << 3),
            (register::ACCEL_CONFIG, (c.accel as u8) << 3),
        ] {
            self.i2c.write(self.address, &[reg, value])?;
        }
        Ok(())
    }

    /// Reads one sample (one burst of 14 bytes).
    ///
    /// # Errors
    /// The bus's.
    pub fn read(&mut self) -> Result<Sample, Error<I2C::Error>> {
        let mut b = [0u8; 14];
        self.i2c
            .write_read(self.address, &[register::ACCEL_XOUT_H], &mut b)?;
        let mut words = [0i16; 7];
        for (w, pair) in words.iter_mut().zip(b.chunks_exact(2)) {
            if let [high, low] = pair {
                *w = i16::from_be_bytes([*high, *low]);
            }
        }
        let [ax, ay, az, temp, gx, gy, gz] = words;
        Ok(Sample {
            raw: [ax, ay, az, gx, gy, gz],
            temperature_c: temperature_c(temp),
        })
    }

    /// Fills `block` with consecutive samples; the mean die temperature over them, C (what
    /// the corrector's `set_environment` takes). An empty block reads nothing and gives NaN.
    ///
    /// # Errors
    /// The bus's; `block` then holds what was read before the failure.
    pub fn read_block(&mut self, block: &mut [[i16; 6]]) -> Result<f32, Error<I2C::Error>> {
        let mut sum = 0.0f32;
        for slot in block.iter_mut() {
            let s = self.read()?;
            *slot = s.raw;
            sum += s.temperature_c;
        }
        Ok(sum / block.len() as f32)
    }

    /// The set-up.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Gives the bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }
}
