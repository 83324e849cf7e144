//! A unit at rest and being handled, as raw codes of its calibration's device correction
//! (`calflash simulate --rest`, and the input of the health check's tests and golden vectors).
//!
//! The unit's true outputs at rest are the specific force `R' (0, 0, g)` and Earth's rate in
//! its body frame, plus its bias errors against the stored calibration and white noise of the
//! stored densities. Raw codes come from inverting the corrector locally (its Jacobian by
//! central differences about the pose's codes, two Newton steps) and rounding, so the
//! quantisation is the converter's. Between rest poses the unit turns about a fixed axis at a
//! constant rate for one second.

use nalgebra::{Matrix6, Rotation3, Vector3, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use spincal::correct::{Corrected, ImuCorrector};
use spincal::model::Calibration;

/// Accelerometer features at rest ([`spincal::correct::REST_FEATURES`]).
const REST: usize = spincal::correct::REST_FEATURES.len();
/// Earth's rate, rad/s.
const EARTH_RATE: f64 = 7.292_115e-5;

/// A simulated unit.
pub struct Unit<'a> {
    /// Its corrector (the device's).
    pub imu: ImuCorrector<'a, u16>,
    /// The factory correction, which the raw codes invert (the device's may carry an overlay).
    factory: ImuCorrector<'a, u16>,
    rate: f64,
    /// Bias errors against the stored calibration, `[ax .. wz]`.
    pub bias: [f64; 6],
    /// Per accelerometer axis, its parameters' error over the features at rest
    /// ([`ImuCorrector::accel_rest_features`]): the pose-dependent part of a unit's own
    /// calibration error (zero unless [`Unit::with_accel_error`]).
    pub accel_error: [[f64; REST]; 3],
    /// The magnitude of gravity where it rests.
    pub gravity: f64,
    white: [f64; 6],
    rng: ChaCha8Rng,
    normal: Normal<f64>,
    /// Earth's rate in the local level frame (x north, z up), rad/s.
    earth: Vector3<f64>,
    /// When set, every raw sample is recorded here.
    pub recording: Option<Vec<[u16; 6]>>,
}

/// The rest pose with body axis `axis` (0..3) up (`sign` +1) or down (-1), turned by `roll`
/// about it.
#[must_use]
pub fn face(axis: usize, sign: f64, roll: f64) -> Rotation3<f64> {
    let up = Vector3::z();
    let body = Vector3::ith(axis, sign);
    let tilt = Rotation3::rotation_between(&body, &up)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
    Rotation3::from_axis_angle(&Vector3::z_axis(), roll) * tilt
}

impl<'a> Unit<'a> {
    /// A unit of calibration `cal` sampled at `rate` Hz at 25 C and 3.3 V, with bias errors
    /// `bias`, resting where gravity is `gravity`, its noise drawn from `seed`.
    ///
    /// # Panics
    /// When `cal` is not an IMU with noise terms.
    #[must_use]
    pub fn new(cal: &'a Calibration, rate: f64, bias: [f64; 6], gravity: f64, seed: u64) -> Self {
        let mut imu = ImuCorrector::new(cal, rate as f32).expect("an IMU calibration");
        imu.set_environment(TEMPERATURE as f32, 3.3);
        let noise = cal.data().noise.expect("noise terms");
        let latitude = 45f64.to_radians();
        Self {
            factory: imu.clone(),
            imu,
            rate,
            bias,
            accel_error: [[0.0; REST]; 3],
            gravity,
            white: noise.white.map(|d| f64::from(d) * rate.sqrt()),
            rng: ChaCha8Rng::seed_from_u64(seed),
            normal: Normal::new(0.0, 1.0).expect("unit normal"),
            earth: Vector3::new(latitude.cos(), 0.0, latitude.sin()) * EARTH_RATE,
            recording: None,
        }
    }

    /// This unit carrying the accelerometer calibration error `theta` (per axis, over the
    /// features at rest): its error then depends on the pose, as a real unit's does.
    #[must_use]
    pub fn with_accel_error(mut self, theta: [[f64; REST]; 3]) -> Self {
        self.accel_error = theta;
        self
    }

    /// Draws an accelerometer calibration error from the stated covariance of `cal`
    /// ([`ImuCorrector::accel_rest_covariance`] at 25 C, 3.3 V): what a unit whose
    /// calibration is as good as it states carries.
    ///
    /// # Panics
    /// When `cal` is not an IMU with covariance factors.
    pub fn draw_accel_error(&mut self, cal: &Calibration) -> [[f64; REST]; 3] {
        let mut imu = ImuCorrector::<u16>::new(cal, 1000.0).expect("an IMU calibration");
        imu.set_environment(TEMPERATURE as f32, 3.3);
        let blocks = imu.accel_rest_covariance().expect("covariance factors");
        std::array::from_fn(|axis| {
            // The packed upper triangle, row by row.
            let c = nalgebra::DMatrix::from_fn(REST, REST, |i, j| {
                let (a, b) = (i.min(j), i.max(j));
                let k = a * REST - a * (a.saturating_sub(1)) / 2 + (b - a);
                f64::from(blocks[axis][k])
            });
            // A covariance that is only semi-definite (an unobserved feature) draws nothing
            // along its null space.
            let eig = c.symmetric_eigen();
            let z = nalgebra::DVector::from_fn(REST, |i, _| {
                eig.eigenvalues[i].max(0.0).sqrt() * self.normal.sample(&mut self.rng)
            });
            let theta = eig.eigenvectors * z;
            std::array::from_fn(|i| theta[i])
        })
    }

    /// The true outputs (before noise) with attitude `pose` (body to level) turning at
    /// `w_body`.
    pub(crate) fn truth(&self, pose: &Rotation3<f64>, w_body: &Vector3<f64>) -> Vector6<f64> {
        let f = pose.inverse() * Vector3::new(0.0, 0.0, self.gravity);
        let w = pose.inverse() * self.earth + w_body;
        let error = self.accel_error(&[f[0], f[1], f[2]]);
        Vector6::from_fn(|i, _| {
            let v = if i < 3 { f[i] + error[i] } else { w[i - 3] };
            v + self.bias[i]
        })
    }

    /// The accelerometer's pose-dependent error under the specific force `f`.
    #[must_use]
    pub fn accel_error(&self, f: &[f64; 3]) -> [f64; 3] {
        let features = self.factory.accel_rest_features(&f.map(|x| x as f32));
        std::array::from_fn(|i| {
            features[i]
                .iter()
                .zip(&self.accel_error[i])
                .map(|(x, t)| f64::from(*x) * t)
                .sum()
        })
    }

    /// Corrects raw codes with a copy of the corrector (no state kept, no rate derivative).
    fn probe(&self, raw: &[f64; 6]) -> Vector6<f64> {
        let mut imu = self.factory.clone();
        imu.reset();
        let codes = raw.map(|r| r.round().clamp(1.0, 65_534.0) as u16);
        let out = imu.correct(codes);
        Vector6::from_fn(|i, _| f64::from(out.values[i]))
    }

    /// The codes whose correction is `target`, and the inverse Jacobian there.
    ///
    /// # Errors
    /// [`RestError::Unreachable`] when no codes within the converter's range correct to
    /// `target` (a bias shifted or aged beyond what the codes express): the output furthest
    /// from it is named.
    pub(crate) fn invert(
        &self,
        target: &Vector6<f64>,
    ) -> Result<([f64; 6], Matrix6<f64>), RestError> {
        let mut raw = [32_768.0; 6];
        let mut jinv = Matrix6::identity();
        let unreachable = |y: &Vector6<f64>| {
            let (i, _) = (target - y).abs().argmax();
            RestError::Unreachable {
                output: OUTPUTS[i],
                value: target[i],
            }
        };
        for _ in 0..3 {
            raw = raw.map(f64::round);
            let y0 = self.probe(&raw);
            let mut j = Matrix6::zeros();
            for c in 0..6 {
                let (mut up, mut down) = (raw, raw);
                up[c] += 64.0;
                down[c] -= 64.0;
                let d = (self.probe(&up) - self.probe(&down)) / 128.0;
                j.set_column(c, &d);
            }
            jinv = j.try_inverse().ok_or_else(|| unreachable(&y0))?;
            let step = jinv * (target - y0);
            for (r, s) in raw.iter_mut().zip(step.iter()) {
                *r += s;
            }
        }
        // Within a few codes of the target, and inside the rails.
        let y = self.probe(&raw);
        let off = jinv * (target - y);
        if raw.iter().any(|r| !(1.0..=65_534.0).contains(r)) || off.amax() > 4.0 {
            return Err(unreachable(&y));
        }
        Ok((raw, jinv))
    }

    /// One sample with the true outputs `truth` (codes `raw` there, inverse Jacobian `jinv`).
    fn sample(&mut self, raw: &[f64; 6], jinv: &Matrix6<f64>) -> Corrected<6> {
        let noise = Vector6::from_fn(|i, _| self.white[i] * self.normal.sample(&mut self.rng));
        let dr = jinv * noise;
        let codes: [u16; 6] =
            std::array::from_fn(|i| (raw[i] + dr[i]).round().clamp(0.0, 65_535.0) as u16);
        if let Some(r) = &mut self.recording {
            r.push(codes);
        }
        self.imu.correct(codes)
    }

    /// `seconds` at rest in `pose`; `each` sees every corrected sample and the corrector.
    pub fn rest(
        &mut self,
        pose: &Rotation3<f64>,
        seconds: f64,
        each: &mut dyn FnMut(&mut ImuCorrector<'a, u16>, &Corrected<6>),
    ) -> Result<(), RestError> {
        let (raw, jinv) = self.invert(&self.truth(pose, &Vector3::zeros()))?;
        for _ in 0..(seconds * self.rate).round() as usize {
            let out = self.sample(&raw, &jinv);
            each(&mut self.imu, &out);
        }
        Ok(())
    }

    /// One second turning from `from` to `to` about a fixed axis at a constant rate.
    pub fn turn(
        &mut self,
        from: &Rotation3<f64>,
        to: &Rotation3<f64>,
        each: &mut dyn FnMut(&mut ImuCorrector<'a, u16>, &Corrected<6>),
    ) -> Result<(), RestError> {
        let delta = from.inverse() * to;
        let (axis, angle) = delta.axis_angle().unwrap_or((Vector3::x_axis(), 0.0));
        let n = self.rate.round() as usize;
        let w_body = axis.into_inner() * angle;
        // Re-linearised every 16 samples: the pose moves by at most 0.2 rad in between.
        for k in (0..n).step_by(16) {
            let t = (k as f64 + 8.0) / n as f64;
            let pose = from * Rotation3::from_axis_angle(&axis, angle * t);
            let (raw, jinv) = self.invert(&self.truth(&pose, &w_body))?;
            for _ in 0..16.min(n - k) {
                let out = self.sample(&raw, &jinv);
                each(&mut self.imu, &out);
            }
        }
        Ok(())
    }

    /// Draws `sigma * N(0, 1)`.
    pub fn normal(&mut self, sigma: f64) -> f64 {
        sigma * self.normal.sample(&mut self.rng)
    }
}

/// A session of a unit at rest and handled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Session {
    /// Samples per second.
    pub rate: f64,
    /// How far each bias is off the calibration, in its stated 1-sigma at rest.
    pub shift_sigmas: [f64; 6],
    /// Rest poses (faces up in turn: z, x, -y, -z, -x, y, ..., each rolled).
    pub poses: usize,
    /// Seconds at rest in each.
    pub hold: f64,
    /// Seconds of ageing before the session: each bias has also wandered by its stored random
    /// walk over them (a draw of `K sqrt(t)`).
    pub aged_s: f64,
    /// The noise's seed.
    pub seed: u64,
}

/// A calibration a unit at rest cannot be simulated from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RestError {
    /// The IMU corrector refuses it (not an IMU, say).
    #[error(transparent)]
    Corrector(#[from] spincal::Error),
    /// No covariance factors.
    #[error("the calibration has no covariance factors, so it states no 1-sigma")]
    NoCovariance,
    /// No noise terms.
    #[error("the calibration has no noise terms (calflash calibrate --noise-terms)")]
    NoNoise,
    /// Codes other than unsigned 16-bit.
    #[error("a unit at rest is simulated for unsigned 16-bit codes")]
    NotU16,
    /// A true output the unit's converter cannot express.
    #[error(
        "the unit's output {output} would have to read {value:.4e} (SI), which its converter's \
         codes cannot express: the bias shift (--shift) or the ageing (--aged) is too large for \
         this unit"
    )]
    Unreachable {
        /// The output: ax .. wz.
        output: &'static str,
        /// The value it would read.
        value: f64,
    },
}

/// The six outputs' names.
const OUTPUTS: [&str; 6] = ["ax", "ay", "az", "wx", "wy", "wz"];

/// The stated 1-sigma of each output of `cal` at rest with z up (25 C, 3.3 V).
///
/// # Errors
/// When `cal` is not an IMU with covariance factors.
pub fn stated_sigma(cal: &Calibration) -> Result<[f64; 6], RestError> {
    let mut imu = ImuCorrector::<u16>::new(cal, 1000.0)?;
    imu.set_environment(TEMPERATURE as f32, 3.3);
    let unit = Unit::new(cal, 1000.0, [0.0; 6], 9.81, 0);
    let target = unit.truth(&face(2, 1.0, 0.0), &Vector3::zeros());
    let (raw, _) = unit.invert(&target)?;
    let out = imu.correct(raw.map(|r| r.round().clamp(0.0, 65_535.0) as u16));
    let (total, _) = imu
        .factory_variances(&out.values)
        .ok_or(RestError::NoCovariance)?;
    Ok(total.map(|v| f64::from(v).sqrt()))
}

impl Session {
    /// The raw samples.
    ///
    /// # Errors
    /// When `cal` is not an unsigned 16-bit IMU with covariance factors and noise terms.
    pub fn record(&self, cal: &Calibration) -> Result<Vec<[u16; 6]>, RestError> {
        if cal.data().noise.is_none() {
            return Err(RestError::NoNoise);
        }
        if spincal::correct::format_of(cal) != spincal::model::SampleFormat::U16 {
            return Err(RestError::NotU16);
        }
        let sigma = stated_sigma(cal)?;
        let walk = cal.data().noise.map_or([0.0; 6], |n| n.bias_walk);
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x5eed_a9e5);
        let normal = Normal::new(0.0, 1.0).expect("unit normal");
        let shift: [f64; 6] = std::array::from_fn(|i| {
            let aged = f64::from(walk[i]) * self.aged_s.sqrt() * normal.sample(&mut rng);
            self.shift_sigmas[i] * sigma[i] + aged
        });
        let mut unit = Unit::new(cal, self.rate, shift, 9.81, self.seed);
        unit.recording = Some(Vec::new());
        let faces = [
            (2, 1.0),
            (0, 1.0),
            (1, -1.0),
            (2, -1.0),
            (0, -1.0),
            (1, 1.0),
        ];
        let poses: Vec<Rotation3<f64>> = (0..self.poses)
            .map(|k| {
                let (axis, sign) = faces[k % faces.len()];
                face(axis, sign, 0.4 + 0.9 * k as f64)
                    * Rotation3::from_euler_angles(0.2, -0.15, 0.0)
            })
            .collect();
        let mut ignore = |_: &mut ImuCorrector<'_, u16>, _: &Corrected<6>| {};
        for (k, pose) in poses.iter().enumerate() {
            if k > 0 {
                unit.turn(&poses[k - 1], pose, &mut ignore)?;
            }
            unit.rest(pose, self.hold, &mut ignore)?;
        }
        Ok(unit.recording.take().unwrap_or_default())
    }
}

/// The temperature, C, a simulated unit rests at (and its supply voltage is 3.3 V).
pub const TEMPERATURE: f64 = 25.0;

/// Writes raw samples as a recording: a header `t,ax,ay,az,gx,gy,gz,temp`, then the time (s),
/// the six counts and the temperature the unit rested at ([`TEMPERATURE`]) per line, so that
/// `calflash health` corrects it where it was recorded.
///
/// # Errors
/// The writer's.
pub fn write_csv(raw: &[[u16; 6]], rate: f64, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    writeln!(w, "t,ax,ay,az,gx,gy,gz,temp")?;
    for (k, [a, b, c, d, e, f]) in raw.iter().enumerate() {
        writeln!(
            w,
            "{:.6},{a},{b},{c},{d},{e},{f},{TEMPERATURE}",
            k as f64 / rate
        )?;
    }
    Ok(())
}
