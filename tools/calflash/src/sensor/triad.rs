//! Triads and IMUs with a known reference (multi-position tumbles, rate-table steps,
//! centrifuge levels): bias and scale-misalignment per output axis, optional own-axis
//! nonlinearity, gyro g-sensitivity, accelerometer lever arms from spin, a coefficient set per
//! temperature and voltage point, and the correction.
//!
//! Forward model of output axis `i` (counts), fitted axis by axis, as `spincal::model::rotation`
//! writes it: `out_i = b_i + s_i . F_i [+ c2 x^2 + c3 x^3 + coq x|x|] [+ g_i . f (gyro)]`, with
//! `F_i` the specific force at accelerometer axis `i`'s lever arm (the reference rate for a
//! gyro) and `x` what the axis senses along itself in SI units; `sensor::lever` turns it into
//! regressions (Gauss-Newton for the lever arms). The device applies
//! `y = S^-1 (u - (b - center))`, `G = S^-1 g`, and the lever arms `r_i` as fitted.

use nalgebra::{DMatrix, Matrix3};
use spincal::model::{
    AxisNonlinearity, BoundedVec, CalibrationData, Channel, ImuCovariance, ImuOutputCovariance,
    ImuSet, Quantity, Sensor, Span, TriadCovariance, TriadSet,
};

use super::invert::{Own, TriadDevice, TriadForward, linearization, triad_inversion_error};
use super::table::{self, Layout};
use super::{AxisFit, Calibrated, Options, PointFit, WorkflowError, covariance, device, lever};
use crate::columns as col;
use crate::formula::{self, Formula};
use crate::obs::{self, Table};
use crate::stats::{self, select};

/// What is calibrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// An accelerometer triad.
    Accel,
    /// A gyro triad.
    Gyro,
    /// Both, sampled together.
    Imu,
}

/// The results of one triad.
struct TriadResult {
    /// Per point, per axis.
    fits: Vec<[AxisFit; 3]>,
    sets: Vec<TriadSet>,
    covs: Vec<TriadCovariance>,
    /// Per point, the IMU form of the covariance factors (`spincal::model::IMU_FEATURES`).
    imu_covs: Vec<[ImuOutputCovariance; 3]>,
    errors: Vec<[f64; 3]>,
    noise: Vec<[f64; 3]>,
    /// g-sensitivity per point (device form), gyro only.
    g: Vec<[[f64; 3]; 3]>,
    /// Lever arms (reference point), accelerometer only.
    lever: Option<[[f64; 3]; 3]>,
    centers: [f64; 3],
    ranges: [Span; 3],
}

struct Spec<'a> {
    outputs: [&'a str; 3],
    inputs: [&'a str; 3],
    /// A gyro (its sensed input is the rate; g-sensitivity possible).
    gyro: bool,
    /// g-sensitivity regressors (gyro).
    g_sens: bool,
    /// Lever-arm regressors (accelerometer under spin).
    lever: bool,
    nonlinear: bool,
}

/// Most regression steps of one axis' fit (Gauss-Newton for the lever arms, refreshed sensed
/// inputs for the nonlinear terms); it converges in a handful.
const MAX_STEPS: usize = 50;
/// Converged when no estimate moves by more than this, relative to the axis' scale factor (or
/// in metres for the lever arm).
const STEP_TOLERANCE: f64 = 1e-11;

fn fit_one(
    formula: &Formula,
    t: &Table,
    own: &str,
    alpha: f64,
    path: &std::path::Path,
    where_: &str,
) -> Result<AxisFit, WorkflowError> {
    AxisFit::fit(formula, t, own, alpha, (path, where_), true)
}

/// Fits axis `i` of a triad at one table point: one regression when the model is linear in
/// its coefficients, else regression steps from [`lever::Estimate::start`] until the estimates
/// the regressors are made from stop moving (`sensor::lever`).
#[allow(clippy::too_many_arguments)]
fn fit_axis(
    spec: &Spec<'_>,
    formula: &Formula,
    t: &Table,
    i: usize,
    lever_use: Option<&[bool; 3]>,
    opts: &Options,
    where_: &str,
) -> Result<AxisFit, WorkflowError> {
    let iterate = lever_use.is_some() || spec.nonlinear;
    let mut est = lever::Estimate::start(i);
    for step in 0..MAX_STEPS {
        let at = lever::axis_table(
            t,
            spec.gyro,
            i,
            spec.outputs[i],
            &est,
            lever_use,
            spec.nonlinear,
        );
        let fit = fit_one(formula, &at, spec.inputs[i], opts.alpha, &opts.file, where_)?;
        if !iterate {
            return Ok(fit);
        }
        let s = spec.inputs.map(|n| fit.coef(n));
        // The first step's lever coefficients are S_ii r_ik (its regressors assume a unit
        // sensitivity); later ones are r_ik.
        let per = if step == 0 { s[i] } else { 1.0 };
        let next = lever::Estimate {
            s,
            r: std::array::from_fn(|k| fit.coef(&lever::column(i, k)) / per),
            g: if spec.gyro {
                col::F.map(|n| fit.coef(n))
            } else {
                [0.0; 3]
            },
        };
        let scale = s[i].abs().max(f64::MIN_POSITIVE);
        let moved = (0..3)
            .map(|k| {
                ((next.s[k] - est.s[k]).abs() / scale)
                    .max((next.r[k] - est.r[k]).abs())
                    .max((next.g[k] - est.g[k]).abs() / scale)
            })
            .fold(0.0, f64::max);
        if step > 0 && moved <= STEP_TOLERANCE {
            return Ok(fit);
        }
        if !next.s.iter().chain(&next.r).all(|x| x.is_finite()) || s[i] == 0.0 {
            break;
        }
        est = next;
    }
    Err(WorkflowError::msg(
        &opts.file,
        format!(
            "{} at {where_}: the fit of the sensitivity and lever arm did not settle in {MAX_STEPS} steps; the plan may not separate them (spin the unit at several rates and hold it still in several positions)",
            spec.outputs[i]
        ),
    ))
}

/// Notes on the lever-arm components the plan cannot estimate.
fn lever_notes(estimable: &[[bool; 3]; 3], notes: &mut Vec<String>) {
    let missing: Vec<String> = (0..3)
        .flat_map(|i| (0..3).map(move |k| (i, k)))
        .filter(|(i, k)| !estimable[*i][*k])
        .map(|(i, k)| format!("r_{}{}", lever::AXES[i], lever::AXES[k]))
        .collect();
    let estimated = 9 - missing.len();
    if missing.is_empty() {
        notes.push("the plan spins the unit about axes and diagonals: all nine lever-arm components of the accelerometer are estimated".into());
    } else {
        notes.push(format!(
            "the plan spins the unit: {estimated} of the nine lever-arm components are estimated; {} cannot be (component k of axis i needs a spin with rate along both i and k, or an angular acceleration about the third axis) and are set to 0: add a `diagonal:LO:HI:N` plan item (the rate table's 45-degree fixture) to estimate them",
            missing.join(", ")
        ));
    }
}

fn triad(
    spec: &Spec<'_>,
    table: &Table,
    layout: &Layout,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<TriadResult, WorkflowError> {
    let path = &opts.file;
    let reference = layout.reference();
    let ref_table = table.select(&layout.points[reference].rows);
    let ref_where = table::describe(&layout.points[reference]);
    let estimable = spec
        .lever
        .then(|| lever::estimable(lever::motion(table).into_iter()));
    if let Some(e) = &estimable {
        lever_notes(e, notes);
    }
    let mut formulas = Vec::new();
    for i in 0..3 {
        let mut text = format!(
            "{} ~ 1 + {} + {} + {}",
            spec.outputs[i], spec.inputs[0], spec.inputs[1], spec.inputs[2]
        );
        if spec.nonlinear {
            let n = lever::SENSED;
            text.push_str(&format!(" + {n}^2 + {n}^3 + {n}:abs({n})"));
        }
        if spec.g_sens {
            text.push_str(&format!(" + {} + {} + {}", col::F[0], col::F[1], col::F[2]));
        }
        if let Some(e) = &estimable {
            for k in (0..3).filter(|k| e[i][*k]) {
                text.push_str(&format!(" + {}", lever::column(i, k)));
            }
        }
        notes.push(format!("preset expands {} to: {text}", spec.outputs[i]));
        let mut f = formula::parse(&text)?;
        // Terms are chosen on the first step's regressors at the reference point.
        let first = lever::axis_table(
            &ref_table,
            spec.gyro,
            i,
            spec.outputs[i],
            &lever::Estimate::start(i),
            estimable.as_ref().map(|e| &e[i]),
            spec.nonlinear,
        );
        fit_one(&f, &first, spec.inputs[i], opts.alpha, path, &ref_where)?;
        if !opts.keep_all_terms {
            let d = f.design(&first);
            let sopts = stats::Options {
                alpha: opts.alpha,
                ..stats::Options::default()
            };
            let linear: Vec<String> = spec.inputs.iter().map(|s| s.to_string()).collect();
            let ff = f.clone();
            let e = select::backward(
                &d.x,
                &d.y,
                &d.names,
                true,
                &sopts,
                opts.alpha,
                |names, j| {
                    let n = &names[j];
                    if n == "1" || linear.contains(n) {
                        return false;
                    }
                    let Some(t) = ff.terms.iter().find(|t| &t.name() == n) else {
                        return false;
                    };
                    !ff.terms
                        .iter()
                        .filter(|o| names.contains(&o.name()))
                        .any(|o| Formula::contains(o, t))
                },
            )
            .map_err(|e| WorkflowError::Message(e.to_string()))?;
            for s in &e.steps {
                notes.push(format!(
                    "{}: dropped {} (p = {:.3} > {})",
                    spec.outputs[i], s.dropped, s.p_value, opts.alpha
                ));
                f = f.without(&s.dropped);
            }
        }
        formulas.push(f);
    }
    // The lever components each axis' formula kept.
    let lever_use: Option<[[bool; 3]; 3]> = estimable.map(|_| {
        std::array::from_fn(|i| {
            std::array::from_fn(|k| {
                formulas[i]
                    .terms
                    .iter()
                    .any(|t| t.name() == lever::column(i, k))
            })
        })
    });

    let mut fits: Vec<[AxisFit; 3]> = Vec::new();
    for p in &layout.points {
        let t = table.select(&p.rows);
        let w = table::describe(p);
        let one = |i: usize| {
            fit_axis(
                spec,
                &formulas[i],
                &t,
                i,
                lever_use.as_ref().map(|u| &u[i]),
                opts,
                &w,
            )
        };
        fits.push([one(0)?, one(1)?, one(2)?]);
    }
    let s_of = |f: &[AxisFit; 3]| Matrix3::from_fn(|i, j| f[i].coef(spec.inputs[j]));
    let b_of = |f: &[AxisFit; 3]| [f[0].coef("1"), f[1].coef("1"), f[2].coef("1")];
    let lever_of = |f: &[AxisFit; 3]| -> [[f64; 3]; 3] {
        std::array::from_fn(|i| std::array::from_fn(|k| f[i].coef(&lever::column(i, k))))
    };
    let lever_arm = lever_use.map(|_| lever_of(&fits[reference]));
    let ranges = calibrated_ranges(spec, table, &s_of(&fits[reference]), lever_arm.as_ref());
    for (j, r) in ranges.iter().enumerate() {
        if r.lo >= r.hi {
            return Err(WorkflowError::msg(
                path,
                format!(
                    "{} is constant over the observations: the plan gives the triad no input along it",
                    spec.inputs[j]
                ),
            ));
        }
    }
    let centers = b_of(&fits[reference]);
    let mut out = TriadResult {
        fits: Vec::new(),
        sets: Vec::new(),
        covs: Vec::new(),
        imu_covs: Vec::new(),
        errors: Vec::new(),
        noise: Vec::new(),
        g: Vec::new(),
        lever: lever_arm,
        centers,
        ranges,
    };
    for (f, p) in fits.iter().zip(&layout.points) {
        let s = s_of(f);
        let b = b_of(f);
        let t = table.select(&p.rows);
        let inv = s.try_inverse().ok_or_else(|| {
            WorkflowError::msg(
                path,
                "the fitted sensitivity matrix is singular: the plan does not separate the axes",
            )
        })?;
        let own = |i: usize| Own {
            bias: b[i],
            slope: s[(i, i)],
            c2: f[i].coef(&format!("{}^2", lever::SENSED)),
            c3: f[i].coef(&format!("{}^3", lever::SENSED)),
            coq: f[i].coef(&format!("{0}:abs({0})", lever::SENSED)),
            ..Own::default()
        };
        // What each axis senses (SI, along itself) over the calibrated box, the data's own
        // sensed inputs included: the span its linearisation must cover.
        let corners = box_corners(&ranges);
        let fitted: [_; 3] = std::array::from_fn(|i| {
            let sensed = |x: &[f64; 3]| (0..3).map(|j| s[(i, j)] * x[j]).sum::<f64>() / s[(i, i)];
            let (lo, hi) = corners
                .iter()
                .map(sensed)
                .chain(sensed_values(spec, &t, i, &f[i]))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                });
            linearization(&own(i), centers[i], lo, hi)
        });
        let lins: [[f64; 5]; 3] = fitted.map(|f| f.n);
        // y = S^-1 (L - (b - center)), L_j = alpha_j + gamma_j u_j: the device's matrix is
        // S^-1 diag(gamma) and its offset S^-1 (alpha - (b - center)).
        let m = Matrix3::from_fn(|i, j| inv[(i, j)] * fitted[j].gamma);
        let off: [f64; 3] = std::array::from_fn(|i| {
            (0..3)
                .map(|k| inv[(i, k)] * (fitted[k].alpha - (b[k] - centers[k])))
                .sum::<f64>()
        });
        let err = triad_inversion_error(
            &TriadForward {
                s,
                own: std::array::from_fn(own),
            },
            &TriadDevice {
                lins,
                centers,
                m,
                off,
            },
            &ranges.map(|r| (f64::from(r.lo), f64::from(r.hi))),
        );
        let cov_of = |i: usize| {
            let idx: Vec<usize> = std::iter::once("1")
                .chain(spec.inputs)
                .map(|t| f[i].index(t).unwrap_or(0))
                .collect();
            DMatrix::from_fn(4, 4, |r, c| f[i].fit.covariance[(idx[r], idx[c])])
        };
        let md = DMatrix::from_fn(3, 3, |i, j| m[(i, j)]);
        let inv_d = DMatrix::from_fn(3, 3, |i, j| inv[(i, j)]);
        let at = table::describe(p);
        let located = |e: covariance::CovarianceError| {
            WorkflowError::msg(path, format!("{} at {at}: {e}", spec.outputs.join(" ")))
        };
        let factors = covariance::triad(&inv_d, &[cov_of(0), cov_of(1), cov_of(2)], &md, &off)
            .map_err(located)?;
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
                quadratic: lins[i][0] as f32,
                cubic: lins[i][1] as f32,
                odd_quadratic: lins[i][2] as f32,
                asymmetry: 0.0,
                asymmetry_break: 0.0,
            }),
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)] as f32)),
            offset: off.map(|o| o as f32),
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
    }
    out.fits = fits;
    Ok(out)
}

/// Axis `i`'s factor over the IMU's features of its output
/// (`spincal::model::IMU_FEATURES`): bias, sensitivity row, lever arm (its regressor is
/// `S_ii` times the device's feature) or g-sensitivity row, g-squared term.
fn imu_covariance(
    spec: &Spec<'_>,
    fit: &AxisFit,
    i: usize,
) -> Result<ImuOutputCovariance, covariance::CovarianceError> {
    let slope = fit.coef(spec.inputs[i]);
    let sq = format!("{}^2", lever::SENSED);
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
            ],
            [1.0; 8],
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
            ],
            [1.0, 1.0, 1.0, 1.0, slope, slope, slope, 1.0],
        )
    };
    covariance::imu_output(&fit.fit, &names, &scale, slope)
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

/// Adds the Earth's rate at `station` to the reference rate of every observation
/// (`crate::earth`): a still one needs the fixture's mark `h_*`.
fn add_earth_rate(
    table: &mut Table,
    station: &crate::earth::Station,
    path: &std::path::Path,
) -> Result<(), WorkflowError> {
    let get = |t: &Table, names: [&str; 3], r: usize| -> [f64; 3] {
        std::array::from_fn(|k| t.column(names[k]).map_or(0.0, |c| c[r]))
    };
    let mut w: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(table.len()));
    for r in 0..table.len() {
        let (f, wr, h) = (
            get(table, col::F, r),
            get(table, col::W, r),
            get(table, col::H, r),
        );
        let e = station.rate_in_body(f, wr, h).map_err(|why| {
            WorkflowError::msg(
                path,
                format!(
                    "line {}: {why}; --latitude needs the columns {} for still positions",
                    table.lines[r],
                    col::H.join(" ")
                ),
            )
        })?;
        for k in 0..3 {
            w[k].push(wr[k] + e[k]);
        }
    }
    for (name, values) in col::W.iter().zip(w) {
        table.set_column(name, values);
    }
    Ok(())
}

/// Without a station the Earth's rate is left out of the gyro's reference: how large it is
/// against the gyro bias's standard error. A REVIEW when the gyro resolves it.
fn earth_neglected(fits: &[AxisFit; 3]) -> super::Finding {
    let (axis, se) = fits
        .iter()
        .map(|f| {
            let i = f.index("1").unwrap_or(0);
            (f.output.clone(), f.fit.std_errors[i] / f.coef(&f.own).abs())
        })
        .fold((String::new(), f64::INFINITY), |best, x| {
            if x.1 < best.1 { x } else { best }
        });
    let ratio = crate::earth::RATE / se;
    let text = format!(
        "{axis}: the Earth's rate ({:.3e} rad/s, 15.04 deg/h), not in the model, is {ratio:.2} times the gyro bias's standard error ({se:.2e} rad/s)",
        crate::earth::RATE
    );
    if ratio >= 1.0 {
        super::Finding {
            verdict: super::Verdict::Review,
            text: format!(
                "{text}: the bias and misalignment absorb it; give --latitude and --heading, and the fixture's mark h_x h_y h_z of each still position"
            ),
        }
    } else {
        super::Finding {
            verdict: super::Verdict::Accept,
            text: format!("{text}: below what this gyro resolves"),
        }
    }
}

/// The eight corners of the calibrated box.
fn box_corners(ranges: &[Span; 3]) -> Vec<[f64; 3]> {
    (0..8)
        .map(|c| {
            std::array::from_fn(|j| {
                let r = ranges[j];
                f64::from(if c & (1 << j) == 0 { r.lo } else { r.hi })
            })
        })
        .collect()
}

/// The calibrated range of each output: what the device range-checks. For a gyro, the
/// reference rates; for an accelerometer, the sensor-domain force `f + e(w, dw)` the axes
/// sensed (`spincal::model::rotation`), centripetal included, over every observation: a rate
/// table that drove an axis past the centrifuge's levels calibrated it there.
fn calibrated_ranges(
    spec: &Spec<'_>,
    table: &Table,
    s: &Matrix3<f64>,
    lever_arm: Option<&[[f64; 3]; 3]>,
) -> [Span; 3] {
    let get = |names: [&str; 3], r: usize| -> [f64; 3] {
        std::array::from_fn(|k| table.column(names[k]).map_or(0.0, |c| c[r]))
    };
    let inv = s.try_inverse();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for r in 0..table.len() {
        let mut x = get(spec.inputs, r);
        if let (Some(arm), Some(inv)) = (lever_arm, &inv) {
            let (f, w, dw) = (get(col::F, r), get(col::W, r), get(col::DW, r));
            // z_i - s_i . f: what axis i sensed of its lever terms; S^-1 of it.
            let d: [f64; 3] = std::array::from_fn(|i| {
                let at = spincal::model::rotation::force_at(&f, &w, &dw, &arm[i]);
                (0..3).map(|j| s[(i, j)] * (at[j] - f[j])).sum()
            });
            for (j, xj) in x.iter_mut().enumerate() {
                *xj += (0..3).map(|k| inv[(j, k)] * d[k]).sum::<f64>();
            }
        }
        for j in 0..3 {
            lo[j] = lo[j].min(x[j]);
            hi[j] = hi[j].max(x[j]);
        }
    }
    std::array::from_fn(|j| Span::new(lo[j] as f32, hi[j] as f32))
}

/// Calibrates a triad or an IMU from the observations in `opts.file`.
///
/// # Errors
/// A [`WorkflowError`] naming the file, column, term or table point.
pub fn calibrate(opts: &Options, kind: Kind, nonlinear: bool) -> Result<Calibrated, WorkflowError> {
    let path = &opts.file;
    let header = obs::header(path, opts.format)?;
    let mut need: Vec<&str> = Vec::new();
    match kind {
        Kind::Accel => need.extend(col::F.iter().chain(&col::A)),
        Kind::Gyro => need.extend(col::W.iter().chain(&col::GYRO)),
        Kind::Imu => need.extend(
            col::F
                .iter()
                .chain(&col::W)
                .chain(&col::A)
                .chain(&col::GYRO),
        ),
    }
    let missing: Vec<&str> = need
        .iter()
        .copied()
        .filter(|n| !header.iter().any(|h| h == n))
        .collect();
    if !missing.is_empty() {
        return Err(WorkflowError::msg(
            path,
            format!(
                "missing the column{} {} (reference f_* in m/s^2, w_* in rad/s; outputs a_*, g_* in counts); the file has: {}",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", "),
                header.join(", ")
            ),
        ));
    }
    let has = |c: &str| header.iter().any(|h| h == c);
    let mut wanted: Vec<String> = need.iter().map(|s| s.to_string()).collect();
    for c in col::F
        .iter()
        .chain(&col::W)
        .chain(&col::DW)
        .chain(&col::H)
        .chain(&[col::TEMP, col::VOLT])
    {
        if has(c) && !wanted.iter().any(|w| w == c) {
            wanted.push(c.to_string());
        }
    }
    let mut table = obs::read_columns(path, &wanted, opts.format)?;
    let outputs: Vec<&str> = need
        .iter()
        .copied()
        .filter(|c| col::A.contains(c) || col::GYRO.contains(c))
        .collect();
    let beyond = super::exclude_beyond_rails(&mut table, &outputs, &opts.rails, path)?;
    let mut notes = Vec::new();
    if let Some(station) = &opts.earth {
        add_earth_rate(&mut table, station, path)?;
        notes.push(format!(
            "the Earth's rate at latitude {} deg with the fixture's mark at heading {} deg ({:.3e} rad/s) is in every observation's reference rate",
            station.latitude_deg,
            station.heading_deg,
            crate::earth::RATE
        ));
    }
    let spin = table.column(col::W[0]).is_some()
        && (0..table.len()).any(|r| {
            col::W
                .iter()
                .any(|w| table.column(w).is_some_and(|c| c[r] != 0.0))
        });
    let accel_lever = spin && kind != Kind::Gyro;
    if !accel_lever && kind != Kind::Gyro {
        notes.push(
            "the plan does not spin the unit: no lever arms (size effect) are estimated".into(),
        );
    }
    let f_varies = col::F.iter().all(|c| {
        table
            .column(c)
            .is_some_and(|v| v.iter().any(|x| *x != v[0]))
    });
    let layout = table::layout(
        &table,
        has(col::TEMP).then_some(col::TEMP),
        has(col::VOLT).then_some(col::VOLT),
    )
    .map_err(|e| WorkflowError::msg(path, e))?;
    if !table::exact_setpoints(&table, col::TEMP, &layout) {
        let temps = table.column(col::TEMP).unwrap_or_default();
        let (lo, hi) = temps
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(*t), b.max(*t))
            });
        return Err(WorkflowError::msg(
            path,
            format!(
                "the temperatures are spread from {lo:.1} to {hi:.1} C, as along a ramp, not held at setpoints: the continuous temperature model is fitted for single-axis sensors so far; a triad or an IMU needs its observations at a few exact temperatures (each reading within 1 C of its setpoint, the setpoints at least 3 C apart)"
            ),
        ));
    }
    let accel = (kind != Kind::Gyro)
        .then(|| {
            triad(
                &Spec {
                    outputs: col::A,
                    inputs: col::F,
                    gyro: false,
                    g_sens: false,
                    lever: accel_lever,
                    nonlinear,
                },
                &table,
                &layout,
                opts,
                &mut notes,
            )
        })
        .transpose()?;
    let gyro_g = kind != Kind::Accel && f_varies;
    if kind != Kind::Accel && !f_varies {
        notes.push(
            "the specific force does not vary in all three axes: no g-sensitivity is estimated"
                .into(),
        );
    }
    if kind == Kind::Gyro && gyro_g {
        notes.push(
            "a lone gyro triad cannot apply g-sensitivity on the device (it has no accelerometer); it is estimated and reported only"
                .into(),
        );
    }
    let gyro = (kind != Kind::Accel)
        .then(|| {
            triad(
                &Spec {
                    outputs: col::GYRO,
                    inputs: col::W,
                    gyro: true,
                    g_sens: gyro_g,
                    lever: false,
                    nonlinear,
                },
                &table,
                &layout,
                opts,
                &mut notes,
            )
        })
        .transpose()?;

    let env = device::environment(&table, &layout, opts)?;
    let identity = device::identity(opts)?;
    let channels = |t: &TriadResult| -> [Channel; 3] {
        std::array::from_fn(|j| Channel {
            center: t.centers[j] as f32,
            range: t.ranges[j],
        })
    };
    let bv = |n: usize| device::too_many(path, n);
    let sensor = match (&accel, &gyro) {
        (Some(a), Some(g)) => Sensor::Imu {
            accel_rails: opts.rails,
            gyro_rails: opts.rails,
            accel: channels(a),
            gyro: channels(g),
            lever_arm: a.lever.map(|r| r.map(|row| row.map(|v| v as f32))),
            sets: BoundedVec::from_slice(
                &a.sets
                    .iter()
                    .zip(&g.sets)
                    .enumerate()
                    .map(|(k, (sa, sg))| ImuSet {
                        accel: *sa,
                        gyro: *sg,
                        g_sensitivity: g
                            .g
                            .get(k)
                            .map_or([[0.0; 3]; 3], |m| m.map(|r| r.map(|v| v as f32))),
                    })
                    .collect::<Vec<_>>(),
            )
            .ok_or_else(|| bv(a.sets.len()))?,
            covariance: Some(
                BoundedVec::from_slice(
                    &a.imu_covs
                        .iter()
                        .zip(&g.imu_covs)
                        .map(|(ca, cg)| ImuCovariance {
                            accel: *ca,
                            gyro: *cg,
                        })
                        .collect::<Vec<_>>(),
                )
                .ok_or_else(|| bv(a.imu_covs.len()))?,
            ),
        },
        (Some(t), None) | (None, Some(t)) => Sensor::Triad {
            quantity: if accel.is_some() {
                Quantity::Acceleration
            } else {
                Quantity::AngularRate
            },
            rails: opts.rails,
            channels: channels(t),
            sets: BoundedVec::from_slice(&t.sets).ok_or_else(|| bv(t.sets.len()))?,
            covariance: Some(BoundedVec::from_slice(&t.covs).ok_or_else(|| bv(t.covs.len()))?),
        },
        (None, None) => return Err(WorkflowError::Message("nothing to calibrate".into())),
    };
    let data = CalibrationData {
        identity,
        environment: env,
        sensor,
    };
    let mut points = Vec::new();
    let parts: Vec<&TriadResult> = accel.iter().chain(gyro.iter()).collect();
    for (k, p) in layout.points.iter().enumerate() {
        let mut pf = PointFit {
            temp: p.temp,
            volt: p.volt,
            axes: Vec::new(),
            inversion_error: Vec::new(),
            noise: Vec::new(),
        };
        for t in &parts {
            pf.axes.extend(t.fits[k].iter().cloned());
            pf.inversion_error.extend(t.errors[k]);
            pf.noise.extend(t.noise[k]);
        }
        points.push(pf);
    }
    let (blob, output_errors) = device::build_and_check(path, &data, &points)?;
    let device_error = output_errors.iter().copied().fold(0.0, f64::max);
    let mut names = Vec::new();
    let mut units = Vec::new();
    let mut ranges = Vec::new();
    if let Some(a) = &accel {
        names.extend(col::A.map(String::from));
        units.extend([device::unit(Quantity::Acceleration); 3]);
        ranges.extend(a.ranges);
    }
    if let Some(g) = &gyro {
        names.extend(col::GYRO.map(String::from));
        units.extend([device::unit(Quantity::AngularRate); 3]);
        ranges.extend(g.ranges);
        if let Some(gm) = g.g.get(layout.reference()) {
            notes.push(format!(
                "g-sensitivity at the reference point (rad/s per m/s^2, device form): {:?}",
                gm.map(|r| r.map(|v| (v * 1e6).round() / 1e6))
            ));
        }
    }
    if let Some(r) = accel.as_ref().and_then(|a| a.lever) {
        notes.push(format!(
            "lever arms (m), rows = accelerometer axes: {:?}",
            r.map(|row| row.map(|v| (v * 1e5).round() / 1e5))
        ));
    }
    let mut findings = super::findings(&points, &names, &units, opts, &output_errors);
    findings.extend(beyond);
    if let (Some(g), None) = (&gyro, &opts.earth) {
        findings.push(earth_neglected(&g.fits[layout.reference()]));
    }
    Ok(Calibrated {
        data,
        blob,
        points,
        temps: layout.temps.clone(),
        volts: layout.volts.clone(),
        reference: layout.reference(),
        notes,
        breakpoint: 0.0,
        decisions: Vec::new(),
        ranges,
        units,
        device_error,
        findings,
        earth: opts.earth,
        thermal: None,
    })
}
