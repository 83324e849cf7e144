//! Is the calibration still good? The unit judges it at rest, in use.
//!
//! A [`RestMonitor`] watches the corrected samples of an [`ImuCorrector`]. Its stillness
//! detector cuts them into windows of [`WINDOW`] samples and calls a window *quiet* when every
//! output's sample variance is what the stored white noise and the quantisation explain
//! (`(n-1) s^2 / sigma^2` below the chi-square quantile at [`STILL_MISS`]), and *steady* when
//! its means also agree with the previous quiet window's (chi-square with 6 degrees of freedom).
//! A quiet, steady window is rest: its mean gyro rate is zero and its mean specific force has
//! the magnitude of gravity, direction unknown.
//!
//! Each rest window updates a Kalman filter over the biases (`health/filter.rs`); two of them run side
//! by side, one whose prior is the stored calibration's (each output's stated 1-sigma at the
//! rest pose, Earth's rate included for the gyros), one whose prior adds what ageing may
//! explain (the bias random walk over the stored ageing time). The accelerometer's state is
//! its parameters' error (bias, sensitivity row, g-squared term: what the calibration's
//! covariance factors state), so that its error at each pose, and what one pose teaches about
//! the next, follow from one prior. The process noise is the bias random walk over each window;
//! a change of pose adds the part of the gyros' stated error that depends on it. The verdict comes from each filter's per-axis
//! statistic `x^2 / (spread - P)`, chi-square with one degree of freedom when its prior holds,
//! tested on the axes the data observe with Bonferroni's correction, at checkpoints after
//! 1, 2, 4, 8, ... rest windows of one rest period, the `j`-th spending `alpha / 2^(j+1)` of
//! the stored false-alarm rate `alpha` (so that a whole rest period, however long, spends at
//! most `alpha`):
//!
//! - [`Verdict::Ok`]: the factory prior holds;
//! - [`Verdict::Drifted`]: it does not, but the aged prior does: the aged filter's refined
//!   biases go to the corrector as an [`Overlay`] (in RAM; the stored calibration is never
//!   touched), refreshed at every later checkpoint, and its [`sigma`](ImuCorrector::sigma)
//!   uses their variances (the gyros' with Earth's rate, which the unit cannot tell from a
//!   bias);
//! - [`Verdict::Suspect`]: not even ageing explains it (shock damage or a fault): every sample
//!   is flagged [`Flags::CALIBRATION_SUSPECT`] until [`RestMonitor::reset`].
//!
//! What it cannot do: refine in flight (no reference then: a GNSS velocity or attitude would
//! be one, through the same filter with the navigation states added); tell a slow turn about
//! the vertical (a turntable) from a gyro bias; see an accelerometer bias across gravity
//! until the unit is turned.
//!
//! ```
//! use spincal::{correct::ImuCorrector, health::{RestMonitor, Verdict}, model::*};
//!
//! let cal = Calibration::new(CalibrationData::example_imu())?;
//! let mut imu = ImuCorrector::<u16>::new(&cal, 1000.0)?;
//! imu.set_environment(25.0, 3.3);
//! let mut health = RestMonitor::new(&cal, 1000.0)?;
//! let raw = [32768u16; 6];
//! let out = imu.correct(raw);
//! health.observe_rest(&mut imu, &out);
//! assert_eq!(health.health().verdict, Verdict::NotYet);
//! # Ok::<(), spincal::Error>(())
//! ```

mod filter;
mod quantile;
mod window;

use serde::{Deserialize, Serialize};

use crate::Error;
use crate::correct::{Corrected, Flags, ImuCorrector, Overlay, Sample};
use crate::model::{Calibration, Sensor, Span};
use filter::Filter;
use window::{Stats, Window};

/// Outputs of an IMU sample.
const OUTPUTS: usize = 6;

/// Samples per window of the stillness detector.
pub const WINDOW: u16 = 64;

/// The probability that one output of a window at rest fails the quiet or the steady test
/// (the window is then taken as moving and lost, and the rest period ends).
pub const STILL_MISS: f64 = 1e-4;

/// Rest windows before a rest period's first checkpoint (0.5 s at 1 kHz): a checkpoint on
/// less data spends its share of the false-alarm rate for little power.
pub const FIRST_CHECKPOINT: u32 = 8;

/// Earth's rate, rad/s: at rest the gyros read it, in a direction the unit does not know.
const EARTH_RATE: f32 = 7.292_115e-5;

/// Flags that keep a sample out of the stillness detector: a converter at its rail (the true
/// value is unknown) or no calibration. A value beyond the calibrated range is kept: it is the
/// model's extrapolation, and at rest after a 1 g bench half of a vertical axis' readings lie
/// just beyond the range; leaving them out would censor the rest's mean (pulling the refined
/// bias down) or, for a unit shocked upward, leave it unjudged.
const UNUSABLE: Flags =
    Flags::from_bits_truncate(Flags::SATURATED.bits() | Flags::NO_CALIBRATION.bits());

/// What the unit concludes about its calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Verdict {
    /// No rest seen yet.
    NotYet,
    /// What the unit sees at rest agrees with its calibration.
    Ok,
    /// The biases have moved, within what ageing explains: refined biases are applied.
    Drifted,
    /// The biases have moved beyond what ageing explains: every sample is flagged.
    Suspect,
}

impl Verdict {
    /// The verdict in capitals, as the reports write it.
    #[must_use]
    pub const fn word(self) -> &'static str {
        match self {
            Verdict::NotYet => "NOT-YET",
            Verdict::Ok => "OK",
            Verdict::Drifted => "DRIFTED",
            Verdict::Suspect => "SUSPECT",
        }
    }
}

/// The unit's health, as [`RestMonitor::health`] reports it (and the protocol carries it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// The verdict.
    pub verdict: Verdict,
    /// The refined biases `[ax, ay, az, wx, wy, wz]` under the aged prior, m/s^2 and rad/s
    /// (the overlay when DRIFTED).
    pub bias: [f32; OUTPUTS],
    /// Their 1-sigma.
    pub bias_sigma: [f32; OUTPUTS],
    /// Each bias's 1-sigma as the stored calibration states it (its covariance at the first
    /// rest pose, Earth's rate included for the gyros, with the random walk since): what a
    /// refined bias is held against.
    pub stated_sigma: [f32; OUTPUTS],
    /// The accelerometer biases' covariance, packed upper triangle (`00 01 02 11 12 22`).
    pub accel_covariance: [f32; 6],
    /// The error of the assumed magnitude of gravity, m/s^2, and its 1-sigma.
    pub gravity_error: [f32; 2],
    /// The largest per-axis statistic under the factory prior and under the aged prior, at
    /// the last checkpoint.
    pub statistic: [f32; 2],
    /// The thresholds they were held to.
    pub threshold: [f32; 2],
    /// Seconds at rest, all rest periods together.
    pub rest_s: f32,
    /// Rest windows used.
    pub rest_windows: u32,
    /// Windows taken as moving.
    pub moving_windows: u32,
    /// Samples left out (NaN, saturated, no calibration).
    pub ignored_samples: u32,
}

/// The health check's state: the stillness detector and the two filters (under 512 bytes).
#[derive(Debug, Clone)]
pub struct RestMonitor {
    /// Where the unit may rest: the magnitude of gravity.
    gravity: Span,
    /// The stated false-alarm rate per rest period.
    false_alarm: f32,
    window: Window,
    /// Per output, the white noise variance of one sample.
    white_var: [f32; OUTPUTS],
    /// Per output, the bias walk's variance over one window.
    walk: [f32; OUTPUTS],
    /// Per output, the variance ageing may explain.
    ageing: [f32; OUTPUTS],
    /// Seconds per window.
    window_s: f32,
    /// `chi2_(n-1)(1 - STILL_MISS) / (n - 1)`: the largest variance ratio of a quiet output.
    quiet_limit: f32,
    /// `chi2_6(1 - STILL_MISS)`: the largest mean change of a steady window.
    steady_limit: f32,
    /// The previous quiet window's mean (overlay removed).
    previous: Option<[f32; OUTPUTS]>,
    /// The specific force of the last pose the filters saw.
    pose: Option<[f32; 3]>,
    /// Under the factory prior and under the aged prior; `None` before the first rest.
    filters: Option<[Filter; 2]>,
    /// The accelerometer parameters' prior at the environment it was computed at.
    prior: Option<([f32; 2], [[f32; filter::BLOCK]; 3])>,
    /// The overlay given to the corrector.
    applied: [f32; OUTPUTS],
    verdict: Verdict,
    /// Rest windows in the current rest period, and the next checkpoint's count.
    period: u32,
    checkpoint: u32,
    spent: u8,
    statistic: [f32; 2],
    threshold: [f32; 2],
    rest_windows: u32,
    moving_windows: u32,
    ignored_samples: u32,
}

impl RestMonitor {
    /// A monitor for an IMU calibration corrected at `sample_rate_hz`.
    ///
    /// # Errors
    /// [`Error::CorrectorWrongSensor`] when `cal` is not an IMU; [`Error::HealthNoNoiseTerms`]
    /// and [`Error::HealthNoCovariance`] when it lacks what the check needs (the unit still
    /// corrects); [`Error::CorrectorBadSampleRate`] for a rate that is not finite and
    /// positive.
    pub fn new(cal: &Calibration, sample_rate_hz: f32) -> Result<Self, Error> {
        let data = cal.data();
        let Sensor::Imu { covariance, .. } = &data.sensor else {
            return Err(Error::CorrectorWrongSensor);
        };
        let noise = data.noise.ok_or(Error::HealthNoNoiseTerms)?;
        if covariance.is_none() {
            return Err(Error::HealthNoCovariance);
        }
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(Error::CorrectorBadSampleRate);
        }
        let n = f64::from(WINDOW);
        let window_s = f32::from(WINDOW) / sample_rate_hz;
        Ok(Self {
            gravity: noise.gravity,
            false_alarm: noise.false_alarm,
            window: Window::new(WINDOW),
            white_var: noise.white.map(|d| d * d * sample_rate_hz),
            walk: noise.bias_walk.map(|k| k * k * window_s),
            ageing: noise.bias_walk.map(|k| k * k * noise.ageing_s),
            window_s,
            quiet_limit: (quantile::chi2_upper(n - 1.0, STILL_MISS) / (n - 1.0)) as f32,
            steady_limit: quantile::chi2_upper(6.0, STILL_MISS) as f32,
            previous: None,
            pose: None,
            filters: None,
            prior: None,
            applied: [0.0; OUTPUTS],
            verdict: Verdict::NotYet,
            period: 0,
            checkpoint: FIRST_CHECKPOINT,
            spent: 0,
            statistic: [0.0; 2],
            threshold: [0.0; 2],
            rest_windows: 0,
            moving_windows: 0,
            ignored_samples: 0,
        })
    }

    /// Takes one corrected sample of `imu` (as its `correct` or `correct_batch` gave it). At
    /// the end of each window it judges stillness, refines, and at a checkpoint gives `imu`
    /// the verdict's overlay or flag. Returns the verdict.
    pub fn observe_rest<S: Sample>(
        &mut self,
        imu: &mut ImuCorrector<'_, S>,
        out: &Corrected<OUTPUTS>,
    ) -> Verdict {
        let total: f32 = out.values.iter().sum();
        if !total.is_finite() || out.flags.bits() & UNUSABLE.bits() != 0 {
            self.ignored_samples = self.ignored_samples.saturating_add(1);
            return self.verdict;
        }
        if let Some(stats) = self.window.push(&out.values) {
            self.window_done(imu, &stats);
        }
        self.verdict
    }

    /// The unit's health now.
    #[must_use]
    pub fn health(&self) -> Health {
        let (bias, variance, accel_covariance, (dg, dg_var), stated) = match &self.filters {
            Some([factory, aged]) => (
                aged.bias(),
                reported_variance(aged),
                aged.accel_covariance(),
                aged.gravity_error(),
                factory.spread(),
            ),
            None => (
                [0.0; OUTPUTS],
                [0.0; OUTPUTS],
                [0.0; 6],
                (0.0, 0.0),
                [0.0; OUTPUTS],
            ),
        };
        Health {
            verdict: self.verdict,
            bias,
            bias_sigma: variance.map(libm::sqrtf),
            stated_sigma: stated.map(libm::sqrtf),
            accel_covariance,
            gravity_error: [dg, libm::sqrtf(dg_var)],
            statistic: self.statistic,
            threshold: self.threshold,
            rest_s: self.rest_windows as f32 * self.window_s,
            rest_windows: self.rest_windows,
            moving_windows: self.moving_windows,
            ignored_samples: self.ignored_samples,
        }
    }

    /// Forgets everything learnt (after a bench check, or a new calibration) and takes the
    /// overlay and the flag off `imu`.
    pub fn reset<S: Sample>(&mut self, imu: &mut ImuCorrector<'_, S>) {
        self.window.clear();
        self.previous = None;
        self.pose = None;
        self.filters = None;
        self.prior = None;
        self.applied = [0.0; OUTPUTS];
        self.verdict = Verdict::NotYet;
        self.end_period();
        self.statistic = [0.0; 2];
        self.threshold = [0.0; 2];
        self.rest_windows = 0;
        self.moving_windows = 0;
        self.ignored_samples = 0;
        imu.set_overlay(None);
        imu.set_suspect(false);
    }

    fn end_period(&mut self) {
        self.period = 0;
        self.checkpoint = FIRST_CHECKPOINT;
        self.spent = 0;
    }

    fn window_done<S: Sample>(&mut self, imu: &mut ImuCorrector<'_, S>, stats: &Stats) {
        if let Some(filters) = &mut self.filters {
            for f in filters.iter_mut() {
                f.add_noise(&self.walk);
            }
        }
        // Each output's own noise: white and quantisation.
        let mut own = imu.quantisation_variance();
        for (v, w) in own.iter_mut().zip(&self.white_var) {
            *v += w;
        }
        let sample_var = imu.sample_variance(&own);
        let quiet = stats
            .var
            .iter()
            .zip(&sample_var)
            .all(|(s, v)| *s <= self.quiet_limit * v);
        if !quiet {
            self.moving_windows = self.moving_windows.saturating_add(1);
            self.previous = None;
            self.end_period();
            return;
        }
        let mut mean = stats.mean;
        for (m, a) in mean.iter_mut().zip(&self.applied) {
            *m += a;
        }
        // Each mean's variance: the tangential term's differenced gyro noise cancels in it.
        let n = f32::from(self.window.len());
        let mean_var = own.map(|v| v / n);
        let steady = self
            .previous
            .is_some_and(|p| change(&p, &mean, &mean_var) <= self.steady_limit);
        self.previous = Some(mean);
        if !steady {
            self.end_period();
            return;
        }
        self.rest(imu, &mean, &mean_var);
    }

    /// A rest window with mean `mean` (overlay removed), each mean's variance `r`.
    fn rest<S: Sample>(
        &mut self,
        imu: &mut ImuCorrector<'_, S>,
        mean: &[f32; OUTPUTS],
        r: &[f32; OUTPUTS],
    ) {
        let [a0, a1, a2, w0, w1, w2] = *mean;
        let force = [a0, a1, a2];
        let earth = EARTH_RATE * EARTH_RATE / 3.0;
        let Some((total, own)) = imu.factory_variances(mean) else {
            return;
        };
        // The accelerometer's prior at this environment, computed again only when it changes.
        let env = imu.environment();
        let accel_prior = match self.prior {
            Some((at, prior)) if at == env => prior,
            _ => {
                let Some(prior) = imu.accel_rest_covariance() else {
                    return;
                };
                self.prior = Some((env, prior));
                prior
            }
        };
        let phi = imu.accel_rest_features(&force);
        // The gyros' stated error that depends on the pose (g-sensitivity, scale times Earth's
        // rate), and Earth's rate itself: fresh at each new pose. The accelerometer's carries
        // over through its parameters' correlations in the filter.
        let [.., t3, t4, t5] = total;
        let [.., o3, o4, o5] = own;
        let gyro_pose_part = [t3 - o3, t4 - o4, t5 - o5].map(|v| v.max(0.0) + earth);
        match (&mut self.filters, self.pose) {
            (None, _) => {
                // The stated error at rest; the gyros' with Earth's rate.
                let gyro = [t3, t4, t5].map(|v| v + earth);
                let Span { lo, hi } = self.gravity;
                let gravity_var = (hi - lo) * (hi - lo) / 12.0;
                let [ga0, ga1, ga2, gg0, gg1, gg2] = self.ageing;
                let aged_gyro = [gyro[0] + gg0, gyro[1] + gg1, gyro[2] + gg2];
                self.filters = Some([
                    Filter::new(&accel_prior, &[0.0; 3], &gyro, gravity_var, &phi),
                    Filter::new(
                        &accel_prior,
                        &[ga0, ga1, ga2],
                        &aged_gyro,
                        gravity_var,
                        &phi,
                    ),
                ]);
            }
            (Some(filters), Some(pose)) => {
                if change(&force, &pose, r) > self.steady_limit {
                    for f in filters.iter_mut() {
                        f.add_gyro_noise(&gyro_pose_part);
                    }
                }
            }
            (Some(_), None) => {}
        }
        self.pose = Some(force);
        let stated = filter::stated_at(&accel_prior, &phi);
        let g0 = 0.5 * (self.gravity.lo + self.gravity.hi);
        let [ra0, ra1, ra2, rw0, rw1, rw2] = *r;
        if let Some(filters) = &mut self.filters {
            for f in filters.iter_mut() {
                f.update_gyro(&[w0, w1, w2], &[rw0, rw1, rw2]);
                f.update_accel(&force, &[ra0, ra1, ra2], g0, (&phi, &stated));
            }
        }
        self.rest_windows = self.rest_windows.saturating_add(1);
        self.period = self.period.saturating_add(1);
        if self.period >= self.checkpoint {
            self.judge(imu);
            self.checkpoint = self.checkpoint.saturating_mul(2);
            self.spent = self.spent.saturating_add(1);
        }
    }

    /// The checkpoint's verdict, given to `imu`.
    fn judge<S: Sample>(&mut self, imu: &mut ImuCorrector<'_, S>) {
        let Some([factory, aged]) = &self.filters else {
            return;
        };
        let alpha = f64::from(self.false_alarm) / libm::pow(2.0, f64::from(self.spent) + 1.0);
        let threshold = |used: u8| quantile::chi2_1_upper(alpha / f64::from(used.max(1))) as f32;
        let (tf, mf) = factory.statistic();
        let (ta, ma) = aged.statistic();
        self.statistic = [tf, ta];
        self.threshold = [threshold(mf), threshold(ma)];
        let was = self.verdict;
        self.verdict = if was == Verdict::Suspect || ta > self.threshold[1] {
            Verdict::Suspect
        } else if was == Verdict::Drifted || tf > self.threshold[0] {
            Verdict::Drifted
        } else {
            Verdict::Ok
        };
        match self.verdict {
            Verdict::Drifted => {
                let overlay = Overlay {
                    bias: aged.bias(),
                    variance: reported_variance(aged),
                };
                self.applied = overlay.bias;
                imu.set_overlay(Some(overlay));
            }
            Verdict::Suspect if was != Verdict::Suspect => {
                self.applied = [0.0; OUTPUTS];
                imu.set_overlay(None);
                imu.set_suspect(true);
            }
            Verdict::Ok if was == Verdict::Drifted => {
                self.applied = [0.0; OUTPUTS];
                imu.set_overlay(None);
            }
            _ => {}
        }
    }
}

/// The chi-square statistic of the change from the mean `b` to the mean `a`, each of whose
/// components has the variance `var`.
fn change(a: &[f32], b: &[f32], var: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .zip(var)
        .map(|((x, y), v)| (x - y) * (x - y) / (2.0 * v))
        .sum()
}

/// The refined biases' variances as reported and applied: the gyros' with Earth's rate added,
/// which the filter cannot separate from their biases.
fn reported_variance(filter: &Filter) -> [f32; OUTPUTS] {
    let mut v = filter.variance();
    for x in v.iter_mut().skip(3) {
        *x += EARTH_RATE * EARTH_RATE / 3.0;
    }
    v
}
