//! The sample rate of a stream: stated, or read off its timestamps, and the time steps that
//! are not that rate (a dropped sample, a stall, a clock jump), where a rate derivative taken
//! by backward difference means nothing.

/// A step counts as off the rate when it differs from the nominal period by more than this
/// fraction of it.
pub const STEP_TOLERANCE: f64 = 0.01;

/// The rate of a stream and the samples that follow an off-rate step.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    /// Samples per second.
    pub rate: f64,
    /// Where the rate came from, in words.
    pub source: String,
    /// Indices of samples whose step from the previous sample is not the nominal period.
    pub off_rate: Vec<usize>,
}

/// A rate that cannot be established.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TimingError {
    /// No rate given and no timestamps.
    #[error("no sample rate: give it, or the timestamps")]
    Missing,
    /// A stated rate that is not a positive finite number.
    #[error("the sample rate {0} Hz is not a positive number")]
    BadRate(f64),
    /// Timestamps that never advance.
    #[error("the timestamps never advance, so they give no rate")]
    NoSteps,
    /// A stated rate that the timestamps contradict.
    #[error(
        "the stated rate of {stated} Hz disagrees with the timestamps, whose median step is {median_s:e} s ({:.6} Hz)",
        1.0 / median_s
    )]
    Disagrees {
        /// The stated rate, Hz.
        stated: f64,
        /// The median step of the timestamps, s.
        median_s: f64,
    },
}

impl Timing {
    /// The timing of a stream with the optional `stated` rate (Hz) and optional timestamps
    /// (seconds). With both, they must agree to [`STEP_TOLERANCE`].
    ///
    /// # Errors
    /// A [`TimingError`] saying what is missing or contradictory.
    pub fn new(stated: Option<f64>, t: Option<&[f64]>) -> Result<Self, TimingError> {
        if let Some(r) = stated
            && !(r.is_finite() && r > 0.0)
        {
            return Err(TimingError::BadRate(r));
        }
        let Some(t) = t else {
            return stated.map_or(Err(TimingError::Missing), |rate| {
                Ok(Self {
                    rate,
                    source: format!("{rate} Hz as stated"),
                    off_rate: Vec::new(),
                })
            });
        };
        let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        steps.retain(|d| d.is_finite() && *d > 0.0);
        if steps.is_empty() {
            return match stated {
                Some(rate) if t.len() <= 1 => Ok(Self {
                    rate,
                    source: format!("{rate} Hz as stated"),
                    off_rate: Vec::new(),
                }),
                _ => Err(TimingError::NoSteps),
            };
        }
        steps.sort_by(f64::total_cmp);
        let median = steps[steps.len() / 2];
        let period = match stated {
            Some(rate) => {
                if ((1.0 / rate) - median).abs() > STEP_TOLERANCE * median {
                    return Err(TimingError::Disagrees {
                        stated: rate,
                        median_s: median,
                    });
                }
                1.0 / rate
            }
            None => median,
        };
        let off_rate = t
            .windows(2)
            .enumerate()
            .filter(|(_, w)| {
                let off = ((w[1] - w[0]) - period).abs();
                // NaN steps count as off the rate.
                off.is_nan() || off > STEP_TOLERANCE * period
            })
            .map(|(i, _)| i + 1)
            .collect();
        Ok(Self {
            rate: 1.0 / period,
            source: match stated {
                Some(r) => format!("{r} Hz as stated, the timestamps agreeing"),
                None => format!("{:.6} Hz from the timestamps' median step", 1.0 / period),
            },
            off_rate,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_comes_from_the_timestamps_and_off_rate_steps_are_found() {
        let mut t: Vec<f64> = (0..100).map(|i| f64::from(i) * 0.0005).collect();
        // A dropped sample after index 40, and a stall at 70.
        t.remove(41);
        t[69] += 0.0001;
        let tm = Timing::new(None, Some(&t)).unwrap();
        assert!((tm.rate - 2000.0).abs() < 1e-6, "{tm:?}");
        assert_eq!(tm.off_rate, vec![41, 69, 70]);
        // Stated and agreeing; stated and not.
        assert!(Timing::new(Some(2000.0), Some(&t)).is_ok());
        match Timing::new(Some(1000.0), Some(&t)) {
            Err(TimingError::Disagrees { stated, median_s }) => {
                assert!(stated == 1000.0 && (median_s - 0.0005).abs() < 1e-12);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(Timing::new(None, None), Err(TimingError::Missing));
        assert!(matches!(
            Timing::new(Some(f64::NAN), None),
            Err(TimingError::BadRate(_))
        ));
        assert_eq!(
            Timing::new(Some(-5.0), None),
            Err(TimingError::BadRate(-5.0))
        );
        assert_eq!(
            Timing::new(None, Some(&[1.0, 1.0, 1.0])),
            Err(TimingError::NoSteps)
        );
        let t = Timing::new(Some(500.0), None).unwrap();
        assert_eq!((t.rate, t.off_rate.len()), (500.0, 0));
    }
}
