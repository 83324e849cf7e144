//! What a mission profile says at a glance: the range of each quantity and the time spent at
//! each level, the peak setback, the spin over time, and for a recorded flight the vibration
//! above the rigid-body motion (its spectrum per axis) with the rectification a g-squared term
//! makes of it: a unit whose output has `K2 f^2` reads `K2 <v^2>` too much on average when the
//! axis vibrates with mean square `<v^2>` (source text: the vibration environment "is not well
//! known"; a recorded flight measures it).

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

use super::{Profile, Quantity};

/// Standard gravity, m/s^2.
const G: f64 = 9.806_65;
/// The mean square below which a segment is never a transient, g^2 (1 mg rms).
const TRANSIENT_FLOOR: f64 = 1e-6;
/// Bins of a histogram.
pub const BINS: usize = 12;

/// One quantity's range and time at each level.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Range {
    /// The quantity's column name.
    pub name: &'static str,
    /// Lowest value, SI.
    pub min: f64,
    /// Highest.
    pub max: f64,
    /// Time-weighted mean.
    pub mean: f64,
    /// Time-weighted RMS.
    pub rms: f64,
    /// Share of the flight's time in each of [`BINS`] equal bins from `min` to `max`.
    pub time_share: Vec<f64>,
}

/// The peak specific force: the setback of a gun launch, the thrust of a rocket.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Peak {
    /// The axis (0, 1, 2).
    pub axis: usize,
    /// The signed value, m/s^2.
    pub value: f64,
    /// When, s.
    pub t: f64,
}

/// The spin: the axis with the largest mean absolute rate, and its rate over time.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Spin {
    /// The axis.
    pub axis: usize,
    /// The largest absolute rate about it, rev/s.
    pub peak_rev_s: f64,
    /// `(time, rev/s)` at the start and the end of each tenth of the flight.
    pub over_time: Vec<(f64, f64)>,
}

/// The vibration of one axis above the rigid-body motion.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Vibration {
    /// The axis.
    pub axis: usize,
    /// Mean square, g^2.
    pub mean_square_g2: f64,
    /// The rectification of a g-squared term of 1 ug/g^2, ug (numerically the mean square in
    /// g^2).
    pub rectification_ug_per_ug_g2: f64,
    /// The frequency of the spectrum's peak, Hz.
    pub peak_hz: f64,
    /// `(low Hz, high Hz, mean square g^2)` in octave bands from the cut-off to Nyquist.
    pub bands: Vec<(f64, f64, f64)>,
    /// Welch segments analysed.
    pub segments: usize,
    /// The start times of the segments left out as transients, s.
    pub transients: Vec<f64>,
}

/// A profile's summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// Samples.
    pub samples: usize,
    /// Duration, s.
    pub duration: f64,
    /// Median sampling step, s.
    pub step: f64,
    /// Each quantity the profile has.
    pub ranges: Vec<Range>,
    /// The peak specific force.
    pub peak: Option<Peak>,
    /// The spin.
    pub spin: Option<Spin>,
    /// The vibration above `vibration_above` Hz, when the sampling resolves it.
    pub vibration: Vec<Vibration>,
    /// The cut-off between rigid-body motion and vibration, Hz.
    pub vibration_above: f64,
    /// Why there is no vibration figure, when there is none.
    pub no_vibration: Option<String>,
    /// What was assumed while reading.
    pub notes: Vec<String>,
}

/// Summarises `p`, taking motion faster than `vibration_above` Hz as vibration.
#[must_use]
pub fn summarise(p: &Profile, vibration_above: f64) -> Summary {
    let dwell = p.dwell();
    let total: f64 = dwell.iter().sum();
    let mut steps: Vec<f64> = p.t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let step = steps[steps.len() / 2];
    let ranges = Quantity::all()
        .iter()
        .filter_map(|q| Some((q, p.series(*q)?)))
        .map(|(q, v)| range(q.name(), &v, &dwell, total))
        .collect();
    let peak = p.f.as_ref().and_then(|f| {
        let (i, k) = (0..f.len())
            .flat_map(|i| (0..3).map(move |k| (i, k)))
            .max_by(|a, b| f[a.0][a.1].abs().total_cmp(&f[b.0][b.1].abs()))?;
        Some(Peak {
            axis: k,
            value: f[i][k],
            t: p.t[i],
        })
    });
    let spin = p.w.as_ref().map(|w| spin(&p.t, w, &dwell));
    let nyquist = 0.5 / step;
    let (vibration, no_vibration) = match &p.f {
        None => (
            Vec::new(),
            Some("the profile has no specific force".to_string()),
        ),
        Some(_) if nyquist <= vibration_above * 1.5 => (
            Vec::new(),
            Some(format!(
                "sampled at {:.0} Hz, the profile resolves motion up to {nyquist:.0} Hz: nothing above {vibration_above} Hz to measure",
                1.0 / step
            )),
        ),
        Some(f) => (
            (0..3)
                .map(|k| vibration(&p.t, f, k, step, vibration_above))
                .collect(),
            None,
        ),
    };
    Summary {
        samples: p.len(),
        duration: p.duration(),
        step,
        ranges,
        peak,
        spin,
        vibration,
        vibration_above,
        no_vibration,
        notes: p.notes.clone(),
    }
}

fn range(name: &'static str, v: &[f64], dwell: &[f64], total: f64) -> Range {
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mean = v.iter().zip(dwell).map(|(x, d)| x * d).sum::<f64>() / total;
    let rms = (v.iter().zip(dwell).map(|(x, d)| x * x * d).sum::<f64>() / total).sqrt();
    let mut time_share = vec![0.0; BINS];
    let width = (max - min) / BINS as f64;
    for (x, d) in v.iter().zip(dwell) {
        let b = if width > 0.0 {
            (((x - min) / width) as usize).min(BINS - 1)
        } else {
            0
        };
        time_share[b] += d / total;
    }
    Range {
        name,
        min,
        max,
        mean,
        rms,
        time_share,
    }
}

fn spin(t: &[f64], w: &[[f64; 3]], dwell: &[f64]) -> Spin {
    let axis = (0..3)
        .max_by(|a, b| {
            let m = |k: usize| {
                w.iter()
                    .zip(dwell)
                    .map(|(v, d)| v[k].abs() * d)
                    .sum::<f64>()
            };
            m(*a).total_cmp(&m(*b))
        })
        .unwrap_or(0);
    let rev = |v: f64| v.abs() / std::f64::consts::TAU;
    let peak_rev_s = w.iter().map(|v| rev(v[axis])).fold(0.0, f64::max);
    let n = t.len();
    let over_time = (0..=10)
        .map(|k| {
            let i = (k * (n - 1)) / 10;
            (t[i], rev(w[i][axis]))
        })
        .collect();
    Spin {
        axis,
        peak_rev_s,
        over_time,
    }
}

/// The vibration of axis `k`: the specific force less its centred moving average over one
/// period of the cut-off, in Welch segments (Hann windows whose bins are at most half the
/// cut-off, half overlapped). Segments whose mean square is over ten times the lower quartile
/// segment's are transients (the quartile, not the median: in a record of a few segments, most
/// may hold the setback) (a setback, a motor's ignition and burnout, the muzzle exit): they are counted
/// and left out of the mean square and the spectrum, which describe the flight's steady
/// vibration.
fn vibration(t: &[f64], f: &[[f64; 3]], k: usize, step: f64, above: f64) -> Vibration {
    let x: Vec<f64> = f.iter().map(|v| v[k] / G).collect();
    let half = ((0.5 / above / step).round() as usize).max(1);
    let mut prefix = vec![0.0; x.len() + 1];
    for (i, v) in x.iter().enumerate() {
        prefix[i + 1] = prefix[i] + v;
    }
    let v: Vec<f64> = (0..x.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(x.len()));
            x[i] - (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect();
    // Segments long enough to resolve the cut-off (bins of at most half of it).
    let wanted = ((2.0 / (above * step)).ceil() as usize).next_power_of_two();
    let seg = wanted.min(v.len().next_power_of_two() / 2).max(8);
    let segments = welch_segments(&v, seg, step);
    let mut squares: Vec<f64> = segments.iter().map(|s| s.0).collect();
    squares.sort_by(f64::total_cmp);
    let quiet = squares.get(squares.len() / 4).copied().unwrap_or(0.0);
    // A segment of under 1 mg rms is never a transient.
    let steady = |ms: f64| ms <= (10.0 * quiet).max(TRANSIENT_FLOOR);
    let kept: Vec<&(f64, Vec<f64>, usize)> = segments.iter().filter(|s| steady(s.0)).collect();
    let transients: Vec<f64> = segments
        .iter()
        .filter(|s| !steady(s.0))
        .map(|s| t[s.2])
        .collect();
    let count = kept.len().max(1) as f64;
    let mean_square_g2 = kept.iter().map(|s| s.0).sum::<f64>() / count;
    let mut psd = vec![0.0; seg / 2 + 1];
    for s in &kept {
        for (p, q) in psd.iter_mut().zip(&s.1) {
            *p += q / count;
        }
    }
    let df = 1.0 / (seg as f64 * step);
    let peak = psd
        .iter()
        .enumerate()
        .skip(1)
        .filter(|(j, _)| *j as f64 * df >= above)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0.0, |(j, _)| j as f64 * df);
    let nyquist = 0.5 / step;
    let mut bands = Vec::new();
    let mut lo = above;
    while lo < nyquist {
        let hi = (2.0 * lo).min(nyquist);
        let ms: f64 = psd
            .iter()
            .enumerate()
            .filter(|(j, _)| {
                let fj = *j as f64 * df;
                fj >= lo && fj < hi
            })
            .map(|(_, p)| p * df)
            .fold(0.0, |a, b| a + b);
        bands.push((lo, hi, ms));
        lo = hi;
    }
    Vibration {
        axis: k,
        mean_square_g2,
        rectification_ug_per_ug_g2: mean_square_g2,
        peak_hz: peak,
        bands,
        segments: segments.len(),
        transients,
    }
}

/// Welch's segments of `x` (sampled every `step` s), `seg` samples long, half overlapped:
/// each segment's mean square, its one-sided power spectral density per Hz (Hann window) at
/// `j / (seg step)` Hz for `j` in `0..=seg/2`, and its first sample.
fn welch_segments(x: &[f64], seg: usize, step: f64) -> Vec<(f64, Vec<f64>, usize)> {
    let window: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / seg as f64).cos())
        .collect();
    let power: f64 = window.iter().map(|w| w * w).sum();
    let fft = FftPlanner::new().plan_fft_forward(seg);
    let mut out = Vec::new();
    let mut buf = vec![Complex::new(0.0, 0.0); seg];
    let mut start = 0;
    while start + seg <= x.len() {
        let part = &x[start..start + seg];
        for (i, b) in buf.iter_mut().enumerate() {
            *b = Complex::new(part[i] * window[i], 0.0);
        }
        fft.process(&mut buf);
        let scale = step / power;
        let psd = (0..=seg / 2)
            .map(|j| buf[j].norm_sqr() * scale * if j == 0 || j == seg / 2 { 1.0 } else { 2.0 })
            .collect();
        let ms = part.iter().map(|v| v * v).sum::<f64>() / seg as f64;
        out.push((ms, psd, start));
        start += seg / 2;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(t: Vec<f64>, f: Vec<[f64; 3]>) -> Profile {
        let n = t.len();
        Profile {
            source: "test".into(),
            t,
            line: (1..=n as u64).collect(),
            w: Some(vec![[0.0, 10.0, 0.0]; n]),
            dw: Some(vec![[0.0; 3]; n]),
            f: Some(f),
            temp: None,
            volt: None,
            notes: Vec::new(),
        }
    }

    #[test]
    fn a_sine_of_known_amplitude_has_its_mean_square_its_peak_and_its_band() {
        // 1 g at 1 s^-1 (rigid-body) plus 0.5 g at 120 Hz, sampled at 2 kHz for 4 s.
        let rate = 2_000.0;
        let t: Vec<f64> = (0..8_000).map(|i| f64::from(i) / rate).collect();
        let f = t
            .iter()
            .map(|t| {
                let v = 0.5 * G * (std::f64::consts::TAU * 120.0 * t).sin();
                [G * (std::f64::consts::TAU * t).sin() + v, 0.0, -G]
            })
            .collect();
        let s = summarise(&profile(t, f), 20.0);
        let x = &s.vibration[0];
        // 0.5^2 / 2 = 0.125 g^2, less the small share the moving average keeps.
        assert!((x.mean_square_g2 - 0.125).abs() < 0.01, "{x:?}");
        assert!((x.peak_hz - 120.0).abs() < 8.0, "{x:?}");
        let band = x
            .bands
            .iter()
            .find(|b| b.0 <= 120.0 && 120.0 < b.1)
            .unwrap();
        assert!((band.2 - 0.125).abs() < 0.015, "{:?}", x.bands);
        assert!(s.vibration[2].mean_square_g2 < 1e-20);
        assert!(x.transients.is_empty());
        assert_eq!(s.spin.as_ref().unwrap().axis, 1);
        let peak = s.peak.unwrap();
        assert!(peak.value.abs() > G);
    }

    #[test]
    fn time_at_each_level_weighs_samples_by_the_time_they_stand_for() {
        // Three samples at 0, 0.1 and 1.0 s: the last two stand for most of the time.
        let t = vec![0.0, 0.1, 1.0];
        let f = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let s = summarise(&profile(t, f), 20.0);
        let fx = &s.ranges[0];
        assert_eq!(fx.name, "f_x");
        assert!((fx.time_share[0] - 0.05).abs() < 1e-12);
        assert!((fx.time_share[BINS - 1] - 0.95).abs() < 1e-12);
        assert!(s.no_vibration.is_some());
    }
}

#[cfg(test)]
mod transients {
    use super::*;

    #[test]
    fn a_shock_is_counted_apart_from_the_steady_vibration() {
        // 0.1 g at 200 Hz for 4 s at 2 kHz, with a 50 g, 5 ms shock at 2 s.
        let rate = 2_000.0;
        let t: Vec<f64> = (0..8_000).map(|i| f64::from(i) / rate).collect();
        let f: Vec<[f64; 3]> = t
            .iter()
            .map(|t| {
                let shock = if (2.0..2.005).contains(t) {
                    50.0 * G
                } else {
                    0.0
                };
                [
                    0.1 * G * (std::f64::consts::TAU * 200.0 * t).sin() + shock,
                    0.0,
                    G,
                ]
            })
            .collect();
        let n = t.len();
        let p = Profile {
            source: "shock".into(),
            t,
            line: (1..=n as u64).collect(),
            f: Some(f),
            w: None,
            dw: None,
            temp: None,
            volt: None,
            notes: Vec::new(),
        };
        let v = &summarise(&p, 20.0).vibration[0];
        assert!((v.mean_square_g2 - 0.005).abs() < 0.0005, "{v:?}");
        assert!(!v.transients.is_empty() && v.transients.len() < 6, "{v:?}");
        assert!(v.transients.iter().all(|t| (1.8..2.1).contains(t)), "{v:?}");
        // A record of 0.3 s around the shock: two of its three segments hold it, and it is
        // still a transient, not the vibration (it was, when the median segment held it).
        let keep: Vec<usize> = (0..n).filter(|&i| (1.85..2.15).contains(&p.t[i])).collect();
        let short = Profile {
            t: keep.iter().map(|&i| p.t[i]).collect(),
            line: keep.iter().map(|&i| p.line[i]).collect(),
            f: p.f.as_ref().map(|f| keep.iter().map(|&i| f[i]).collect()),
            ..p.clone()
        };
        let v = &summarise(&short, 20.0).vibration[0];
        assert!(!v.transients.is_empty(), "{v:?}");
        // The one segment kept holds the edge of the shock's smeared moving average: far
        // below the shock's own mean square (over 5 g^2), not the steady 0.005.
        assert!(v.mean_square_g2 < 0.2, "{v:?}");
    }
}
