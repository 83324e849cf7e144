//! The kernels themselves, in assembly, and the offsets of the blocks they read.

use core::mem::{offset_of, size_of};

use super::super::Corrected;
use super::{FullBlock, Header, LinearBlock};

// The offsets the assembly below uses, pinned.
const _: () = {
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
    assert!(offset_of!(FullBlock, max_step_sq) == 396);
    assert!(offset_of!(FullBlock, asym) == 400);
    assert!(offset_of!(Corrected<6>, values) == 0);
    assert!(offset_of!(Corrected<6>, flags) == 24);
    assert!(size_of::<Corrected<6>>() == 28);
};

// Every kernel: r0 = block, r1 = raw samples, r2 = outputs, r3 = count. They return in r0 the
// number of samples corrected before the first one outside a window (the count when none is).
// The window test decides as the Rust one does, `w_j < limit` for every axis with
// `w_j = raw_j - base_j` (the limits are powers of two). Registers: r4-r12 and lr the codes,
// their offsets w and the header's words; r3 the samples left, whose starting value is saved
// on the stack. s16-s31 are callee-saved and pushed. Each kernel exists for `[i32; 6]` samples
// (unsuffixed) and for 16-bit ones (`_16`, both `i16` and `u16`: only the offsets' arithmetic
// modulo 2^16 is used), which differ only in spincal_codes.
core::arch::global_asm!(
    ".syntax unified",
    ".thumb",
    ".fpu fpv4-sp-d16",
    //
    // Shared by both kernels. Entry: save r3 (the count) and the callee-saved registers, point
    // r0 at the header's word 4 (see `Header`): the offsets from r0 below are 16 less than
    // the blocks' own, which the assertions above give.
    ".macro spincal_entry",
    "push {{r3-r11, lr}}",
    "vpush {{s16-s31}}",
    "add r0, r0, #16",
    ".endm",
    // The next sample: load its six codes, leave for 3f when either triad is outside its
    // window, else convert the offsets w to f32 in s0-s5. `fmt` 0, `[i32; 6]`: one `ldm`,
    // `w = raw + (-base)` by `add`, the OR of each triad's offsets against its limit. `fmt` 1,
    // `[i16; 6]` and `[u16; 6]`: three `ldr` (which need no word alignment) of two codes each
    // (little-endian: code 2k is the low half of word k), `uadd16` adds the negated bases to
    // both halves at once; the OR of word 0 with word 1 shifted up holds the accelerometer's
    // offsets (w0 | w1 | w2 in the high half), of word 2 with word 1 shifted down the gyro's,
    // and each masked by its triad's mask must be zero (see `Header`); `vcvt.f32.u16`
    // converts the low half of a register, so only the high halves need a shift.
    ".macro spincal_codes fmt",
    ".if \\fmt == 0",
    "ldm r1!, {{r4-r9}}",
    "ldmdb r0, {{r10-r12, lr}}",
    "add r4, r4, r10",
    "add r5, r5, r11",
    "add r6, r6, r12",
    "orr r10, r4, r5",
    "orr r10, r10, r6",
    "cmp r10, lr",
    "bhs 3f",
    "ldm r0, {{r10-r12, lr}}",
    "add r7, r7, r10",
    "add r8, r8, r11",
    "add r9, r9, r12",
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
    ".else",
    "ldr r8, [r1, #4]",
    "ldr r9, [r1, #8]",
    "ldr r7, [r1], #12",
    "ldm r0, {{r4-r6, r10, r11}}",
    "uadd16 r7, r7, r4",
    "uadd16 r8, r8, r5",
    "uadd16 r9, r9, r6",
    "orr r4, r7, r8, lsl #16",
    "orr r5, r9, r8, lsr #16",
    "and r4, r4, r10",
    "and r5, r5, r11",
    "orrs r4, r4, r5",
    "bne 3f",
    "lsr r4, r7, #16",
    "lsr r5, r8, #16",
    "lsr r6, r9, #16",
    "vmov s0, s1, r7, r4",
    "vmov s2, s3, r8, r5",
    "vmov s4, s5, r9, r6",
    "vcvt.f32.u16 s0, s0, #0",
    "vcvt.f32.u16 s1, s1, #0",
    "vcvt.f32.u16 s2, s2, #0",
    "vcvt.f32.u16 s3, s3, #0",
    "vcvt.f32.u16 s4, s4, #0",
    "vcvt.f32.u16 s5, s5, #0",
    ".endif",
    ".endm",
    // The flags word into s12: word 8 of the `i32` header, word 3 of the 16-bit one.
    ".macro spincal_flags fmt",
    ".if \\fmt == 0",
    "vldr s12, [r0, #16]",
    ".else",
    "vldr s12, [r0, #-4]",
    ".endif",
    ".endm",
    // The flags word into s12 as `spincal_flags`, with RATE_STEP (bit 7) added when the
    // condition flags say greater (the rate step's comparison, through r6).
    ".macro spincal_flags_or_rate_step fmt",
    ".if \\fmt == 0",
    "ldr r6, [r0, #16]",
    ".else",
    "ldr r6, [r0, #-4]",
    ".endif",
    "it gt",
    "orrgt r6, r6, #128",
    "vmov s12, r6",
    ".endm",
    // Store the outputs s6-s11 and the flags word in s12 (the flag byte and the three bytes of
    // padding after it: one `vstm` writes the whole `Corrected<6>`), loop to 1b while samples
    // are left; 3: return the number corrected.
    ".macro spincal_store_and_return",
    "vstm r2!, {{s6-s12}}",
    "subs r3, r3, #1",
    "bne 1b",
    "3:",
    "vpop {{s16-s31}}",
    "pop {{r1, r4-r11, lr}}",
    "sub r0, r1, r3",
    "bx lr",
    ".endm",
    //
    // Linear: y = off_lin + M w per triad. The matrices stay in s14-s31 and the flags in s12
    // for the whole batch.
    ".macro spincal_linear fmt",
    "spincal_entry",
    "add r4, r0, #44",
    "vldm r4, {{s14-s31}}",
    "spincal_flags \\fmt",
    "cmp r3, #0",
    "beq 3f",
    "1:",
    "spincal_codes \\fmt",
    "add r4, r0, #20",
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
    "add r4, r0, #20",
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
    "add r5, r0, #384",
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
    // output 1 from the first load (s18-s31), the rest from the second (s18-s30), which also
    // brings max_step_sq (s31) for the rate step.
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
    "vldm r4!, {{s18-s31}}",
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
    // The rate step: |d|^2 (d0 d0 + d1 d1, then + d2 d2, as the Rust path) against
    // max_step_sq; the flags word gains RATE_STEP (bit 7) when above (not when unordered).
    "vmul.f32 s15, s15, s15",
    "vmla.f32 s15, s16, s16",
    "vmla.f32 s15, s17, s17",
    "vcmp.f32 s15, s31",
    "vmrs APSR_nzcv, fpscr",
    "spincal_flags_or_rate_step \\fmt",
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
    "spincal_flags \\fmt",
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
    "spincal_define spincal_imu_linear_16_m4f, 1, 1, 0, 0",
    "spincal_define spincal_imu_full_16_m4f, 1, 0, 0, 1",
    "spincal_define spincal_imu_full_asym_16_m4f, 1, 0, 1, 1",
    "spincal_define spincal_imu_poly_16_m4f, 1, 0, 0, 0",
    "spincal_define spincal_imu_poly_asym_16_m4f, 1, 0, 1, 0",
);
