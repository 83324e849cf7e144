//! A simulated hand tumble: an IMU with a known correction rests, then is turned through still
//! poses with smooth rotations between them, sampled with noise and rounded to counts. The
//! truth is in the correction form `calflash selfcal` fits, so a test can compare directly.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

use crate::obs::recording::Recording;

/// The simulated unit and session.
#[derive(Debug, Clone)]
pub struct Tumble {
    /// Accelerometer correction: `a = M (r - center) + o` (m/s^2).
    pub accel_matrix: Matrix3<f64>,
    /// Its offset, m/s^2.
    pub accel_offset: Vector3<f64>,
    /// Accelerometer zero code.
    pub accel_center: f64,
    /// Gyro correction: `w = G (r - bias)` (rad/s).
    pub gyro_matrix: Matrix3<f64>,
    /// Gyro bias, counts.
    pub gyro_bias: Vector3<f64>,
    /// Gravity, m/s^2.
    pub g: f64,
    /// Sampling rate, Hz.
    pub rate: f64,
    /// Initial rest, s.
    pub rest: f64,
    /// Still poses after the rest.
    pub poses: usize,
    /// Seconds each pose is held.
    pub hold: f64,
    /// Seconds each rotation takes.
    pub turn: f64,
    /// Noise, counts (1 sigma), accelerometer and gyro.
    pub noise: (f64, f64),
    /// Rails: codes at or beyond them are clipped there.
    pub rails: (f64, f64),
    /// Seed.
    pub seed: u64,
}

impl Default for Tumble {
    fn default() -> Self {
        Self {
            accel_matrix: Matrix3::new(
                1.0 / 412.0,
                3e-5,
                -2e-5,
                0.0,
                1.0 / 409.0,
                4e-5,
                0.0,
                0.0,
                1.0 / 415.0,
            ),
            accel_offset: Vector3::new(0.15, -0.08, 0.05),
            accel_center: 32768.0,
            gyro_matrix: Matrix3::new(
                2.09e-4, 1e-6, -2e-6, 3e-6, 2.1e-4, -1.1e-5, 5e-6, 0.0, 2.095e-4,
            ),
            gyro_bias: Vector3::new(32770.0, 32455.0, 32511.0),
            g: 9.81,
            rate: 100.0,
            rest: 30.0,
            poses: 36,
            hold: 4.0,
            turn: 2.0,
            noise: (3.0, 3.0),
            rails: (0.0, 65535.0),
            seed: 1,
        }
    }
}

impl Tumble {
    /// The true accelerometer parameters in the order the fit gives them (the upper
    /// triangular matrix by rows, then the offset), referred to the fit's `center`.
    #[must_use]
    pub fn accel_parameters(&self, center: [f64; 3]) -> [f64; 9] {
        let m = &self.accel_matrix;
        let shift = Vector3::from_fn(|j, _| center[j] - self.accel_center);
        let o = self.accel_offset + m * shift;
        [
            m[(0, 0)],
            m[(0, 1)],
            m[(0, 2)],
            m[(1, 1)],
            m[(1, 2)],
            m[(2, 2)],
            o[0],
            o[1],
            o[2],
        ]
    }

    /// The recording.
    #[must_use]
    pub fn record(&self) -> Recording {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(self.seed);
        let normal = Normal::new(0.0, 1.0).expect("unit normal");
        let dt = 1.0 / self.rate;
        let a_inv = self
            .accel_matrix
            .try_inverse()
            .expect("invertible accelerometer");
        let g_inv = self.gyro_matrix.try_inverse().expect("invertible gyro");
        let gw = Vector3::new(0.0, 0.0, self.g);
        // Body-to-world attitude; starts level.
        let mut att = Rotation3::identity();
        let mut t = Vec::new();
        let mut acc = Vec::new();
        let mut gyro = Vec::new();
        let mut emit =
            |att: &Rotation3<f64>, w: Vector3<f64>, rng: &mut rand_chacha::ChaCha8Rng| {
                let f = att.inverse() * gw;
                let ra = a_inv * (f - self.accel_offset) + Vector3::repeat(self.accel_center);
                let rg = g_inv * w + self.gyro_bias;
                let q = |x: f64, s: f64, rng: &mut rand_chacha::ChaCha8Rng| {
                    (x + s * normal.sample(rng))
                        .round()
                        .clamp(self.rails.0, self.rails.1)
                };
                acc.push(std::array::from_fn(|j| q(ra[j], self.noise.0, rng)));
                gyro.push(std::array::from_fn(|j| q(rg[j], self.noise.1, rng)));
                t.push(t.len() as f64 * dt);
            };
        for _ in 0..(self.rest * self.rate) as usize {
            emit(&att, Vector3::zeros(), &mut rng);
        }
        for _ in 0..self.poses {
            // A rotation of 60 to 150 degrees about a random axis, with a sine rate profile.
            let axis = Unit::new_normalize(Vector3::new(
                normal.sample(&mut rng),
                normal.sample(&mut rng),
                normal.sample(&mut rng),
            ));
            let angle = rng.random_range(60f64..150.0).to_radians();
            let n = (self.turn * self.rate) as usize;
            for s in 0..n {
                let phase = std::f64::consts::PI * (s as f64 + 0.5) / n as f64;
                let w = axis.into_inner()
                    * (angle * std::f64::consts::PI / (2.0 * self.turn) * phase.sin());
                // Body rates: integrate the attitude exactly over the step.
                att *= Rotation3::new(w * dt);
                emit(&att, w, &mut rng);
            }
            for _ in 0..(self.hold * self.rate) as usize {
                emit(&att, Vector3::zeros(), &mut rng);
            }
        }
        let at_rail = |s: &[f64; 3]| s.iter().any(|x| *x <= self.rails.0 || *x >= self.rails.1);
        let sa: Vec<bool> = acc.iter().map(at_rail).collect();
        let sg: Vec<bool> = gyro.iter().map(at_rail).collect();
        Recording {
            source: format!("simulated tumble (seed {})", self.seed),
            line: (1..=t.len())
                .map(|k| u32::try_from(k).unwrap_or(u32::MAX))
                .collect(),
            saturated: sa.iter().zip(&sg).map(|(a, b)| *a || *b).collect(),
            saturated_count: (
                sa.iter().filter(|x| **x).count(),
                sg.iter().filter(|x| **x).count(),
            ),
            t,
            acc,
            gyro,
            gaps: Vec::new(),
            period: dt,
            rest: None,
            units: [crate::obs::units::Read::COUNTS; 2],
            temperature: None,
        }
    }
}
