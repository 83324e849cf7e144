//! The container a part delivers its codes in (a leaf: the error type names it, and the model
//! re-exports it as [`crate::model::SampleFormat`]).

use serde::{Deserialize, Serialize};

/// The container the part delivers its codes in, which a corrector's samples must have: the
/// blob states it and a corrector for another refuses it when it is built
/// ([`Error::CorrectorWrongFormat`](crate::Error::CorrectorWrongFormat)), never per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SampleFormat {
    /// `u16`: unsigned (offset-binary) codes of up to 16 bits.
    U16,
    /// `i16`: two's-complement codes of up to 16 bits.
    I16,
    /// `i32`: codes of up to 32 bits (signed) or 31 bits (unsigned).
    I32,
}

impl SampleFormat {
    /// The smallest and largest code the container holds.
    #[must_use]
    pub const fn limits(self) -> (i32, i32) {
        match self {
            SampleFormat::U16 => (0, u16::MAX as i32),
            SampleFormat::I16 => (i16::MIN as i32, i16::MAX as i32),
            SampleFormat::I32 => (i32::MIN, i32::MAX),
        }
    }

    /// The container's name in Rust: `u16`, `i16` or `i32`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            SampleFormat::U16 => "u16",
            SampleFormat::I16 => "i16",
            SampleFormat::I32 => "i32",
        }
    }
}
