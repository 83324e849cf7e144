//! The correction: raw ADC counts in, SI values and [`Flags`] out.
//!
//! Build a corrector from a validated [`Calibration`](crate::model::Calibration) (or take the
//! explicit `identity` fallback, which passes raw counts through and flags every sample
//! [`Flags::NO_CALIBRATION`]). Tell it the temperature and supply voltage with
//! `set_environment` whenever they change: that interpolates the coefficient table once and
//! precomputes everything the per-sample path needs. Until it is called, every sample is
//! flagged [`Flags::TEMPERATURE_CLAMPED`] and [`Flags::VOLTAGE_CLAMPED`] (the coefficients of the
//! middle of the calibrated spans are used). Then call `correct` per sample, or
//! `correct_batch` over a DMA block.
//!
//! | sensor      | corrector              | raw      | output                        |
//! |-------------|------------------------|----------|-------------------------------|
//! | single axis | [`AxisCorrector<S>`]   | `S`      | `[f32; 1]`                    |
//! | triad       | [`TriadCorrector<S>`]  | `[S; 3]` | `[f32; 3]`                    |
//! | IMU         | [`ImuCorrector<S>`]    | `[S; 6]` | `[f32; 6]`: ax ay az gx gy gz |
//!
//! The sample type `S` ([`Sample`]) is the container the part delivers its codes in: `u16`,
//! `i16` or `i32`. The calibration states it ([`SampleFormat`](crate::model::SampleFormat), in
//! its rails); a corrector of another type refuses the calibration when it is built
//! ([`Error::CorrectorWrongFormat`](crate::Error::CorrectorWrongFormat)), never per sample.
//! Hosts holding every format's codes as `i32` use [`AnyImuCorrector`] and its siblings.
//!
//! On hard-float Arm targets (the Cortex-M4F), `ImuCorrector::correct` and `correct_batch` run
//! hand-scheduled kernels for every IMU shape; they give the same bits as the compiled path
//! (`BENCHMARKS.md`).
//!
//! None of these functions can panic, for any input, NaN temperatures and voltages included.
//! The `f32` outputs are finite for every raw code inside the ADC rails; a code beyond a rail is
//! corrected as if it were at the rail, and flagged.

mod any;
mod environment;
mod flags;
mod imu;
mod kernel;
#[cfg(all(target_arch = "arm", target_abi = "eabihf", target_os = "none"))]
mod m4f;
mod sample;
mod single;
mod triad;
mod widened;

pub use any::AnyCorrector;
pub use flags::Flags;
pub use imu::{
    DEFAULT_MAX_ANGULAR_ACCELERATION, ImuCorrector, MAX_SAMPLE_RATE_HZ, Overlay, REST_FEATURES,
};
pub use sample::Sample;
pub use single::AxisCorrector;
pub use triad::TriadCorrector;
pub use widened::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector, format_of};

/// A corrected sample: `N` values in SI units (m/s^2, rad/s) and the flags that apply.
///
/// `#[repr(C)]`: the Cortex-M4F batch kernels write it directly.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(C)]
pub struct Corrected<const N: usize> {
    /// Corrected values.
    pub values: [f32; N],
    /// Why the sample cannot be fully trusted; empty when it can.
    pub flags: Flags,
}

impl<const N: usize> Default for Corrected<N> {
    fn default() -> Self {
        Self {
            values: [0.0; N],
            flags: Flags::NONE,
        }
    }
}

/// `|L' f|` for a packed lower-triangular `L` (row-major) of dimension `N`: the 1-sigma of an
/// output whose features are `f`. The factor is read once, in its own order: row `i` adds
/// `L_ij f_i` to each `(L' f)_j`, `j <= i` (each sum over `i` in the same order as by columns,
/// so the same bits).
fn factor_norm<const N: usize>(packed: &[f32], f: &[f32; N]) -> f32 {
    let mut v = [0.0f32; N];
    let mut factor = packed.iter();
    for (i, fi) in f.iter().enumerate() {
        for vj in v.iter_mut().take(i + 1) {
            *vj += factor.next().copied().unwrap_or(0.0) * fi;
        }
    }
    crate::sqrt::sqrtf(v.iter().fold(0.0, |s, x| s + x * x))
}

#[cfg(test)]
mod tests {
    use super::factor_norm;

    #[test]
    fn factor_norm_is_sqrt_of_quadratic_form() {
        // L = [[2, 0], [1, 3]] -> C = L L' = [[4, 2], [2, 10]]; f = [1, 2] -> f'Cf = 4+8+40.
        let s = factor_norm(&[2.0, 1.0, 3.0], &[1.0, 2.0]);
        assert!((s - 52f32.sqrt()).abs() < 1e-6);
    }
}
