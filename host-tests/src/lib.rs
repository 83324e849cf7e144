//! Shared by the host tests and by the QEMU test firmware's build script: the golden blobs and
//! vectors, their text format, and the host-side computation of the expected outputs.
#![forbid(unsafe_code)]

pub mod fields;
pub mod flight_golden;
pub mod flight_reference;
pub mod flight_round;
pub mod golden;
pub mod health_golden;
pub mod mainjob;
pub mod nor;
pub mod postgres;
pub mod qemu;
pub mod reference;
pub mod spin_rig;
pub mod tcp_unit;
pub mod unit;
