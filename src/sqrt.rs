//! The single-precision square root, the same bits on every target: on a hard-float Arm core
//! (the Cortex-M4F) its FPU's `VSQRT.F32`, one instruction where `libm`'s integer algorithm
//! takes about fifty; elsewhere `libm`'s. Both are IEEE 754's correctly rounded square root
//! (round to nearest, the FPU's reset mode), so the device and the host agree to the bit, as
//! the golden vectors check on QEMU; a negative or NaN argument goes to `libm` on every target
//! so that even its NaN is the host's.

/// `sqrt(x)` in single precision, correctly rounded.
#[must_use]
#[inline]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    if x >= 0.0 {
        return fpu(x);
    }
    libm::sqrtf(x)
}

/// `VSQRT.F32` on the argument's bits.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
fn fpu(x: f32) -> f32 {
    let bits: u32;
    // SAFETY: the three instructions read the input register, write `s0` (declared clobbered)
    // and the output register, and touch no memory, stack or flags.
    unsafe {
        core::arch::asm!(
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {out}, s0",
            x = in(reg) x.to_bits(),
            out = lateout(reg) bits,
            out("s0") _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::sqrtf;

    #[test]
    fn it_is_libms_square_root_to_the_bit() {
        for x in [
            0.0f32,
            -0.0,
            1.0,
            2.0,
            1e-40,
            3.4e38,
            f32::INFINITY,
            0.1,
            123.456,
        ] {
            assert_eq!(sqrtf(x).to_bits(), libm::sqrtf(x).to_bits(), "{x}");
        }
        assert!(sqrtf(-1.0).is_nan() && sqrtf(f32::NAN).is_nan());
    }
}
