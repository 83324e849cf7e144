//! Shared by the QEMU test binaries: the golden cases compiled in by `build.rs`, the CMSDK
//! timer used to count instructions under `-icount`, and a runner over the three correctors.
#![no_std]

use spincal::correct::{AxisCorrector, Corrected, ImuCorrector, TriadCorrector};
use spincal::model::Calibration;

/// The sensor kind of a golden case.
#[derive(Clone, Copy)]
pub enum Kind {
    /// Single axis.
    Single,
    /// Triad.
    Triad,
    /// IMU at a sample rate (Hz).
    Imu(f32),
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

include!(concat!(env!("OUT_DIR"), "/golden_cases.rs"));

/// Any of the three correctors.
#[expect(
    clippy::large_enum_variant,
    reason = "one runner per test, never moved in a loop"
)]
pub enum Runner<'a> {
    /// Single axis.
    Single(AxisCorrector<'a>),
    /// Triad.
    Triad(TriadCorrector<'a>),
    /// IMU.
    Imu(ImuCorrector<'a>),
}

impl<'a> Runner<'a> {
    /// The corrector for `kind`, or `None` if the calibration is of another kind.
    pub fn new(cal: &'a Calibration, kind: Kind) -> Option<Self> {
        Some(match kind {
            Kind::Single => Self::Single(AxisCorrector::new(cal).ok()?),
            Kind::Triad => Self::Triad(TriadCorrector::new(cal).ok()?),
            Kind::Imu(rate) => Self::Imu(ImuCorrector::new(cal, rate).ok()?),
        })
    }

    /// Sets the environment.
    pub fn set_environment(&mut self, t: f32, v: f32) {
        match self {
            Self::Single(c) => c.set_environment(t, v),
            Self::Triad(c) => c.set_environment(t, v),
            Self::Imu(c) => c.set_environment(t, v),
        }
    }

    /// Corrects `raw` into `out` (as bits); returns the number of outputs and the flags, or
    /// `None` on a wrong length.
    pub fn correct(&mut self, raw: &[i32], out: &mut [u32; 6]) -> Option<(usize, u8)> {
        fn put<const N: usize>(c: Corrected<N>, out: &mut [u32; 6]) -> (usize, u8) {
            for (o, v) in out.iter_mut().zip(c.values.iter()) {
                *o = v.to_bits();
            }
            (N, c.flags.bits())
        }
        Some(match self {
            Self::Single(c) => put(c.correct(*raw.first()?), out),
            Self::Triad(c) => put(c.correct(raw.try_into().ok()?), out),
            Self::Imu(c) => put(c.correct(raw.try_into().ok()?), out),
        })
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
