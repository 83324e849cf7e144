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
//! The `offset_of!` assertions beside the assembly (`kernels.rs`) pin every offset it uses.

#![allow(unsafe_code)]

mod kernels;

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
            (I16 | U16, false, true) => spincal_imu_full_16_m4f,
            (I16 | U16, true, true) => spincal_imu_full_asym_16_m4f,
            (I16 | U16, false, false) => spincal_imu_poly_16_m4f,
            (I16 | U16, true, false) => spincal_imu_poly_asym_16_m4f,
        })
    }
}

/// The window test's words and the environment flags: nine words in the layout of the
/// kernel's sample format. A kernel points r0 at word 4 so that one `ldm` or `ldmdb` reaches
/// each group.
///
/// - `i32` kernels: the accelerometer's three negated window bases and its limit (words 0-3,
///   `ldmdb`), the gyro's (words 4-7, `ldm`), the flags (word 8). The kernel adds the negated
///   bases and compares the OR of each triad's offsets with its limit.
/// - 16-bit kernels (`i16` and `u16`): the flags (word 3), then the negated bases in halfword
///   pairs as the codes lie in a sample (codes 0-1, 2-3, 4-5) and the masks `!(limit - 1)` of
///   each triad in both halves (the bits an offset inside its window cannot have; words 4-8,
///   one `ldm`). `uadd16` forms two offsets modulo 2^16 in one instruction; as validation keeps
///   the rails (and so the windows, strictly inside them) within the container's range, an
///   offset modulo 2^16 is below the limit exactly when the code is inside its window. Words
///   0-2 are not used.
///
/// A closed window has no mask: the caller does not run a 16-bit kernel while the lever arm's
/// state closes the accelerometer's window ([`Header::set_accel_limit`]), nor build one for an
/// environment whose windows are not both open (`ImuCorrector::refresh_m4f`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Header {
    words: [u32; 9],
}

impl Header {
    /// The header for kernels of `format`: the windows of `accel` (with its window open at
    /// `accel_limit`, the limit computed for the environment, which the lever arm's state closes
    /// and opens per call) and `gyro`, and the environment's `flags`.
    pub fn new(
        (accel, accel_limit): (&TriadKernel, u32),
        gyro: &TriadKernel,
        flags: u8,
        format: SampleFormat,
    ) -> Self {
        let neg = |b: i32| b.wrapping_neg() as u32;
        let flags = u32::from(flags);
        let words = match format {
            SampleFormat::I32 => {
                let [a0, a1, a2] = accel.base.map(neg);
                let [g0, g1, g2] = gyro.base.map(neg);
                [a0, a1, a2, accel_limit, g0, g1, g2, gyro.limit, flags]
            }
            SampleFormat::I16 | SampleFormat::U16 => {
                let [b0, b1, b2, b3, b4, b5] = join(accel.base, gyro.base).map(neg);
                let pair = |lo: u32, hi: u32| (lo & 0xFFFF) | (hi << 16);
                let (ma, mg) = (mask(accel_limit), mask(gyro.limit));
                let [p0, p1, p2] = [pair(b0, b1), pair(b2, b3), pair(b4, b5)];
                [0, 0, 0, flags, p0, p1, p2, pair(ma, ma), pair(mg, mg)]
            }
        };
        Self { words }
    }

    /// Closes the accelerometer's window (`limit` 0) or opens it again (`limit` the one the
    /// block was built with) for the next run of a kernel of `format`. False when the kernel
    /// must not run: a 16-bit kernel's masks cannot close a window, so the caller takes the
    /// slow path instead (which is what the kernel would do with every sample).
    pub fn set_accel_limit(&mut self, limit: u32, format: SampleFormat) -> bool {
        match format {
            SampleFormat::I32 => {
                self.words[3] = limit;
                true
            }
            SampleFormat::I16 | SampleFormat::U16 => limit != 0,
        }
    }
}

/// The bits of a 16-bit offset that must be clear for it to lie below `limit`, a power of two
/// up to 2^16 (a closed window, 0, has no mask; see [`Header`]).
fn mask(limit: u32) -> u32 {
    !limit.wrapping_sub(1) & 0xFFFF
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
    pub fn new(header: Header, accel: &TriadKernel, gyro: &TriadKernel) -> Self {
        Self {
            header,
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
    /// The square of the largest rate change between two samples before a sample is flagged
    /// a rate step (the lever kernels only; loaded with the lever term's last coefficients).
    max_step_sq: f32,
    /// Per axis the asymmetry `s`, then its breakpoint `b` (the asymmetric kernel only).
    asym: [f32; 12],
}

impl FullBlock {
    pub fn new(
        header: Header,
        accel: &TriadKernel,
        gyro: &TriadKernel,
        neg_g: &[[f32; 3]; 3],
        terms: &LeverTerms<f32>,
        (prev_rate, prev_lever): ([f32; 3], [f32; 3]),
        max_step_sq: f32,
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
            header,
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
            max_step_sq,
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

fn join<T: Copy>(a: [T; 3], b: [T; 3]) -> [T; 6] {
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
    fn spincal_imu_linear_16_m4f(
        b: *const LinearBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_full_asym_16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_16_m4f(
        b: *mut FullBlock,
        r: *const u8,
        o: *mut Corrected<6>,
        n: usize,
    ) -> usize;
    fn spincal_imu_poly_asym_16_m4f(
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
        SampleFormat::I16 | SampleFormat::U16 => spincal_imu_linear_16_m4f,
    };
    // SAFETY: the kernel for `S`'s format reads `n` samples `[S; 6]` from `raw` (the 16-bit
    // ones by word loads that need no alignment) and writes `n` outputs (28 bytes each: the
    // values, the flag byte and the padding after it) to `out`, reads only `block`, saves every callee-saved
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
