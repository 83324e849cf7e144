//! Two stages from one truth: six single-axis sensors (each with its own bias, scale factor,
//! nonlinearity, asymmetry and temperature curves, as [`SingleTruth`] writes them) before
//! assembly, and the IMU they are assembled into: each sensor senses along its mounted
//! direction, scaled and biased by what assembly changed, the accelerometers at their lever
//! arms, the gyros with g-sensitivity.
//!
//! Sensor `k` of the unit outputs `h_k(x_k)` ([`SingleTruth::output`] with no cross inputs),
//! `x_k = db_k + (1 + ds_k) n_k . F_k` for an accelerometer (`F_k` the specific force at its
//! lever arm) and `x_k = db_k + (1 + ds_k) n_k . w + g_k . f` for a gyro, `n_k` a unit vector.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use spincal::model::rotation;

use super::plan::Condition;
use super::truth::SingleTruth;
use super::{Observations, Sensor};
use crate::columns as col;

/// The assembled unit's truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AssembledTruth {
    /// The six sensors before assembly, in the order a_x, a_y, a_z, g_x, g_y, g_z.
    pub sensors: Vec<SingleTruth>,
    /// Each sensor's sensing direction in the unit's axes (unit vectors).
    pub directions: [[f64; 3]; 6],
    /// What assembly changed in each scale factor (relative).
    pub scale_change: [f64; 6],
    /// What assembly changed in each bias (SI).
    pub bias_change: [f64; 6],
    /// The accelerometers' positions, metres (row = axis).
    pub lever: [[f64; 3]; 3],
    /// The gyros' g-sensitivity, rad/s per m/s^2 (row = axis).
    pub g_sensitivity: [[f64; 3]; 3],
}

fn normal(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    Normal::new(0.0, sigma).map_or(0.0, |n| n.sample(rng))
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = rotation::dot(&v, &v).sqrt();
    v.map(|x| x / n)
}

impl AssembledTruth {
    /// A unit drawn from `seed`: accelerometers of 400 counts per m/s^2 (+-8 g on 16 bits) and
    /// gyros of 900 counts per rad/s, each with a bias, a g-squared term of up to 3e-4 per
    /// m/s^2 (about 3e-3 per g), a cubic term, an asymmetric scale factor of up to 1e-3,
    /// a bias curving in temperature and a scale factor drifting with it; mounted 2 mrad off
    /// their axes (1-sigma), the accelerometers 1 to 3 mm from the reference point, the gyros
    /// sensing 1e-4 rad/s per m/s^2. Assembly changes nothing else.
    #[must_use]
    pub fn draw(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensors = (0..6)
            .map(|k| {
                let gyro = k >= 3;
                let (k1, noise) = if gyro { (900.0, 2.0) } else { (400.0, 2.0) };
                SingleTruth {
                    k0: 32_768.0 + normal(&mut rng, 200.0),
                    k1: k1 * (1.0 + normal(&mut rng, 5e-3)),
                    k2: normal(&mut rng, if gyro { 2e-4 } else { 1.5e-4 }),
                    k3: normal(&mut rng, if gyro { 5e-6 } else { 2e-6 }),
                    // On its own fixture a sensor has no cross-axis terms: in the unit, its
                    // mounted direction takes their place.
                    kp: 0.0,
                    ko: 0.0,
                    asym: normal(&mut rng, 5e-4),
                    k0_temp: normal(&mut rng, 0.5),
                    k1_temp: normal(&mut rng, 80e-6),
                    k0_temp2: normal(&mut rng, 4e-3),
                    k1_temp2: normal(&mut rng, 4e-7),
                    ref_volt: 3.3,
                    noise,
                    ..SingleTruth::default()
                }
            })
            .collect();
        let directions = std::array::from_fn(|k| {
            let mut v: [f64; 3] = std::array::from_fn(|_| normal(&mut rng, 2e-3));
            v[k % 3] = 1.0;
            unit(v)
        });
        let lever = std::array::from_fn(|_| {
            std::array::from_fn(|_| {
                let r: f64 = rng.random_range(1e-3..3e-3);
                if rng.random_bool(0.5) { r } else { -r }
            })
        });
        let g_sensitivity =
            std::array::from_fn(|_| std::array::from_fn(|_| normal(&mut rng, 1e-4)));
        Self {
            sensors,
            directions,
            scale_change: [0.0; 6],
            bias_change: [0.0; 6],
            lever,
            g_sensitivity,
        }
    }

    /// What sensor `k` senses along itself in the unit (SI): `x_k`.
    #[must_use]
    pub fn sensed(&self, k: usize, c: &Condition, w: [f64; 3]) -> f64 {
        let n = self.directions[k];
        let along = if k < 3 {
            let at = rotation::force_at(&c.f, &w, &c.dw, &self.lever[k]);
            rotation::dot(&n, &at)
        } else {
            rotation::dot(&n, &w) + rotation::dot(&self.g_sensitivity[k - 3], &c.f)
        };
        self.bias_change[k] + (1.0 + self.scale_change[k]) * along
    }

    /// The six noise-free outputs (counts) of the assembled unit at condition `c`.
    #[must_use]
    pub fn outputs(&self, c: &Condition) -> [f64; 6] {
        std::array::from_fn(|k| {
            let x = self.sensed(k, c, c.w);
            self.sensors[k].output(x, 0.0, 0.0, c.temp, c.volt, 0.0)
        })
    }

    /// The true input of output `k` for the unit at condition `c`, as the device's corrected
    /// output states it: the specific force at the accelerometer's position along the unit's
    /// axis (the device removes the lever term, leaving the reference point's force) or the
    /// rate about it.
    #[must_use]
    pub fn truth_of(k: usize, c: &Condition) -> f64 {
        if k < 3 { c.f[k] } else { c.w[k - 3] }
    }

    /// Stage one of sensor `k`: its single-axis observations on `conditions` (the x component
    /// of `f` or `w` along it).
    #[must_use]
    pub fn stage_one(&self, k: usize, conditions: &[Condition], seed: u64) -> Observations {
        super::simulate(
            &Sensor::Single {
                gyro: k >= 3,
                truth: self.sensors[k].clone(),
            },
            conditions,
            seed,
            false,
        )
    }

    /// Stage two: the assembled unit's observations on `conditions`, the columns of an IMU
    /// plan (`f_*`, `w_*`, `dw_*` when the plan spins up, `temp`, `volt`, `a_*`, `g_*`).
    #[must_use]
    pub fn stage_two(&self, conditions: &[Condition], seed: u64) -> Observations {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let spins_up = conditions.iter().any(|c| c.dw.iter().any(|x| *x != 0.0));
        let mut names: Vec<&str> = col::F.iter().chain(&col::W).copied().collect();
        if spins_up {
            names.extend(col::DW);
        }
        names.extend([col::TEMP, col::VOLT]);
        names.extend(col::A.iter().chain(&col::GYRO));
        let rows = conditions
            .iter()
            .map(|c| {
                let mut row: Vec<f64> = c.f.iter().chain(&c.w).copied().collect();
                if spins_up {
                    row.extend(c.dw);
                }
                row.extend([c.temp, c.volt]);
                let out = self.outputs(c);
                row.extend(
                    out.iter()
                        .zip(&self.sensors)
                        .map(|(o, s)| o + normal(&mut rng, s.noise)),
                );
                row
            })
            .collect();
        Observations {
            names: names.into_iter().map(String::from).collect(),
            rows,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_aligned_unit_reads_each_sensor_as_stage_one_saw_it() {
        let mut t = AssembledTruth::draw(3);
        t.directions =
            std::array::from_fn(|k| std::array::from_fn(|j| f64::from(u8::from(j == k % 3))));
        t.lever = [[0.0; 3]; 3];
        t.g_sensitivity = [[0.0; 3]; 3];
        let c = Condition {
            f: [1.5, -9.0, 3.0],
            w: [0.2, 0.0, -4.0],
            dw: [0.0; 3],
            h: [0.0; 3],
            temp: 40.0,
            volt: 3.3,
            dir: 0.0,
        };
        let out = t.outputs(&c);
        for (k, got) in out.iter().enumerate() {
            let x = AssembledTruth::truth_of(k, &c);
            let want = t.sensors[k].output(x, 0.0, 0.0, 40.0, 3.3, 0.0);
            assert_eq!(*got, want, "output {k}");
        }
        // Assembly's scale change multiplies what the sensor senses.
        t.scale_change[1] = 1e-3;
        let moved = t.outputs(&c)[1];
        let want = t.sensors[1].output(-9.0 * 1.001, 0.0, 0.0, 40.0, 3.3, 0.0);
        assert!((moved - want).abs() < 1e-9, "{moved} {want}");
    }
}
