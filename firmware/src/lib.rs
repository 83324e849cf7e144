//! Shared by the QEMU test binaries: the golden cases compiled in by `build.rs`, the CMSDK
//! timer used to count instructions under `-icount`, a runner over the three correctors, the
//! example device, and a simulated MPU-6050 behind the `embedded-hal` I2C trait.
#![no_std]

pub mod device;
pub mod flight_golden;
pub mod simulated_mpu6050;

use spincal::correct::AnyCorrector;
use spincal::model::Calibration;

/// The sensor kind of a golden case.
#[derive(Clone, Copy)]
pub enum Kind {
    /// Single axis.
    Single,
    /// Triad.
    Triad,
    /// IMU at a sample rate (Hz), with the largest angular acceleration (rad/s^2).
    Imu(f32, f32),
}

/// One step of a golden case.
pub enum Step {
    /// Set temperature and voltage.
    Env(f32, f32),
    /// Correct `raw`; expect these output bits and flags.
    Sample {
        /// Raw codes.
        raw: &'static [i32],
        /// Expected outputs as bits.
        expected: &'static [u32],
        /// Expected flag bits.
        flags: u8,
        /// Expected 1-sigma of each output as bits; empty without covariance factors.
        sigma: &'static [u32],
    },
}

/// A golden case: a blob and its steps.
pub struct Case {
    /// Name (the file stem).
    pub name: &'static str,
    /// Blob bytes.
    pub blob: &'static [u8],
    /// Sensor kind.
    pub kind: Kind,
    /// Steps.
    pub steps: &'static [Step],
}

/// What the health check must report after one sample of a health golden case.
pub struct HealthCheck {
    /// Index of the sample.
    pub after: usize,
    /// `Verdict as u8`.
    pub verdict: u8,
    /// That sample's flag bits.
    pub flags: u8,
    /// Refined biases (6), their 1-sigma (6), the two statistics, as `f32` bits.
    pub bits: [u32; 14],
}

/// A health golden case: raw samples of a unit at rest and handled, at 25 C and 3.3 V.
pub struct HealthCase {
    /// Name (the file stem).
    pub name: &'static str,
    /// Blob bytes.
    pub blob: &'static [u8],
    /// Sample rate, Hz.
    pub rate: f32,
    /// Raw samples.
    pub raw: &'static [[u16; 6]],
    /// Checks, in sample order.
    pub checks: &'static [HealthCheck],
}

include!(concat!(env!("OUT_DIR"), "/golden_cases.rs"));

/// The corrector of a golden case: the crate's [`AnyCorrector`] for the calibration's kind and
/// sample format (the golden codes are `i32`; a code beyond the format's container is clamped
/// to it).
pub struct Runner<'a>(AnyCorrector<'a>);

impl<'a> Runner<'a> {
    /// The corrector for `kind`, or `None` if the calibration is of another kind.
    pub fn new(cal: &'a Calibration, kind: Kind) -> Option<Self> {
        let (rate, max_acc) = match kind {
            Kind::Imu(rate, max_acc) => (rate, max_acc),
            Kind::Single | Kind::Triad => (1000.0, 1.0),
        };
        let mut c = AnyCorrector::new(cal, rate).ok()?;
        c.set_max_angular_acceleration(max_acc).ok()?;
        let same = matches!(
            (&c, kind),
            (AnyCorrector::Axis(_), Kind::Single)
                | (AnyCorrector::Triad(_), Kind::Triad)
                | (AnyCorrector::Imu(_), Kind::Imu(..))
        );
        same.then_some(Self(c))
    }

    /// Sets the environment.
    pub fn set_environment(&mut self, t: f32, v: f32) {
        self.0.set_environment(t, v);
    }

    /// Corrects `raw` into `out` (as bits); returns the number of outputs and the flags, or
    /// `None` on a wrong length.
    pub fn correct(&mut self, raw: &[i32], out: &mut [u32; 6]) -> Option<(usize, u8)> {
        let c = self.0.correct(raw)?;
        for (o, v) in out.iter_mut().zip(c.values.iter()) {
            *o = v.to_bits();
        }
        Some((self.0.outputs(), c.flags.bits()))
    }

    /// The stated 1-sigma of each output of the sample `raw` that [`correct`](Self::correct)
    /// gave `values` (as bits) into `out`; `false` without covariance factors.
    pub fn sigma(&self, raw: &[i32], values: &[u32; 6], out: &mut [u32; 6]) -> bool {
        match self.0.sigma(raw, &values.map(f32::from_bits)) {
            Some(s) => {
                *out = s.map(f32::to_bits);
                true
            }
            None => false,
        }
    }
}

/// UART0 of mps2-an386 (CMSDK APB UART). Its receiver raises IRQ 0; the core sleeps (`wfi`)
/// until a byte comes instead of spinning on the status register, so an idle unit draws no
/// power (and a unit under QEMU no host core).
pub struct Uart {
    base: usize,
}

impl Uart {
    const DATA: usize = 0x00;
    const STATE: usize = 0x04;
    const CTRL: usize = 0x08;
    const INTCLEAR: usize = 0x0C;
    const BAUDDIV: usize = 0x10;
    /// CTRL: transmitter, receiver, receive interrupt.
    const TX_RX_RXIRQ: u32 = 0b1011;
    /// INTSTATUS / INTCLEAR: the receive interrupt.
    const RX_IRQ: u32 = 0b10;
    /// The NVIC's set-enable and clear-pending registers for IRQs 0 to 31; UART0's receiver
    /// is IRQ 0 on mps2-an386.
    const NVIC_ISER0: usize = 0xE000_E100;
    const NVIC_ICPR0: usize = 0xE000_E280;
    const UART0_RX_IRQ: u32 = 1 << 0;

    /// UART0 at 0x40004000, transmitter and receiver enabled. Interrupts are masked (PRIMASK)
    /// and the receive interrupt only wakes the core from `wfi`: no handler ever runs.
    pub fn uart0() -> Self {
        cortex_m::interrupt::disable();
        let u = Self { base: 0x4000_4000 };
        // SAFETY: the documented CMSDK UART registers of mps2-an386 and the NVIC's enable
        // register of the Cortex-M4; with PRIMASK set the enabled IRQ is never taken.
        unsafe {
            ((u.base + Self::BAUDDIV) as *mut u32).write_volatile(16);
            ((u.base + Self::CTRL) as *mut u32).write_volatile(Self::TX_RX_RXIRQ);
            (Self::NVIC_ISER0 as *mut u32).write_volatile(Self::UART0_RX_IRQ);
        }
        u
    }

    fn state(&self) -> u32 {
        // SAFETY: a read of the STATE register.
        unsafe { ((self.base + Self::STATE) as *const u32).read_volatile() }
    }

    /// Waits for and returns one byte, sleeping while none has come. The receive interrupt
    /// is cleared at the UART and in the NVIC before the status is looked at, so a byte that
    /// comes between the look and the `wfi` leaves the interrupt pending and `wfi` returns.
    pub fn read(&self) -> u8 {
        loop {
            // SAFETY: writes of the UART's INTCLEAR and the NVIC's clear-pending register.
            unsafe {
                ((self.base + Self::INTCLEAR) as *mut u32).write_volatile(Self::RX_IRQ);
                (Self::NVIC_ICPR0 as *mut u32).write_volatile(Self::UART0_RX_IRQ);
            }
            if self.state() & 0b10 != 0 {
                break;
            }
            cortex_m::asm::wfi();
        }
        // SAFETY: a read of the DATA register with the receive buffer full.
        unsafe { ((self.base + Self::DATA) as *const u32).read_volatile() as u8 }
    }

    /// Sends bytes, waiting while the transmit buffer is full.
    pub fn write_all(&self, bytes: &[u8]) {
        for b in bytes {
            while self.state() & 0b1 != 0 {}
            // SAFETY: a write of the DATA register with the transmit buffer free.
            unsafe { ((self.base + Self::DATA) as *mut u32).write_volatile(u32::from(*b)) };
        }
    }
}

/// The calibration region of `memory.x` (writable code SSRAM under QEMU) as a NOR flash:
/// erase sets 0xFF, programming only clears bits, 4-byte writes, 4 KiB sectors.
pub struct RamFlash {
    base: usize,
    len: usize,
}

/// A RAM flash never fails.
#[derive(Debug, Clone, Copy)]
pub struct RamFlashError;

impl embedded_storage::nor_flash::NorFlashError for RamFlashError {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        embedded_storage::nor_flash::NorFlashErrorKind::OutOfBounds
    }
}

impl RamFlash {
    /// Bytes per slot (`_calib_slot_size` of memory.x).
    pub const SLOT_SIZE: u32 = 0x8000;

    /// The 72 KiB region at `_calib_start` (0x003EE000).
    pub fn calibration_region() -> Self {
        Self {
            base: 0x003E_E000,
            len: 0x1_2000,
        }
    }

    fn check(&self, offset: u32, len: usize) -> Result<usize, RamFlashError> {
        let o = offset as usize;
        if o.checked_add(len).is_some_and(|end| end <= self.len) {
            Ok(self.base + o)
        } else {
            Err(RamFlashError)
        }
    }
}

impl embedded_storage::nor_flash::ErrorType for RamFlash {
    type Error = RamFlashError;
}

impl embedded_storage::nor_flash::ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamFlashError> {
        let at = self.check(offset, bytes.len())?;
        for (i, b) in bytes.iter_mut().enumerate() {
            // SAFETY: inside the calibration region, which nothing else uses.
            *b = unsafe { ((at + i) as *const u8).read_volatile() };
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.len
    }
}

impl embedded_storage::nor_flash::NorFlash for RamFlash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 4096;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamFlashError> {
        let at = self.check(from, to.saturating_sub(from) as usize)?;
        for i in 0..(to - from) as usize {
            // SAFETY: inside the calibration region.
            unsafe { ((at + i) as *mut u8).write_volatile(0xff) };
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamFlashError> {
        let at = self.check(offset, bytes.len())?;
        for (i, b) in bytes.iter().enumerate() {
            let p = (at + i) as *mut u8;
            // SAFETY: inside the calibration region; programming only clears bits.
            unsafe { p.write_volatile(p.read_volatile() & b) };
        }
        Ok(())
    }
}

/// Ends the QEMU run with the given status (semihosting `SYS_EXIT`: QEMU exits 0 or 1).
pub fn exit(success: bool) -> ! {
    cortex_m_semihosting::debug::exit(if success {
        cortex_m_semihosting::debug::EXIT_SUCCESS
    } else {
        cortex_m_semihosting::debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m_semihosting::hprintln!("PANIC: {}", info);
    exit(false)
}

/// Stack high-water marks: paint the free stack below the stack pointer, run, find the lowest
/// word that changed.
pub mod stack {
    const PAINT: u32 = 0xDEAD_BEEF;
    const DEPTH: usize = 64 * 1024;

    /// Runs `f` and returns its result and the bytes of stack it used (to 4 bytes).
    #[inline(never)]
    pub fn high_water<R>(f: impl FnOnce() -> R) -> (R, usize) {
        let sp = cortex_m::register::msp::read() as usize;
        let bottom = sp - DEPTH;
        for addr in (bottom..sp).step_by(4) {
            // SAFETY: free stack below the stack pointer of this function, in the 4 MiB RAM;
            // nothing else runs (no interrupts are enabled).
            unsafe { (addr as *mut u32).write_volatile(PAINT) };
        }
        let r = f();
        let mut lowest = sp;
        for addr in (bottom..sp).step_by(4) {
            // SAFETY: as above, reading back.
            if unsafe { (addr as *const u32).read_volatile() } != PAINT {
                lowest = addr;
                break;
            }
        }
        (r, sp - lowest)
    }
}

/// The CMSDK APB timer 0 of mps2-an386, counting down at 25 MHz.
pub mod timer {
    const BASE: usize = 0x4000_0000;
    const CTRL: *mut u32 = BASE as *mut u32;
    const VALUE: *mut u32 = (BASE + 0x4) as *mut u32;
    const RELOAD: *mut u32 = (BASE + 0x8) as *mut u32;

    /// Starts the timer free-running from `u32::MAX`.
    pub fn start() {
        // SAFETY: the CMSDK timer registers of mps2-an386, written as documented.
        unsafe {
            RELOAD.write_volatile(u32::MAX);
            VALUE.write_volatile(u32::MAX);
            CTRL.write_volatile(1);
        }
    }

    /// The current count (decreasing).
    #[inline(always)]
    pub fn now() -> u32 {
        // SAFETY: a read of the timer's VALUE register.
        unsafe { VALUE.read_volatile() }
    }

    /// Instructions executed for `ticks` timer ticks under `-icount shift=10` (each instruction
    /// advances virtual time by 1024 ns; the timer runs at 25 MHz).
    pub fn instructions(ticks: u32) -> u64 {
        (u64::from(ticks) * 40 + 512) / 1024
    }
}
