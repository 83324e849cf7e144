//! Decodes the golden blobs on the Cortex-M4F, runs every golden step through the correction,
//! and compares the outputs bit for bit and the flags with the vectors computed on the host.
//! Exits 0 when everything matches, 1 otherwise (with every mismatch printed).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::blob;
use spincal::correct::{Corrected, ImuCorrector, Sample, format_of};
use spincal::health::RestMonitor;
use spincal::model::{Calibration, SampleFormat};
use spincal_firmware::{CASES, Case, HEALTH_CASES, HealthCase, Kind, Runner, Step};

/// Samples per `correct_batch` call: the steps between two environments go through in blocks
/// of this many, so the batch path meets the window edges at every position.
const BLOCK: usize = 16;

#[entry]
fn main() -> ! {
    let mut failures = 0u32;
    let mut checked = 0u32;
    for case in CASES {
        let cal = match blob::decode(case.blob) {
            Ok(cal) => cal,
            Err(e) => {
                hprintln!("FAIL {}: blob does not decode: {}", case.name, e);
                failures += 1;
                continue;
            }
        };
        let Some(mut runner) = Runner::new(&cal, case.kind) else {
            hprintln!(
                "FAIL {}: blob is not of the expected sensor kind",
                case.name
            );
            failures += 1;
            continue;
        };
        for (i, step) in case.steps.iter().enumerate() {
            match step {
                Step::Env(t, v) => runner.set_environment(*t, *v),
                Step::Sample {
                    raw,
                    expected,
                    flags,
                    sigma,
                } => {
                    checked += 1;
                    let mut out = [0u32; 6];
                    let Some((n, got_flags)) = runner.correct(raw, &mut out) else {
                        hprintln!("FAIL {} step {}: wrong sample length", case.name, i);
                        failures += 1;
                        continue;
                    };
                    let got = out.get(..n).unwrap_or_default();
                    if got != *expected || got_flags != *flags {
                        failures += 1;
                        hprintln!(
                            "FAIL {} step {}: raw {:?}: got {:08x?} flags {:02x}, expected {:08x?} flags {:02x}",
                            case.name,
                            i,
                            raw,
                            got,
                            got_flags,
                            expected,
                            flags
                        );
                    }
                    // The stated 1-sigma of the outputs, where the case holds it.
                    let mut stated = [0u32; 6];
                    let has = runner.sigma(raw, &out, &mut stated);
                    let got = if has {
                        stated.get(..n).unwrap_or_default()
                    } else {
                        &[]
                    };
                    if got != *sigma {
                        failures += 1;
                        hprintln!(
                            "FAIL {} step {}: raw {:?}: 1-sigma {:08x?}, expected {:08x?}",
                            case.name,
                            i,
                            raw,
                            got,
                            sigma
                        );
                    }
                }
            }
        }
        if let Kind::Imu(rate, max_acc) = case.kind {
            let (n, bad) = check_batch(case, &cal, (rate, max_acc));
            checked += n;
            failures += bad;
        }
        hprintln!("case {}: {} steps", case.name, case.steps.len());
    }
    for case in HEALTH_CASES {
        let (n, bad) = check_health(case);
        checked += n;
        failures += bad;
        hprintln!("case {}: {} samples", case.name, case.raw.len());
    }
    hprintln!(
        "golden: {} samples checked, {} mismatches",
        checked,
        failures
    );
    spincal_firmware::exit(failures == 0)
}

/// A block of samples `[S; 6]` placed after one `S` of padding, in a word-aligned struct: for
/// a 16-bit format the block then starts two bytes past a word boundary, which the kernels'
/// word loads must handle as well as the aligned start of `raw`.
#[repr(C, align(4))]
struct Shifted<S> {
    pad: S,
    raw: [[S; 6]; BLOCK],
}

/// Samples waiting for one `correct_batch` call, with what they must give.
struct Batch<'c, S> {
    name: &'c str,
    raw: [[S; 6]; BLOCK],
    shifted: Shifted<S>,
    expected: [(&'c [u32], u8); BLOCK],
    filled: usize,
    flushes: u32,
    checked: u32,
    failures: u32,
}

impl<'c, S: Sample> Batch<'c, S> {
    fn push(&mut self, raw: &[i32], expected: &'c [u32], flags: u8) -> bool {
        let (Some(slot), Some(shifted), Some(want), Ok(codes)) = (
            self.raw.get_mut(self.filled),
            self.shifted.raw.get_mut(self.filled),
            self.expected.get_mut(self.filled),
            <[i32; 6]>::try_from(raw),
        ) else {
            return false;
        };
        // A golden code beyond the container is beyond the rails: clamped, it saturates the
        // same way.
        *slot = codes.map(S::clamped);
        *shifted = *slot;
        *want = (expected, flags);
        self.filled += 1;
        true
    }

    /// Corrects the waiting samples, from the aligned block and the shifted one in turn.
    fn flush(&mut self, imu: &mut ImuCorrector<'_, S>) {
        let mut out = [Corrected::<6>::default(); BLOCK];
        let filled = self.filled;
        let raw = if self.flushes.is_multiple_of(2) {
            self.raw.get(..filled)
        } else {
            self.shifted.raw.get(..filled)
        }
        .unwrap_or_default();
        self.flushes += 1;
        let n = imu.correct_batch(raw, &mut out);
        for (o, (want, flags)) in out.iter().zip(&self.expected).take(n) {
            self.checked += 1;
            let got = o.values.map(f32::to_bits);
            if got.as_slice() != *want || o.flags.bits() != *flags {
                self.failures += 1;
                hprintln!(
                    "FAIL {} batch: got {:08x?} flags {:02x}, expected {:08x?} flags {:02x}",
                    self.name,
                    got,
                    o.flags.bits(),
                    want,
                    flags
                );
            }
        }
        if n != filled {
            self.failures += 1;
            hprintln!("FAIL {} batch: {} of {} corrected", self.name, n, filled);
        }
        self.filled = 0;
    }
}

/// Runs an IMU case again through `correct_batch` (the hand-scheduled Cortex-M4F kernels of
/// the calibration's sample format) and compares every output bit and flag with the vectors;
/// returns the samples checked and the mismatches.
fn check_batch(case: &Case, cal: &Calibration, rate: (f32, f32)) -> (u32, u32) {
    match format_of(cal) {
        SampleFormat::U16 => check_batch_as::<u16>(case, cal, rate),
        SampleFormat::I16 => check_batch_as::<i16>(case, cal, rate),
        SampleFormat::I32 => check_batch_as::<i32>(case, cal, rate),
    }
}

fn check_batch_as<S: Sample>(
    case: &Case,
    cal: &Calibration,
    (rate, max_acc): (f32, f32),
) -> (u32, u32) {
    let Ok(mut imu) = ImuCorrector::<S>::new(cal, rate) else {
        hprintln!("FAIL {}: no IMU corrector for the batch pass", case.name);
        return (0, 1);
    };
    if imu.set_max_angular_acceleration(max_acc).is_err() {
        hprintln!(
            "FAIL {}: the largest angular acceleration is refused",
            case.name
        );
        return (0, 1);
    }
    let zero = S::clamped(0);
    let mut batch = Batch {
        name: case.name,
        raw: [[zero; 6]; BLOCK],
        shifted: Shifted {
            pad: zero,
            raw: [[zero; 6]; BLOCK],
        },
        expected: [(&[], 0); BLOCK],
        filled: 0,
        flushes: 0,
        checked: 0,
        failures: 0,
    };
    for step in case.steps {
        match step {
            Step::Env(t, v) => {
                batch.flush(&mut imu);
                imu.set_environment(*t, *v);
            }
            Step::Sample {
                raw,
                expected,
                flags,
                ..
            } => {
                if !batch.push(raw, expected, *flags) {
                    hprintln!("FAIL {} batch: a sample is not 6 codes", case.name);
                    return (batch.checked, batch.failures + 1);
                }
                if batch.filled == BLOCK {
                    batch.flush(&mut imu);
                }
            }
        }
    }
    batch.flush(&mut imu);
    (batch.checked, batch.failures)
}

/// Runs a health case's samples through the corrector and the monitor, one `correct` at a
/// time as the device would, and compares the health after each checked sample bit for bit.
fn check_health(case: &HealthCase) -> (u32, u32) {
    let Ok(cal) = blob::decode(case.blob) else {
        hprintln!("FAIL {}: blob does not decode", case.name);
        return (0, 1);
    };
    let (Ok(mut imu), Ok(mut monitor)) = (
        ImuCorrector::<u16>::new(&cal, case.rate),
        RestMonitor::new(&cal, case.rate),
    ) else {
        hprintln!("FAIL {}: no corrector or monitor", case.name);
        return (0, 1);
    };
    imu.set_environment(25.0, 3.3);
    let mut checks = case.checks.iter().peekable();
    let mut failures = 0;
    for (i, raw) in case.raw.iter().enumerate() {
        let out = imu.correct(*raw);
        monitor.observe_rest(&mut imu, &out);
        let Some(check) = checks.next_if(|c| c.after == i) else {
            continue;
        };
        let h = monitor.health();
        let mut bits = [0u32; 14];
        for (b, x) in bits
            .iter_mut()
            .zip(h.bias.iter().chain(&h.bias_sigma).chain(&h.statistic))
        {
            *b = x.to_bits();
        }
        let verdict = h.verdict as u8;
        if bits != check.bits || verdict != check.verdict || out.flags.bits() != check.flags {
            failures += 1;
            hprintln!(
                "FAIL {} sample {}: verdict {} flags {:02x} {:08x?}, expected {} {:02x} {:08x?}",
                case.name,
                i,
                verdict,
                out.flags.bits(),
                bits,
                check.verdict,
                check.flags,
                check.bits
            );
        }
    }
    (case.raw.len() as u32, failures)
}
