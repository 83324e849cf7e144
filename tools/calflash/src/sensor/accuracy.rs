//! A corrected stream held against its reference (a spin rig's or a rate table's known
//! inputs): per output, the mean and RMS error of the samples the device did not flag, and the
//! mean 1-sigma it stated for them.

/// Running sums per output.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    names: Vec<String>,
    n: usize,
    sum: Vec<f64>,
    square: Vec<f64>,
    sigma: Vec<f64>,
    stated: usize,
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
            stated: 0,
        }
    }

    /// Adds one clean sample: its corrected `values`, the `reference` and the stated `sigma`.
    pub fn add(&mut self, values: &[f32], reference: &[f64], sigma: Option<&[f32]>) {
        for (k, (v, r)) in values.iter().zip(reference).enumerate() {
            let e = f64::from(*v) - r;
            self.sum[k] += e;
            self.square[k] += e * e;
            if let Some(s) = sigma.and_then(|s| s.get(k)) {
                self.sigma[k] += f64::from(*s);
            }
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
            .map(|(k, name)| Row {
                name: name.clone(),
                mean: self.sum[k] / n,
                rms: (self.square[k] / n).sqrt(),
                sigma: (self.stated == self.n).then(|| self.sigma[k] / n),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_rms_and_stated_sigma() {
        let mut a = Accuracy::new(&["x", "y"]);
        a.add(&[1.0, 2.0], &[0.0, 2.0], Some(&[0.5, 0.1]));
        a.add(&[-1.0, 2.5], &[0.0, 2.0], Some(&[0.7, 0.3]));
        let r = a.rows();
        assert_eq!((r[0].mean, r[0].rms), (0.0, 1.0));
        assert!((r[1].mean - 0.25).abs() < 1e-12 && (r[1].rms - 0.125f64.sqrt()).abs() < 1e-12);
        assert!((r[0].sigma.unwrap() - 0.6).abs() < 1e-7);
        a.add(&[0.0, 2.0], &[0.0, 2.0], None);
        assert_eq!(a.rows()[0].sigma, None);
        assert_eq!(a.count(), 3);
    }
}
