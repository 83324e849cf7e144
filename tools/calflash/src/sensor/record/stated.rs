//! What a calibration record states of a corrected IMU sample: the 1-sigma calibration error
//! of each output, from the record's full covariance of every term each output's fit kept, in
//! double precision.
//!
//! The unit states the same from the blob's covariance factors, in single precision
//! (`spincal::correct::ImuCorrector::sigma`). The two share the written model of the IMU under
//! rotation (`spincal::model::rotation`: the force at each axis' position, the lever arm's
//! gradient) and nothing else: here the directions, lever arms and g-sensitivity come from the
//! record's own coefficients, the covariance from its fits, and the arithmetic is f64. Holding
//! the unit's statement against this one at every sample of a flight is how a wrong factor (a
//! jitter, a variance in the wrong unit, a term dropped) or a cancellation in f32 is caught.

use nalgebra::{DMatrix, DVector};
use spincal::model::IMU_FEATURES;
use spincal::model::rotation;

use super::{AxisRecord, PointRecord};
use crate::sensor::lever;

/// Output names, in the corrector's order.
pub const OUTPUTS: [&str; 6] = ["a_x", "a_y", "a_z", "g_x", "g_y", "g_z"];

/// Why a record's point cannot state an IMU's error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatedError {
    /// Not an IMU's record, or an output missing.
    #[error("the record holds no fit of {0}")]
    Missing(&'static str),
    /// A term that is not a function of a corrected sample.
    #[error("{output}'s term `{term}` is not one a corrected sample can evaluate")]
    Term {
        /// The output.
        output: &'static str,
        /// The term.
        term: String,
    },
    /// The sensitivity rows are singular.
    #[error("the sensitivity rows of the {0} are singular")]
    Singular(&'static str),
}

/// A term of a record's fit, as a corrected sample evaluates it from the device's error
/// features ([`IMU_FEATURES`]): the feature's index, and whether the regressor is the axis'
/// sensitivity times it (a lever arm).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Regressor(usize, bool);

impl Regressor {
    /// The term `term` of output `out` (0..6, the corrector's order); `None` for a term that is
    /// not a function of a corrected sample (a temperature term, another axis' lever arm).
    #[must_use]
    pub fn of(term: &str, out: usize) -> Option<Self> {
        let xyz = |prefix: &str| {
            ["x", "y", "z"]
                .iter()
                .position(|a| term == format!("{prefix}{a}"))
        };
        let s = lever::SENSED;
        Some(match term {
            "1" => Self(0, false),
            t if t == format!("{s}^2") => Self(7, false),
            lever::SENSED_KINK => Self(8, false),
            t if t == format!("{s}^3") => Self(9, false),
            t if t == format!("{s}:abs({s})") => Self(10, false),
            _ if out < 3 => {
                if let Some(k) = xyz("f_") {
                    Self(1 + k, false)
                } else {
                    let lever = format!("lever_{}", ["x", "y", "z"][out]);
                    Self(4 + xyz(&lever)?, true)
                }
            }
            _ => match (xyz("w_"), xyz("f_")) {
                (Some(k), _) => Self(1 + k, false),
                (None, Some(k)) => Self(4 + k, false),
                (None, None) => return None,
            },
        })
    }

    /// Its value at a sample whose device features are `phi`, for an axis of sensitivity
    /// `slope` (counts per SI unit).
    #[must_use]
    pub fn value<T: Copy + Into<f64>>(self, phi: &[T; IMU_FEATURES], slope: f64) -> f64 {
        phi[self.0].into() * if self.1 { slope } else { 1.0 }
    }
}

/// One output's fit as the statement needs it.
#[derive(Debug, Clone)]
struct Output {
    terms: Vec<Regressor>,
    /// Its own sensitivity (counts per SI unit): a lever arm's regressor is it times the
    /// feature.
    slope: f64,
    /// The covariance of its parameters over its sensitivity squared.
    q: DMatrix<f64>,
}

/// A record's table point, ready to state the error of corrected samples.
#[derive(Debug, Clone)]
pub struct PointStatement {
    outputs: Vec<Output>,
    /// Sensing directions, each scaled to a unit own component (the device's form).
    directions: [[f64; 3]; 6],
    /// Accelerometer lever arms, m.
    lever: [[f64; 3]; 3],
    /// Gyro g-sensitivity in the device's form (rad/s per m/s^2 of the sensed rate).
    g: [[f64; 3]; 3],
}

fn coef(fit: &AxisRecord, term: &str) -> f64 {
    fit.terms
        .iter()
        .position(|t| t == term)
        .and_then(|k| fit.coefficients.get(k).copied())
        .unwrap_or(0.0)
}

impl PointStatement {
    /// The statement of one of a record's table points.
    ///
    /// # Errors
    /// [`StatedError`].
    pub fn of(point: &PointRecord) -> Result<Self, StatedError> {
        let mut fits = Vec::with_capacity(6);
        for name in OUTPUTS {
            fits.push(
                point
                    .axes
                    .iter()
                    .find(|a| a.output == name)
                    .ok_or(StatedError::Missing(name))?,
            );
        }
        let inputs = |out: usize| {
            if out < 3 {
                ["f_x", "f_y", "f_z"]
            } else {
                ["w_x", "w_y", "w_z"]
            }
        };
        let rows: [[f64; 3]; 6] =
            std::array::from_fn(|out| inputs(out).map(|t| coef(fits[out], t)));
        let mut outputs = Vec::with_capacity(6);
        for (out, fit) in fits.iter().enumerate() {
            let slope = rows[out][out % 3];
            if slope == 0.0 {
                return Err(StatedError::Missing(OUTPUTS[out]));
            }
            let (names, covariance) = fit.stated();
            let terms = names
                .iter()
                .map(|t| {
                    Regressor::of(t, out).ok_or_else(|| StatedError::Term {
                        output: OUTPUTS[out],
                        term: t.clone(),
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            let n = terms.len();
            let q = DMatrix::from_fn(n, n, |i, j| {
                covariance
                    .get(i)
                    .and_then(|r| r.get(j))
                    .copied()
                    .unwrap_or(0.0)
                    / (slope * slope)
            });
            outputs.push(Output { terms, slope, q });
        }
        let directions = std::array::from_fn(|out| rows[out].map(|x| x / rows[out][out % 3]));
        let lever =
            std::array::from_fn(|i| std::array::from_fn(|k| coef(fits[i], &lever::column(i, k))));
        // The forward gyro is `S w + g f`; the device senses `w + G f` along `S_i / S_ii`, so
        // `G = S^-1 g`.
        let s = DMatrix::from_fn(3, 3, |i, j| rows[3 + i][j]);
        let gf = DMatrix::from_fn(3, 3, |i, j| coef(fits[3 + i], ["f_x", "f_y", "f_z"][j]));
        let sinv = s.try_inverse().ok_or(StatedError::Singular("gyros"))?;
        let gd = sinv * gf;
        let g = std::array::from_fn(|i| std::array::from_fn(|j| gd[(i, j)]));
        Ok(Self {
            outputs,
            directions,
            lever,
            g,
        })
    }

    /// Per output of the corrected sample `values` (`[ax, ay, az, wx, wy, wz]`), the features
    /// of its calibration error in double precision (the device's, `error_features`).
    #[must_use]
    pub fn features(&self, values: &[f64; 6]) -> [[f64; IMU_FEATURES]; 6] {
        let [f0, f1, f2, w0, w1, w2] = *values;
        let (f, w) = ([f0, f1, f2], [w0, w1, w2]);
        let zero = [0.0; 3];
        let nonlinear = |x: f64| [x * x, x.abs(), x * x * x, x * x.abs()];
        let sensed_rate: [f64; 3] = std::array::from_fn(|k| w[k] + rotation::dot(&self.g[k], &f));
        std::array::from_fn(|out| {
            let n = &self.directions[out];
            if out < 3 {
                let at = rotation::force_at(&f, &w, &zero, &self.lever[out]);
                let [g0, g1, g2] = rotation::lever_gradient(n, &w, &zero);
                let [s, a, c, o] = nonlinear(rotation::dot(n, &at));
                [1.0, at[0], at[1], at[2], g0, g1, g2, s, a, c, o]
            } else {
                let [s, a, c, o] = nonlinear(rotation::dot(n, &sensed_rate));
                [1.0, w0, w1, w2, f0, f1, f2, s, a, c, o]
            }
        })
    }

    /// The 1-sigma calibration error of each output of the corrected sample `values`.
    #[must_use]
    pub fn sigma(&self, values: &[f64; 6]) -> [f64; 6] {
        let features = self.features(values);
        std::array::from_fn(|out| self.sigma_at(out, &features[out]))
    }

    /// Output `out`'s 1-sigma at its features `phi`: `sqrt(r' Q r)` over its fit's regressors.
    #[must_use]
    pub fn sigma_at<T: Copy + Into<f64>>(&self, out: usize, phi: &[T; IMU_FEATURES]) -> f64 {
        let o = &self.outputs[out];
        let r =
            DVector::from_iterator(o.terms.len(), o.terms.iter().map(|t| t.value(phi, o.slope)));
        (r.transpose() * &o.q * &r)[(0, 0)].max(0.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::Regressor;

    #[test]
    fn a_records_terms_are_read_as_the_devices_features() {
        let x = 64.0f32;
        let phi = [
            1.0,
            x,
            2.0,
            3.0,
            0.5,
            0.25,
            0.125,
            x * x,
            x,
            x * x * x,
            x * x,
        ];
        let v = |t: &str, out: usize| Regressor::of(t, out).map(|r| r.value(&phi, 16.0));
        // The gyro x: its rates, its g-sensitivity's force, what it senses.
        assert_eq!(v("w_x", 3), Some(64.0));
        assert_eq!(v("f_y", 3), Some(0.25));
        assert_eq!(v("sensed^3", 3), Some(64.0f64.powi(3)));
        assert_eq!(v("sensed:abs(sensed)", 3), Some(64.0 * 64.0));
        assert_eq!(v("sensed_kink", 3), Some(64.0));
        // An accelerometer's lever arm is its sensitivity times the gradient.
        assert_eq!(v("lever_xz", 0), Some(0.125 * 16.0));
        assert_eq!(v("f_z", 0), Some(3.0));
        assert!(v("temp_1", 3).is_none() && v("lever_xx", 3).is_none());
    }
}
