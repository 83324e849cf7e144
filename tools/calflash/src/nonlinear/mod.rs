//! Nonlinear least squares and calibration without external equipment: Levenberg-Marquardt,
//! static-interval detection, the accelerometer from gravity's magnitude, the gyro from the
//! rotations between still poses.

pub mod gravity;
pub mod lm;
pub mod rotation;
pub mod selfcal;
pub mod statics;
