//! Threshold, dead band and resolution from a fine-step run near zero input (the seed, section
//! 3), once the scale factor has been accepted.
//!
//! - threshold (each side): the smallest input from which on the response is at least half of
//!   what the scale factor predicts;
//! - dead band: the interval between the two thresholds, where input changes are not seen;
//! - resolution: the smallest step between consecutive inputs outside the dead band whose
//!   output change is at least half of what the scale factor predicts for it.

/// The result of a fine-step analysis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Threshold {
    /// Output at zero input (counts): `--bias` when given, else the run's mean at input 0.
    pub zero: f64,
    /// The run's mean output at input 0, when it has that input.
    pub measured_zero: Option<f64>,
    /// Inputs, mean response and ratio to the expected response, per distinct input.
    pub steps: Vec<(f64, f64, f64)>,
    /// Positive threshold, SI (`None`: never reached).
    pub positive: Option<f64>,
    /// Negative threshold, SI.
    pub negative: Option<f64>,
    /// Dead band `[negative, positive]`.
    pub dead_band: Option<(f64, f64)>,
    /// Resolution, SI.
    pub resolution: Option<f64>,
}
/// Why a threshold run cannot be analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ThresholdError {
    /// Neither an input of 0 nor a given bias.
    #[error("the run has no input of 0 and no --bias was given: the zero-input output is unknown")]
    NoZero,
    /// Inputs on one side of zero only.
    #[error("the run needs inputs on both sides of zero")]
    OneSided,
}

/// Analyses `(input, output)` pairs with the accepted scale factor (counts per SI unit); the
/// zero-input output is `bias` when given, else the mean at input 0.
///
/// # Errors
/// When there is neither an input of 0 nor a bias, or no inputs on one side.
pub fn analyse(
    input: &[f64],
    output: &[f64],
    scale: f64,
    bias: Option<f64>,
) -> Result<Threshold, ThresholdError> {
    let mut groups: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut order: Vec<usize> = (0..input.len()).collect();
    order.sort_by(|&a, &b| input[a].total_cmp(&input[b]));
    for i in order {
        match groups.last_mut() {
            Some((x, v)) if *x == input[i] => v.push(output[i]),
            _ => groups.push((input[i], vec![output[i]])),
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let measured_zero = groups.iter().find(|(x, _)| *x == 0.0).map(|(_, v)| mean(v));
    let zero = bias.or(measured_zero).ok_or(ThresholdError::NoZero)?;
    let steps: Vec<(f64, f64, f64)> = groups
        .iter()
        .filter(|(x, _)| *x != 0.0)
        .map(|(x, v)| {
            let r = mean(v) - zero;
            (*x, r, r / (scale * x))
        })
        .collect();
    if !steps.iter().any(|s| s.0 > 0.0) || !steps.iter().any(|s| s.0 < 0.0) {
        return Err(ThresholdError::OneSided);
    }
    // The threshold on a side: the innermost input from which outward every ratio is >= 1/2.
    let side = |positive: bool| -> Option<f64> {
        let mut xs: Vec<&(f64, f64, f64)> =
            steps.iter().filter(|s| (s.0 > 0.0) == positive).collect();
        if !positive {
            xs.reverse();
        }
        // xs runs from the smallest |x| outwards.
        let mut found = None;
        for s in xs.iter().rev() {
            if s.2 >= 0.5 {
                found = Some(s.0);
            } else {
                break;
            }
        }
        found
    };
    let positive = side(true);
    let negative = side(false);
    let dead_band = negative.zip(positive);
    let outside: Vec<&(f64, f64, f64)> = steps
        .iter()
        .filter(|s| positive.is_some_and(|p| s.0 >= p) || negative.is_some_and(|n| s.0 <= n))
        .collect();
    let resolution = outside
        .windows(2)
        .filter(|w| (w[0].0 > 0.0) == (w[1].0 > 0.0))
        .filter(|w| (w[1].1 - w[0].1) / (scale * (w[1].0 - w[0].0)) >= 0.5)
        .map(|w| (w[1].0 - w[0].0).abs())
        .min_by(f64::total_cmp);
    Ok(Threshold {
        zero,
        measured_zero,
        steps,
        positive,
        negative,
        dead_band,
        resolution,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_band_of_a_sensor_that_ignores_small_inputs() {
        // Scale 400 counts per unit; no response inside +-0.01; steps of 0.0025.
        let input: Vec<f64> = (-20..=20).map(|i| f64::from(i) * 0.0025).collect();
        let output: Vec<f64> = input
            .iter()
            .map(|x| 1000.0 + if x.abs() <= 0.01 { 0.0 } else { 400.0 * x })
            .collect();
        let t = analyse(&input, &output, 400.0, None).unwrap();
        assert_eq!(t.zero, 1000.0);
        assert!((t.positive.unwrap() - 0.0125).abs() < 1e-12, "{t:?}");
        assert!((t.negative.unwrap() + 0.0125).abs() < 1e-12);
        assert!((t.resolution.unwrap() - 0.0025).abs() < 1e-12);
        assert_eq!(
            analyse(&[1.0, 2.0], &[1.0, 2.0], 1.0, None),
            Err(ThresholdError::NoZero)
        );
        assert_eq!(
            analyse(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0], 1.0, None),
            Err(ThresholdError::OneSided)
        );
        // A given bias is used even where the run has an input of 0, and the run's is kept.
        let b = analyse(&input, &output, 400.0, Some(1002.0)).unwrap();
        assert_eq!((b.zero, b.measured_zero), (1002.0, Some(1000.0)));
        assert_ne!(b.steps, t.steps);
    }
}
