//! The stillness detector's window: per output, the mean and the sample variance of `n`
//! corrected samples, accumulated about the window's first sample (so that single precision
//! keeps the variance of a 9.8 m/s^2 signal with millimetre-per-second-squared noise).

use super::OUTPUTS;

/// One window's statistics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stats {
    /// Per output, the mean.
    pub mean: [f32; OUTPUTS],
    /// Per output, the sample variance (`n - 1` in the denominator).
    pub var: [f32; OUTPUTS],
}

/// A window being filled.
#[derive(Debug, Clone, Copy)]
pub(super) struct Window {
    len: u16,
    count: u16,
    origin: [f32; OUTPUTS],
    sum: [f32; OUTPUTS],
    sumsq: [f32; OUTPUTS],
}

impl Window {
    /// An empty window of `len` samples (at least 2).
    pub const fn new(len: u16) -> Self {
        Self {
            len: if len < 2 { 2 } else { len },
            count: 0,
            origin: [0.0; OUTPUTS],
            sum: [0.0; OUTPUTS],
            sumsq: [0.0; OUTPUTS],
        }
    }

    /// Samples per window.
    pub const fn len(&self) -> u16 {
        self.len
    }

    /// Adds one sample (finite values); returns the window's statistics when it is full and
    /// starts the next one.
    #[inline]
    pub fn push(&mut self, values: &[f32; OUTPUTS]) -> Option<Stats> {
        if self.count == 0 {
            self.origin = *values;
        }
        for (((s, q), o), v) in self
            .sum
            .iter_mut()
            .zip(self.sumsq.iter_mut())
            .zip(&self.origin)
            .zip(values)
        {
            let d = v - o;
            *s += d;
            *q += d * d;
        }
        self.count += 1;
        if self.count < self.len {
            return None;
        }
        let n = f32::from(self.len);
        let mut stats = Stats {
            mean: [0.0; OUTPUTS],
            var: [0.0; OUTPUTS],
        };
        for (i, ((m, v), (s, q))) in stats
            .mean
            .iter_mut()
            .zip(stats.var.iter_mut())
            .zip(self.sum.iter().zip(&self.sumsq))
            .enumerate()
        {
            let d = s / n;
            *m = self.origin.get(i).copied().unwrap_or(0.0) + d;
            *v = ((q - s * d) / (n - 1.0)).max(0.0);
        }
        self.clear();
        Some(stats)
    }

    /// Drops the samples gathered so far.
    pub fn clear(&mut self) {
        self.count = 0;
        self.sum = [0.0; OUTPUTS];
        self.sumsq = [0.0; OUTPUTS];
    }
}

#[cfg(test)]
#[expect(clippy::unwrap_used, reason = "a test: the window is full")]
mod tests {
    use super::*;

    #[test]
    fn mean_and_variance_of_a_window() {
        let mut w = Window::new(4);
        let xs = [9.80, 9.81, 9.79, 9.82];
        let mut out = None;
        for x in xs {
            out = w.push(&[x, 0.0, 1.0, 0.0, 0.0, 0.0]);
        }
        let s = out.unwrap();
        let mean = xs.iter().sum::<f32>() / 4.0;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / 3.0;
        assert!((s.mean[0] - mean).abs() < 1e-6);
        assert!((s.var[0] / var - 1.0).abs() < 1e-3, "{} {var}", s.var[0]);
        assert_eq!(s.mean[2], 1.0);
        assert_eq!(s.var[2], 0.0);
        // The next window starts afresh.
        assert!(w.push(&[0.0; 6]).is_none());
    }
}
