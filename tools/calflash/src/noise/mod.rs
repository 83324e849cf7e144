//! Sensor noise: the overlapping Allan deviation and the IEEE Std 952 noise terms, and the
//! noise terms a blob carries for the unit's health check.

pub mod allan;
pub mod kalibr;
pub mod said;
pub mod stated;
