//! Clipping found from the data (issue 66: a sensor read in physical units has no converter
//! rails to hold its samples against, so an ADXL355 pinned at +-20.48 m/s^2 went unnoticed).
//! An axis is clipped at its largest (or smallest) value when the samples pile up there: at
//! least [`MIN_PINNED`] of them exactly at that value, some in a run, more than in the band of
//! values just inside it, on an axis that moves far beyond its sample-to-sample steps.

/// The fewest samples exactly at an extreme for it to be a clip level.
pub const MIN_PINNED: usize = 3;

/// One side of one axis found clipped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clip {
    /// The axis, 0 to 2.
    pub axis: usize,
    /// The value the samples are pinned at.
    pub level: f64,
    /// Its largest value (else its smallest).
    pub high: bool,
    /// How many samples are at it.
    pub samples: usize,
}

impl Clip {
    /// Whether `sample` is at this clip level or beyond it.
    #[must_use]
    pub fn holds(&self, sample: &[f64; 3]) -> bool {
        let x = sample[self.axis];
        if self.high {
            x >= self.level
        } else {
            x <= self.level
        }
    }
}

impl std::fmt::Display for Clip {
    /// "x at 20.48 (21 samples)".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} at {} ({} samples)",
            ["x", "y", "z"][self.axis],
            self.level,
            self.samples
        )
    }
}

/// The clip levels of `values` (each axis, each side).
#[must_use]
pub fn clips(values: &[[f64; 3]]) -> Vec<Clip> {
    let mut found = Vec::new();
    for axis in 0..3 {
        let x: Vec<f64> = values.iter().map(|v| v[axis]).collect();
        if x.len() < 10 {
            continue;
        }
        let (lo, hi) = x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let range = hi - lo;
        let (median, _) = crate::stats::robust::median_mad(&x);
        // A still axis (its extremes a few steps of its sample-to-sample noise) cannot tell a
        // clip from a repeated reading.
        let steps: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        let (mut step, _) = crate::stats::robust::median_mad(&steps);
        if step == 0.0 {
            // Readings that mostly repeat: their quantum.
            step = steps
                .iter()
                .copied()
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min);
        }
        if range <= 20.0 * step || !step.is_finite() {
            continue;
        }
        for (level, high) in [(lo, false), (hi, true)] {
            if (level - median).abs() < 0.25 * range {
                continue;
            }
            let pinned = x.iter().filter(|v| **v == level).count();
            let run = x.windows(2).any(|w| w[0] == level && w[1] == level);
            // The band just inside the extreme: a signal that peaks there without a clip has
            // more samples near its peak than exactly at it.
            let band = 0.02 * range;
            let inside = x
                .iter()
                .filter(|v| **v != level && (**v - level).abs() < band)
                .count();
            if pinned >= MIN_PINNED && run && pinned > inside {
                found.push(Clip {
                    axis,
                    level,
                    high,
                    samples: pinned,
                });
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A turn to +-25 m/s^2 read by a sensor that clips at +-20.48: both sides found, with the
    /// samples at them; the same motion unclipped, a sine's peaks, and a still axis are not.
    #[test]
    fn a_pile_up_at_an_extreme_is_a_clip_and_a_peak_is_not() {
        let motion = |k: usize| 25.0 * (k as f64 * 0.01).sin();
        let clipped: Vec<[f64; 3]> = (0..2000)
            .map(|k| {
                let v = motion(k).clamp(-20.48, 20.48);
                // A quantized reading, as a logger writes it.
                [(v * 1000.0).round() / 1000.0, 0.01 * (k % 7) as f64, 9.81]
            })
            .collect();
        let c = clips(&clipped);
        assert_eq!(c.len(), 2, "{c:?}");
        assert!(
            c.iter()
                .all(|c| c.axis == 0 && c.level.abs() == 20.48 && c.samples > 50)
        );
        let free: Vec<[f64; 3]> = (0..2000)
            .map(|k| [(motion(k) * 1000.0).round() / 1000.0, 0.0, 9.81])
            .collect();
        assert!(clips(&free).is_empty(), "{:?}", clips(&free));
        // A still axis whose readings repeat their extremes, and one that mostly repeats one.
        let still: Vec<[f64; 3]> = (0..2000)
            .map(|k| [0.01 * ((k * 7919) % 5) as f64, 0.0, 9.81])
            .collect();
        assert!(clips(&still).is_empty());
        let quiet: Vec<[f64; 3]> = (0..2000)
            .map(|k| [if k % 50 < 3 { 0.01 } else { 0.0 }, 0.0, 9.81])
            .collect();
        assert!(clips(&quiet).is_empty());
    }
}
