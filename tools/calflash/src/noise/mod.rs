//! Sensor noise: the overlapping Allan deviation and the IEEE Std 952 noise terms.

pub mod allan;
