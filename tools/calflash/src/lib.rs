//! `calflash`: the host half of the calibration toolchain. Reads observations, fits sensor
//! models with regression-grade statistics, and reports them.
//!
//! The library holds all the logic; `main.rs` is a thin CLI over it.
#![forbid(unsafe_code)]

pub mod approval;
pub mod cmd;
pub mod columns;
pub mod db;
pub mod design;
pub mod device;
pub mod earth;
pub mod files;
pub mod formula;
pub mod lot;
pub mod mission;
pub mod nav;
pub mod noise;
pub mod nonlinear;
pub mod obs;
pub mod regression;
pub mod report;
pub mod sensor;
pub mod signing;
pub mod sim;
pub mod stats;
