//! A corrected stream held against its reference (a spin rig's or a rate table's known
//! inputs, a simulated flight's truth): per output, the mean and RMS error of the samples the
//! device did not flag and the mean 1-sigma it stated for them, with robust figures beside
//! them (the median error, the robust spread `1.4826 MAD`, the 99th percentile of the absolute
//! error, the worst sample and the samples far out: more than five robust spreads from the
//! median, which a Gaussian error makes once in two million), and every error kept for a
//! figure. The stated 1-sigma is the calibration's error alone; the spread includes each
//! sample's noise.
//!
//! The stated 1-sigma is judged against the errors, per output ([`Statement`]): a typical
//! (median) stated 1-sigma over three times the RMS error is overstated (a check against it
//! cannot fail), a mean error beyond three of its sigmas (the stated 1-sigma, which does not
//! average out, with the noise over the root of the samples, which does) is understated.

/// Running sums per output, and each sample's error.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    names: Vec<String>,
    n: usize,
    sum: Vec<f64>,
    square: Vec<f64>,
    sigma: Vec<f64>,
    /// Per output, each sample's stated 1-sigma.
    stated_each: Vec<Vec<f64>>,
    stated: usize,
    /// Per output: `(sample index, error)`.
    errors: Vec<Vec<(usize, f64)>>,
}

/// One output's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The output.
    pub name: String,
    /// Mean error (corrected minus reference).
    pub mean: f64,
    /// RMS error.
    pub rms: f64,
    /// Mean stated 1-sigma, when every sample stated one.
    pub sigma: Option<f64>,
    /// The typical stated 1-sigma: their median, when every sample stated one.
    pub typical: Option<f64>,
    /// Median error.
    pub median: f64,
    /// 99th percentile of the absolute error.
    pub p99: f64,
    /// The largest absolute error and its sample's index.
    pub worst: (f64, usize),
    /// The robust spread of the errors, `1.4826` times their median absolute deviation.
    pub spread: f64,
    /// Samples more than five robust spreads from the median error.
    pub far_out: usize,
}

impl Accuracy {
    /// Empty sums for the outputs `names`.
    #[must_use]
    pub fn new(names: &[&str]) -> Self {
        let k = names.len();
        Self {
            names: names.iter().map(|s| (*s).to_string()).collect(),
            n: 0,
            sum: vec![0.0; k],
            square: vec![0.0; k],
            sigma: vec![0.0; k],
            stated_each: vec![Vec::new(); k],
            stated: 0,
            errors: vec![Vec::new(); k],
        }
    }

    /// Adds clean sample `index`: its corrected `values`, the `reference` and the stated
    /// `sigma`.
    pub fn add(&mut self, index: usize, values: &[f32], reference: &[f64], sigma: Option<&[f32]>) {
        for (k, (v, r)) in values.iter().zip(reference).enumerate() {
            let e = f64::from(*v) - r;
            self.sum[k] += e;
            self.square[k] += e * e;
            if let Some(s) = sigma.and_then(|s| s.get(k)) {
                self.sigma[k] += f64::from(*s);
                self.stated_each[k].push(f64::from(*s));
            }
            self.errors[k].push((index, e));
        }
        self.n += 1;
        self.stated += usize::from(sigma.is_some());
    }

    /// Samples added.
    #[must_use]
    pub fn count(&self) -> usize {
        self.n
    }

    /// The figures per output (empty before any sample).
    #[must_use]
    pub fn rows(&self) -> Vec<Row> {
        if self.n == 0 {
            return Vec::new();
        }
        let n = self.n as f64;
        self.names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let errors = &self.errors[k];
                let mut signed: Vec<f64> = errors.iter().map(|e| e.1).collect();
                signed.sort_by(f64::total_cmp);
                let median = quantile(&signed, 0.5);
                let mut absolute: Vec<f64> = signed.iter().map(|e| e.abs()).collect();
                absolute.sort_by(f64::total_cmp);
                let mut deviation: Vec<f64> = signed.iter().map(|e| (e - median).abs()).collect();
                deviation.sort_by(f64::total_cmp);
                let spread = 1.4826 * quantile(&deviation, 0.5);
                let worst = errors
                    .iter()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .map_or((0.0, 0), |e| (e.1.abs(), e.0));
                Row {
                    name: name.clone(),
                    mean: self.sum[k] / n,
                    rms: (self.square[k] / n).sqrt(),
                    sigma: (self.stated == self.n).then(|| self.sigma[k] / n),
                    typical: (self.stated == self.n).then(|| {
                        let mut v = self.stated_each[k].clone();
                        v.sort_by(f64::total_cmp);
                        quantile(&v, 0.5)
                    }),
                    median,
                    p99: quantile(&absolute, 0.99),
                    worst,
                    spread,
                    far_out: deviation.iter().filter(|d| **d > 5.0 * spread).count(),
                }
            })
            .collect()
    }

    /// Output `k`'s errors: `(sample index, error)`.
    #[must_use]
    pub fn errors(&self, k: usize) -> &[(usize, f64)] {
        self.errors.get(k).map_or(&[], Vec::as_slice)
    }

    /// Output `k`'s stated 1-sigma at each clean sample (in the order of [`Accuracy::errors`]),
    /// when every sample stated one.
    #[must_use]
    pub fn stated(&self, k: usize) -> Option<&[f64]> {
        (self.stated == self.n && self.n > 0)
            .then(|| self.stated_each.get(k).map(Vec::as_slice))
            .flatten()
    }

    /// The outputs' names.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }
}

/// What the errors say of an output's stated 1-sigma.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Statement {
    /// Neither overstated nor understated.
    Holds,
    /// The typical stated 1-sigma is over three times the RMS error: a check against it
    /// cannot fail.
    Overstated,
    /// The mean error is beyond three of its sigmas.
    Understated,
    /// No 1-sigma stated.
    None,
}

impl Row {
    /// The mean error over its sigma: the typical stated 1-sigma (the calibration's error,
    /// which does not average out) and the robust spread over `sqrt(n)` (the noise, which
    /// does), for `n` samples.
    #[must_use]
    pub fn mean_z(&self, n: usize) -> Option<f64> {
        let sigma = self.typical?;
        let sd = (sigma * sigma + self.spread * self.spread / n.max(1) as f64).sqrt();
        (sd > 0.0).then(|| self.mean / sd)
    }

    /// The stated 1-sigma judged against the errors of `n` samples.
    #[must_use]
    pub fn statement(&self, n: usize) -> Statement {
        let Some(typical) = self.typical else {
            return Statement::None;
        };
        if self.mean_z(n).is_some_and(|z| z.abs() > 3.0) {
            Statement::Understated
        } else if typical > 3.0 * self.rms {
            Statement::Overstated
        } else {
            Statement::Holds
        }
    }
}

/// The `q` quantile of sorted values (linear between order statistics).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    match sorted.len() {
        0 => 0.0,
        1 => sorted[0],
        n => {
            let at = q * (n - 1) as f64;
            let (i, frac) = (at.floor() as usize, at.fract());
            let next = sorted[(i + 1).min(n - 1)];
            sorted[i] + frac * (next - sorted[i])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_rms_and_stated_sigma() {
        let mut a = Accuracy::new(&["x", "y"]);
        a.add(0, &[1.0, 2.0], &[0.0, 2.0], Some(&[0.5, 0.1]));
        a.add(1, &[-1.0, 2.5], &[0.0, 2.0], Some(&[0.7, 0.3]));
        let r = a.rows();
        assert_eq!((r[0].mean, r[0].rms), (0.0, 1.0));
        assert!((r[1].mean - 0.25).abs() < 1e-12 && (r[1].rms - 0.125f64.sqrt()).abs() < 1e-12);
        assert!((r[0].sigma.unwrap() - 0.6).abs() < 1e-7);
        assert!((r[0].typical.unwrap() - 0.6).abs() < 1e-7);
        assert_eq!(r[1].worst, (0.5, 1));
        a.add(2, &[0.0, 2.0], &[0.0, 2.0], None);
        assert_eq!(a.rows()[0].sigma, None);
        assert_eq!(a.count(), 3);
        assert_eq!(a.errors(0), &[(0, 1.0), (1, -1.0), (2, 0.0)]);
    }

    #[test]
    fn robust_figures_ignore_a_few_wild_samples() {
        let mut a = Accuracy::new(&["x"]);
        for i in 0..1000 {
            let e = if i % 250 == 0 {
                100.0
            } else {
                0.001 * f64::from(i % 7)
            };
            a.add(i as usize, &[e as f32], &[0.0], None);
        }
        let r = &a.rows()[0];
        assert!(r.rms > 6.0, "the RMS sees the four wild samples");
        assert!(r.median < 0.01 && r.p99 < 0.01, "{r:?}");
        assert_eq!(r.worst.0, 100.0);
        assert_eq!(r.far_out, 4, "{r:?}");
        assert!(r.spread > 0.0 && r.spread < 0.01, "{r:?}");
    }

    /// The two flags on a stated 1-sigma: 245 against an RMS error of 3.8 (the spinning round's
    /// a_z before its factor was mended) is overstated; a mean error of 1 against a stated 0.1
    /// is understated; a stated 1-sigma of the error's size holds.
    #[test]
    fn a_stated_sigma_is_flagged_overstated_or_understated() {
        let judge = |sigma: f32, bias: f64| {
            let mut a = Accuracy::new(&["x"]);
            for i in 0..2000 {
                let noise = 3.8 * (f64::from(i) * 0.7).sin() * std::f64::consts::SQRT_2;
                a.add(i as usize, &[(bias + noise) as f32], &[0.0], Some(&[sigma]));
            }
            a.rows()[0].statement(a.count())
        };
        assert_eq!(judge(245.0, 0.0), Statement::Overstated);
        assert_eq!(judge(0.1, 1.0), Statement::Understated);
        assert_eq!(judge(0.3, 0.1), Statement::Holds);
        assert_eq!(judge(0.3, 0.1), Statement::Holds);
        let mut none = Accuracy::new(&["x"]);
        none.add(0, &[1.0], &[0.0], None);
        assert_eq!(none.rows()[0].statement(1), Statement::None);
    }
}
