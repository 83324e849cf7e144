//! The gyro from the rotations between poses: its fit with the accelerometer's error in the
//! rotations' end directions, and how many directions the poses face.

use super::super::gravity::{self, AccelFit};
use super::super::rotation::{self, GyroFit, KnownTurn};
use nalgebra::Matrix3;

use super::{MIN_ROTATIONS, SelfCalError, fit_err, segments, unit};

/// The gyro's fit to the rotations between poses (`turns`), with a Ferraris session's turns of
/// known angle and the closed form's start where `known` holds them; its covariance including
/// the accelerometer's error in the rotations' end directions, and the angle each rotation of
/// the constant-bias check turned through.
///
/// # Errors
/// Too few usable rotations (each skipped one says why), or a fit that fails.
pub(super) fn gyro_fit(
    source: &str,
    turns: &segments::Turns,
    accel: &AccelFit,
    known: Option<&(Vec<KnownTurn>, [[f64; 3]; 3])>,
) -> Result<(GyroFit, Vec<f64>), SelfCalError> {
    let segments::Turns {
        segments,
        const_segments,
        ends: end_means,
        skipped,
        ..
    } = turns;
    // Three known turns give the nine entries by themselves.
    if segments.len() < MIN_ROTATIONS && known.is_none_or(|(k, _)| k.len() < 3) {
        let why = if skipped.is_empty() {
            "none".into()
        } else {
            skipped
                .iter()
                .map(|s| s.why.clone())
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Err(SelfCalError::TooFewRotations {
            file: source.into(),
            usable: segments.len(),
            skipped: skipped.len(),
            why,
            needed: MIN_ROTATIONS,
        });
    }
    let mut gyro = match known {
        Some((known, start)) => rotation::fit_with_turns(segments, known, *start),
        None => rotation::fit(segments, segments::gyro_start(segments)),
    }
    .map_err(fit_err(source, "gyro"))?;
    // The rotations' ends are the accelerometer's gravity directions: its error is the gyro's.
    // (With known turns the fit's own covariance stands: the known turns' angles do not move
    // with the accelerometer.)
    if let (Some(cov_a), None) = (&accel.covariance, known) {
        let center = accel.model.center;
        let ends = |q: &[f64]| {
            let model = gravity::AccelModel::from_params(center, q);
            end_means
                .iter()
                .map(|[a, b]| (unit(model.apply(*a)), unit(model.apply(*b))))
                .collect::<Vec<_>>()
        };
        if let Some(c) = rotation::with_direction_error(segments, &gyro, &accel.params, cov_a, ends)
        {
            gyro.covariance = Some(c);
        }
    }
    let m = Matrix3::from_fn(|i, j| gyro.matrix[i][j]);
    let constant_bias_angles = const_segments
        .iter()
        .map(|s| rotation::angle(&m, s))
        .collect();
    Ok((gyro, constant_bias_angles))
}

/// How many of the pose means `means` (counts) face directions at least 10 degrees from each
/// other: the poses a fit can tell apart. The directions are taken about the middle of the
/// means' range; means that spread less than 100 times the noise (`rest_level`, a variance, in
/// the means' own unit) face one direction.
pub(super) fn directions(means: &[[f64; 3]], rest_level: f64) -> usize {
    if means.is_empty() {
        return 0;
    }
    let span = |j: usize| {
        let (lo, hi) = means
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
                (lo.min(m[j]), hi.max(m[j]))
            });
        (lo, hi)
    };
    let ranges: [(f64, f64); 3] = std::array::from_fn(span);
    let widest = ranges.iter().map(|(lo, hi)| hi - lo).fold(0.0f64, f64::max);
    // The noise's own scale, not a count's: in m/s^2 a full turn spans 20 (issue 66: imucal's
    // Ferraris session in m/s^2 had its six faces counted as one direction under a floor of
    // one unit of noise).
    if widest <= 100.0 * rest_level.sqrt() {
        return 1;
    }
    let center: [f64; 3] = std::array::from_fn(|j| (ranges[j].0 + ranges[j].1) / 2.0);
    let cos_limit = 10f64.to_radians().cos();
    let mut seen: Vec<[f64; 3]> = Vec::new();
    for m in means {
        let d: [f64; 3] = std::array::from_fn(|j| m[j] - center[j]);
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if n == 0.0 {
            continue;
        }
        let u = d.map(|x| x / n);
        if seen
            .iter()
            .all(|s| s[0] * u[0] + s[1] * u[1] + s[2] * u[2] < cos_limit)
        {
            seen.push(u);
        }
    }
    seen.len().max(1)
}

#[cfg(test)]
mod tests {
    use super::directions;

    /// Six faces in m/s^2 (a span of 20 against noise of 0.01) face six directions; the same
    /// in codes too. A floor of one unit of noise once made every recording in physical units
    /// face one direction.
    #[test]
    fn six_faces_face_six_directions_in_any_unit() {
        let g = 9.81;
        let faces = |s: f64| -> Vec<[f64; 3]> {
            (0..6)
                .map(|k| {
                    let mut m = [0.0; 3];
                    m[k / 2] = if k % 2 == 0 { s } else { -s };
                    m
                })
                .collect()
        };
        assert_eq!(directions(&faces(g), 1e-4), 6);
        assert_eq!(directions(&faces(16_384.0), 9.0), 6);
        // A rest split by noise into poses facing one way is one direction.
        let rest: Vec<[f64; 3]> = (0..6).map(|k| [0.0, 0.0, g + 1e-3 * k as f64]).collect();
        assert_eq!(directions(&rest, 1e-4), 1);
    }
}
