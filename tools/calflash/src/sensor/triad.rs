//! Triads and IMUs with a known reference (multi-position tumbles, rate-table steps,
//! centrifuge levels): bias and scale-misalignment per output axis, optional own-axis
//! nonlinearity, gyro g-sensitivity, accelerometer lever arms from spin, a coefficient set per
//! temperature and voltage point, and the correction.
//!
//! Forward model of output axis `i` (counts), fitted axis by axis:
//! `out_i = b_i + sum_j S_ij x_j [+ c2 x_i^2 + c3 x_i^3 + coq x_i|x_i|]
//!          [+ sum_j Gout_ij f_j (gyro)] [+ sum_k L_ik (w_i w_k - d_ik |w|^2) (accelerometer)]`,
//! with `x` the reference specific force (accelerometer) or rate (gyro). The device applies
//! `y = S^-1 (u - (b - center))`, `G = S^-1 Gout`, and lever arms `r_ik = L_ik / S_ii`.

use nalgebra::{DMatrix, Matrix3};
use spincal::model::{
    AxisNonlinearity, BoundedVec, CalibrationData, Channel, ImuCovariance, ImuSet, Quantity,
    Sensor, Span, TriadCovariance, TriadSet,
};

use super::invert::{Own, linearization, linearize};
use super::table::{self, Layout};
use super::{AxisFit, Calibrated, Options, PointFit, WorkflowError, covariance, device};
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

/// Name of the lever-arm regressor of accelerometer axis `i`, component `k`.
fn lever_column(i: usize, k: usize) -> String {
    format!("lever_{}{}", ["x", "y", "z"][i], ["x", "y", "z"][k])
}

/// The results of one triad.
struct TriadResult {
    /// Per point, per axis.
    fits: Vec<[AxisFit; 3]>,
    sets: Vec<TriadSet>,
    covs: Vec<TriadCovariance>,
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
    /// g-sensitivity regressors (gyro).
    g_sens: bool,
    /// Lever-arm regressors (accelerometer under spin).
    lever: bool,
    nonlinear: bool,
}

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
    let mut formulas = Vec::new();
    for i in 0..3 {
        let mut text = format!(
            "{} ~ 1 + {} + {} + {}",
            spec.outputs[i], spec.inputs[0], spec.inputs[1], spec.inputs[2]
        );
        let own = spec.inputs[i];
        if spec.nonlinear {
            text.push_str(&format!(" + {own}^2 + {own}^3 + {own}:abs({own})"));
        }
        if spec.g_sens {
            text.push_str(&format!(" + {} + {} + {}", col::F[0], col::F[1], col::F[2]));
        }
        if spec.lever {
            for k in 0..3 {
                let name = lever_column(i, k);
                if table
                    .column(&name)
                    .is_some_and(|c| c.iter().any(|v| v.abs() > 1e-12))
                {
                    text.push_str(&format!(" + {name}"));
                }
            }
        }
        notes.push(format!("preset expands {} to: {text}", spec.outputs[i]));
        let mut f = formula::parse(&text)?;
        fit_one(&f, &ref_table, own, opts.alpha, path, &ref_where)?;
        if !opts.keep_all_terms {
            let d = f.design(&ref_table);
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

    let mut fits: Vec<[AxisFit; 3]> = Vec::new();
    for p in &layout.points {
        let t = table.select(&p.rows);
        let w = table::describe(p);
        let a = fit_one(&formulas[0], &t, spec.inputs[0], opts.alpha, path, &w)?;
        let b = fit_one(&formulas[1], &t, spec.inputs[1], opts.alpha, path, &w)?;
        let c = fit_one(&formulas[2], &t, spec.inputs[2], opts.alpha, path, &w)?;
        fits.push([a, b, c]);
    }
    let ranges: [Span; 3] = std::array::from_fn(|j| {
        let c = table.column(spec.inputs[j]).unwrap_or_default();
        Span::new(
            c.iter().copied().fold(f64::INFINITY, f64::min) as f32,
            c.iter().copied().fold(f64::NEG_INFINITY, f64::max) as f32,
        )
    });
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
    let s_of = |f: &[AxisFit; 3]| Matrix3::from_fn(|i, j| f[i].coef(spec.inputs[j]));
    let b_of = |f: &[AxisFit; 3]| [f[0].coef("1"), f[1].coef("1"), f[2].coef("1")];
    let centers = b_of(&fits[reference]);
    let mut out = TriadResult {
        fits: Vec::new(),
        sets: Vec::new(),
        covs: Vec::new(),
        errors: Vec::new(),
        noise: Vec::new(),
        g: Vec::new(),
        lever: None,
        centers,
        ranges,
    };
    for f in &fits {
        let s = s_of(f);
        let b = b_of(f);
        let m = s.try_inverse().ok_or_else(|| {
            WorkflowError::msg(
                path,
                "the fitted sensitivity matrix is singular: the plan does not separate the axes",
            )
        })?;
        let own = |i: usize| Own {
            bias: b[i],
            slope: s[(i, i)],
            c2: f[i].coef(&format!("{}^2", spec.inputs[i])),
            c3: f[i].coef(&format!("{}^3", spec.inputs[i])),
            coq: f[i].coef(&format!("{0}:abs({0})", spec.inputs[i])),
            ..Own::default()
        };
        let fitted: [_; 3] = std::array::from_fn(|i| {
            linearization(
                &own(i),
                centers[i],
                f64::from(ranges[i].lo),
                f64::from(ranges[i].hi),
            )
        });
        let lins: [[f64; 5]; 3] = fitted.map(|f| f.n);
        // y = S^-1 (L - (b - center)), L_j = alpha_j + gamma_j u_j: the device's matrix is
        // S^-1 diag(gamma) and its offset S^-1 (alpha - (b - center)).
        let inv = m;
        let m = Matrix3::from_fn(|i, j| inv[(i, j)] * fitted[j].gamma);
        let off: [f64; 3] = std::array::from_fn(|i| {
            (0..3)
                .map(|k| inv[(i, k)] * (fitted[k].alpha - (b[k] - centers[k])))
                .sum::<f64>()
        });
        // Inversion error over the calibrated box: forward (fitted, cross-axis included), then
        // the device's correction in f64.
        let mut err = [0.0f64; 3];
        for k in 0..1000u32 {
            let x: [f64; 3] = std::array::from_fn(|j| {
                let frac = (f64::from(k) * [0.618_034, 0.754_878, 0.569_840][j]).fract();
                f64::from(ranges[j].lo) + (f64::from(ranges[j].hi) - f64::from(ranges[j].lo)) * frac
            });
            let out: [f64; 3] = std::array::from_fn(|i| {
                let o = own(i);
                o.output(x[i])
                    + (0..3)
                        .filter(|j| *j != i)
                        .map(|j| s[(i, j)] * x[j])
                        .sum::<f64>()
            });
            let u: [f64; 3] = std::array::from_fn(|i| linearize(&lins[i], out[i] - centers[i]));
            for i in 0..3 {
                let y = off[i] + (0..3).map(|j| m[(i, j)] * u[j]).sum::<f64>();
                err[i] = err[i].max((y - x[i]).abs());
            }
        }
        let cov_of = |i: usize| {
            let idx: Vec<usize> = std::iter::once("1")
                .chain(spec.inputs)
                .map(|t| f[i].index(t).unwrap_or(0))
                .collect();
            DMatrix::from_fn(4, 4, |r, c| f[i].fit.covariance[(idx[r], idx[c])])
        };
        let md = DMatrix::from_fn(3, 3, |i, j| m[(i, j)]);
        let inv_d = DMatrix::from_fn(3, 3, |i, j| inv[(i, j)]);
        let factors = covariance::triad(&inv_d, &[cov_of(0), cov_of(1), cov_of(2)], &md, &off);
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
    if spec.lever {
        let f = &fits[reference];
        let s = s_of(f);
        out.lever = Some(std::array::from_fn(|i| {
            std::array::from_fn(|k| f[i].coef(&lever_column(i, k)) / s[(i, i)])
        }));
    }
    out.fits = fits;
    Ok(out)
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
    for c in col::F.iter().chain(&col::W).chain(&[col::TEMP, col::VOLT]) {
        if has(c) && !wanted.iter().any(|w| w == c) {
            wanted.push(c.to_string());
        }
    }
    let mut table = obs::read_columns(path, &wanted, opts.format)?;
    let mut notes = Vec::new();
    let spin = table.column(col::W[0]).is_some()
        && (0..table.len()).any(|r| {
            col::W
                .iter()
                .any(|w| table.column(w).is_some_and(|c| c[r] != 0.0))
        });
    let accel_lever = spin && kind != Kind::Gyro;
    if accel_lever {
        let w: Vec<[f64; 3]> = (0..table.len())
            .map(|r| std::array::from_fn(|k| table.column(col::W[k]).map_or(0.0, |c| c[r])))
            .collect();
        for i in 0..3 {
            for k in 0..3 {
                let v: Vec<f64> = w
                    .iter()
                    .map(|w| {
                        w[i] * w[k]
                            - if i == k {
                                w.iter().map(|c| c * c).sum::<f64>()
                            } else {
                                0.0
                            }
                    })
                    .collect();
                table.push_column(&lever_column(i, k), v);
            }
        }
        notes.push("the plan spins the unit: the accelerometer's lever arms are estimated".into());
    } else if kind != Kind::Gyro {
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
    let accel = (kind != Kind::Gyro)
        .then(|| {
            triad(
                &Spec {
                    outputs: col::A,
                    inputs: col::F,
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
                    &a.covs
                        .iter()
                        .zip(&g.covs)
                        .map(|(ca, cg)| ImuCovariance {
                            accel: *ca,
                            gyro: *cg,
                        })
                        .collect::<Vec<_>>(),
                )
                .ok_or_else(|| bv(a.covs.len()))?,
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
    let (blob, device_error) = device::build_and_check(path, &data, &points)?;
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
    let findings = super::findings(&points, &names, &units, opts, device_error);
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
    })
}
