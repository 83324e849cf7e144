//! A calibration of an assembled unit held against its truth over the operating range: the
//! error of the calibration's forward model (its prediction of each output, over the true
//! slope: an error in the input's unit) and the device's stated 1-sigma there. Shared by the
//! two-stage Monte Carlos on our simulator's units and on the independent forward model's.

use calflash::sensor::Calibrated;

/// An input to the assembled unit: specific force at the reference point (m/s^2) and rate
/// (rad/s), unit axes.
#[derive(Clone, Copy, Debug)]
pub struct Input {
    pub f: [f64; 3],
    pub w: [f64; 3],
}

/// What a calibration's forward model predicts (counts) for output `k` at `input`.
pub fn predicted(fit: &calflash::stats::Fit, k: usize, input: &Input) -> f64 {
    let coef = |n: &str| {
        fit.names
            .iter()
            .position(|m| m == n)
            .map_or(0.0, |i| fit.coefficients[i])
    };
    const FORCES: [&str; 3] = ["f_x", "f_y", "f_z"];
    let (inputs, values) = if k < 3 {
        (FORCES, input.f)
    } else {
        (["w_x", "w_y", "w_z"], input.w)
    };
    let mut z: f64 = (0..3).map(|j| coef(inputs[j]) * values[j]).sum();
    if k >= 3 {
        z += (0..3).map(|j| coef(FORCES[j]) * input.f[j]).sum::<f64>();
    }
    let x = z / coef(inputs[k % 3]);
    let feature = |n: &str| -> f64 {
        match n {
            "1" => 1.0,
            "sensed^2" => x * x,
            "sensed^3" => x * x * x,
            "sensed:abs(sensed)" => x * x.abs(),
            "sensed_kink" => x.abs(),
            n if n.starts_with("lever_") => 0.0,
            n => match inputs.iter().position(|m| *m == n) {
                Some(j) => values[j],
                None => FORCES
                    .iter()
                    .position(|m| *m == n)
                    .map_or(0.0, |j| input.f[j]),
            },
        }
    };
    fit.names
        .iter()
        .zip(&fit.coefficients)
        .map(|(n, b)| b * feature(n))
        .sum()
}

/// Per output family (accelerometers, gyros): the sum of squared errors (SI) and their count;
/// how many errors fall inside 1.96 stated sigma; at zero input, the sum of squared errors over
/// the stated 1-sigma and their count.
#[derive(Default, Clone, Copy)]
pub struct Score {
    pub sq: [f64; 2],
    pub n: [usize; 2],
    pub inside: [usize; 2],
    pub z0: [f64; 2],
    pub n0: [usize; 2],
    /// The sum of the squared stated 1-sigma over the range, per family.
    pub stated: [f64; 2],
    /// The sum of the squared errors over their stated 1-sigma over the range, per family.
    pub zz: [f64; 2],
}

/// The unit's truth: its six noise-free outputs (counts) at an input and a temperature, and
/// each output's true slope there (counts per SI unit).
pub trait Truth {
    fn outputs(&self, input: &Input, temp: f64) -> [f64; 6];
    fn slope(&self, k: usize, temp: f64) -> f64;
}

/// `c` against `truth` at each of its temperature points: the accelerometers over `accel`, the
/// gyros over `gyro`, and every output at zero input.
pub fn score(c: &Calibrated, truth: &impl Truth, accel: &[Input], gyro: &[Input]) -> Score {
    let mut s = Score::default();
    let cal = spincal::blob::decode(&c.blob).unwrap();
    let mut device = spincal::correct::AnyImuCorrector::new(&cal, 1000.0).unwrap();
    let zero = Input {
        f: [0.0; 3],
        w: [0.0; 3],
    };
    for point in &c.points {
        let t = point.temp.unwrap_or(25.0);
        device.set_environment(t as f32, 3.3);
        let stated = device.sigma(&[0.0; 6]).unwrap();
        let outputs = truth.outputs(&zero, t);
        for (k, sigma) in stated.iter().enumerate() {
            let err = (predicted(&point.axes[k].fit, k, &zero) - outputs[k]) / truth.slope(k, t);
            let family = usize::from(k >= 3);
            s.z0[family] += (err / f64::from(*sigma)).powi(2);
            s.n0[family] += 1;
        }
        for k in 0..6 {
            let family = usize::from(k >= 3);
            for input in if k < 3 { accel } else { gyro } {
                let err = (predicted(&point.axes[k].fit, k, input) - truth.outputs(input, t)[k])
                    / truth.slope(k, t);
                let values: [f32; 6] = std::array::from_fn(|j| {
                    (if j < 3 { input.f[j] } else { input.w[j - 3] }) as f32
                });
                let stated = f64::from(device.sigma(&values).unwrap()[k]);
                s.sq[family] += err * err;
                s.stated[family] += stated * stated;
                s.zz[family] += (err / stated).powi(2);
                s.n[family] += 1;
                s.inside[family] += usize::from(err.abs() <= 1.96 * stated);
            }
        }
    }
    s
}

/// Pooled over units, per family: RMS error, the share of errors inside the device's 95 %
/// intervals, and the RMS of the error over the stated 1-sigma at zero input.
pub fn rms(scores: &[Score], family: usize) -> f64 {
    let sq: f64 = scores.iter().map(|s| s.sq[family]).sum();
    let n: usize = scores.iter().map(|s| s.n[family]).sum();
    (sq / n as f64).sqrt()
}

/// Pooled over units, per family: the RMS of the device's stated 1-sigma over the range (what
/// the calibration says its error is).
pub fn stated_rms(scores: &[Score], family: usize) -> f64 {
    let sq: f64 = scores.iter().map(|s| s.stated[family]).sum();
    let n: usize = scores.iter().map(|s| s.n[family]).sum();
    (sq / n as f64).sqrt()
}

pub fn coverage(scores: &[Score], family: usize) -> f64 {
    scores.iter().map(|s| s.inside[family]).sum::<usize>() as f64
        / scores.iter().map(|s| s.n[family]).sum::<usize>() as f64
}

/// Both families together.
pub fn coverage_all(scores: &[Score]) -> f64 {
    scores
        .iter()
        .map(|s| s.inside[0] + s.inside[1])
        .sum::<usize>() as f64
        / scores.iter().map(|s| s.n[0] + s.n[1]).sum::<usize>() as f64
}

pub fn z0(scores: &[Score], family: usize) -> f64 {
    (scores.iter().map(|s| s.z0[family]).sum::<f64>()
        / scores.iter().map(|s| s.n0[family]).sum::<usize>() as f64)
        .sqrt()
}

/// Pooled over units, per family: the RMS of the error over its stated 1-sigma over the range.
#[allow(dead_code)] // the independent model's test only
pub fn z_rms(scores: &[Score], family: usize) -> f64 {
    (scores.iter().map(|s| s.zz[family]).sum::<f64>()
        / scores.iter().map(|s| s.n[family]).sum::<usize>() as f64)
        .sqrt()
}
