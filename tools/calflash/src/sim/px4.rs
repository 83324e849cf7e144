//! PX4's thermal calibration as a reference to measure the continuous temperature model
//! against: `process_sensor_caldata.py` fits each axis' bias as a cubic in the temperature
//! (relative to a reference temperature) and keeps one scale factor. Here that model,
//! `output = b0 + b1 dT + b2 dT^2 + b3 dT^3 + s input`, is fitted by least squares (nalgebra's
//! SVD, independent of the regression engine) to the same simulated ramp as `calflash
//! calibrate`, and both are scored on held-out temperatures against the truth.

use std::path::Path;

use nalgebra::{DMatrix, DVector};
use spincal::correct::AnyAxisCorrector;
use spincal::model::Quantity;

use super::ramp::Ramp;
use super::truth::SingleTruth;
use super::{Sensor, plan};
use crate::sensor::{Options, WorkflowError, single};

/// Why one seed of the comparison could not be run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// PX4's least-squares problem has no solution.
    #[error("PX4's fit has no solution: {0}")]
    Px4Fit(&'static str),
    /// The scenario's plan cannot be read.
    #[error(transparent)]
    Plan(#[from] plan::PlanError),
    /// The simulator wrote no temperature column.
    #[error("no temp column")]
    NoTemperature,
    /// The simulated ramp could not be written.
    #[error("{}: {source}", path.display())]
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// `calflash calibrate`'s workflow failed on the ramp.
    #[error(transparent)]
    Calibrate(#[from] WorkflowError),
    /// The ramp was calibrated without a continuous temperature model.
    #[error("the ramp was not fitted with a continuous temperature model")]
    NotContinuous,
    /// The blob or the device's corrector refused the calibration.
    #[error(transparent)]
    Device(#[from] spincal::Error),
}

/// PX4's model of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Px4 {
    /// Reference temperature (the middle of the calibrated range), C.
    pub t_ref: f64,
    /// Half the calibrated span, C (the polynomial is in `(T - t_ref) / half`).
    pub half: f64,
    /// The bias polynomial, counts.
    pub bias: [f64; 4],
    /// Counts per input unit.
    pub scale: f64,
}

impl Px4 {
    /// Fits PX4's model to observations.
    ///
    /// # Errors
    /// When the least-squares problem has no solution (fewer than 5 distinct observations).
    pub fn fit(input: &[f64], output: &[f64], temp: &[f64]) -> Result<Self, Error> {
        let lo = temp.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = temp.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (t_ref, half) = (0.5 * (lo + hi), (0.5 * (hi - lo)).max(1e-9));
        let x = DMatrix::from_fn(input.len(), 5, |i, j| match j {
            4 => input[i],
            k => ((temp[i] - t_ref) / half).powi(k as i32),
        });
        let b = x
            .svd(true, true)
            .solve(&DVector::from_column_slice(output), 1e-12)
            .map_err(Error::Px4Fit)?;
        Ok(Self {
            t_ref,
            half,
            bias: [b[0], b[1], b[2], b[3]],
            scale: b[4],
        })
    }

    /// The corrected input for output `out` at temperature `t`.
    #[must_use]
    pub fn correct(&self, out: f64, t: f64) -> f64 {
        let d = (t - self.t_ref) / self.half;
        let bias = self.bias[0] + d * (self.bias[1] + d * (self.bias[2] + d * self.bias[3]));
        (out - bias) / self.scale
    }
}

/// A simulated thermal calibration: a unit, a plan cycled through a ramp.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Its name in the table.
    pub name: &'static str,
    /// The unit.
    pub truth: SingleTruth,
    /// The chamber.
    pub ramp: Ramp,
    /// Observations: `head:16` repeated this many times.
    pub repeat: usize,
}

/// RMS errors of the corrected input against the truth on held-out temperatures, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// `calflash calibrate`'s continuous model, in f64.
    pub model: f64,
    /// The device (the blob's table, the host build of the firmware's correction).
    pub device: f64,
    /// PX4's model.
    pub px4: f64,
}

/// What calflash is told of the sensor's model.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Told<'a> {
    /// The model to fit instead of the preset.
    pub model: Option<&'a str>,
    /// Whether an asymmetric scale is left out instead of tested.
    pub no_asymmetry: bool,
}

/// Runs one seed of a scenario: simulates the ramp into `dir`, calibrates it with `calflash
/// calibrate`'s single-axis workflow (its preset, or what it is `told`) and with PX4's model,
/// and scores both on 37 temperatures between the observations' and 21 inputs over +-1 g, at
/// the unit's true temperature.
///
/// # Errors
/// A calibration that fails, in words.
pub fn run(s: &Scenario, seed: u64, dir: &Path, told: Told<'_>) -> Result<Errors, Error> {
    let conditions = plan::plan(
        &["head:16".into()],
        &[25.0],
        &[s.truth.ref_volt],
        s.repeat,
        true,
    )?;
    let (conditions, temps) = super::ramp::run(&s.ramp, &conditions);
    let sensor = Sensor::Single {
        gyro: false,
        truth: s.truth.clone(),
    };
    let mut obs = super::simulate(&sensor, &conditions, seed, false);
    let ti = obs
        .names
        .iter()
        .position(|n| n == crate::columns::TEMP)
        .ok_or(Error::NoTemperature)?;
    for (row, t) in obs.rows.iter_mut().zip(&temps.reported) {
        row[ti] = *t;
    }
    let path = dir.join(format!("ramp-{seed}.csv"));
    let mut buf = Vec::new();
    obs.write_csv(&mut buf)
        .and_then(|()| std::fs::write(&path, buf))
        .map_err(|source| Error::Write {
            path: path.clone(),
            source,
        })?;
    let mut opts = Options::new(&path, "PX4CMP");
    opts.created = Some(0);
    opts.model = told.model.map(String::from);
    if told.no_asymmetry {
        opts.asymmetry = Some(false);
    }
    let c = single::calibrate(&opts, Quantity::Acceleration)?;
    let _ = std::fs::remove_file(&path);
    let tf = c.thermal.first().ok_or(Error::NotContinuous)?;
    let col = |n: &str| obs.column(n).unwrap_or_default();
    let px4 = Px4::fit(
        &col(crate::columns::INPUT),
        &col(crate::columns::OUTPUT),
        &temps.reported,
    )?;
    let cal = spincal::blob::decode(&c.blob)?;
    let mut device = AnyAxisCorrector::new(&cal)?;
    let (lo, hi) = (tf.scale.lo, tf.scale.hi);
    let mut sums = [0.0f64; 3];
    let mut n = 0.0;
    for k in 0..37 {
        let t = lo + (hi - lo) * (f64::from(k) + 0.5) / 37.0;
        let own =
            single::coefficients::own_of(&tf.base.term_names(), &tf.coefficients_at(t).0, 0.0);
        device.set_environment(t as f32, s.truth.ref_volt as f32);
        for i in 0..=20 {
            let x = plan::G * (f64::from(i) / 10.0 - 1.0);
            let code = s
                .truth
                .output(x, 0.0, 0.0, t, s.truth.ref_volt, 0.0)
                .round();
            let truth = s.truth.input(code, t, s.truth.ref_volt);
            let model = own.input_for(code, (code - own.bias) / own.slope);
            let dev = f64::from(device.correct(code as i32).values[0]);
            for (sum, e) in
                sums.iter_mut()
                    .zip([model - truth, dev - truth, px4.correct(code, t) - truth])
            {
                *sum += e * e;
            }
            n += 1.0;
        }
    }
    Ok(Errors {
        model: (sums[0] / n).sqrt(),
        device: (sums[1] / n).sqrt(),
        px4: (sums[2] / n).sqrt(),
    })
}

/// The comparison's scenarios: a unit whose bias is PX4's cubic and whose scale does not
/// drift; a unit whose bias has a tanh-like step and whose scale drifts; that unit with its
/// temperature read in whole degrees, behind an uneven ramp, and lagging the chamber with
/// self-heating. Each is 400 observations over -40 to 70 C in two hours.
#[must_use]
pub fn scenarios() -> Vec<Scenario> {
    let linear = SingleTruth {
        k2: 0.0,
        k3: 0.0,
        kp: 0.0,
        ko: 0.0,
        ..SingleTruth::default()
    };
    let cubic = SingleTruth {
        k0_temp: 0.6,
        k0_temp2: -0.01,
        k0_temp3: 2e-4,
        k1_temp: 0.0,
        ..linear.clone()
    };
    let tanh = SingleTruth {
        k0_temp: 0.3,
        k0_tanh: 25.0,
        k1_temp: 80e-6,
        k1_tanh: 1.5e-3,
        tanh_center: 10.0,
        tanh_width: 12.0,
        ..linear
    };
    let ramp = Ramp::even(-40.0, 70.0, 7200.0);
    let one = |name, truth: &SingleTruth, ramp| Scenario {
        name,
        truth: truth.clone(),
        ramp,
        repeat: 25,
    };
    vec![
        one("cubic bias, constant scale", &cubic, ramp),
        one("tanh bias, drifting scale", &tanh, ramp),
        one(
            "tanh, temperature in whole degrees",
            &tanh,
            Ramp {
                step: Some(1.0),
                ..ramp
            },
        ),
        one(
            "tanh, uneven ramp",
            &tanh,
            Ramp {
                uneven: true,
                ..ramp
            },
        ),
        one(
            "tanh, 120 s lag and 3 C self-heating",
            &tanh,
            Ramp {
                lag: 120.0,
                self_heating: Some((3.0, 300.0)),
                ..ramp
            },
        ),
    ]
}
