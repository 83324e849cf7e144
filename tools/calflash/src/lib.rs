//! `calflash`: the host half of the calibration toolchain.
#![forbid(unsafe_code)]
