//! How [`ImuCorrector`] uses the Cortex-M4F kernels ([`m4f`]): the
//! coefficient block is built with the environment, `correct` runs the kernel on one sample and
//! `correct_batch` on the whole batch; a sample outside a window, and any outside samples after
//! it, take the Rust slow path. The kernel is the one for the corrector's sample type.

use super::super::Corrected;
use super::super::kernel::Shape;
use super::super::m4f::{self, Full, FullBlock, Header, Hot, LinearBlock};
use super::super::sample::{self, Sample};
use super::{ImuCorrector, split};
use crate::model::SampleFormat;

impl<S: Sample> ImuCorrector<'_, S> {
    /// Builds the kernel's block for the current effective coefficients (none for a shape
    /// without a kernel).
    pub(super) fn refresh_m4f(&mut self) {
        self.state_to_corrector();
        // A 16-bit kernel's masks cannot close a window: with a window that never opens in
        // this environment the compiled path runs (it flags every sample through the slow
        // path, as the kernel would hand each one to it).
        if S::FORMAT != SampleFormat::I32 && self.limits.contains(&0) {
            self.hot = Hot::None;
            return;
        }
        let header = self.header();
        self.hot = match (self.mode.shape, self.mode.lever) {
            (Shape::Linear, _) => Hot::Linear(LinearBlock::new(header, &self.accel, &self.gyro)),
            (shape @ (Shape::Polynomial | Shape::Asymmetric), lever) => Hot::Full(
                FullBlock::new(
                    header,
                    &self.accel,
                    &self.gyro,
                    &self.neg_g,
                    &self.terms,
                    (self.prev_rate, self.prev_lever),
                    self.max_step_sq,
                ),
                Full::new::<S>(shape == Shape::Asymmetric, lever),
            ),
            _ => Hot::None,
        };
    }

    /// The kernels' window words and flags, with the accelerometer's window open at the limit
    /// computed for the environment (the lever arm's state closes and opens it per call): the
    /// 16-bit masks are made from it once.
    fn header(&self) -> Header {
        let [accel_limit, _] = self.limits;
        let flags = self.env_flags.bits();
        Header::new((&self.accel, accel_limit), &self.gyro, flags, S::FORMAT)
    }

    /// Runs the kernel until the first sample outside a window; `None` when the shape has no
    /// kernel. While a full kernel exists, the lever-arm state (the previous rate and lever
    /// term) lives in its block, which the kernel reads and writes; the slow path works on the
    /// corrector's copy ([`state_to_corrector`](Self::state_to_corrector) and back).
    #[inline(always)]
    fn kernel(&mut self, raw: &[[S; 6]], out: &mut [Corrected<6>]) -> Option<usize> {
        match &mut self.hot {
            Hot::None => None,
            Hot::Linear(block) => Some(m4f::linear(block, raw, out)),
            Hot::Full(block, kind) => {
                if !block.header.set_accel_limit(self.accel.limit, S::FORMAT) {
                    return Some(0);
                }
                Some(m4f::full(*kind, block, raw, out))
            }
        }
    }

    /// The lever-arm state from the kernel's block into the corrector, before the slow path
    /// or a new block.
    #[inline(never)]
    fn state_to_corrector(&mut self) {
        if let Hot::Full(block, _) = &self.hot {
            self.prev_rate = block.prev_rate;
            self.prev_lever = block.prev_lever;
        }
    }

    /// The lever-arm state from the corrector back into the kernel's block, after the slow
    /// path.
    #[inline(never)]
    fn state_to_block(&mut self) {
        if let Hot::Full(block, _) = &mut self.hot {
            block.prev_rate = self.prev_rate;
            block.prev_lever = self.prev_lever;
        }
    }

    /// The slow path of the shapes that have a kernel, on the corrector's copy of the
    /// lever-arm state (see [`kernel`](Self::kernel)).
    fn slow_m4f(&mut self, raw: [i32; 6], out: &mut Corrected<6>) {
        match (self.mode.shape, self.mode.lever) {
            (Shape::Asymmetric, true) => self.slow::<true, true, true>(raw, out),
            (Shape::Asymmetric, false) => self.slow::<true, true, false>(raw, out),
            (Shape::Polynomial, true) => self.slow::<true, false, true>(raw, out),
            (Shape::Polynomial, false) => self.slow::<true, false, false>(raw, out),
            _ => self.slow::<false, false, false>(raw, out),
        }
    }

    /// `correct` on the kernel; false when the shape has none.
    #[inline(always)]
    pub(super) fn one_m4f(&mut self, raw: [S; 6], out: &mut Corrected<6>) -> bool {
        match self.kernel(core::slice::from_ref(&raw), core::slice::from_mut(out)) {
            None => false,
            Some(1) => true,
            Some(_) => {
                self.state_to_corrector();
                self.slow_m4f(sample::codes(raw), out);
                self.state_to_block();
                true
            }
        }
    }

    /// `correct_batch` on the kernel; false (nothing done) when the shape has none. A run of
    /// samples outside the windows (a saturated burst) stays on the slow path until a sample is
    /// inside again.
    pub(super) fn batch_m4f(&mut self, raw: &[[S; 6]], out: &mut [Corrected<6>]) -> bool {
        if matches!(self.hot, Hot::None) {
            return false;
        }
        let (mut raw, mut out) = (raw, out);
        loop {
            let done = self.kernel(raw, out).unwrap_or(0);
            (raw, out) = after(raw, out, done);
            if raw.is_empty() {
                return true;
            }
            self.state_to_corrector();
            let mut slow = 0;
            for (r, o) in raw.iter().zip(out.iter_mut()) {
                if self.inside(r) {
                    break;
                }
                self.slow_m4f(sample::codes(*r), o);
                slow += 1;
            }
            self.state_to_block();
            if slow == 0 {
                return true;
            }
            (raw, out) = after(raw, out, slow);
        }
    }

    /// The fast path's window test.
    #[inline(always)]
    fn inside(&self, raw: &[S; 6]) -> bool {
        let (ra, rg) = split(sample::codes(*raw));
        let (_, acc_a) = self.accel.offsets(ra);
        let (_, acc_g) = self.gyro.offsets(rg);
        (acc_a < self.accel.limit) & (acc_g < self.gyro.limit)
    }
}

/// Both slices without their first `k` items.
fn after<'r, 'o, S>(
    raw: &'r [[S; 6]],
    out: &'o mut [Corrected<6>],
    k: usize,
) -> (&'r [[S; 6]], &'o mut [Corrected<6>]) {
    (
        raw.get(k..).unwrap_or_default(),
        out.get_mut(k..).unwrap_or_default(),
    )
}
