//! Talking to a unit: the link (serial device, pty or TCP), the protocol client, the flash
//! procedure with read-back and test vectors, and slot images for other flashers.

pub mod client;
pub mod flash;
pub mod image;
pub mod link;

pub use client::{Client, DeviceError};
pub use flash::{FlashOptions, FlashReport, flash, key_hex, trust_name};
