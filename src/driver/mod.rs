//! Drivers of real inertial parts over the `embedded-hal` 1.0 traits: raw samples in the
//! order and the sample format the correctors take (accelerometer `x y z`, then gyro `x y z`),
//! so that a block read from the part goes straight into
//! [`ImuCorrector::correct_batch`](crate::correct::ImuCorrector::correct_batch).

pub mod mpu6050;
