//! The true coefficients of a virtual sensor, written as forward models (what the sensor
//! outputs, in counts, for a known input), the way the physics and IEEE Std 1293 write them.

use serde::{Deserialize, Serialize};

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
            k0_volt: 0.0,
            k1_volt: 0.0,
            ref_volt: 5.0,
            noise: 2.0,
        }
    }
}

impl SingleTruth {
    /// The noise-free output for input `a` (cross inputs `ap`, `ao`), temperature `t`, supply
    /// `v`, and direction `dir` (+1 ascending, -1 descending, 0 unknown).
    #[must_use]
    pub fn output(&self, a: f64, ap: f64, ao: f64, t: f64, v: f64, dir: f64) -> f64 {
        let dt = t - REF_TEMP;
        let dv = v - self.ref_volt;
        let k0 = self.k0 + self.k0_temp * dt + self.k0_temp2 * dt * dt + self.k0_volt * dv;
        let k1 = self.k1 * (1.0 + self.k1_temp * dt + self.k1_volt * dv);
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

/// A triad: `out = b(T,V) + S(T,V) f + diag(S) (K2 f^2 + K3 f^3 + Koq f|f|) + G a + lever`,
/// per axis, where `f` is the measured quantity at the reference point and, for a gyro, `a` the
/// specific force (g-sensitivity); for an accelerometer each axis `i` at lever arm `r_i` also
/// feels `[w x (w x r_i)]_i`.
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
            bias_volt: [0.0; 3],
            ref_volt: 3.3,
            noise: [2.0, 2.0, 2.0],
        }
    }

    /// Noise-free outputs for the measured quantity `x` at the reference point, specific force
    /// `f` (g-sensitivity), rate `w` (lever arm), temperature and supply voltage.
    #[must_use]
    pub fn output(&self, x: [f64; 3], f: [f64; 3], w: [f64; 3], t: f64, v: f64) -> [f64; 3] {
        let dt = t - REF_TEMP;
        let dv = v - self.ref_volt;
        let ww: f64 = w.iter().map(|c| c * c).sum();
        std::array::from_fn(|i| {
            let scale = 1.0 + self.scale_temp[i] * dt;
            let r = self.lever[i];
            let dot = w[0] * r[0] + w[1] * r[1] + w[2] * r[2];
            // The own-axis input including the size effect at this axis' position.
            let centripetal = w[i] * dot - r[i] * ww;
            let xi: [f64; 3] =
                std::array::from_fn(|j| x[j] + if j == i { centripetal } else { 0.0 });
            let lin: f64 = (0..3).map(|j| self.s[i][j] * xi[j]).sum::<f64>();
            let own = xi[i];
            let nl = self.s[i][i]
                * (self.k2[i] * own * own
                    + self.k3[i] * own.powi(3)
                    + self.koq[i] * own * own.abs());
            let g: f64 = (0..3).map(|j| self.g[i][j] * f[j]).sum();
            self.bias[i] + self.bias_temp[i] * dt + self.bias_volt[i] * dv + scale * (lin + nl) + g
        })
    }
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

impl Default for ImuTruth {
    fn default() -> Self {
        Self {
            accel: TriadTruth::accelerometer(),
            gyro: TriadTruth::gyro(),
        }
    }
}
