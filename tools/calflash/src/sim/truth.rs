//! The true coefficients of a virtual sensor, written as forward models (what the sensor
//! outputs, in counts, for a known input), the way the physics and IEEE Std 1293 write them.

use serde::{Deserialize, Serialize};
use spincal::model::rotation;

/// Reference conditions at which the nominal coefficients hold.
pub const REF_TEMP: f64 = 25.0;

/// A single-axis sensor (sensitive axis x; cross axes p = y, o = z):
/// `out = K0(T,V) + K1(T,V) (a + K2 a^2 + K3 a^3 + Koq a|a| + Kp a_p + Ko a_o + Kip a a_p)
///        + asym K1 |a - breakpoint| + hysteresis dir`, zero inside the dead band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SingleTruth {
    /// Bias K0, counts.
    pub k0: f64,
    /// Scale factor K1, counts per SI unit.
    pub k1: f64,
    /// g-squared K2, 1/SI.
    pub k2: f64,
    /// Cubic K3, 1/SI^2.
    pub k3: f64,
    /// Odd-quadratic Koq, 1/SI.
    pub koq: f64,
    /// Cross-axis sensitivity to a_p (dimensionless).
    pub kp: f64,
    /// Cross-axis sensitivity to a_o.
    pub ko: f64,
    /// Cross-coupling a * a_p, 1/SI.
    pub kip: f64,
    /// Asymmetry: the slope is K1 (1 + asym) above the breakpoint and K1 (1 - asym) below.
    pub asym: f64,
    /// Asymmetry breakpoint, SI.
    pub breakpoint: f64,
    /// Hysteresis: +h counts on ascending inputs, -h descending.
    pub hysteresis: f64,
    /// Dead band half-width, SI: inputs inside it give no response.
    pub dead_band: f64,
    /// Bias temperature coefficient, counts per degree C.
    pub k0_temp: f64,
    /// Scale-factor temperature coefficient, relative per degree C.
    pub k1_temp: f64,
    /// Quadratic bias temperature coefficient, counts per degree C^2.
    pub k0_temp2: f64,
    /// Cubic bias temperature coefficient, counts per degree C^3.
    pub k0_temp3: f64,
    /// Quadratic scale-factor temperature coefficient, relative per degree C^2.
    pub k1_temp2: f64,
    /// A step in the bias that no low-order polynomial follows: `k0_tanh tanh((T - tanh_center)
    /// / tanh_width)` counts.
    pub k0_tanh: f64,
    /// The same in the scale factor, relative.
    pub k1_tanh: f64,
    /// Where the steps are, C.
    pub tanh_center: f64,
    /// How wide they are, C.
    pub tanh_width: f64,
    /// Bias supply-voltage coefficient, counts per volt (from `ref_volt`).
    pub k0_volt: f64,
    /// Scale-factor supply-voltage coefficient, relative per volt.
    pub k1_volt: f64,
    /// Supply voltage of the nominal coefficients.
    pub ref_volt: f64,
    /// Output noise, counts (1-sigma).
    pub noise: f64,
}

impl Default for SingleTruth {
    fn default() -> Self {
        Self {
            k0: 32_768.0 + 137.4,
            k1: 408.0,
            k2: 1.5e-4,
            k3: -2.0e-6,
            koq: 0.0,
            kp: 2.0e-3,
            ko: -1.0e-3,
            kip: 0.0,
            asym: 0.0,
            breakpoint: 0.0,
            hysteresis: 0.0,
            dead_band: 0.0,
            k0_temp: 0.6,
            k1_temp: 80e-6,
            k0_temp2: 0.0,
            k0_temp3: 0.0,
            k1_temp2: 0.0,
            k0_tanh: 0.0,
            k1_tanh: 0.0,
            tanh_center: 10.0,
            tanh_width: 15.0,
            k0_volt: 0.0,
            k1_volt: 0.0,
            ref_volt: 5.0,
            noise: 2.0,
        }
    }
}

impl SingleTruth {
    /// The input (no cross inputs, no sweep) whose noise-free output at temperature `t` and
    /// supply `v` is `out`: Newton's method on [`output`](Self::output), the truth a corrected
    /// code is held against.
    #[must_use]
    pub fn input(&self, out: f64, t: f64, v: f64) -> f64 {
        let f = |x: f64| self.output(x, 0.0, 0.0, t, v, 0.0);
        let mut x = (out - f(0.0)) / (f(1.0) - f(0.0));
        for _ in 0..30 {
            let h = 1e-3;
            let step = (f(x) - out) / ((f(x + h) - f(x - h)) / (2.0 * h));
            x -= step;
            if step.abs() < 1e-13 {
                break;
            }
        }
        x
    }

    /// The noise-free output for input `a` (cross inputs `ap`, `ao`), temperature `t`, supply
    /// `v`, and direction `dir` (+1 ascending, -1 descending, 0 unknown).
    #[must_use]
    pub fn output(&self, a: f64, ap: f64, ao: f64, t: f64, v: f64, dir: f64) -> f64 {
        let dt = t - REF_TEMP;
        let dv = v - self.ref_volt;
        let step = if self.k0_tanh == 0.0 && self.k1_tanh == 0.0 {
            0.0
        } else {
            ((t - self.tanh_center) / self.tanh_width).tanh()
        };
        let k0 = self.k0
            + self.k0_temp * dt
            + self.k0_temp2 * dt * dt
            + self.k0_temp3 * dt * dt * dt
            + self.k0_tanh * step
            + self.k0_volt * dv;
        let k1 = self.k1
            * (1.0
                + self.k1_temp * dt
                + self.k1_temp2 * dt * dt
                + self.k1_tanh * step
                + self.k1_volt * dv);
        let a = if a.abs() <= self.dead_band { 0.0 } else { a };
        k0 + k1
            * (a + self.k2 * a * a
                + self.k3 * a * a * a
                + self.koq * a * a.abs()
                + self.kp * ap
                + self.ko * ao
                + self.kip * a * ap
                + self.asym * ((a - self.breakpoint).abs() - self.breakpoint.abs()))
            + self.hysteresis * dir
    }
}

/// A triad, written as `spincal::model::rotation` writes the model under rotation: axis `i`
/// senses `z_i = s_i . F_i` (counts; `s_i` is row `i` of `S` scaled by its temperature
/// coefficient) and outputs `b_i(T,V) + z_i + S_ii (K2 x^2 + K3 x^3 + Koq x|x|)` with
/// `x = z_i / S_ii`, what it senses in SI units. For an accelerometer `F_i` is the specific
/// force at the axis' lever arm `r_i`, centripetal and tangential terms included; for a gyro
/// `z_i = s_i . w + g_i . f` with `f` the specific force at the reference point
/// (g-sensitivity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TriadTruth {
    /// Bias, counts.
    pub bias: [f64; 3],
    /// Sensitivity and misalignment, counts per SI unit, row i = output axis i.
    pub s: [[f64; 3]; 3],
    /// Own-axis g-squared per axis, 1/SI.
    pub k2: [f64; 3],
    /// Own-axis cubic per axis, 1/SI^2.
    pub k3: [f64; 3],
    /// Own-axis odd-quadratic per axis, 1/SI.
    pub koq: [f64; 3],
    /// g-sensitivity (gyros), counts per m/s^2.
    pub g: [[f64; 3]; 3],
    /// Lever arms (accelerometers), metres; row i = position of axis i.
    pub lever: [[f64; 3]; 3],
    /// Bias temperature coefficients, counts per degree C.
    pub bias_temp: [f64; 3],
    /// Scale temperature coefficients, relative per degree C.
    pub scale_temp: [f64; 3],
    /// Bias curvature in temperature, counts per degree C squared (`(T - 25)^2`).
    #[serde(default, skip_serializing_if = "all_zero")]
    pub bias_temp2: [f64; 3],
    /// Bias supply-voltage coefficients, counts per volt.
    pub bias_volt: [f64; 3],
    /// Supply voltage of the nominal coefficients.
    pub ref_volt: f64,
    /// Output noise per axis, counts (1-sigma).
    pub noise: [f64; 3],
}

impl Default for TriadTruth {
    fn default() -> Self {
        Self::accelerometer()
    }
}

impl TriadTruth {
    /// A typical accelerometer triad: 412 counts per m/s^2, small misalignment.
    #[must_use]
    pub fn accelerometer() -> Self {
        let k = 412.0;
        Self {
            bias: [32_768.0 + 341.5, 32_768.0 + 561.2, 32_768.0 - 212.8],
            s: [
                [k * 1.002, k * 1.5e-3, -k * 0.8e-3],
                [-k * 0.6e-3, k * 0.997, k * 2.1e-3],
                [k * 1.1e-3, -k * 1.7e-3, k * 1.004],
            ],
            k2: [0.0; 3],
            k3: [0.0; 3],
            koq: [0.0; 3],
            g: [[0.0; 3]; 3],
            lever: [[0.0; 3]; 3],
            bias_temp: [0.35, 0.2, -0.5],
            scale_temp: [80e-6, 60e-6, -40e-6],
            bias_temp2: [0.0; 3],
            bias_volt: [0.0; 3],
            ref_volt: 3.3,
            noise: [3.0, 3.0, 3.5],
        }
    }

    /// A typical gyro triad: 900 counts per rad/s, g-sensitivity of a few counts per g.
    #[must_use]
    pub fn gyro() -> Self {
        let k = 900.0;
        Self {
            bias: [32_768.0 + 18.0, 32_768.0 - 338.5, 32_768.0 - 250.7],
            s: [
                [k * 0.998, k * 3.0e-3, k * 1.0e-3],
                [-k * 2.5e-3, k * 1.003, k * 4.0e-3],
                [k * 1.2e-3, -k * 3.5e-3, k * 1.001],
            ],
            k2: [0.0; 3],
            k3: [0.0; 3],
            koq: [0.0; 3],
            g: [
                [0.18, -0.09, 0.045],
                [0.07, 0.13, -0.03],
                [-0.02, 0.05, 0.27],
            ],
            lever: [[0.0; 3]; 3],
            bias_temp: [0.8, -0.3, 0.1],
            scale_temp: [-120e-6, -100e-6, -90e-6],
            bias_temp2: [0.0; 3],
            bias_volt: [0.0; 3],
            ref_volt: 3.3,
            noise: [2.0, 2.0, 2.0],
        }
    }

    /// Noise-free accelerometer outputs for the specific force `f` at the reference point, the
    /// rate `w` and angular acceleration `dw`, temperature `t` and supply `v`.
    #[must_use]
    pub fn accel_output(&self, f: [f64; 3], w: [f64; 3], dw: [f64; 3], t: f64, v: f64) -> [f64; 3] {
        std::array::from_fn(|i| {
            let at = rotation::force_at(&f, &w, &dw, &self.lever[i]);
            self.respond(i, rotation::dot(&self.row(i, t), &at), t, v)
        })
    }

    /// Noise-free gyro outputs for the rate `w` and the specific force `f` at the reference
    /// point (g-sensitivity), temperature `t` and supply `v`.
    #[must_use]
    pub fn gyro_output(&self, w: [f64; 3], f: [f64; 3], t: f64, v: f64) -> [f64; 3] {
        std::array::from_fn(|i| {
            let z = rotation::dot(&self.row(i, t), &w) + rotation::dot(&self.g[i], &f);
            self.respond(i, z, t, v)
        })
    }

    /// Row `i` of the scale-misalignment matrix at temperature `t`.
    fn row(&self, i: usize, t: f64) -> [f64; 3] {
        let scale = 1.0 + self.scale_temp[i] * (t - REF_TEMP);
        self.s[i].map(|x| x * scale)
    }

    /// The output of axis `i` sensing `z` counts.
    fn respond(&self, i: usize, z: f64, t: f64, v: f64) -> f64 {
        let dt = t - REF_TEMP;
        let dv = v - self.ref_volt;
        let s = self.row(i, t)[i];
        let x = z / s;
        let nl = s * (self.k2[i] * x * x + self.k3[i] * x * x * x + self.koq[i] * x * x.abs());
        self.bias[i]
            + self.bias_temp[i] * dt
            + self.bias_temp2[i] * dt * dt
            + self.bias_volt[i] * dv
            + z
            + nl
    }
}

/// Whether every element is zero (a term the truth file need not name).
fn all_zero(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

/// An IMU: an accelerometer triad and a gyro triad.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuTruth {
    /// Accelerometer.
    pub accel: TriadTruth,
    /// Gyro.
    pub gyro: TriadTruth,
}

impl ImuTruth {
    /// The six raw codes (accelerometer x y z, gyro x y z) the unit puts out feeling specific
    /// force `f`, rate `w` and angular acceleration `dw` at `temp` C and `volt` V: each with a
    /// draw of its noise from `rng`, rounded (not yet held at a converter's rails).
    pub fn codes(
        &self,
        (f, w, dw): ([f64; 3], [f64; 3], [f64; 3]),
        (temp, volt): (f64, f64),
        rng: &mut impl rand::Rng,
    ) -> [f64; 6] {
        use rand_distr::{Distribution, Normal};
        let a = self.accel.accel_output(f, w, dw, temp, volt);
        let g = self.gyro.gyro_output(w, f, temp, volt);
        let mut draw = |sigma: f64| {
            if sigma > 0.0 {
                Normal::new(0.0, sigma).map_or(0.0, |n| n.sample(rng))
            } else {
                0.0
            }
        };
        // Drawn axis by axis, the accelerometer's then the gyro's (the order the spin rig's
        // flights were always drawn in, so that a seed gives the same flight).
        let mut out = [0.0; 6];
        for i in 0..3 {
            out[i] = (a[i] + draw(self.accel.noise[i])).round();
            out[i + 3] = (g[i] + draw(self.gyro.noise[i])).round();
        }
        out
    }

    /// An IMU for a round that spins to 300 Hz: a high-g accelerometer (about +-2000 g on a
    /// 16-bit converter, 1.67 counts per m/s^2) with lever arms of 0.5 to 3 mm, a few mrad of
    /// misalignment and g-squared terms, and a gyro reading +-2000 rad/s (16.4 counts per
    /// rad/s) with g-sensitivity and g-squared terms.
    #[must_use]
    pub fn spinning_round() -> Self {
        let ka = 32_768.0 / (2000.0 * 9.806_65);
        let kg = 32_768.0 / 2000.0;
        Self {
            accel: TriadTruth {
                bias: [32_768.0 + 14.2, 32_768.0 - 9.6, 32_768.0 + 5.3],
                s: [
                    [ka * 1.003, ka * 2.0e-3, -ka * 1.2e-3],
                    [-ka * 1.5e-3, ka * 0.998, ka * 2.5e-3],
                    [ka * 0.9e-3, -ka * 1.8e-3, ka * 1.002],
                ],
                k2: [4.0e-7, -3.0e-7, 2.5e-7],
                k3: [0.0; 3],
                koq: [0.0; 3],
                g: [[0.0; 3]; 3],
                lever: [
                    [0.0008, 0.0025, -0.0012],
                    [-0.0030, 0.0005, 0.0018],
                    [0.0015, -0.0021, 0.0009],
                ],
                bias_temp: [0.0; 3],
                scale_temp: [0.0; 3],
                bias_temp2: [0.0; 3],
                bias_volt: [0.0; 3],
                ref_volt: 3.3,
                noise: [2.0, 2.0, 2.0],
            },
            gyro: TriadTruth {
                bias: [32_768.0 + 3.1, 32_768.0 - 4.4, 32_768.0 + 1.7],
                s: [
                    [kg * 0.999, kg * 2.5e-3, kg * 1.0e-3],
                    [-kg * 2.0e-3, kg * 1.002, kg * 3.0e-3],
                    [kg * 1.5e-3, -kg * 2.2e-3, kg * 1.001],
                ],
                k2: [1.0e-6, -0.8e-6, 0.6e-6],
                k3: [0.0; 3],
                koq: [0.0; 3],
                // About 0.1 deg/s per g: 1.8e-4 rad/s per m/s^2, in counts.
                g: [
                    [kg * 1.8e-4, -kg * 0.9e-4, kg * 0.5e-4],
                    [kg * 0.7e-4, kg * 1.3e-4, -kg * 0.4e-4],
                    [-kg * 0.3e-4, kg * 0.6e-4, kg * 2.0e-4],
                ],
                lever: [[0.0; 3]; 3],
                bias_temp: [0.0; 3],
                scale_temp: [0.0; 3],
                bias_temp2: [0.0; 3],
                bias_volt: [0.0; 3],
                ref_volt: 3.3,
                noise: [1.5, 1.5, 1.5],
            },
        }
    }
}

impl Default for ImuTruth {
    fn default() -> Self {
        Self {
            accel: TriadTruth::accelerometer(),
            gyro: TriadTruth::gyro(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `examples/data/spinning_round.truth.json` is [`ImuTruth::spinning_round`], so the
    /// README's spin-rig commands simulate the unit the tests calibrate. Written again with
    /// `SPINCAL_ACCEPT=1`.
    #[test]
    fn the_spinning_round_example_file_is_the_constructor() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/data/spinning_round.truth.json");
        let want = serde_json::to_string_pretty(&ImuTruth::spinning_round()).unwrap() + "\n";
        if std::env::var("SPINCAL_ACCEPT").is_ok_and(|v| v == "1") {
            std::fs::write(&path, &want).unwrap();
        }
        let got = std::fs::read_to_string(&path).unwrap();
        assert_eq!(got, want, "{} differs", path.display());
        // And it reads as a truth (to the last digit serde_json prints).
        let _: ImuTruth = serde_json::from_str(&got).unwrap();
    }
}
