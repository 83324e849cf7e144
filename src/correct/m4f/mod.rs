//! Hand-scheduled Cortex-M4F kernels for every IMU shape: bias and matrix only (`Linear`), and
//! polynomial with g-sensitivity (the full model), with or without the asymmetric scale and the
//! lever arm; run by `ImuCorrector::correct` and `correct_batch` (`imu/fast.rs`). Compiled only
//! for hard-float Arm targets; everywhere else the compiled Rust path runs.
//!
//! # Why assembly
//!
//! LLVM loads each coefficient with its own `vldr` and spills the window bases, which costs
//! about 20 instructions per sample for the linear shape and 75 for the full one (see
//! `BENCHMARKS.md`). These kernels lay the coefficients out in the order they are used and load
//! each block with one `vldm`, move two codes into the FPU per `vmov`, store the six outputs
//! with one `vstm`, and keep the window test in integer registers.
//!
//! # Bit-exact with the Rust path
//!
//! Every kernel performs exactly the operations of [`ImuCorrector`](super::ImuCorrector)'s fast
//! path, in the same order: `vmla`/`vmls` on the Cortex-M4F round the product before the
//! addition (they are not fused), which is what the Rust expressions `a + b * c` and
//! `a - b * c` compute. A kernel returns at the first sample outside the safe window; the caller
//! corrects that sample with the Rust slow path and resumes. The QEMU golden test checks the
//! outputs of `correct` and of `correct_batch` against the host's bit for bit.
//!
//! # Memory layout
//!
//! Each kernel reads one `#[repr(C)]` block: a [`Header`] (window bases and limits of both
//! triads, the environment flags) and then the coefficients in the order the kernel loads them.
//! The `offset_of!` assertions below pin every offset the assembly uses.

#![allow(unsafe_code)]

use core::mem::{offset_of, size_of};

use super::Corrected;
use super::kernel::TriadKernel;
use super::sample::Sample;
use crate::model::SampleFormat;
use crate::model::rotation::LeverTerms;

/// The block of the current environment's kernel, if its shape has one.
#[derive(Debug, Clone, Copy)]
#[expect(
    clippy::large_enum_variant,
    reason = "one per corrector, built with the environment, never moved per sample"
)]
pub(crate) enum Hot {
    /// No kernel for the shape: the compiled Rust path.
    None,
    /// Bias and matrix only.
    Linear(LinearBlock),
    /// Polynomial and g-sensitivity, with or without the asymmetric scale and the lever arm.
    Full(FullBlock, Full),
}

/// A full kernel's entry point (the samples are `[S; 6]` of the kernel's format).
type FullKernel =
    unsafe extern "C" fn(*mut FullBlock, *const u8, *mut Corrected<6>, usize) -> usize;

/// Which full kernel, chosen once with the environment.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Full(FullKernel);

impl Full {
    /// The kernel for samples `[S; 6]` with (or without) the asymmetry term `s |v - b|` and
    /// the lever arm (which reads and writes `prev_rate`).
    pub fn new<S: Sample>(asym: bool, lever: bool) -> Self {
        use SampleFormat::{I16, I32, U16};
        Self(match (S::FORMAT, asym, lever) {
            (I32, false, true) => spincal_imu_full_m4f,
            (I32, true, true) => spincal_imu_full_asym_m4f,
            (I32, false, false) => spincal_imu_poly_m4f,
            (I32, true, false) => spincal_imu_poly_asym_m4f,
            (I16, false, true) => spincal_imu_full_i16_m4f,
            (I16, true, true) => spincal_imu_full_asym_i16_m4f,
            (I16, false, false) => spincal_imu_poly_i16_m4f,
            (I16, true, false) => spincal_imu_poly_asym_i16_m4f,
            (U16, false, true) => spincal_imu_full_u16_m4f,
            (U16, true, true) => spincal_imu_full_asym_u16_m4f,
            (U16, false, false) => spincal_imu_poly_u16_m4f,
            (U16, true, false) => spincal_imu_poly_asym_u16_m4f,
        })
    }
}

/// Negated window bases and limits of both triads and the environment flags (36 bytes). The
/// bases are negated so that the 16-bit kernels add them while they widen each code
/// (`sxtah`/`uxtah`), at no cost over the `i32` kernels' subtraction.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Header {
    accel_neg_base: [i32; 3],
    /// Accelerometer window limit (0 until the lever arm is primed).
    pub accel_limit: u32,
    gyro_neg_base: [i32; 3],
    gyro_limit: u32,
    flags: u32,
}

impl Header {
    fn new(accel: &TriadKernel, gyro: &TriadKernel, flags: u8) -> Self {
        Self {
            accel_neg_base: accel.base.map(i32::wrapping_neg),
            accel_limit: accel.limit,
            gyro_neg_base: gyro.base.map(i32::wrapping_neg),
            gyro_limit: gyro.limit,
            flags: u32::from(flags),
        }
    }
}

/// Coefficients of the linear kernel: offsets (the six accumulators' start values), then the
/// accelerometer and gyro matrices row-major.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinearBlock {
    header: Header,
    offset: [f32; 6],
    matrix: [f32; 18],
}

impl LinearBlock {
    pub fn new(accel: &TriadKernel, gyro: &TriadKernel, flags: u8) -> Self {
        Self {
            header: Header::new(accel, gyro, flags),
            offset: join(accel.off_lin, gyro.off_lin),
            matrix: matrices(accel, gyro),
        }
    }
}

/// Coefficients of the full kernel in the order it loads them, and the lever-arm state.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub(crate) struct FullBlock {
    /// Windows and flags.
    pub header: Header,
    /// Per axis `q` (the first `vldm` also loads `delta`, `k` and `o`).
    q: [f32; 6],
    delta: [f32; 6],
    k: [f32; 6],
    o: [f32; 6],
    offset: [f32; 6],
    matrix: [f32; 18],
    /// Negated g-sensitivity, row-major.
    neg_g: [[f32; 3]; 3],
    /// The previous corrected gyro rate; the lever kernels update it.
    pub prev_rate: [f32; 3],
    /// The previous lever term; the lever kernels update it.
    pub prev_lever: [f32; 3],
    /// The lever term's coefficients, per output the six quadratic then the three tangential
    /// ones ([`LeverTerms`]).
    lever: [f32; 27],
    /// Per axis the asymmetry `s`, then its breakpoint `b` (the asymmetric kernel only).
    asym: [f32; 12],
}

impl FullBlock {
    pub fn new(
        accel: &TriadKernel,
        gyro: &TriadKernel,
        flags: u8,
        neg_g: &[[f32; 3]; 3],
        terms: &LeverTerms<f32>,
        (prev_rate, prev_lever): ([f32; 3], [f32; 3]),
    ) -> Self {
        let pick = |f: fn([f32; 5]) -> f32| join(accel.nl.map(f), gyro.nl.map(f));
        let mut lever = [0.0; 27];
        let per_output = terms
            .quad
            .iter()
            .zip(&terms.tangential)
            .flat_map(|(q, t)| q.iter().chain(t));
        for (dst, src) in lever.iter_mut().zip(per_output) {
            *dst = *src;
        }
        Self {
            header: Header::new(accel, gyro, flags),
            q: pick(|[q, ..]| q),
            delta: join(accel.delta, gyro.delta),
            k: pick(|[_, k, ..]| k),
            o: pick(|[_, _, o, ..]| o),
            offset: join(accel.off, gyro.off),
            matrix: matrices(accel, gyro),
            neg_g: *neg_g,
            prev_rate,
            prev_lever,
            lever,
            asym: {
                let mut sb = [0.0; 12];
                let (s, b) = (pick(|[.., s, _]| s), pick(|[.., b]| b));
                for (dst, src) in sb.iter_mut().zip(s.iter().chain(&b)) {
                    *dst = *src;
                }
                sb
            },
        }
    }
}

fn join(a: [f32; 3], b: [f32; 3]) -> [f32; 6] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a0, a1, a2, b0, b1, b2]
}

fn matrices(accel: &TriadKernel, gyro: &TriadKernel) -> [f32; 18] {
    let mut m = [0.0; 18];
    for (dst, src) in m
        .iter_mut()
        .zip(accel.m.iter().flatten().chain(gyro.m.iter().flatten()))
    {
        *dst = *src;
    }
    m
}

// The offsets the assembly below uses.
const _: () = {
    assert!(offset_of!(Header, accel_limit) == 12);
    assert!(offset_of!(Header, gyro_neg_base) == 16);
    assert!(offset_of!(Header, gyro_limit) == 28);
    assert!(offset_of!(Header, flags) == 32);
    assert!(size_of::<Header>() == 36);
    assert!(offset_of!(LinearBlock, offset) == 36);
    assert!(offset_of!(LinearBlock, matrix) == 60);
    assert!(offset_of!(FullBlock, q) == 36);
    assert!(offset_of!(FullBlock, delta) == 60);
    assert!(offset_of!(FullBlock, k) == 84);
    assert!(offset_of!(FullBlock, o) == 108);
    assert!(offset_of!(FullBlock, offset) == 132);
    assert!(offset_of!(FullBlock, matrix) == 156);
    assert!(offset_of!(FullBlock, neg_g) == 228);
    assert!(offset_of!(FullBlock, prev_rate) == 264);
    assert!(offset_of!(FullBlock, prev_lever) == 276);
    assert!(offset_of!(FullBlock, lever) == 288);
    assert!(offset_of!(FullBlock, asym) == 396);
    assert!(offset_of!(Corrected<6>, values) == 0);
    assert!(offset_of!(Corrected<6>, flags) == 24);
    assert!(size_of::<Corrected<6>>() == 28);
};

// Every kernel: r0 = block, r1 = raw samples, r2 = outputs, r3 = count. They return in r0 the
// number of samples corrected before the first one outside a window (the count when none is).
// The window test is the Rust one: `(w0 | w1 | w2) < limit` (unsigned) for both triads, with
// `w_j = raw_j - base_j` (wrapping). Registers: r4-r9 the six codes, then the offsets w; r10,
// r11, r12, lr a triad's negated bases and limit; r3 the samples left, whose starting value is
// saved on the stack. s16-s31 are callee-saved and pushed. Each kernel exists for the three
// sample formats (`_i16`, `_u16`, and `i32` unsuffixed), which differ only in spincal_codes.
core::arch::global_asm!(
    ".syntax unified",
    ".thumb",
    ".fpu fpv4-sp-d16",
    //
    // Shared by both kernels. Entry: save r3 (the count) and the callee-saved registers.
    ".macro spincal_entry",
    "push {{r3-r11, lr}}",
    "vpush {{s16-s31}}",
    ".endm",
    // The next sample: load its six codes, leave for 3f when either triad is outside its
    // window, else convert the offsets w to f32 in s0-s5. `fmt`: 0 `[i32; 6]` (one `ldm`,
    // `w = raw + (-base)` by `add`), 1 `[i16; 6]` and 2 `[u16; 6]` (three `ldr`, which need
    // no word alignment, then `sxtah`/`uxtah` widen each halfword and add the negated base in
    // one instruction). Little-endian: code 2k is the low half of word k.
    ".macro spincal_widen fmt, rd, rn, rm, hi",
    ".if \\fmt == 1",
    ".if \\hi",
    "sxtah \\rd, \\rn, \\rm, ror #16",
    ".else",
    "sxtah \\rd, \\rn, \\rm",
    ".endif",
    ".else",
    ".if \\hi",
    "uxtah \\rd, \\rn, \\rm, ror #16",
    ".else",
    "uxtah \\rd, \\rn, \\rm",
    ".endif",
    ".endif",
    ".endm",
    ".macro spincal_codes fmt",
    ".if \\fmt == 0",
    "ldm r1!, {{r4-r9}}",
    "ldm r0, {{r10-r12, lr}}",
    "add r4, r4, r10",
    "add r5, r5, r11",
    "add r6, r6, r12",
    ".else",
    "ldr r8, [r1, #4]",
    "ldr r9, [r1, #8]",
    "ldr r7, [r1], #12",
    "ldm r0, {{r10-r12, lr}}",
    "spincal_widen \\fmt, r4, r10, r7, 0",
    "spincal_widen \\fmt, r5, r11, r7, 1",
    "spincal_widen \\fmt, r6, r12, r8, 0",
    ".endif",
    "orr r10, r4, r5",
    "orr r10, r10, r6",
    "cmp r10, lr",
    "bhs 3f",
    "ldrd r10, r11, [r0, #16]",
    "ldrd r12, lr, [r0, #24]",
    ".if \\fmt == 0",
    "add r7, r7, r10",
    "add r8, r8, r11",
    "add r9, r9, r12",
    ".else",
    "spincal_widen \\fmt, r7, r10, r8, 1",
    "spincal_widen \\fmt, r8, r11, r9, 0",
    "spincal_widen \\fmt, r9, r12, r9, 1",
    ".endif",
    "orr r10, r7, r8",
    "orr r10, r10, r9",
    "cmp r10, lr",
    "bhs 3f",
    "vmov s0, s1, r4, r5",
    "vmov s2, s3, r6, r7",
    "vmov s4, s5, r8, r9",
    "vcvt.f32.s32 s0, s0",
    "vcvt.f32.s32 s1, s1",
    "vcvt.f32.s32 s2, s2",
    "vcvt.f32.s32 s3, s3",
    "vcvt.f32.s32 s4, s4",
    "vcvt.f32.s32 s5, s5",
    ".endm",
    // Store the outputs s6-s11 and the flags, loop to 1b while samples are left; 3: return
    // the number corrected.
    ".macro spincal_store_and_return",
    "vstm r2!, {{s6-s11}}",
    "ldr r4, [r0, #32]",
    "strb r4, [r2], #4",
    "subs r3, r3, #1",
    "bne 1b",
    "3:",
    "vpop {{s16-s31}}",
    "pop {{r1, r4-r11, lr}}",
    "sub r0, r1, r3",
    "bx lr",
    ".endm",
    //
    // Linear: y = off_lin + M w per triad. The matrices stay in s14-s31 for the whole batch.
    ".macro spincal_linear fmt",
    "spincal_entry",
    "add r4, r0, #60",
    "vldm r4, {{s14-s31}}",
    "cmp r3, #0",
    "beq 3f",
    "1:",
    "spincal_codes \\fmt",
    "add r4, r0, #36",
    "vldm r4, {{s6-s11}}",
    "vmla.f32 s6, s14, s0",
    "vmla.f32 s6, s15, s1",
    "vmla.f32 s6, s16, s2",
    "vmla.f32 s7, s17, s0",
    "vmla.f32 s7, s18, s1",
    "vmla.f32 s7, s19, s2",
    "vmla.f32 s8, s20, s0",
    "vmla.f32 s8, s21, s1",
    "vmla.f32 s8, s22, s2",
    "vmla.f32 s9, s23, s3",
    "vmla.f32 s9, s24, s4",
    "vmla.f32 s9, s25, s5",
    "vmla.f32 s10, s26, s3",
    "vmla.f32 s10, s27, s4",
    "vmla.f32 s10, s28, s5",
    "vmla.f32 s11, s29, s3",
    "vmla.f32 s11, s30, s4",
    "vmla.f32 s11, s31, s5",
    "spincal_store_and_return",
    ".endm",
    //
    // Full: per axis v = w - delta, u = v + v (v (q + k v) + o |v|) (+ s |v - b| with `asym`);
    // y = off + M u per triad; gyro w_i += (-g_i) . x; with `lever`, x = a - e_prev and the
    // accelerometer output a - e(w, w - w_prev) (model/rotation.rs). r4 walks the block from
    // `q` to the lever coefficients.
    ".macro spincal_full fmt, asym, lever",
    "spincal_entry",
    "cmp r3, #0",
    "beq 3f",
    "1:",
    "spincal_codes \\fmt",
    // q -> s6-s11 (the accumulators t), delta -> s12-s17, k -> s18-s23, o -> s24-s29.
    "add r4, r0, #36",
    "vldm r4!, {{s6-s29}}",
    "vsub.f32 s0, s0, s12",
    "vsub.f32 s1, s1, s13",
    "vsub.f32 s2, s2, s14",
    "vsub.f32 s3, s3, s15",
    "vsub.f32 s4, s4, s16",
    "vsub.f32 s5, s5, s17",
    "vmla.f32 s6, s18, s0",
    "vmla.f32 s7, s19, s1",
    "vmla.f32 s8, s20, s2",
    "vmla.f32 s9, s21, s3",
    "vmla.f32 s10, s22, s4",
    "vmla.f32 s11, s23, s5",
    "vmul.f32 s6, s0, s6",
    "vmul.f32 s7, s1, s7",
    "vmul.f32 s8, s2, s8",
    "vmul.f32 s9, s3, s9",
    "vmul.f32 s10, s4, s10",
    "vmul.f32 s11, s5, s11",
    "vabs.f32 s30, s0",
    "vmla.f32 s6, s24, s30",
    "vabs.f32 s30, s1",
    "vmla.f32 s7, s25, s30",
    "vabs.f32 s30, s2",
    "vmla.f32 s8, s26, s30",
    "vabs.f32 s30, s3",
    "vmla.f32 s9, s27, s30",
    "vabs.f32 s30, s4",
    "vmla.f32 s10, s28, s30",
    "vabs.f32 s30, s5",
    "vmla.f32 s11, s29, s30",
    ".if \\asym",
    // Asymmetry: s -> s12-s17, b -> s18-s23 (the block's end), then |v - b| in s18-s23.
    "add r5, r0, #396",
    "vldm r5, {{s12-s23}}",
    "vsub.f32 s18, s0, s18",
    "vsub.f32 s19, s1, s19",
    "vsub.f32 s20, s2, s20",
    "vsub.f32 s21, s3, s21",
    "vsub.f32 s22, s4, s22",
    "vsub.f32 s23, s5, s23",
    "vabs.f32 s18, s18",
    "vabs.f32 s19, s19",
    "vabs.f32 s20, s20",
    "vabs.f32 s21, s21",
    "vabs.f32 s22, s22",
    "vabs.f32 s23, s23",
    ".endif",
    "vmla.f32 s0, s0, s6",
    "vmla.f32 s1, s1, s7",
    "vmla.f32 s2, s2, s8",
    "vmla.f32 s3, s3, s9",
    "vmla.f32 s4, s4, s10",
    "vmla.f32 s5, s5, s11",
    ".if \\asym",
    "vmla.f32 s0, s12, s18",
    "vmla.f32 s1, s13, s19",
    "vmla.f32 s2, s14, s20",
    "vmla.f32 s3, s15, s21",
    "vmla.f32 s4, s16, s22",
    "vmla.f32 s5, s17, s23",
    ".endif",
    // offsets -> s6-s11 (the outputs), matrices -> s12-s29.
    "vldm r4!, {{s6-s29}}",
    "vmla.f32 s6, s12, s0",
    "vmla.f32 s6, s13, s1",
    "vmla.f32 s6, s14, s2",
    "vmla.f32 s7, s15, s0",
    "vmla.f32 s7, s16, s1",
    "vmla.f32 s7, s17, s2",
    "vmla.f32 s8, s18, s0",
    "vmla.f32 s8, s19, s1",
    "vmla.f32 s8, s20, s2",
    "vmla.f32 s9, s21, s3",
    "vmla.f32 s9, s22, s4",
    "vmla.f32 s9, s23, s5",
    "vmla.f32 s10, s24, s3",
    "vmla.f32 s10, s25, s4",
    "vmla.f32 s10, s26, s5",
    "vmla.f32 s11, s27, s3",
    "vmla.f32 s11, s28, s4",
    "vmla.f32 s11, s29, s5",
    // Gyro w += (-g) . x, with x the specific force at the reference point: a itself without
    // the lever arm; with it, a less the previous lever term (model/rotation.rs).
    ".if \\lever",
    // -g -> s12-s20, previous rate -> s21-s23, previous lever term -> s24-s26; r5 keeps the
    // address after them for the state's store.
    "vldm r4!, {{s12-s26}}",
    "mov r5, r4",
    "vsub.f32 s24, s6, s24",
    "vsub.f32 s25, s7, s25",
    "vsub.f32 s26, s8, s26",
    "vmla.f32 s9, s12, s24",
    "vmla.f32 s9, s13, s25",
    "vmla.f32 s9, s14, s26",
    "vmla.f32 s10, s15, s24",
    "vmla.f32 s10, s16, s25",
    "vmla.f32 s10, s17, s26",
    "vmla.f32 s11, s18, s24",
    "vmla.f32 s11, s19, s25",
    "vmla.f32 s11, s20, s26",
    // Rate difference d -> s15-s17; monomials w0^2 w1^2 w2^2 w0w1 w0w2 w1w2 -> s0-s5.
    "vsub.f32 s15, s9, s21",
    "vsub.f32 s16, s10, s22",
    "vsub.f32 s17, s11, s23",
    "vmul.f32 s0, s9, s9",
    "vmul.f32 s1, s10, s10",
    "vmul.f32 s2, s11, s11",
    "vmul.f32 s3, s9, s10",
    "vmul.f32 s4, s9, s11",
    "vmul.f32 s5, s10, s11",
    // Lever term e_j = quad_j . m + tan_j . d -> s12-s14: output 0 and five terms of
    // output 1 from the first load (s18-s31), the rest from the second (s18-s30).
    "vldm r4!, {{s18-s31}}",
    "vmul.f32 s12, s18, s0",
    "vmla.f32 s12, s19, s1",
    "vmla.f32 s12, s20, s2",
    "vmla.f32 s12, s21, s3",
    "vmla.f32 s12, s22, s4",
    "vmla.f32 s12, s23, s5",
    "vmla.f32 s12, s24, s15",
    "vmla.f32 s12, s25, s16",
    "vmla.f32 s12, s26, s17",
    "vmul.f32 s13, s27, s0",
    "vmla.f32 s13, s28, s1",
    "vmla.f32 s13, s29, s2",
    "vmla.f32 s13, s30, s3",
    "vmla.f32 s13, s31, s4",
    "vldm r4!, {{s18-s30}}",
    "vmla.f32 s13, s18, s5",
    "vmla.f32 s13, s19, s15",
    "vmla.f32 s13, s20, s16",
    "vmla.f32 s13, s21, s17",
    "vmul.f32 s14, s22, s0",
    "vmla.f32 s14, s23, s1",
    "vmla.f32 s14, s24, s2",
    "vmla.f32 s14, s25, s3",
    "vmla.f32 s14, s26, s4",
    "vmla.f32 s14, s27, s5",
    "vmla.f32 s14, s28, s15",
    "vmla.f32 s14, s29, s16",
    "vmla.f32 s14, s30, s17",
    // f = a - e; store the new rate and lever term as the state.
    "vsub.f32 s6, s6, s12",
    "vsub.f32 s7, s7, s13",
    "vsub.f32 s8, s8, s14",
    "vstmdb r5!, {{s9-s14}}",
    ".else",
    // -g -> s12-s20.
    "vldm r4, {{s12-s20}}",
    "vmla.f32 s9, s12, s6",
    "vmla.f32 s9, s13, s7",
    "vmla.f32 s9, s14, s8",
    "vmla.f32 s10, s15, s6",
    "vmla.f32 s10, s16, s7",
    "vmla.f32 s10, s17, s8",
    "vmla.f32 s11, s18, s6",
    "vmla.f32 s11, s19, s7",
    "vmla.f32 s11, s20, s8",
    ".endif",
    "spincal_store_and_return",
    ".endm",
    //
    // One kernel: its own section (unused ones are dropped by the linker), `linear` or the
    // full model with `asym` and `lever`, for samples of format `fmt` (see spincal_codes).
    ".macro spincal_define name, fmt, linear, asym, lever",
    ".section .text.\\name,\"ax\",%progbits",
    ".global \\name",
    ".type \\name,%function",
    ".p2align 2",
    ".thumb_func",
    "\\name:",
    ".if \\linear",
    "spincal_linear \\fmt",
    ".else",
    "spincal_full \\fmt, \\asym, \\lever",
    ".endif",
    ".size \\name, . - \\name",
    ".endm",
    "spincal_define spincal_imu_linear_m4f, 0, 1, 0, 0",
    "spincal_define spincal_imu_full_m4f, 0, 0, 0, 1",
    "spincal_define spincal_imu_full_asym_m4f, 0, 0, 1, 1",
    "spincal_define spincal_imu_poly_m4f, 0, 0, 0, 0",
    "spincal_define spincal_imu_poly_asym_m4f, 0, 0, 1, 0",
    "spincal_define spincal_imu_linear_i16_m4f, 1, 1, 0, 0",
    "spincal_define spincal_imu_full_i16_m4f, 1, 0, 0, 1",
    "spincal_define spincal_imu_full_asym_i16_m4f, 1, 0, 1, 1",
    "spincal_define spincal_imu_poly_i16_m4f, 1, 0, 0, 0",
    "spincal_define spincal_imu_poly_asym_i16_m4f, 1, 0, 1, 0",
    "spincal_define spincal_imu_linear_u16_m4f, 2, 1, 0, 0",
    "spincal_define spincal_imu_full_u16_m4f, 2, 0, 0, 1",
    "spincal_define spincal_imu_full_asym_u16_m4f, 2, 0, 1, 1",
    "spincal_define spincal_imu_poly_u16_m4f, 2, 0, 0, 0",
    "spincal_define spincal_imu_poly_asym_u16_m4f, 2, 0, 1, 0",
);

unsafe extern "C" {
    fn spincal_imu_linear_m4f(
        b: *const LinearBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_asym_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_asym_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_linear_i16_m4f(
        b: *const LinearBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_i16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_asym_i16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_i16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_asym_i16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_linear_u16_m4f(
        b: *const LinearBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_u16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_asym_u16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_u16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_asym_u16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
}

/// Corrects samples with the linear kernel until the first one outside a window; returns how
/// many it corrected.
pub(crate) fn linear<S: Sample>(
    block: &LinearBlock,
    raw: &[[S; 6]],
    out: &mut [Corrected<6>],
) -> usize {
    let n = raw.len().min(out.len());
    let kernel = match S::FORMAT {
        SampleFormat::I32 => spincal_imu_linear_m4f,
        SampleFormat::I16 => spincal_imu_linear_i16_m4f,
        SampleFormat::U16 => spincal_imu_linear_u16_m4f,
    };
    // SAFETY: the kernel for `S`'s format reads `n` samples `[S; 6]` from `raw` (the 16-bit
    // ones by word loads that need no alignment) and writes `n` outputs (28 bytes each: the
    // values and the flag byte) to `out`, reads only `block`, saves every callee-saved
    // register it uses and returns at most `n`. The layouts are pinned by the assertions above.
    unsafe { kernel(block, raw.as_ptr().cast(), out.as_mut_ptr(), n) }
}

/// Corrects samples with the `kind` full kernel until the first one outside a window; returns
/// how many it corrected. With the lever arm it leaves the last corrected rate and lever term
/// in `block.prev_rate` and `block.prev_lever`.
#[inline(always)]
pub(crate) fn full<S: Sample>(
    kind: Full,
    block: &mut FullBlock,
    raw: &[[S; 6]],
    out: &mut [Corrected<6>],
) -> usize {
    let n = raw.len().min(out.len());
    // SAFETY: as for `linear` (`kind` was chosen by `Full::new::<S>`); these kernels also
    // write `block.prev_rate` and `block.prev_lever` (with the lever arm).
    unsafe { (kind.0)(block, raw.as_ptr().cast(), out.as_mut_ptr(), n) }
}
