//! Decodes the golden blobs on the Cortex-M4F, runs every golden step through the correction,
//! and compares the outputs bit for bit and the flags with the vectors computed on the host.
//! Exits 0 when everything matches, 1 otherwise (with every mismatch printed).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use spincal::blob;
use spincal_firmware::{CASES, Runner, Step};

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
                }
            }
        }
        hprintln!("case {}: {} steps", case.name, case.steps.len());
    }
    hprintln!(
        "golden: {} samples checked, {} mismatches",
        checked,
        failures
    );
    spincal_firmware::exit(failures == 0)
}
