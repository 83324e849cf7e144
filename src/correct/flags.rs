//! Per-sample flags: why a corrected sample cannot be fully trusted.

use core::fmt;
use core::ops::{BitOr, BitOrAssign};

/// A set of reasons not to trust a corrected sample; empty for a sample the calibration
/// vouches for.
#[derive(Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(transparent)]
pub struct Flags(u8);

impl Flags {
    /// No flag: the calibration vouches for the sample.
    pub const NONE: Self = Self(0);
    /// A raw code at or beyond an ADC rail: the true input may be beyond what was converted.
    pub const SATURATED: Self = Self(1 << 0);
    /// A corrected value outside the calibrated input range: the correction is extrapolated.
    pub const OUT_OF_RANGE: Self = Self(1 << 1);
    /// The temperature is outside the calibrated span (or NaN); the coefficients of the nearest
    /// edge are used.
    pub const TEMPERATURE_CLAMPED: Self = Self(1 << 2);
    /// The supply voltage is outside the calibrated span (or NaN); the coefficients of the
    /// nearest edge are used.
    pub const VOLTAGE_CLAMPED: Self = Self(1 << 3);
    /// No valid calibration: the output is the identity fallback (raw counts).
    pub const NO_CALIBRATION: Self = Self(1 << 4);
    /// The lever-arm correction had no previous gyro sample for the rate derivative (the first
    /// sample after construction or `reset`); the derivative term was taken as zero.
    pub const RATE_DERIVATIVE_UNKNOWN: Self = Self(1 << 5);
    /// The unit judged at rest that its calibration no longer holds, beyond what ageing
    /// explains (shock damage or a fault: [`crate::health`]); every sample carries it until
    /// the unit is checked on the bench.
    pub const CALIBRATION_SUSPECT: Self = Self(1 << 6);
    /// With a lever arm: the corrected rate changed between two samples by more than the
    /// largest angular acceleration an airframe makes
    /// ([`ImuCorrector::set_max_angular_acceleration`](crate::correct::ImuCorrector::set_max_angular_acceleration)):
    /// a glitch or a gap in the stream, whose tangential lever term (`dw/dt x r`) is then wrong.
    pub const RATE_STEP: Self = Self(1 << 7);

    const NAMES: [(Self, &'static str); 8] = [
        (Self::SATURATED, "saturated"),
        (Self::OUT_OF_RANGE, "out-of-range"),
        (Self::TEMPERATURE_CLAMPED, "temperature-clamped"),
        (Self::VOLTAGE_CLAMPED, "voltage-clamped"),
        (Self::NO_CALIBRATION, "no-calibration"),
        (Self::RATE_DERIVATIVE_UNKNOWN, "rate-derivative-unknown"),
        (Self::CALIBRATION_SUSPECT, "calibration-suspect"),
        (Self::RATE_STEP, "rate-step"),
    ];

    /// True when no flag is set.
    #[must_use]
    pub const fn is_clean(self) -> bool {
        self.0 == 0
    }

    /// True when every flag of `other` is set in `self`.
    #[must_use]
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// The flags as bits.
    #[must_use]
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Flags from bits (every bit of a `u8` is a flag).
    #[must_use]
    pub const fn from_bits_truncate(bits: u8) -> Self {
        Self(bits)
    }

    /// `self` with `other` added when `cond` holds (branch-free).
    #[must_use]
    #[inline(always)]
    pub(crate) const fn with_if(self, other: Self, cond: bool) -> Self {
        Self(self.0 | (other.0 & (0u8.wrapping_sub(cond as u8))))
    }
}

impl BitOr for Flags {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

impl BitOrAssign for Flags {
    fn bitor_assign(&mut self, rhs: Self) {
        self.0 |= rhs.0;
    }
}

impl fmt::Debug for Flags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl fmt::Display for Flags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_clean() {
            return f.write_str("clean");
        }
        let mut first = true;
        for (flag, name) in Self::NAMES {
            if self.contains(flag) {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}
