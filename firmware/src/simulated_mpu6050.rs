//! A simulated MPU-6050 behind the `embedded-hal` 1.0 I2C trait, for the example device on
//! QEMU (which has no such part): a register file as the register map lays it out, asleep
//! after reset (`PWR_MGMT_1` = 0x40), `WHO_AM_I` = 0x68, register writes and burst reads with
//! the register pointer's auto-increment, and a new sample in the data registers each time a
//! burst starts at `ACCEL_XOUT_H`. The device reads it through `spincal::driver::mpu6050`
//! exactly as it would read the real part.

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use spincal::driver::mpu6050::{ADDRESS, WHO_AM_I_VALUE, register};

/// The die temperature the part reports, C.
pub const TEMPERATURE_C: f32 = 25.0;

/// The simulated part.
pub struct SimulatedMpu6050 {
    registers: [u8; 0x80],
    pointer: u8,
    sample: i32,
    /// The six codes of sample `k`.
    codes: fn(i32) -> [i16; 6],
}

impl SimulatedMpu6050 {
    /// A part at [`ADDRESS`], fresh from reset, whose sample `k` is `codes(k)`.
    #[must_use]
    pub fn new(codes: fn(i32) -> [i16; 6]) -> Self {
        let mut registers = [0u8; 0x80];
        if let Some(r) = registers.get_mut(usize::from(register::PWR_MGMT_1)) {
            *r = 0x40;
        }
        if let Some(r) = registers.get_mut(usize::from(register::WHO_AM_I)) {
            *r = WHO_AM_I_VALUE;
        }
        Self {
            registers,
            pointer: 0,
            sample: 0,
            codes,
        }
    }

    fn register(&mut self, r: u8) -> Option<&mut u8> {
        self.registers.get_mut(usize::from(r))
    }

    /// Latches the next sample into the data registers (zeros while asleep).
    fn latch(&mut self) {
        let asleep = self
            .register(register::PWR_MGMT_1)
            .is_none_or(|r| *r & 0x40 != 0);
        let [ax, ay, az, gx, gy, gz] = if asleep {
            [0; 6]
        } else {
            (self.codes)(self.sample)
        };
        let temperature = ((TEMPERATURE_C - 36.53) * 340.0) as i16;
        for (k, word) in [ax, ay, az, temperature, gx, gy, gz].iter().enumerate() {
            for (j, byte) in word.to_be_bytes().iter().enumerate() {
                if let Some(r) = self.register(register::ACCEL_XOUT_H + (2 * k + j) as u8) {
                    *r = *byte;
                }
            }
        }
        self.sample += 1;
    }
}

impl ErrorType for SimulatedMpu6050 {
    type Error = ErrorKind;
}

impl I2c for SimulatedMpu6050 {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        if address != ADDRESS {
            return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        }
        for op in operations {
            match op {
                Operation::Write(bytes) => {
                    let Some((first, values)) = bytes.split_first() else {
                        continue;
                    };
                    self.pointer = *first;
                    for v in values {
                        let p = self.pointer;
                        if let Some(r) = self.register(p) {
                            *r = *v;
                        }
                        self.pointer = p.wrapping_add(1);
                    }
                }
                Operation::Read(buffer) => {
                    if self.pointer == register::ACCEL_XOUT_H {
                        self.latch();
                    }
                    for b in buffer.iter_mut() {
                        let p = self.pointer;
                        *b = self.register(p).map_or(0, |r| *r);
                        self.pointer = p.wrapping_add(1);
                    }
                }
            }
        }
        Ok(())
    }
}
