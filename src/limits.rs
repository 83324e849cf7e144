//! What this crate accepts: the blob format version it reads and the bounds of the model and
//! its correctors (a leaf: the error type states them in its messages; `blob` and `model`
//! re-export them).

/// The blob format version this crate writes and reads.
pub const FORMAT_VERSION: u8 = 6;

/// Longest lever arm accepted, in metres.
pub const MAX_LEVER_ARM_M: f32 = 10.0;
/// Highest sample rate an IMU corrector accepts, Hz: above any IMU's output rate, and the rate
/// at which validation proves the lever term's feedback bounded (the tangential term grows
/// with the rate, so that bound holds at every lower rate).
pub const MAX_SAMPLE_RATE_HZ: f32 = 1.0e5;
