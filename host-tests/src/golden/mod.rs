//! Golden vectors: checked-in blobs plus, per blob, a sequence of environments and raw samples
//! with the exact `f32` outputs (as bit patterns) and flags the correction must produce.
//!
//! The same files are checked on the host (`tests/golden.rs`) and compiled into the QEMU test
//! firmware (`firmware/build.rs`), so host and Cortex-M4F are held to the same bits.
//!
//! Vector file format, one item per line (`#` starts a comment):
//!
//! ```text
//! blob imu.blob                 the blob file, relative to the vectors file
//! kind imu 1000                 single | triad | imu <sample rate, Hz>
//! env 41c80000 40533333         temperature and voltage as f32 bits
//! raw 33109 ... => 3f8ccccd ... flags 00
//! ```

use std::path::{Path, PathBuf};

mod format;

pub use format::{ParseError, parse, render};

use spincal::correct::AnyCorrector;
use spincal::model::{Calibration, CalibrationData, Rails, SampleFormat, Sensor, Span};

/// The sensor kind of a case.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// Single axis.
    Single,
    /// Triad.
    Triad,
    /// IMU at a sample rate (Hz), with the largest angular acceleration (rad/s^2) before a
    /// rate step is flagged.
    Imu(f32, f32),
}

impl Kind {
    /// An IMU at `rate` Hz with the device's default largest angular acceleration.
    #[must_use]
    pub const fn imu(rate: f32) -> Self {
        Self::Imu(rate, spincal::correct::DEFAULT_MAX_ANGULAR_ACCELERATION)
    }
}

/// One step of a case.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Set the environment: temperature (C), voltage (V).
    Env(f32, f32),
    /// Correct a raw sample; expect these output bits and flags.
    Sample {
        /// Raw codes.
        raw: Vec<i32>,
        /// Expected outputs as `f32::to_bits`.
        expected: Vec<u32>,
        /// Expected flag bits.
        flags: u8,
        /// Expected 1-sigma calibration error of each output as `f32::to_bits`
        /// (`AnyCorrector::sigma`); empty for a calibration without covariance factors.
        sigma: Vec<u32>,
    },
}

/// A golden case: a blob and the steps run against it.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Blob file name, relative to the golden directory.
    pub blob: String,
    /// Sensor kind.
    pub kind: Kind,
    /// Steps in order.
    pub steps: Vec<Step>,
}

/// The directory with the golden files.
#[must_use]
pub fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// An example calibration.
type Example = fn() -> CalibrationData;

/// The golden cases: name, calibration, kind.
#[must_use]
pub fn examples() -> Vec<(&'static str, CalibrationData, Kind)> {
    let mut cases = vec![
        ("single", CalibrationData::example_single(), Kind::Single),
        ("triad", CalibrationData::example_triad(), Kind::Triad),
        ("imu", CalibrationData::example_imu(), Kind::imu(1000.0)),
        (
            "imu_linear",
            CalibrationData::example_imu_linear(),
            Kind::imu(1000.0),
        ),
        (
            "imu_polynomial",
            CalibrationData::example_imu_polynomial(),
            Kind::imu(1000.0),
        ),
        (
            "imu_no_lever",
            without_lever(CalibrationData::example_imu()),
            Kind::imu(1000.0),
        ),
        (
            "imu_polynomial_no_lever",
            without_lever(CalibrationData::example_imu_polynomial()),
            Kind::imu(1000.0),
        ),
        (
            SPIN_CASE,
            spin_case(),
            Kind::imu(crate::spin_rig::SAMPLE_RATE as f32),
        ),
        // The single axis and the triad in one other format each; every kernel again below.
        (
            "single_i32",
            in_format(CalibrationData::example_single(), SampleFormat::I32),
            Kind::Single,
        ),
        (
            "triad_i16",
            in_format(CalibrationData::example_triad(), SampleFormat::I16),
            Kind::Triad,
        ),
    ];
    // Every kernel again for samples delivered as `i16` and as `i32`.
    let kernels: [(Example, [&'static str; 2]); 5] = [
        (CalibrationData::example_imu, ["imu_i16", "imu_i32"]),
        (
            CalibrationData::example_imu_linear,
            ["imu_linear_i16", "imu_linear_i32"],
        ),
        (
            CalibrationData::example_imu_polynomial,
            ["imu_polynomial_i16", "imu_polynomial_i32"],
        ),
        (
            || without_lever(CalibrationData::example_imu()),
            ["imu_no_lever_i16", "imu_no_lever_i32"],
        ),
        (
            || without_lever(CalibrationData::example_imu_polynomial()),
            ["imu_polynomial_no_lever_i16", "imu_polynomial_no_lever_i32"],
        ),
    ];
    for (k, format) in [SampleFormat::I16, SampleFormat::I32]
        .into_iter()
        .enumerate()
    {
        for (data, names) in &kernels {
            cases.push((names[k], in_format(data(), format), Kind::imu(1000.0)));
        }
    }
    // Triads with windows of different sizes (the examples' are both 2^15 codes), so that a
    // 16-bit kernel testing a gyro code against the accelerometer's window shows.
    cases.push((
        "imu_narrow_gyro_i16",
        in_format(
            narrow_gyro(CalibrationData::example_imu_polynomial(), 8.0),
            SampleFormat::I16,
        ),
        Kind::imu(1000.0),
    ));
    // A gyro range so narrow that no window is safe (limit 0), which a 16-bit kernel cannot
    // express: the device runs the compiled path and flags every sample through the slow one.
    // Without the lever arm, whose state would keep the kernel from running anyway.
    cases.push((
        "imu_closed_gyro_i16",
        in_format(
            without_lever(narrow_gyro(CalibrationData::example_imu_polynomial(), 1e4)),
            SampleFormat::I16,
        ),
        Kind::imu(1000.0),
    ));
    // The lever kernels' rate-step flag: the full IMU at 1 kHz whose airframe turns at most
    // 20,000 rad/s^2 (20 rad/s between samples), so that steps between the samples, all inside
    // the calibrated range (and the kernels' windows), are flagged or not, in both formats.
    for (name, format) in [
        ("imu_rate_step", SampleFormat::U16),
        ("imu_rate_step_i32", SampleFormat::I32),
    ] {
        cases.push((
            name,
            in_format(CalibrationData::example_imu(), format),
            Kind::Imu(1000.0, 20_000.0),
        ));
    }
    // A single axis whose sets are a temperature series.
    cases.push((
        "single_series",
        CalibrationData::example_single_series(),
        Kind::Single,
    ));
    // An IMU whose sets and covariance factors are a temperature series.
    cases.push((
        "imu_series",
        CalibrationData::example_imu_series(),
        Kind::imu(1000.0),
    ));
    cases
}

/// `data` (an example on an unsigned 16-bit converter) for a converter whose codes come in
/// `format`: two's complement (every center moved down by 32768) on a 16-bit converter for
/// `i16`, on an 18-bit one for `i32`. The coefficients are per count from the center, so
/// inside the 16-bit rails the outputs are those of the unsigned example.
#[must_use]
pub fn in_format(mut data: CalibrationData, format: SampleFormat) -> CalibrationData {
    let rails = match format {
        SampleFormat::U16 => return data,
        SampleFormat::I16 => Rails::signed(16),
        SampleFormat::I32 => Rails::signed(18),
    };
    let recenter = |channels: &mut [spincal::model::Channel]| {
        for c in channels {
            c.center -= 32768.0;
        }
    };
    match &mut data.sensor {
        Sensor::Single {
            rails: r, channel, ..
        } => {
            *r = rails;
            recenter(std::slice::from_mut(channel));
        }
        Sensor::Triad {
            rails: r, channels, ..
        } => {
            *r = rails;
            recenter(channels);
        }
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            ..
        } => {
            *accel_rails = rails;
            *gyro_rails = rails;
            recenter(accel);
            recenter(gyro);
        }
    }
    data
}

/// The case of the spinning round (`spin_rig`): its calibration is `calflash`'s fit of the
/// spin-rig plan, kept in `imu_spin.blob` (written again by [`refit_spin_case`]) so that a
/// change in the fitting code does not move the device's vectors; its samples are a flight.
pub const SPIN_CASE: &str = "imu_spin";

fn spin_case() -> CalibrationData {
    let path = dir().join(format!("{SPIN_CASE}.blob"));
    match std::fs::read(&path) {
        Ok(bytes) => spincal::blob::decode(&bytes)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
            .into_data(),
        Err(_) => fit_spin_case(),
    }
}

fn fit_spin_case() -> CalibrationData {
    let truth = calflash::sim::truth::ImuTruth::spinning_round();
    crate::spin_rig::calibrate(&truth, 0x5eed, false).data
}

/// Fits the spin case's calibration again and writes its blob (when golden files are
/// accepted), once per process.
///
/// # Panics
/// When the file cannot be written.
pub fn refit_spin_case() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let path = dir().join(format!("{SPIN_CASE}.blob"));
        std::fs::write(&path, encode(&fit_spin_case()))
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    });
}

/// `data` (an IMU) with its accelerometer at the reference point: no lever arm.
fn without_lever(mut data: CalibrationData) -> CalibrationData {
    if let Sensor::Imu { lever_arm, .. } = &mut data.sensor {
        *lever_arm = None;
    }
    data
}

/// `data` (an IMU) with its gyros' calibrated range `by` times narrower, and so a smaller
/// window.
fn narrow_gyro(mut data: CalibrationData, by: f32) -> CalibrationData {
    if let Sensor::Imu { gyro, .. } = &mut data.sensor {
        for c in gyro.iter_mut() {
            c.range = Span::new(c.range.lo / by, c.range.hi / by);
        }
    }
    data
}

/// Encodes a calibration as a blob.
///
/// # Panics
/// When the data is invalid (the examples are valid).
#[must_use]
pub fn encode(data: &CalibrationData) -> Vec<u8> {
    let cal = Calibration::new(data.clone()).expect("example calibration is valid");
    let mut buf = vec![0u8; spincal::blob::MAX_BLOB_LEN];
    let n = spincal::blob::encode(&cal, &mut buf).expect("fits");
    buf.truncate(n);
    buf
}

/// A small deterministic generator (64-bit LCG), so inputs never change between runs.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) as u32
    }

    /// Uniform in `[lo, hi]`.
    fn range(&mut self, lo: i64, hi: i64) -> i32 {
        let span = (hi - lo + 1) as u64;
        (lo + (u64::from(self.next()) % span) as i64) as i32
    }
}

/// Raw inputs for one axis: mostly inside the calibrated range, then the edges and beyond.
fn axis_inputs(rails: Rails, center: f32, rng: &mut Lcg, n: usize) -> Vec<i32> {
    let c = i64::from(center.round() as i32);
    let (lo, hi) = (i64::from(rails.lo), i64::from(rails.hi));
    let mut v: Vec<i32> = (0..n)
        .map(|_| rng.range((c - 6_000).max(lo + 1), (c + 6_000).min(hi - 1)))
        .collect();
    // Codes at powers of two from the center, where the corrector's safe windows end (each is
    // `2^k` codes centred on the rounded center): a window test that lets through more than
    // its window passes some of these, which are outside the calibrated range, unflagged.
    let probes = (9..=14).flat_map(|j| [c + (1 << j), c - (1 << j) - 1]);
    let probes: Vec<i32> = probes.map(|x| x.clamp(lo, hi) as i32).collect();
    let extremes = [
        rails.lo,
        rails.hi,
        rails.lo + 1,
        rails.hi - 1,
        rails.lo.saturating_sub(7),
        rails.hi.saturating_add(1_000),
        i32::MIN,
        i32::MAX,
        rng.range(lo + 1, hi - 1),
        rng.range(lo + 1, hi - 1),
    ];
    v.extend_from_slice(&extremes);
    v.extend(probes);
    v
}

/// Environments each case is run at: the nominal point, a table edge, between breakpoints,
/// beyond the span, NaN, and between breakpoints again.
fn environments(data: &CalibrationData) -> Vec<(f32, f32)> {
    let env = &data.environment;
    let tmid = 0.5 * (env.temperature_span.lo + env.temperature_span.hi);
    let vmid = 0.5 * (env.voltage_span.lo + env.voltage_span.hi);
    vec![
        (tmid, vmid),
        (env.temperature_span.lo, env.voltage_span.hi),
        (
            37.3,
            env.voltage_span.lo + 0.37 * (env.voltage_span.hi - env.voltage_span.lo),
        ),
        (env.temperature_span.hi + 15.0, env.voltage_span.lo - 0.5),
        (f32::NAN, f32::NAN),
        // Between a temperature series' nodes (and between table breakpoints).
        (-21.7, vmid),
    ]
}

/// Raw samples for a case: per axis, `axis_inputs` shuffled across axes.
fn samples(data: &CalibrationData, rng: &mut Lcg) -> Vec<Vec<i32>> {
    let n = 14;
    let columns: Vec<Vec<i32>> = match &data.sensor {
        Sensor::Single { rails, channel, .. } => vec![axis_inputs(*rails, channel.center, rng, n)],
        Sensor::Triad {
            rails, channels, ..
        } => channels
            .iter()
            .map(|c| axis_inputs(*rails, c.center, rng, n))
            .collect(),
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            ..
        } => {
            let mut cols: Vec<Vec<i32>> = accel
                .iter()
                .map(|c| axis_inputs(*accel_rails, c.center, rng, n))
                .collect();
            cols.extend(
                gyro.iter()
                    .map(|c| axis_inputs(*gyro_rails, c.center, rng, n)),
            );
            cols
        }
    };
    let axes = columns.len();
    let extremes = columns[0].len() - n;
    let in_range = |i: usize| -> Vec<i32> { columns.iter().map(|c| c[i % n]).collect() };
    let mut rows: Vec<Vec<i32>> = (0..n).map(in_range).collect();
    // Each extreme alone on each axis, the others inside the range...
    for e in 0..extremes {
        for a in 0..axes {
            let mut row = in_range(e + a);
            row[a] = columns[a][n + e];
            rows.push(row);
        }
    }
    // ...and all axes at extremes together, rotated so each axis meets each extreme.
    for e in 0..extremes {
        rows.push(
            columns
                .iter()
                .enumerate()
                .map(|(a, c)| c[n + (e + a) % extremes])
                .collect(),
        );
    }
    rows
}

/// Runs a case's inputs through the host build of the correction and records the outputs: a
/// flight for the spin case, samples across and beyond the ranges for the others.
///
/// # Panics
/// When the data does not fit the kind.
#[must_use]
pub fn compute(name: &str, data: &CalibrationData, kind: Kind) -> Case {
    let blob = format!("{name}.blob");
    let cal = Calibration::new(data.clone()).expect("valid");
    let mut rng = Lcg(0x5eed_0000_0000_0001);
    let inputs = if name == SPIN_CASE {
        crate::spin_rig::golden_flight()
            .iter()
            .map(|s| s.raw.iter().map(|x| *x as i32).collect())
            .collect()
    } else {
        samples(data, &mut rng)
    };
    let mut steps = Vec::new();
    let mut runner = Runner::new(&cal, kind);
    for (t, v) in environments(data) {
        steps.push(Step::Env(t, v));
        runner.set_environment(t, v);
        for raw in &inputs {
            let (values, flags, sigma) = runner.correct(raw);
            steps.push(Step::Sample {
                raw: raw.clone(),
                expected: values.iter().map(|x| x.to_bits()).collect(),
                flags,
                sigma: sigma.iter().map(|x| x.to_bits()).collect(),
            });
        }
    }
    Case { blob, kind, steps }
}

/// The corrector of a case: the crate's [`AnyCorrector`] for the case's kind, of the
/// calibration's sample format (codes beyond it are clamped to it).
pub struct Runner<'a>(AnyCorrector<'a>);

impl<'a> Runner<'a> {
    /// The corrector for `kind`.
    ///
    /// # Panics
    /// When the calibration does not fit the kind.
    #[must_use]
    pub fn new(cal: &'a Calibration, kind: Kind) -> Self {
        let (rate, max_acc) = match kind {
            Kind::Imu(rate, max_acc) => (rate, max_acc),
            Kind::Single | Kind::Triad => (1000.0, 1.0),
        };
        let mut c = AnyCorrector::new(cal, rate).expect("a corrector for the case");
        c.set_max_angular_acceleration(max_acc)
            .expect("a positive largest angular acceleration");
        assert!(
            matches!(
                (&c, kind),
                (AnyCorrector::Axis(_), Kind::Single)
                    | (AnyCorrector::Triad(_), Kind::Triad)
                    | (AnyCorrector::Imu(_), Kind::Imu(..))
            ),
            "the calibration is not of the case's kind"
        );
        Self(c)
    }

    /// Sets the environment.
    pub fn set_environment(&mut self, t: f32, v: f32) {
        self.0.set_environment(t, v);
    }

    /// Corrects one sample given as a slice of the right length: its values, flags and the
    /// stated 1-sigma of each value (empty without covariance factors).
    ///
    /// # Panics
    /// On a wrong length.
    pub fn correct(&mut self, raw: &[i32]) -> (Vec<f32>, u8, Vec<f32>) {
        let c = self.0.correct(raw).expect("a sample of the case's length");
        let n = self.0.outputs();
        let sigma = self
            .0
            .sigma(raw, &c.values)
            .map_or_else(Vec::new, |s| s[..n].to_vec());
        (c.values[..n].to_vec(), c.flags.bits(), sigma)
    }
}
