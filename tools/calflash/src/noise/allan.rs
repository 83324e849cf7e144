//! Overlapping Allan deviation of a rate (or specific-force) record and the IEEE Std 952 noise
//! terms read from it.
//!
//! For samples `y_k` at interval `tau0`, with `theta` their running integral, the overlapping
//! Allan variance at `tau = m tau0` is
//!
//! ```text
//! AVAR(tau) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 (N - 2m))
//! ```
//!
//! (IEEE Std 952-1997, annex C). The noise terms are fitted to the curve as the sum of the
//! standard shapes, each with a coefficient that cannot be negative:
//!
//! ```text
//! AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2
//! ```
//!
//! quantization `Q`, angle (or velocity) random walk `N`, bias instability `B`, rate random walk
//! `K` and rate ramp `R`, in the record's unit `u`: `Q` in `u s`, `N` in `u s^(1/2)` (that is,
//! `u/sqrt(Hz)`), `B` in `u`, `K` in `u / s^(1/2)`, `R` in `u / s`. Each point is weighted by
//! the inverse square of its relative uncertainty; every subset of the terms is tried and the
//! best fit with all coefficients non-negative is kept.
use rayon::prelude::*;

use nalgebra::{DMatrix, DVector};

/// One point of the curve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Point {
    /// Cluster time, s.
    pub tau: f64,
    /// Allan deviation, in the record's unit.
    pub adev: f64,
    /// Its 1-sigma relative uncertainty (from the number of independent clusters).
    pub rel_error: f64,
}

/// Overlapping Allan deviation at `per_octave` cluster sizes per doubling (at least 1), from
/// one sample up to a third of the record. `O(n)` per cluster size.
#[must_use]
pub fn overlapping(y: &[f64], tau0: f64, per_octave: usize) -> Vec<Point> {
    let n = y.len();
    if n < 3 {
        return Vec::new();
    }
    // The running integral, in sample units, about the mean (to keep the sums small).
    let mean = y.iter().sum::<f64>() / n as f64;
    let mut theta = Vec::with_capacity(n + 1);
    theta.push(0.0);
    let mut acc = 0.0;
    for v in y {
        acc += v - mean;
        theta.push(acc);
    }
    let mut ms: Vec<usize> = Vec::new();
    let steps = per_octave.max(1) as f64;
    let mut k = 0.0f64;
    loop {
        let m = 2f64.powf(k / steps).round() as usize;
        if m > n / 3 {
            break;
        }
        if ms.last() != Some(&m) {
            ms.push(m);
        }
        k += 1.0;
    }
    let len = theta.len();
    let point = |m: usize| {
        let count = len - 2 * m;
        let sum = second_differences(
            &theta[..count],
            &theta[m..m + count],
            &theta[2 * m..2 * m + count],
        );
        // theta is in samples x (unit); theta * tau0 is the integral. tau = m tau0.
        let avar = sum / (2.0 * (m * m) as f64 * count as f64);
        let independent = (n / m).saturating_sub(1).max(1);
        Point {
            tau: m as f64 * tau0,
            adev: avar.sqrt(),
            rel_error: 1.0 / (2.0 * independent as f64).sqrt(),
        }
    };
    // Each cluster size reads the whole record: on a long record the sizes are shared among
    // the cores (each point is computed alone, in a fixed order: the result does not depend
    // on the machine).
    if n < 100_000 {
        return ms.into_iter().map(point).collect();
    }
    ms.into_par_iter().map(point).collect()
}

/// `sum (c - 2 b + a)^2` over equal-length slices, in four independent lanes so that the
/// processor overlaps them (the sum's order is fixed: the result does not depend on the
/// machine).
fn second_differences(a: &[f64], b: &[f64], c: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let (a4, b4, c4) = (a.chunks_exact(4), b.chunks_exact(4), c.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .zip(c4.remainder())
        .map(|((a, b), c)| (c - 2.0 * b + a).powi(2))
        .sum();
    for ((a, b), c) in a4.zip(b4).zip(c4) {
        for k in 0..4 {
            let d = c[k] - 2.0 * b[k] + a[k];
            lanes[k] += d * d;
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// The IEEE Std 952 noise terms (zero when the curve does not show a term).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NoiseTerms {
    /// Quantization, `u s`.
    pub quantization: f64,
    /// Angle / velocity random walk, `u s^(1/2)` (`u/sqrt(Hz)`).
    pub random_walk: f64,
    /// Bias instability, `u`.
    pub bias_instability: f64,
    /// Rate random walk, `u / s^(1/2)`.
    pub rate_random_walk: f64,
    /// Rate ramp, `u / s`.
    pub rate_ramp: f64,
}

/// Shapes of the five terms at `tau`, as coefficients of the squared parameters.
fn shapes(tau: f64) -> [f64; 5] {
    [
        3.0 / (tau * tau),
        1.0 / tau,
        2.0 * std::f64::consts::LN_2 / std::f64::consts::PI,
        tau / 3.0,
        tau * tau / 2.0,
    ]
}

impl NoiseTerms {
    /// The Allan deviation these terms give at `tau`.
    #[must_use]
    pub fn adev(&self, tau: f64) -> f64 {
        let c = [
            self.quantization,
            self.random_walk,
            self.bias_instability,
            self.rate_random_walk,
            self.rate_ramp,
        ];
        shapes(tau)
            .iter()
            .zip(c)
            .map(|(s, c)| s * c * c)
            .sum::<f64>()
            .sqrt()
    }
}

/// Fits the noise terms to `curve`: the best non-negative fit over every subset of the five
/// shapes, then, while some term of it is not resolved, the best fit without that term.
///
/// A term is resolved when it is what the curve shows somewhere: at some cluster time with at
/// least [`MIN_CLUSTERS`] independent clusters its share of the fitted variance is at least
/// [`MIN_SHARE`]. Without that rule the fit spends a small bias instability, ramp or
/// quantization on the scatter of the points where two other terms cross (a record of white
/// noise and a rate random walk alone was given a bias instability on 81 of 120 axes; with it,
/// see `spurious` below).
#[must_use]
pub fn noise_terms(curve: &[Point]) -> NoiseTerms {
    let rows: Vec<(&Point, f64)> = curve
        .iter()
        .filter(|p| p.adev > 0.0)
        .map(|p| (p, 1.0 / (p.adev * p.adev * 2.0 * p.rel_error)))
        .collect();
    let mut allowed = 0b11111u32;
    loop {
        let Some(c) = best_fit(&rows, allowed) else {
            return NoiseTerms::from_squares([0.0; 5]);
        };
        match weakest_unresolved(&rows, &c) {
            Some(k) => allowed &= !(1 << k),
            None => return NoiseTerms::from_squares(c),
        }
    }
}

/// A term's least share of the fitted Allan variance, at its strongest, for it to be resolved.
pub const MIN_SHARE: f64 = 0.5;

/// The independent clusters a point needs for a term's share there to count.
pub const MIN_CLUSTERS: f64 = 16.0;

/// The squared coefficients of the best weighted non-negative fit using only the shapes in
/// the bit mask `allowed` (every subset of them tried), or `None` when none fits.
fn best_fit(rows: &[(&Point, f64)], allowed: u32) -> Option<[f64; 5]> {
    let mut best: Option<(f64, [f64; 5])> = None;
    for subset in 1u32..32 {
        if subset & !allowed != 0 {
            continue;
        }
        let cols: Vec<usize> = (0..5).filter(|k| subset >> k & 1 == 1).collect();
        if cols.len() > rows.len() {
            continue;
        }
        // Weighted rows: AVAR / (AVAR * relative error of AVAR) = shapes . c.
        let a = DMatrix::from_fn(rows.len(), cols.len(), |i, j| {
            shapes(rows[i].0.tau)[cols[j]] * rows[i].1
        });
        let b = DVector::from_fn(rows.len(), |i, _| {
            rows[i].0.adev * rows[i].0.adev * rows[i].1
        });
        let Some(x) = crate::stats::decompose::svd(a.clone(), true, true)
            .ok()
            .and_then(|svd| svd.solve(&b, 1e-12).ok())
        else {
            continue;
        };
        if x.iter().any(|v| *v < 0.0 || !v.is_finite()) {
            continue;
        }
        let rss = (&a * &x - &b).norm_squared();
        if best.as_ref().is_none_or(|(r, _)| rss < *r * (1.0 - 1e-9)) {
            let mut c = [0.0; 5];
            for (j, &k) in cols.iter().enumerate() {
                c[k] = x[j];
            }
            best = Some((rss, c));
        }
    }
    best.map(|b| b.1)
}

/// The non-zero term of squared coefficients `c` with the smallest greatest share of the
/// fitted variance over the well-sampled points, when that share is under [`MIN_SHARE`].
fn weakest_unresolved(rows: &[(&Point, f64)], c: &[f64; 5]) -> Option<usize> {
    let well_sampled = |p: &Point| 1.0 / (2.0 * p.rel_error * p.rel_error) >= MIN_CLUSTERS;
    let mut share = [0.0f64; 5];
    for (p, _) in rows.iter().filter(|(p, _)| well_sampled(p)) {
        let parts: Vec<f64> = shapes(p.tau).iter().zip(c).map(|(s, c)| s * c).collect();
        let total: f64 = parts.iter().sum();
        if total > 0.0 {
            for (s, v) in share.iter_mut().zip(&parts) {
                *s = s.max(v / total);
            }
        }
    }
    (0..5)
        .filter(|&k| c[k] > 0.0 && share[k] < MIN_SHARE)
        .min_by(|&a, &b| share[a].total_cmp(&share[b]))
}

impl NoiseTerms {
    /// The terms from their squares, in the order of [`shapes`].
    fn from_squares(c: [f64; 5]) -> Self {
        let c = c.map(f64::sqrt);
        Self {
            quantization: c[0],
            random_walk: c[1],
            bias_instability: c[2],
            rate_random_walk: c[3],
            rate_ramp: c[4],
        }
    }
}

/// What `calflash allan --json` writes (schema `calflash.allan/2`; `noise::stated` reads it,
/// and the one-sensor files of `calflash.allan/1` before it).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Record<'a> {
    /// `calflash.allan/2`.
    pub schema: &'static str,
    /// The recording.
    pub source: &'a str,
    /// Each sensor analysed: the accelerometer, the gyro, or both.
    pub sensors: Vec<SensorRecord<'a>>,
}

/// One sensor of a [`Record`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct SensorRecord<'a> {
    /// `accel` or `gyro`.
    pub sensor: &'static str,
    /// The unit of the values (`counts`, or an SI unit).
    pub unit: &'a str,
    /// Per axis, x, y, z.
    pub axes: Vec<AxisRecord<'a>>,
}

/// One axis of a [`SensorRecord`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct AxisRecord<'a> {
    /// `x`, `y` or `z`.
    pub axis: &'static str,
    /// The Allan deviation.
    pub curve: &'a [Point],
    /// Its noise terms.
    pub terms: &'a NoiseTerms,
}

/// The schema of [`Record`].
pub const SCHEMA: &str = "calflash.allan/2";

/// The schema of the one-sensor files written before (`sensor`'s fields at the top level).
pub const SCHEMA_ONE_SENSOR: &str = "calflash.allan/1";

/// The tau at which the fitted curve is lowest (where the bias instability is read), over the
/// curve's span.
#[must_use]
pub fn flattest(terms: &NoiseTerms, curve: &[Point]) -> Option<f64> {
    let (lo, hi) = (curve.first()?.tau, curve.last()?.tau);
    (0..=200)
        .map(|k| lo * (hi / lo).powf(f64::from(k) / 200.0))
        .min_by(|a, b| terms.adev(*a).total_cmp(&terms.adev(*b)))
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;

    #[test]
    fn white_noise_gives_its_density_at_every_tau() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let n = Normal::new(0.0, 1.0).unwrap();
        let tau0: f64 = 0.01;
        let density = 0.02; // u / sqrt(Hz)
        let y: Vec<f64> = (0..200_000)
            .map(|_| density / tau0.sqrt() * n.sample(&mut rng))
            .collect();
        let c = overlapping(&y, tau0, 1);
        for p in c.iter().filter(|p| p.tau <= 20.0) {
            let want = density / p.tau.sqrt();
            assert!(
                (p.adev / want - 1.0).abs() < 4.0 * p.rel_error + 0.01,
                "{p:?} want {want}"
            );
        }
    }
}

#[cfg(test)]
mod recovery {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;

    /// White rate noise of density `n_true` and a rate random walk of `k_true`, 10^7 samples at
    /// 100 Hz: both recovered within 10 %.
    #[test]
    fn recovers_random_walk_and_rate_random_walk_of_simulated_noise() {
        let (n_true, k_true, tau0): (f64, f64, f64) = (0.01, 2e-4, 0.01);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let g = Normal::new(0.0, 1.0).unwrap();
        let mut bias = 0.0;
        let y: Vec<f64> = (0..10_000_000)
            .map(|_| {
                bias += k_true * tau0.sqrt() * g.sample(&mut rng);
                bias + n_true / tau0.sqrt() * g.sample(&mut rng)
            })
            .collect();
        let curve = overlapping(&y, tau0, 2);
        let t = noise_terms(&curve);
        assert!((t.random_walk / n_true - 1.0).abs() < 0.10, "{t:?}");
        assert!((t.rate_random_walk / k_true - 1.0).abs() < 0.10, "{t:?}");
        // And the curve the terms give follows the measured one.
        for p in &curve {
            assert!(
                (t.adev(p.tau) / p.adev - 1.0).abs() < 3.0 * p.rel_error + 0.02,
                "{p:?} {}",
                t.adev(p.tau)
            );
        }
    }
}

#[cfg(test)]
mod flicker {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;

    /// Flicker (1/f) rate noise of bias instability `b` (IEEE 952: Allan floor `0.664 b`) at
    /// interval `tau0`, from a bank of first-order Gauss-Markov processes with corner
    /// frequencies an octave apart from `f_lo` to Nyquist.
    ///
    /// A process of variance `s^2` and corner `f_c` has the one-sided PSD
    /// `4 s^2 T / (1 + (f / f_c)^2)`, `T = 1 / (2 pi f_c)`; a bank of them with corners a ratio
    /// `r` apart and equal variances `s^2 = h ln r` sums to `h / f` between its corners (the
    /// integral over `ln f_c` of the Lorentzians; an octave spacing leaves a ripple well under
    /// 1 %). Flicker noise `h / f` has the Allan variance `2 ln 2 h`, which is IEEE 952's
    /// `(2 ln 2 / pi) B^2` for `h = B^2 / pi`.
    struct FlickerBank {
        phi: Vec<f64>,
        drive: Vec<f64>,
        state: Vec<f64>,
    }

    impl FlickerBank {
        fn new(b: f64, tau0: f64, f_lo: f64, rng: &mut impl rand::Rng) -> Self {
            let h = b * b / std::f64::consts::PI;
            let s = (h * std::f64::consts::LN_2).sqrt();
            let nyquist = 0.5 / tau0;
            let corners: Vec<f64> = (0..)
                .map(|i| f_lo * 2f64.powi(i))
                .take_while(|f| *f < nyquist)
                .collect();
            let g = Normal::new(0.0, 1.0).unwrap();
            let phi: Vec<f64> = corners
                .iter()
                .map(|f| (-2.0 * std::f64::consts::PI * f * tau0).exp())
                .collect();
            Self {
                drive: phi.iter().map(|p| s * (1.0 - p * p).sqrt()).collect(),
                // Started from the stationary distribution.
                state: phi.iter().map(|_| s * g.sample(rng)).collect(),
                phi,
            }
        }

        fn next(&mut self, rng: &mut impl rand::Rng, g: &Normal<f64>) -> f64 {
            let mut sum = 0.0;
            for ((x, p), d) in self.state.iter_mut().zip(&self.phi).zip(&self.drive) {
                *x = p * *x + d * g.sample(rng);
                sum += *x;
            }
            sum
        }
    }

    /// Bias instability `B` and white rate noise `N` together, 10^6 samples at 100 Hz: the
    /// floor of the curve gives `B` and its short-tau slope `N`, both within 10 %.
    #[test]
    fn recovers_bias_instability_of_simulated_flicker_noise() {
        let (b_true, n_true, tau0): (f64, f64, f64) = (1e-3, 2e-4, 0.01);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let g = Normal::new(0.0, 1.0).unwrap();
        let mut bank = FlickerBank::new(b_true, tau0, 1e-6, &mut rng);
        let y: Vec<f64> = (0..1_000_000)
            .map(|_| bank.next(&mut rng, &g) + n_true / tau0.sqrt() * g.sample(&mut rng))
            .collect();
        let curve = overlapping(&y, tau0, 2);
        let t = noise_terms(&curve);
        assert!((t.bias_instability / b_true - 1.0).abs() < 0.10, "{t:?}");
        assert!((t.random_walk / n_true - 1.0).abs() < 0.10, "{t:?}");
        // The floor: from 1 s to the end the curve stays within its uncertainty of 0.664 B.
        let floor = (2.0 * std::f64::consts::LN_2 / std::f64::consts::PI).sqrt() * b_true;
        for p in curve.iter().filter(|p| p.tau >= 1.0) {
            assert!(
                (p.adev / floor - 1.0).abs() < 3.0 * p.rel_error + 0.05,
                "{p:?} floor {floor}"
            );
        }
    }
}

#[cfg(test)]
mod spurious {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;

    /// One hour at 100 Hz of white noise of density `n` and a rate random walk `k` (plus a
    /// ramp `r`), read as integer counts at `per_unit` counts per unit, as a logger writes
    /// them.
    fn hour(seed: u64, (n, k, r): (f64, f64, f64), per_unit: f64) -> Vec<Point> {
        let tau0: f64 = 0.01;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let g = Normal::new(0.0, 1.0).unwrap();
        let mut bias = 0.0;
        let y: Vec<f64> = (0..360_000)
            .map(|i| {
                bias += k * tau0.sqrt() * g.sample(&mut rng);
                let v = bias + r * f64::from(i) * tau0 + n / tau0.sqrt() * g.sample(&mut rng);
                (v * per_unit).round() / per_unit
            })
            .collect();
        overlapping(&y, tau0, 2)
    }

    /// 20 simulated hours of white noise and a rate random walk alone, on an accelerometer's
    /// and a gyro's strengths (six axes each, 120 in all): no bias instability, ramp or
    /// quantization is reported on more than 1 axis in 20, and N and K are read on every
    /// one. (Before the rule, a bias instability on 81 of 120, a ramp on 47.)
    #[test]
    fn white_noise_and_a_random_walk_give_no_bias_instability_or_ramp() {
        let (mut b, mut r, mut q, mut nk, mut axes) = (0, 0, 0, 0, 0);
        for seed in 0..20u64 {
            for axis in 0..6u64 {
                let (strengths, per_unit) = if axis < 3 {
                    ((7.3e-4, 1.2e-4, 0.0), 412.0)
                } else {
                    ((2.2e-4, 2.2e-5, 0.0), 900.0)
                };
                let t = noise_terms(&hour(seed * 6 + axis, strengths, per_unit));
                axes += 1;
                b += usize::from(t.bias_instability > 0.0);
                r += usize::from(t.rate_ramp > 0.0);
                q += usize::from(t.quantization > 0.0);
                nk += usize::from(t.random_walk > 0.0 && t.rate_random_walk > 0.0);
            }
        }
        assert!(b * 20 <= axes, "bias instability on {b} of {axes} axes");
        assert!(r * 20 <= axes, "ramp on {r} of {axes} axes");
        assert!(q * 20 <= axes, "quantization on {q} of {axes} axes");
        assert_eq!(nk, axes, "N and K read on {nk} of {axes} axes");
    }

    /// The same rule keeps a ramp that is there: a drift of 2e-6 u/s over the hour beside
    /// white noise is read within 10 %.
    #[test]
    fn a_ramp_that_is_there_is_read() {
        let t = noise_terms(&hour(5, (2.2e-4, 0.0, 2e-6), 1e6));
        assert!((t.rate_ramp / 2e-6 - 1.0).abs() < 0.10, "{t:?}");
        assert!(t.bias_instability == 0.0, "{t:?}");
    }
}
