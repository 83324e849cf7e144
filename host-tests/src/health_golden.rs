//! Golden vectors of the health check: raw samples of a simulated unit at rest and being
//! handled ([`calflash::sim::rest`]), and the health the device must report at checkpoints along
//! them, bit for bit. Checked on the host (`tests/golden.rs`) and on the Cortex-M4F
//! (`firmware/src/bin/golden.rs`, built in by `firmware/build.rs`).
//!
//! File format, one item per line (`#` starts a comment):
//!
//! ```text
//! blob imu.blob                   the calibration, relative to the vectors file
//! rate 1000                       sample rate, Hz (the environment is 25 C, 3.3 V)
//! raw 33109 ...                   one raw sample (six codes)
//! check <verdict> <flags> <bias x6> <sigma x6> <statistic x2>   f32 as bits, after the
//!                                 sample before it
//! ```

use std::fmt::Write as _;

use spincal::correct::{Corrected, ImuCorrector};
use spincal::health::{Health, RestMonitor};
use spincal::model::{Calibration, CalibrationData};

use calflash::sim::rest::{Unit, face};

/// What the device must report after a sample: verdict, that sample's flags, refined biases,
/// their 1-sigma and the two statistics, as bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Check {
    /// `Verdict as u8`.
    pub verdict: u8,
    /// The sample's flag bits.
    pub flags: u8,
    /// `Health::bias`, bits.
    pub bias: [u32; 6],
    /// `Health::bias_sigma`, bits.
    pub sigma: [u32; 6],
    /// `Health::statistic`, bits.
    pub statistic: [u32; 2],
}

impl Check {
    /// The check of `health` after a sample flagged `flags`.
    #[must_use]
    pub fn of(health: &Health, flags: u8) -> Self {
        Self {
            verdict: health.verdict as u8,
            flags,
            bias: health.bias.map(f32::to_bits),
            sigma: health.bias_sigma.map(f32::to_bits),
            statistic: health.statistic.map(f32::to_bits),
        }
    }
}

/// One step: a raw sample, and the check after it, if any.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Step {
    /// The six codes.
    pub raw: [u16; 6],
    /// What the device must report after it.
    pub check: Option<Check>,
}

/// A health golden case.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Blob file name, relative to the golden directory.
    pub blob: String,
    /// Sample rate, Hz.
    pub rate: f32,
    /// The steps.
    pub steps: Vec<Step>,
}

/// Samples between two checks.
pub const CHECK_EVERY: usize = 256;

/// The cases: name and the unit's bias shift in stated 1-sigmas `[ax .. wz]`. `health_drifted`
/// rests, is turned, rests again (DRIFTED, the overlay applied and refreshed);
/// `health_suspect` rests with a gyro 6 sigma off (SUSPECT, every sample flagged).
#[must_use]
pub fn cases() -> Vec<(&'static str, [f64; 6])> {
    vec![
        ("health_drifted", [0.0, 0.0, 4.5, 4.5, 0.0, 0.0]),
        ("health_suspect", [0.0, 0.0, 0.0, 0.0, -6.0, 0.0]),
    ]
}

/// Computes the case: simulates the unit, runs the monitor, records checks.
///
/// # Panics
/// When the example IMU does not validate.
#[must_use]
pub fn compute(name: &str, shift_sigmas: [f64; 6]) -> Case {
    let cal = Calibration::new(CalibrationData::example_imu()).expect("example validates");
    let rate = 1000.0;
    let sigma = calflash::sim::rest::stated_sigma(&cal).expect("covariance");
    let shift: [f64; 6] = std::array::from_fn(|i| shift_sigmas[i] * sigma[i]);
    let seed = name.bytes().map(u64::from).sum();
    let mut unit = Unit::new(&cal, rate, shift, 9.81, seed);
    unit.recording = Some(Vec::new());
    let mut ignore = |_: &mut ImuCorrector<'_, u16>, _: &Corrected<6>| {};
    let (a, b) = (face(2, 1.0, 0.3), face(0, -1.0, 0.5));
    if name == "health_drifted" {
        unit.rest(&a, 2.0, &mut ignore)
            .expect("the golden unit is within its converter's range");
        unit.turn(&a, &b, &mut ignore)
            .expect("the golden unit is within its converter's range");
        unit.rest(&b, 2.0, &mut ignore)
            .expect("the golden unit is within its converter's range");
    } else {
        unit.rest(&a, 1.5, &mut ignore)
            .expect("the golden unit is within its converter's range");
    }
    let raw = unit.recording.take().unwrap_or_default();
    Case {
        blob: "imu.blob".to_string(),
        rate: rate as f32,
        steps: run(&cal, rate as f32, &raw),
    }
}

/// Runs the device's corrector and monitor over `raw`, checking every [`CHECK_EVERY`]
/// samples and at the last.
///
/// # Panics
/// When `cal` is not an IMU with noise terms and covariance.
#[must_use]
pub fn run(cal: &Calibration, rate: f32, raw: &[[u16; 6]]) -> Vec<Step> {
    let mut imu = ImuCorrector::<u16>::new(cal, rate).expect("an IMU");
    imu.set_environment(25.0, 3.3);
    let mut monitor = RestMonitor::new(cal, rate).expect("health check");
    raw.iter()
        .enumerate()
        .map(|(i, r)| {
            let out = imu.correct(*r);
            monitor.observe_rest(&mut imu, &out);
            let due = (i + 1) % CHECK_EVERY == 0 || i + 1 == raw.len();
            Step {
                raw: *r,
                check: due.then(|| Check::of(&monitor.health(), out.flags.bits())),
            }
        })
        .collect()
}

/// The case as text.
#[must_use]
pub fn render(case: &Case) -> String {
    let mut s = String::from(
        "# spincal health golden vectors: regenerate with SPINCAL_ACCEPT=1 cargo test -p host-tests --test golden\n",
    );
    writeln!(s, "blob {}", case.blob).unwrap();
    writeln!(s, "rate {}", case.rate).unwrap();
    for step in &case.steps {
        let [a, b, c, d, e, f] = step.raw;
        writeln!(s, "raw {a} {b} {c} {d} {e} {f}").unwrap();
        if let Some(k) = &step.check {
            write!(s, "check {} {:02x}", k.verdict, k.flags).unwrap();
            for x in k.bias.iter().chain(&k.sigma).chain(&k.statistic) {
                write!(s, " {x:08x}").unwrap();
            }
            s.push('\n');
        }
    }
    s
}

/// Parses a case.
///
/// # Errors
/// The line and what was wrong with it.
pub fn parse(text: &str) -> Result<Case, String> {
    let mut case = Case {
        blob: String::new(),
        rate: 0.0,
        steps: Vec::new(),
    };
    for (n, line) in text.lines().enumerate() {
        let at = |what: &str| format!("line {}: {what}", n + 1);
        let line = line.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        match words.next() {
            None => {}
            Some("blob") => case.blob = words.next().ok_or_else(|| at("blob needs a file"))?.into(),
            Some("rate") => {
                case.rate = words
                    .next()
                    .and_then(|w| w.parse().ok())
                    .ok_or_else(|| at("rate needs a number"))?;
            }
            Some("raw") => {
                let codes: Vec<u16> = words
                    .map(|w| w.parse().map_err(|_| at("a code is not a u16")))
                    .collect::<Result<_, _>>()?;
                let raw = codes.try_into().map_err(|_| at("raw needs six codes"))?;
                case.steps.push(Step { raw, check: None });
            }
            Some("check") => {
                let verdict = words.next().and_then(|w| w.parse().ok());
                let flags = words.next().and_then(|w| u8::from_str_radix(w, 16).ok());
                let bits: Vec<u32> = words
                    .map(|w| u32::from_str_radix(w, 16).map_err(|_| at("bits are not hex")))
                    .collect::<Result<_, _>>()?;
                let (Some(verdict), Some(flags), 14) = (verdict, flags, bits.len()) else {
                    return Err(at("check needs a verdict, flags and 14 values"));
                };
                let word = |i: usize| bits[i];
                let step = case
                    .steps
                    .last_mut()
                    .ok_or_else(|| at("a check before any sample"))?;
                step.check = Some(Check {
                    verdict,
                    flags,
                    bias: std::array::from_fn(word),
                    sigma: std::array::from_fn(|i| word(6 + i)),
                    statistic: [word(12), word(13)],
                });
            }
            Some(other) => return Err(at(&format!("unknown item {other:?}"))),
        }
    }
    Ok(case)
}
