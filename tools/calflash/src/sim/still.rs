//! An IMU lying still, z up, for as long as an Allan deviation needs: the truth's output for
//! gravity along z and no rate, with its white noise each sample and, when stated, a random
//! walk of each bias (counts per root second), rounded to codes. `calflash allan` reads it
//! back: its noise terms are the white noise and the walk the unit was given.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::plan::G;
use super::truth::ImuTruth;

/// A still recording to make.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Still {
    /// Its length, s.
    pub seconds: f64,
    /// Samples per second.
    pub rate: f64,
    /// Each bias's random walk, counts per root second: the accelerometer's, the gyro's.
    pub walk: [f64; 2],
    /// Temperature, C.
    pub temp: f64,
    /// Supply, V.
    pub volt: f64,
    /// Seed.
    pub seed: u64,
}

/// The six codes of every sample (accelerometer x y z, gyro x y z), not yet held at rails.
#[must_use]
pub fn record(truth: &ImuTruth, s: &Still) -> Vec<[f64; 6]> {
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
    let mut draw = |sigma: f64| {
        if sigma > 0.0 {
            Normal::new(0.0, sigma).map_or(0.0, |n| n.sample(&mut rng))
        } else {
            0.0
        }
    };
    let n = (s.seconds * s.rate).round() as usize;
    let step = (1.0 / s.rate).sqrt();
    let f = [0.0, 0.0, G];
    let a = truth
        .accel
        .accel_output(f, [0.0; 3], [0.0; 3], s.temp, s.volt);
    let g = truth.gyro.gyro_output([0.0; 3], f, s.temp, s.volt);
    let mut bias = [0.0f64; 6];
    (0..n)
        .map(|_| {
            let mut out = [0.0; 6];
            for i in 0..3 {
                bias[i] += draw(s.walk[0] * step);
                bias[i + 3] += draw(s.walk[1] * step);
                out[i] = (a[i] + bias[i] + draw(truth.accel.noise[i])).round();
                out[i + 3] = (g[i] + bias[i + 3] + draw(truth.gyro.noise[i])).round();
            }
            out
        })
        .collect()
}

/// Writes the recording as CSV: `t` (s), the six codes, and the temperature.
///
/// # Errors
/// The writer's.
pub fn write_csv(codes: &[[f64; 6]], s: &Still, mut w: impl std::io::Write) -> std::io::Result<()> {
    writeln!(w, "t,ax,ay,az,gx,gy,gz,temp")?;
    for (k, c) in codes.iter().enumerate() {
        writeln!(
            w,
            "{:.6},{},{},{},{},{},{},{}",
            k as f64 / s.rate,
            c[0],
            c[1],
            c[2],
            c[3],
            c[4],
            c[5],
            s.temp
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_unit_reads_gravity_on_z_with_its_noise() {
        let truth = ImuTruth::default();
        let s = Still {
            seconds: 20.0,
            rate: 100.0,
            walk: [0.0, 0.0],
            temp: 25.0,
            volt: 5.0,
            seed: 3,
        };
        let codes = record(&truth, &s);
        assert_eq!(codes.len(), 2000);
        let f = [0.0, 0.0, G];
        let want = truth.accel.accel_output(f, [0.0; 3], [0.0; 3], 25.0, 5.0);
        let mean = |i: usize| codes.iter().map(|c| c[i]).sum::<f64>() / 2000.0;
        let sd = |i: usize| {
            let m = mean(i);
            (codes.iter().map(|c| (c[i] - m).powi(2)).sum::<f64>() / 1999.0).sqrt()
        };
        for (i, w) in want.iter().enumerate() {
            assert!((mean(i) - w).abs() < 0.2, "{i}: {} against {w}", mean(i));
            // The white noise, with rounding's 1/12 count^2.
            let expect = (truth.accel.noise[i].powi(2) + 1.0 / 12.0).sqrt();
            assert!(
                (sd(i) / expect - 1.0).abs() < 0.06,
                "{i}: {} against {expect}",
                sd(i)
            );
        }
    }
}
