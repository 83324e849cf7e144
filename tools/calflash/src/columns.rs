//! The column names of observation files, shared by the simulator and the workflows.
//!
//! Single axis: `input` (the reference input along the sensitive axis, SI: m/s^2 or rad/s),
//! `output` (counts), and optionally `input_p`, `input_o` (cross-axis inputs), `temp` (degrees
//! C), `volt` (supply, V), `dir` (+1 ascending, -1 descending).
//!
//! Triads and IMUs, in the unit's axes: `f_x f_y f_z` (reference specific force, m/s^2),
//! `w_x w_y w_z` (reference rate, rad/s), `a_x a_y a_z` (accelerometer counts), `g_x g_y g_z`
//! (gyro counts), and optionally `dw_x dw_y dw_z` (angular acceleration, rad/s^2: spin-up and
//! spin-down), `h_x h_y h_z` (the fixture's reference mark, for the Earth's rate: `crate::earth`),
//! `temp`, `volt`.

/// Reference input of a single axis.
pub const INPUT: &str = "input";
/// Cross-axis input p.
pub const INPUT_P: &str = "input_p";
/// Cross-axis input o.
pub const INPUT_O: &str = "input_o";
/// Output counts of a single axis.
pub const OUTPUT: &str = "output";
/// Temperature.
pub const TEMP: &str = "temp";
/// The chamber's temperature, when the sensor's own is in `temp` (reported, not fitted).
pub const CHAMBER_TEMP: &str = "chamber_temp";
/// Time of an observation, seconds.
pub const TIME: &str = "time";
/// Supply voltage.
pub const VOLT: &str = "volt";
/// Sweep direction.
pub const DIR: &str = "dir";
/// Reference specific force.
pub const F: [&str; 3] = ["f_x", "f_y", "f_z"];
/// Reference rate.
pub const W: [&str; 3] = ["w_x", "w_y", "w_z"];
/// Reference angular acceleration.
pub const DW: [&str; 3] = ["dw_x", "dw_y", "dw_z"];
/// The direction of the fixture's reference mark in the unit's axes, for the Earth's rate of a
/// still observation (`crate::earth`).
pub const H: [&str; 3] = ["h_x", "h_y", "h_z"];
/// Accelerometer counts.
pub const A: [&str; 3] = ["a_x", "a_y", "a_z"];
/// Gyro counts.
pub const GYRO: [&str; 3] = ["g_x", "g_y", "g_z"];
