//! The containers a part delivers its codes in (`u16`, `i16`, `i32`): a corrector takes its
//! samples in the one its calibration states ([`SampleFormat`]) and refuses the calibration
//! of another when it is built.

use crate::Error;
use crate::model::{Rails, SampleFormat};

mod sealed {
    pub trait Sealed {}
    impl Sealed for u16 {}
    impl Sealed for i16 {}
    impl Sealed for i32 {}
}

/// A raw code as the part delivers it: `u16`, `i16` or `i32`.
pub trait Sample: Copy + sealed::Sealed {
    /// The format a calibration states for samples of this type.
    const FORMAT: SampleFormat;

    /// The code as an `i32` (exact for every format).
    fn code(self) -> i32;

    /// The code `x` in this container, clamped to its limits (a code beyond them is beyond
    /// the rails too, so it is saturated either way).
    fn clamped(x: i32) -> Self;
}

impl Sample for u16 {
    const FORMAT: SampleFormat = SampleFormat::U16;

    #[inline(always)]
    fn code(self) -> i32 {
        i32::from(self)
    }

    #[inline]
    fn clamped(x: i32) -> Self {
        u16::try_from(x.max(0)).unwrap_or(u16::MAX)
    }
}

impl Sample for i16 {
    const FORMAT: SampleFormat = SampleFormat::I16;

    #[inline(always)]
    fn code(self) -> i32 {
        i32::from(self)
    }

    #[inline]
    fn clamped(x: i32) -> Self {
        i16::try_from(x).unwrap_or(if x < 0 { i16::MIN } else { i16::MAX })
    }
}

impl Sample for i32 {
    const FORMAT: SampleFormat = SampleFormat::I32;

    #[inline(always)]
    fn code(self) -> i32 {
        self
    }

    #[inline]
    fn clamped(x: i32) -> Self {
        x
    }
}

/// The codes of an `N`-axis sample as `i32`.
#[inline(always)]
pub(super) fn codes<S: Sample, const N: usize>(raw: [S; N]) -> [i32; N] {
    raw.map(S::code)
}

/// `Ok` when samples of type `S` are what `rails` states.
pub(super) fn check<S: Sample>(rails: &Rails) -> Result<(), Error> {
    if rails.format == S::FORMAT {
        Ok(())
    } else {
        Err(Error::CorrectorWrongFormat {
            expected: rails.format,
            found: S::FORMAT,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_beyond_a_container_clamp_to_it() {
        assert_eq!(u16::clamped(-5), 0);
        assert_eq!(u16::clamped(70_000), u16::MAX);
        assert_eq!(u16::clamped(1234), 1234);
        assert_eq!(i16::clamped(-40_000), i16::MIN);
        assert_eq!(i16::clamped(40_000), i16::MAX);
        assert_eq!(i16::clamped(-7), -7);
        assert_eq!(i32::clamped(i32::MIN), i32::MIN);
        assert_eq!(codes([u16::MAX, 0]), [65_535, 0]);
        assert_eq!(codes([i16::MIN, -1]), [-32_768, -1]);
    }

    #[test]
    fn a_corrector_takes_only_its_format() {
        assert!(check::<u16>(&Rails::unsigned(16)).is_ok());
        assert!(check::<i16>(&Rails::signed(16)).is_ok());
        assert!(check::<i32>(&Rails::signed(24)).is_ok());
        assert!(check::<i32>(&Rails::unsigned(12).in_format(SampleFormat::I32)).is_ok());
        assert_eq!(
            check::<i32>(&Rails::unsigned(16)),
            Err(Error::CorrectorWrongFormat {
                expected: SampleFormat::U16,
                found: SampleFormat::I32
            })
        );
        assert!(check::<u16>(&Rails::signed(16)).is_err());
    }
}
