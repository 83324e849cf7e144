//! Calibration of inertial sensors on the device: the coefficient models, the checksummed
//! calibration blob, and the per-sample correction.
//!
//! `spincal` is the firmware half of the calibration toolchain. The host tool (`calflash`) fits
//! a sensor model to test-bench observations and writes the result as a *blob*; the device
//! stores the blob, [decodes and validates](blob::decode) it once, and then applies the
//! correction to every raw ADC sample at a high, fixed rate with a [`Corrector`](correct).
//!
//! # The promises
//!
//! - **No panics.** Every untrusted input passes one checking gate: a blob goes through
//!   [`blob::decode`], which checks its length and CRC before it decodes anything and then
//!   validates every value. A [`model::Calibration`] can only be built through that gate (or
//!   [`model::Calibration::new`], which runs the same validation), and after it nothing in the
//!   correction can panic, for any raw sample and any temperature or voltage, NaN included.
//!   The crate denies the lints that would let indexing, `unwrap` or `panic!` slip in.
//! - **No allocation.** Everything is fixed-capacity ([`heapless`]); the decoded calibration
//!   lives wherever the caller puts it (a `static`, the stack).
//! - **Bounded time.** The per-sample path is a fixed sequence of integer and single-precision
//!   operations. A sample inside the precomputed *safe window* (not saturated, provably inside
//!   the calibrated range) takes the fast path; any other sample takes a bounded slow path that
//!   works out exactly which flags apply. `BENCHMARKS.md` gives both counts.
//! - **Every doubtful sample is flagged** ([`correct::Flags`]): saturated input, output outside
//!   the calibrated input range, temperature or voltage outside the calibrated span (the
//!   coefficients are clamped to the table's edge, never extrapolated), no calibration, and an
//!   unknown rate derivative for the lever-arm term on the first sample.
//!
//! # Layout
//!
//! - [`model`]: what a calibration is (axis nonlinearity, single axis, triad, IMU, temperature
//!   and voltage tables, calibrated ranges, ADC rails, identity).
//! - [`blob`]: the wire format (header, CRC, postcard payload), `encode` and `decode`.
//! - [`correct`]: effective coefficients per environment, raw counts to SI units, flags,
//!   lever arm, 1-sigma calibration error.
//! - [`store`]: two power-fail-safe slots over an `embedded-storage` NOR flash.
//! - [`health`]: the unit judges its calibration at rest (stillness, a Kalman filter over the
//!   biases with the calibration's covariance as its prior, OK / DRIFTED / SUSPECT).
//! - [`nav`] and [`flight`]: in flight, the strapdown navigation and the GNSS- and
//!   barometer-aided error-state filter over the corrected samples (`f32` on the round).
//! - [`driver`]: real parts over `embedded-hal` 1.0 (the MPU-6050), raw samples for the
//!   correctors.
//!
//! # Features
//!
//! - `defmt`: derive `defmt::Format` for the public error, flag and identity types.
//!
//! # Example
//!
//! ```
//! use spincal::{blob, correct::TriadCorrector, model::*};
//!
//! // A triad calibration as the host tool would produce it (here: 1 count = 0.01 m/s^2).
//! let data = CalibrationData::example_triad();
//! let cal = Calibration::new(data)?;
//! let mut bytes = [0u8; blob::MAX_BLOB_LEN];
//! let n = blob::encode(&cal, &mut bytes)?;
//!
//! // On the device: decode once, keep the validated copy, correct every sample.
//! let cal = blob::decode(&bytes[..n])?;
//! // The converter delivers unsigned 16-bit codes, as the calibration states; a corrector
//! // for another sample type refuses it here, never per sample.
//! assert_eq!(cal.data().sensor.sample_format(), SampleFormat::U16);
//! assert!(TriadCorrector::<i16>::new(&cal).is_err());
//! let mut corrector = TriadCorrector::<u16>::new(&cal)?;
//! corrector.set_environment(25.0, 3.3);
//! let out = corrector.correct([32768 + 981, 32768, 32768]);
//! assert!((out.values[0] - 9.81).abs() < 1e-3);
//! assert!(out.flags.is_clean());
//! # Ok::<(), spincal::Error>(())
//! ```
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::panic,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]

pub mod blob;
pub mod correct;
pub mod driver;
pub mod flight;
pub mod health;
pub mod model;
pub mod nav;
pub mod protocol;
pub mod signed;
pub mod store;

mod error;
mod limits;
mod sample_format;
mod sqrt;

pub use error::{Error, Field, Part};
