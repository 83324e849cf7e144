//! The device's sets of a triad or an IMU from its fits: each axis' linearisation over what it
//! senses in the calibrated box, the inverse of the sensitivity matrix, the covariance factors
//! of the corrected outputs, and, for a temperature series, the series' coefficients from the
//! sets at its nodes.

use nalgebra::{DMatrix, Matrix3};
use spincal::model::{AxisNonlinearity, ImuOutputCovariance, Span, TriadSet};

use super::fit::{b_of, s_of};
use super::{Spec, TriadError, TriadModel, TriadResult, lever};
use crate::columns as col;
use crate::obs::Table;
use crate::sensor::invert::{
    Own, TriadDevice, TriadForward, linearization, linearize, triad_inversion_error,
};
use crate::sensor::thermal as continuous;
use crate::sensor::{AxisFit, WorkflowError, blob, covariance};

/// What the device applies at one point, in f64: `y = m L(u - center) + off`, `L` each
/// axis' linearisation.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Applied {
    m: Matrix3<f64>,
    off: [f64; 3],
    lins: [[f64; 5]; 3],
    /// Per output, the packed factor of its calibration error's covariance over the features
    /// `[1, u0, u1, u2]` (`sensor::covariance::triad`).
    factors: [[f64; 10]; 3],
}

impl Applied {
    /// The correction of the codes `u`.
    pub(super) fn correct(&self, u: &[f64; 3], centers: &[f64; 3]) -> [f64; 3] {
        let l: [f64; 3] = std::array::from_fn(|k| linearize(&self.lins[k], u[k] - centers[k]));
        std::array::from_fn(|i| self.off[i] + (0..3).map(|k| self.m[(i, k)] * l[k]).sum::<f64>())
    }

    /// The 1-sigma calibration error of each output for the codes `u`, as the device states
    /// it: `|L' f|` with `f = [1, L(u - center)]`.
    pub(super) fn sigma(&self, u: &[f64; 3], centers: &[f64; 3]) -> [f64; 3] {
        let l: [f64; 3] = std::array::from_fn(|k| linearize(&self.lins[k], u[k] - centers[k]));
        let f = [1.0, l[0], l[1], l[2]];
        self.factors.map(|p| {
            let at = |r: usize, k: usize| p[r * (r + 1) / 2 + k];
            (0..4)
                .map(|k| (k..4).map(|r| at(r, k) * f[r]).sum::<f64>().powi(2))
                .sum::<f64>()
                .sqrt()
        })
    }

    /// Every coefficient in a row: the matrix, the offsets, the linearisations, the factors.
    pub(super) fn to_flat(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.m.iter().copied().collect();
        v.extend(self.off);
        v.extend(self.lins.as_flattened());
        v.extend(self.factors.as_flattened());
        v
    }

    /// From [`to_flat`](Self::to_flat)'s row.
    pub(super) fn from_flat(v: &[f64]) -> Self {
        Self {
            m: Matrix3::from_column_slice(&v[..9]),
            off: std::array::from_fn(|i| v[9 + i]),
            lins: std::array::from_fn(|i| std::array::from_fn(|k| v[12 + 5 * i + k])),
            factors: std::array::from_fn(|i| std::array::from_fn(|k| v[27 + 10 * i + k])),
        }
    }

    /// The device's blend: each coefficient linearly.
    pub(super) fn blend(&self, other: &Self, w: f64) -> Self {
        let mix = |a: f64, b: f64| a + (b - a) * w;
        Self {
            m: Matrix3::from_fn(|i, j| mix(self.m[(i, j)], other.m[(i, j)])),
            off: std::array::from_fn(|i| mix(self.off[i], other.off[i])),
            lins: std::array::from_fn(|i| {
                std::array::from_fn(|k| mix(self.lins[i][k], other.lins[i][k]))
            }),
            factors: std::array::from_fn(|i| {
                std::array::from_fn(|k| mix(self.factors[i][k], other.factors[i][k]))
            }),
        }
    }
}

/// The device's set at one point, with what it stands on.
pub(super) struct PointDevice {
    /// The sensitivity matrix.
    pub s: Matrix3<f64>,
    /// Its inverse.
    pub inv: Matrix3<f64>,
    /// Each axis' own forward polynomial.
    pub own: [Own; 3],
    /// What the device applies.
    pub applied: Applied,
}

/// The device's set for the fits `f` of a point: each axis linearised over what it senses in
/// the calibrated box (and over the observations of `sensed`, under the fit), then the inverse
/// of the sensitivity matrix.
pub(super) fn point_device(
    spec: &Spec<'_>,
    f: &[AxisFit; 3],
    (centers, ranges): (&[f64; 3], &[Span; 3]),
    sensed: Option<&Table>,
    (path, at): (&std::path::Path, &str),
) -> Result<PointDevice, WorkflowError> {
    let s = s_of(spec, f);
    let b = b_of(f);
    let inv = s
        .try_inverse()
        .ok_or_else(|| WorkflowError::triad(path, TriadError::SingularSensitivity))?;
    let own: [Own; 3] = std::array::from_fn(|i| Own {
        bias: b[i],
        slope: s[(i, i)],
        c2: f[i].coef(&format!("{}^2", lever::SENSED)),
        c3: f[i].coef(&format!("{}^3", lever::SENSED)),
        coq: f[i].coef(&format!("{0}:abs({0})", lever::SENSED)),
        ca: f[i].coef(lever::SENSED_KINK),
        bp: 0.0,
    });
    // What each axis senses (SI, along itself) over the calibrated box, the data's own
    // sensed inputs included: the span its linearisation must cover.
    let corners = box_corners(ranges);
    let fitted: [_; 3] = std::array::from_fn(|i| {
        let sensed_at = |x: &[f64; 3]| (0..3).map(|j| s[(i, j)] * x[j]).sum::<f64>() / s[(i, i)];
        let data = sensed.map(|t| sensed_values(spec, t, i, &f[i]));
        let (lo, hi) = corners
            .iter()
            .map(sensed_at)
            .chain(data.into_iter().flatten())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        linearization(&own[i], centers[i], lo, hi)
    });
    // y = S^-1 (L - (b - center)), L_j = alpha_j + gamma_j u_j: the device's matrix is
    // S^-1 diag(gamma) and its offset S^-1 (alpha - (b - center)).
    let m = Matrix3::from_fn(|i, j| inv[(i, j)] * fitted[j].gamma);
    let off: [f64; 3] = std::array::from_fn(|i| {
        (0..3)
            .map(|k| inv[(i, k)] * (fitted[k].alpha - (b[k] - centers[k])))
            .sum::<f64>()
    });
    let factors = covariance::triad(
        &DMatrix::from_fn(3, 3, |i, j| inv[(i, j)]),
        &[
            linear_cov(spec, &f[0]),
            linear_cov(spec, &f[1]),
            linear_cov(spec, &f[2]),
        ],
        &DMatrix::from_fn(3, 3, |i, j| m[(i, j)]),
        &off,
    )
    .map_err(|source| WorkflowError::Covariance {
        path: path.to_path_buf(),
        outputs: spec.outputs.join(" "),
        at: at.into(),
        source,
    })?;
    Ok(PointDevice {
        s,
        inv,
        own,
        applied: Applied {
            m,
            off,
            lins: fitted.map(|f| f.n),
            factors: factors.map(|p| std::array::from_fn(|k| p[k])),
        },
    })
}

/// The device's sets of a triad at its points: each point's fits, where it is (for messages)
/// and the observations whose sensed inputs its linearisation must cover.
pub(super) fn device_sets(
    spec: &Spec<'_>,
    model: TriadModel,
    points: Vec<([AxisFit; 3], String, Table)>,
    path: &std::path::Path,
) -> Result<TriadResult, WorkflowError> {
    let (centers, ranges) = (model.centers, model.ranges);
    let mut out = TriadResult {
        fits: Vec::new(),
        sets: Vec::new(),
        covs: Vec::new(),
        imu_covs: Vec::new(),
        errors: Vec::new(),
        noise: Vec::new(),
        g: Vec::new(),
        lever: model.lever,
        centers,
        ranges,
        thermal: model.thermal,
    };
    for (f, at, t) in points {
        let d = point_device(spec, &f, (&centers, &ranges), Some(&t), (path, &at))?;
        let (s, inv, a) = (d.s, d.inv, &d.applied);
        let err = triad_inversion_error(
            &TriadForward { s, own: d.own },
            &TriadDevice {
                lins: a.lins,
                centers,
                m: a.m,
                off: a.off,
            },
            &ranges.map(|r| (f64::from(r.lo), f64::from(r.hi))),
        );
        let located = |source| WorkflowError::Covariance {
            path: path.to_path_buf(),
            outputs: spec.outputs.join(" "),
            at: at.clone(),
            source,
        };
        let factors = a.factors;
        out.imu_covs.push([
            imu_covariance(spec, &f[0], 0).map_err(located)?,
            imu_covariance(spec, &f[1], 1).map_err(located)?,
            imu_covariance(spec, &f[2], 2).map_err(located)?,
        ]);
        out.covs.push(std::array::from_fn(|i| {
            std::array::from_fn(|k| factors[i][k] as f32)
        }));
        out.sets.push(TriadSet {
            axes: std::array::from_fn(|i| AxisNonlinearity {
                quadratic: a.lins[i][0] as f32,
                cubic: a.lins[i][1] as f32,
                odd_quadratic: a.lins[i][2] as f32,
                asymmetry: a.lins[i][3] as f32,
                asymmetry_break: a.lins[i][4] as f32,
            }),
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| a.m[(i, j)] as f32)),
            offset: a.off.map(|o| o as f32),
        });
        out.errors.push(err);
        out.noise.push(std::array::from_fn(|i| {
            f[i].fit.sigma2.sqrt() / s[(i, i)].abs()
        }));
        if spec.g_sens {
            let gout = Matrix3::from_fn(|i, j| f[i].coef(col::F[j]));
            let g = inv * gout;
            out.g
                .push(std::array::from_fn(|i| std::array::from_fn(|j| g[(i, j)])));
        }
        out.fits.push(f);
    }
    Ok(out)
}

/// The covariance of an axis' bias and sensitivity row (`1` and the three inputs).
pub(super) fn linear_cov(spec: &Spec<'_>, f: &AxisFit) -> DMatrix<f64> {
    let idx: Vec<usize> = std::iter::once("1")
        .chain(spec.inputs)
        .map(|t| f.index(t).unwrap_or(0))
        .collect();
    DMatrix::from_fn(4, 4, |r, c| f.fit.covariance[(idx[r], idx[c])])
}

/// Chebyshev coefficients of per-node values (interpolation at the series' nodes, in their
/// order), each value through its row of numbers.
fn series_of<T>(values: &[T], flat: impl Fn(&T) -> Vec<f64>, back: impl Fn(&[f64]) -> T) -> Vec<T> {
    let rows: Vec<Vec<f64>> = values.iter().map(flat).collect();
    continuous::device::chebyshev_rows(&rows)
        .iter()
        .map(|r| back(r))
        .collect()
}

/// Numbers of an array of `f32` arrays, as `f64`.
fn flat_f32<const N: usize, const M: usize>(a: &[[f32; N]; M]) -> Vec<f64> {
    a.as_flattened().iter().map(|v| f64::from(*v)).collect()
}

/// [`flat_f32`]'s inverse.
fn unflat_f32<const N: usize, const M: usize>(v: &[f64]) -> [[f32; N]; M] {
    std::array::from_fn(|i| std::array::from_fn(|k| v[i * N + k] as f32))
}

impl TriadResult {
    /// The device's sets, covariance factors and g-sensitivity at a series' nodes (in their
    /// order) turned into the series' coefficients; the fits stay the nodes'.
    pub(super) fn into_series(mut self) -> Self {
        self.sets = series_of(&self.sets, blob::triad_row, blob::triad_of_row);
        self.covs = series_of(&self.covs, flat_f32, unflat_f32);
        self.imu_covs = series_of(
            &self.imu_covs,
            |c| c.iter().flat_map(flat_f32).collect(),
            |v| {
                let n = size_of::<spincal::model::ImuOutputCovariance>() / size_of::<f32>();
                std::array::from_fn(|i| unflat_f32(&v[i * n..(i + 1) * n]))
            },
        );
        self.g = series_of(
            &self.g,
            |g| g.as_flattened().to_vec(),
            |v| std::array::from_fn(|i| std::array::from_fn(|k| v[3 * i + k])),
        );
        self
    }
}

/// Axis `i`'s factor over the IMU's features of its output
/// (`spincal::model::IMU_FEATURES`): bias, sensitivity row, lever arm (its regressor is
/// `S_ii` times the device's feature) or g-sensitivity row, and the nonlinear terms (g-squared,
/// kink, cubic, odd-quadratic): every term the correction applies.
fn imu_covariance(
    spec: &Spec<'_>,
    fit: &AxisFit,
    i: usize,
) -> Result<ImuOutputCovariance, covariance::CovarianceError> {
    let slope = fit.coef(spec.inputs[i]);
    let s = lever::SENSED;
    let (sq, cube, odd) = (format!("{s}^2"), format!("{s}^3"), format!("{s}:abs({s})"));
    let levers: [String; 3] = std::array::from_fn(|k| lever::column(i, k));
    let [i0, i1, i2] = spec.inputs;
    let (names, scale) = if spec.gyro {
        let [f0, f1, f2] = col::F;
        (
            [
                Some("1"),
                Some(i0),
                Some(i1),
                Some(i2),
                Some(f0),
                Some(f1),
                Some(f2),
                Some(sq.as_str()),
                Some(lever::SENSED_KINK),
                Some(cube.as_str()),
                Some(odd.as_str()),
            ],
            [1.0; 11],
        )
    } else {
        (
            [
                Some("1"),
                Some(i0),
                Some(i1),
                Some(i2),
                Some(levers[0].as_str()),
                Some(levers[1].as_str()),
                Some(levers[2].as_str()),
                Some(sq.as_str()),
                Some(lever::SENSED_KINK),
                Some(cube.as_str()),
                Some(odd.as_str()),
            ],
            [1.0, 1.0, 1.0, 1.0, slope, slope, slope, 1.0, 1.0, 1.0, 1.0],
        )
    };
    covariance::imu_output(fit.stated_fit(), &names, &scale, slope)
}

/// What axis `i` sensed (SI, along itself) at each observation of `t`, under its fit.
fn sensed_values(spec: &Spec<'_>, t: &Table, i: usize, fit: &AxisFit) -> Vec<f64> {
    let est = lever::Estimate {
        s: spec.inputs.map(|n| fit.coef(n)),
        r: std::array::from_fn(|k| fit.coef(&lever::column(i, k))),
        g: if spec.gyro {
            col::F.map(|n| fit.coef(n))
        } else {
            [0.0; 3]
        },
    };
    let at = lever::axis_table(t, spec.gyro, i, spec.outputs[i], &est, None, true);
    at.column(lever::SENSED).unwrap_or_default().to_vec()
}

/// The eight corners of the calibrated box.
pub(super) fn box_corners(ranges: &[Span; 3]) -> Vec<[f64; 3]> {
    (0..8)
        .map(|c| {
            std::array::from_fn(|j| {
                let r = ranges[j];
                f64::from(if c & (1 << j) == 0 { r.lo } else { r.hi })
            })
        })
        .collect()
}
