//! A simulated NOR flash for the store's power-fail tests: erase sets bytes to 0xFF,
//! programming only clears bits, every write unit is programmed at most once per erase (a second
//! program is recorded as a violation), and a power cut can be scheduled before any write or
//! erase, tearing it in one of several ways.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// How an operation is torn by the power cut scheduled on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tear {
    /// The operation never starts.
    Skip,
    /// The operation completes, then the power goes.
    Complete,
    /// A write programs only its first `n` bytes.
    Partial(usize),
    /// A write clears a random subset of the bits it would clear (seeded).
    RandomBits(u64),
    /// An erase stops early: the sector reads 0xFF but for random zero bits (seeded).
    RandomZeros(u64),
}

/// The flash's error: out of bounds, misaligned, or the power is gone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimError(pub NorFlashErrorKind);

impl NorFlashError for SimError {
    fn kind(&self) -> NorFlashErrorKind {
        self.0
    }
}

/// A NOR flash of write size `W` and erase size `E`.
#[derive(Debug, Clone)]
pub struct SimFlash<const W: usize, const E: usize> {
    /// The contents.
    pub mem: Vec<u8>,
    programmed: Vec<bool>,
    /// Write and erase operations since the last reboot.
    pub ops: usize,
    cut: Option<(usize, Tear)>,
    dead: bool,
    /// NOR rules broken (should stay empty).
    pub violations: Vec<String>,
}

fn xorshift(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

impl<const W: usize, const E: usize> SimFlash<W, E> {
    /// A flash of `size` bytes, as delivered: all zeros, never erased (like the RAM that stands in
    /// for flash under QEMU).
    #[must_use]
    pub fn new(size: usize) -> Self {
        Self {
            mem: vec![0; size],
            programmed: vec![false; size / W],
            ops: 0,
            cut: None,
            dead: false,
            violations: Vec::new(),
        }
    }

    /// Schedules a power cut on operation `at` (0-based, counted from now).
    pub fn cut_at(&mut self, at: usize, tear: Tear) {
        self.cut = Some((self.ops + at, tear));
    }

    /// Power back on: no cut scheduled, operations counted from 0.
    pub fn reboot(&mut self) {
        self.dead = false;
        self.cut = None;
        self.ops = 0;
    }

    /// True when the power is gone.
    #[must_use]
    pub fn dead(&self) -> bool {
        self.dead
    }

    fn begin(&mut self) -> Result<Option<Tear>, SimError> {
        if self.dead {
            return Err(SimError(NorFlashErrorKind::Other));
        }
        let op = self.ops;
        self.ops += 1;
        Ok(match self.cut {
            Some((at, tear)) if at == op => {
                self.dead = true;
                Some(tear)
            }
            _ => None,
        })
    }

    fn program(&mut self, offset: usize, bytes: &[u8], tear: Option<Tear>) {
        let n = match tear {
            Some(Tear::Skip) => 0,
            Some(Tear::Partial(n)) => n.min(bytes.len()),
            _ => bytes.len(),
        };
        let mut rng = match tear {
            Some(Tear::RandomBits(s)) => Some(s | 1),
            _ => None,
        };
        for unit in (offset / W)..(offset + n).div_ceil(W) {
            if self.programmed[unit] {
                self.violations.push(format!(
                    "write unit at {} programmed twice without an erase",
                    unit * W
                ));
            }
            self.programmed[unit] = true;
        }
        for (i, b) in bytes.iter().take(n).enumerate() {
            let cell = &mut self.mem[offset + i];
            let target = *cell & b;
            *cell = match &mut rng {
                // Clear each bit the program would clear with probability 1/2.
                Some(state) => *cell & !((*cell & !target) & (xorshift(state) as u8)),
                None => target,
            };
        }
    }
}

impl<const W: usize, const E: usize> ErrorType for SimFlash<W, E> {
    type Error = SimError;
}

impl<const W: usize, const E: usize> ReadNorFlash for SimFlash<W, E> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SimError> {
        let o = offset as usize;
        let src = self
            .mem
            .get(o..o + bytes.len())
            .ok_or(SimError(NorFlashErrorKind::OutOfBounds))?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const W: usize, const E: usize> NorFlash for SimFlash<W, E> {
    const WRITE_SIZE: usize = W;
    const ERASE_SIZE: usize = E;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), SimError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(E) || !to.is_multiple_of(E) || from > to {
            return Err(SimError(NorFlashErrorKind::NotAligned));
        }
        if to > self.mem.len() {
            return Err(SimError(NorFlashErrorKind::OutOfBounds));
        }
        let tear = self.begin()?;
        match tear {
            Some(Tear::Skip) => {}
            Some(Tear::RandomZeros(seed)) => {
                let mut state = seed | 1;
                for b in &mut self.mem[from..to] {
                    // About one bit in sixteen left at zero.
                    let r = xorshift(&mut state);
                    *b = !((r as u8) & ((r >> 8) as u8) & ((r >> 16) as u8) & ((r >> 24) as u8));
                }
            }
            _ => self.mem[from..to].fill(0xff),
        }
        if !matches!(tear, Some(Tear::Skip)) {
            self.programmed[from / W..to / W].fill(false);
        }
        if tear.is_some() {
            return Err(SimError(NorFlashErrorKind::Other));
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimError> {
        let o = offset as usize;
        if !o.is_multiple_of(W) || !bytes.len().is_multiple_of(W) {
            return Err(SimError(NorFlashErrorKind::NotAligned));
        }
        if o + bytes.len() > self.mem.len() {
            return Err(SimError(NorFlashErrorKind::OutOfBounds));
        }
        let tear = self.begin()?;
        self.program(o, bytes, tear);
        if tear.is_some() {
            return Err(SimError(NorFlashErrorKind::Other));
        }
        Ok(())
    }
}
