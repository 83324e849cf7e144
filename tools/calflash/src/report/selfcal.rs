//! Reports of a calibration without equipment: the terminal summary, the JSON record
//! (`calflash.selfcal/1`, with the convention spelled out) and the HTML report with its figures.

use std::fmt::Write as _;

use serde_json::{Value, json};

use super::html::esc;
use super::plot::{Figure, Series, svg};
use super::terminal::{num, pval};
use crate::nonlinear::selfcal::SelfCal;
use crate::obs::recording::Recording;
use crate::obs::units::Sensor;
use crate::sensor::Verdict;
use crate::sensor::selfcal::DeviceCheck;

/// The convention of the stored coefficients, for users applying them elsewhere.
pub const CONVENTION: &str = "raw counts r per axis (or SI values, as `inputs` says: then read `count` as that unit), v = r - center (counts); accelerometer a = M (v + q * v^2) + o in m/s^2, \
M upper triangular (m/s^2 per count), rows and columns in x, y, z order, q per axis (1/count), o in m/s^2; \
gyro w = G v in rad/s, G full 3x3 (rad/s per count) that also rotates the gyro axes into the body frame, \
center = the gyro bias in counts; body frame = accelerometer frame: x along the accelerometer's x axis, y in its x-y plane, z completing a right-handed frame. \
Matrices are row-major: M[i][j] multiplies v[j] into output i.";

/// The gyro fit's RMS angle error above which it explains the rotations too badly to be
/// trusted, degrees (good hand tumbles leave a few tenths).
pub const GYRO_REJECT_DEG: f64 = 3.0;

/// The accelerometer fit's RMS of |a| - g above which it cannot be trusted, as a fraction of g
/// (good tumbles leave a few parts in 10^4).
pub const ACCEL_REJECT: f64 = 0.01;

/// Why the calibration cannot be trusted (empty when it can): parameters a fit cannot observe,
/// or fits that do not explain the recording. Such a calibration is judged REJECT and writes no
/// blob unless `--force-blob`.
#[must_use]
pub fn rejected(c: &SelfCal) -> Vec<String> {
    let mut why = Vec::new();
    if c.accel.covariance.is_none() {
        why.push("the accelerometer's parameters are not all observable from these poses: turn the unit through more directions".to_string());
    }
    if c.gyro.covariance.is_none() {
        why.push("the gyro's parameters are not all observable from these rotations: rotate about all three axes".to_string());
    }
    if c.accel.rms() > ACCEL_REJECT * c.options.g {
        why.push(format!(
            "the accelerometer fit leaves |a| - g of {:.4} m/s^2 RMS ({:.2} % of g, more than {} %): poses that moved, or a --g far from the site's",
            c.accel.rms(),
            100.0 * c.accel.rms() / c.options.g,
            100.0 * ACCEL_REJECT
        ));
    }
    if c.gyro.rms_deg() > GYRO_REJECT_DEG {
        why.push(format!(
            "the gyro fit predicts the gravity direction after each rotation {:.1} degrees RMS off (more than {GYRO_REJECT_DEG}): the rotations are not what the gyro measured (a wrong --rate, a gyro file of another recording, poses that moved)",
            c.gyro.rms_deg()
        ));
    }
    why
}

/// Whether the result can be used as it is: REJECT with the reasons of [`rejected`], else
/// REVIEW with what to look at, else ACCEPT.
#[must_use]
pub fn verdict(c: &SelfCal, check: Option<&DeviceCheck>) -> (Verdict, Vec<String>) {
    let why = rejected(c);
    if !why.is_empty() {
        return (Verdict::Reject, why);
    }
    let mut notes = Vec::new();
    if c.holdout.rms > 2.0 * c.accel.rms() {
        notes.push(format!(
            "poses left out are predicted {:.1} times worse than the fit: too few poses for the model, or a pose that moved",
            c.holdout.rms / c.accel.rms()
        ));
    }
    if !c.skipped.is_empty() {
        notes.push(format!(
            "{} rotations left out of the gyro fit",
            c.skipped.len()
        ));
    }
    let limit = 1e-3 * c.accel.sigma();
    if let Some(check) = check
        && check.accel > limit.max(1e-5)
    {
        notes.push(format!(
            "the device's f32 correction differs from the fit by {:.2e} m/s^2",
            check.accel
        ));
    }
    let v = if notes.is_empty() {
        Verdict::Accept
    } else {
        Verdict::Review
    };
    (v, notes)
}

fn matrix_lines(name: &str, m: &[[f64; 3]; 3], sd: Option<&[[f64; 3]; 3]>, unit: &str) -> String {
    let mut s = String::new();
    for i in 0..3 {
        let row: Vec<String> = (0..3)
            .map(|j| match sd {
                Some(e) if e[i][j] > 0.0 => format!("{:>13} ± {:<9}", num(m[i][j]), num(e[i][j])),
                _ => format!("{:>13}   {:<9}", num(m[i][j]), ""),
            })
            .collect();
        let _ = writeln!(
            s,
            "    {}{} {}",
            if i == 0 {
                format!("{name:<3}")
            } else {
                "   ".into()
            },
            row.join(" "),
            if i == 0 { unit } else { "" }
        );
    }
    s
}

/// Standard errors of the accelerometer's matrix, offset and quadratic terms.
type AccelSd = ([[f64; 3]; 3], [f64; 3], [f64; 3]);

fn accel_sd(c: &SelfCal) -> Option<AccelSd> {
    let cov = c.accel.covariance.as_ref()?;
    let sd = |k: usize| cov[(k, k)].sqrt();
    Some((
        [
            [sd(0), sd(1), sd(2)],
            [0.0, sd(3), sd(4)],
            [0.0, 0.0, sd(5)],
        ],
        [sd(6), sd(7), sd(8)],
        if c.accel.params.len() == 12 {
            [sd(9), sd(10), sd(11)]
        } else {
            [0.0; 3]
        },
    ))
}

fn gyro_sd(c: &SelfCal) -> Option<[[f64; 3]; 3]> {
    let cov = c.gyro.covariance.as_ref()?;
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| cov[(3 * i + j, 3 * i + j)].sqrt())
    }))
}

fn rms_deg(a: &[f64]) -> f64 {
    (a.iter().map(|x| x * x).sum::<f64>() / a.len().max(1) as f64)
        .sqrt()
        .to_degrees()
}

/// The terminal summary.
#[must_use]
pub fn summary(c: &SelfCal, rec: &Recording, check: Option<&DeviceCheck>, serial: &str) -> String {
    let mut s = String::new();
    let (v, notes) = verdict(c, check);
    let word = v.word();
    let _ = writeln!(s, "calflash selfcal  {}  unit {serial}: {word}", rec.source);
    for n in &notes {
        let _ = writeln!(s, "  {word} {n}");
    }
    let dur = rec.t[rec.len() - 1] - rec.t[0];
    let _ = writeln!(
        s,
        "  recording    {} samples at {:.1} Hz over {:.1} s; {} gaps ({} samples dropped); saturated samples excluded: {} accelerometer, {} gyro",
        rec.len(),
        rec.rate(),
        dur,
        rec.gaps.len(),
        rec.gaps.iter().map(|g| g.missing).sum::<usize>(),
        rec.saturated_count.0,
        rec.saturated_count.1
    );
    if let Some((name, lo, mean, hi)) = temperature(rec) {
        let _ = writeln!(
            s,
            "  temperature  column {name}: {lo} to {hi}, mean {mean:.2} (carried into the record)"
        );
    }
    let trials: Vec<String> = c
        .trials
        .iter()
        .map(|t| {
            format!(
                "{}x: {} poses{}",
                t.multiplier,
                t.poses,
                t.rms.map_or(String::new(), |r| format!(" {:.3}", r * 1e3))
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "  still poses  {} at {} x the initial rest's level ({} s rest, window {} s, at least {} s still); searched [mm/s^2]: {}",
        c.poses.len(),
        c.trials[c.chosen].multiplier,
        c.options.init_rest,
        c.options.window,
        c.options.min_still,
        trials.join(", ")
    );
    let _ = writeln!(
        s,
        "  accelerometer  |a| - g over {} poses: RMS {:.3} mm/s^2, max {:.3} mm/s^2 (g = {} m/s^2); hold-out ({} folds): RMS {:.3}, max {:.3} mm/s^2",
        c.poses.len(),
        c.accel.rms() * 1e3,
        c.accel.max() * 1e3,
        c.options.g,
        c.holdout.folds,
        c.holdout.rms * 1e3,
        c.holdout.max * 1e3
    );
    if let Some(q) = &c.quadratic_test {
        let _ = writeln!(
            s,
            "    quadratic terms: F = {}, p = {}: {}",
            num(q.f),
            pval(q.p),
            if q.kept {
                "kept"
            } else {
                "not significant, not kept"
            }
        );
    }
    let sd = accel_sd(c);
    let m = &c.accel.model;
    let [ua, ug] = rec.units;
    let (pa, pg) = (ua.per(Sensor::Accel), ug.per(Sensor::Gyro));
    let _ = writeln!(
        s,
        "  inputs  accelerometer in {}, gyro in {}",
        ua.describe(Sensor::Accel),
        ug.describe(Sensor::Gyro)
    );
    s.push_str(&matrix_lines(
        "M",
        &m.matrix,
        sd.as_ref().map(|x| &x.0),
        &format!("m/s^2 per {pa}"),
    ));
    let _ = writeln!(
        s,
        "    o   {} m/s^2",
        (0..3)
            .map(|j| format!(
                "{} ± {}",
                num(m.offset[j]),
                sd.map_or("-".into(), |x| num(x.1[j]))
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if c.accel.params.len() == 12 {
        let _ = writeln!(
            s,
            "    q   {} 1/({pa})",
            (0..3)
                .map(|j| format!(
                    "{} ± {}",
                    num(m.quadratic[j]),
                    sd.map_or("-".into(), |x| num(x.2[j]))
                ))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(
        s,
        "    center {} {}",
        m.center.map(|x| format!("{x}")).join(", "),
        plural(pa)
    );
    let bias_word = match c.options.gyro_bias {
        crate::nonlinear::selfcal::GyroBias::Poses => "bias from the poses on either side",
        crate::nonlinear::selfcal::GyroBias::Rest => "bias from the initial rest",
    };
    let _ = writeln!(
        s,
        "  gyro  gravity-direction error over {} rotations: RMS {:.3} deg, max {:.3} deg ({bias_word}); with the stored constant bias: RMS {:.3} deg",
        c.rotations.len(),
        c.gyro.rms_deg(),
        c.gyro.max_deg(),
        rms_deg(&c.constant_bias_angles)
    );
    s.push_str(&matrix_lines(
        "G",
        &c.gyro.matrix,
        gyro_sd(c).as_ref(),
        &format!("rad/s per {pg}"),
    ));
    let _ = writeln!(
        s,
        "    bias {} {u} (stored as the gyro center); spread of the bias between poses {} {u}",
        c.gyro_bias.map(|x| format!("{x:.5}")).join(", "),
        c.gyro_bias_spread.map(|x| format!("{x:.5}")).join(", "),
        u = plural(pg)
    );
    for k in &c.skipped {
        let _ = writeln!(
            s,
            "    rotation after pose {} left out: {}",
            k.pose + 1,
            k.why
        );
    }
    match check {
        Some(check) => {
            let _ = writeln!(
                s,
                "  device  blob {} bytes; its f32 correction against the f64 fit: {:.1e} m/s^2, {:.1e} rad/s; |a| - g from its corrected samples: RMS {:.3} mm/s^2",
                check.blob.len(),
                check.accel,
                check.gyro,
                check.device_accel_rms * 1e3
            );
        }
        None => {
            let _ = writeln!(s, "  device  {NO_BLOB}");
        }
    }
    s
}

/// Why a calibration of physical values has no blob.
pub const NO_BLOB: &str = "no blob: the values are physical (SI) and the device corrects converter \
codes; give --lsb ACCEL,GYRO (the value of one code, from the part's datasheet) to calibrate the \
codes and write one";

/// A temperature column's name, least, mean and largest value.
fn temperature(rec: &Recording) -> Option<(&str, f64, f64, f64)> {
    let (name, v) = rec.temperature.as_ref()?;
    if v.is_empty() {
        return None;
    }
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some((name, lo, v.iter().sum::<f64>() / v.len() as f64, hi))
}

/// `count` -> `counts`; a unit stays as it is.
fn plural(per: &str) -> &str {
    if per == "count" { "counts" } else { per }
}

/// The JSON record.
#[must_use]
pub fn record(c: &SelfCal, rec: &Recording, check: Option<&DeviceCheck>, serial: &str) -> Value {
    let (v, notes) = verdict(c, check);
    let word = v.word();
    let t0 = rec.t[0];
    let poses: Vec<Value> = c
        .poses
        .iter()
        .zip(&c.pose_means)
        .zip(&c.accel.residuals)
        .map(|((r, m), e)| json!({"from_s": rec.t[r.start] - t0, "to_s": rec.t[r.end - 1] - t0, "lines": [rec.line[r.start], rec.line[r.end - 1]], "accel_mean_counts": m, "residual_m_s2": e}))
        .collect();
    let rotations: Vec<Value> = c.rotations.iter().zip(&c.gyro.angles).zip(&c.constant_bias_angles).map(|((k, a), b)| json!({"after_pose": k, "angle_error_deg": a.to_degrees(), "constant_bias_angle_error_deg": b.to_degrees()})).collect();
    let cov = |m: &Option<nalgebra::DMatrix<f64>>| {
        m.as_ref().map(|m| {
            (0..m.nrows())
                .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect::<Vec<f64>>())
                .collect::<Vec<_>>()
        })
    };
    json!({
        "schema": "calflash.selfcal/1",
        "serial": serial,
        "verdict": word,
        "notes": notes,
        "convention": CONVENTION,
        "recording": {"source": rec.source, "samples": rec.len(), "rate_hz": rec.rate(), "gaps": rec.gaps, "saturated": {"accel": rec.saturated_count.0, "gyro": rec.saturated_count.1}, "temperature": temperature(rec).map(|(name, lo, mean, hi)| json!({"column": name, "min": lo, "mean": mean, "max": hi}))},
        "options": c.options,
        "threshold_search": c.trials,
        "chosen_multiplier": c.trials[c.chosen].multiplier,
        "poses": poses,
        "accel": {
            "center_counts": c.accel.model.center,
            "matrix_m_s2_per_count": c.accel.model.matrix,
            "offset_m_s2": c.accel.model.offset,
            "quadratic_per_count": c.accel.model.quadratic,
            "terms": c.accel.terms,
            "parameters": c.accel.params,
            "covariance": cov(&c.accel.covariance),
            "rms_m_s2": c.accel.rms(),
            "max_m_s2": c.accel.max(),
            "sigma_m_s2": c.accel.sigma(),
            "quadratic_test": c.quadratic_test,
            "holdout": c.holdout,
        },
        "gyro": {
            "bias_counts": c.gyro_bias,
            "bias_spread_counts": c.gyro_bias_spread,
            "bias_rms_counts": c.gyro_bias_rms,
            "matrix_rad_s_per_count": c.gyro.matrix,
            "terms": crate::nonlinear::rotation::TERMS,
            "covariance": cov(&c.gyro.covariance),
            "rms_deg": c.gyro.rms_deg(),
            "max_deg": c.gyro.max_deg(),
            "constant_bias_rms_deg": rms_deg(&c.constant_bias_angles),
            "rotations": rotations,
            "skipped": c.skipped,
        },
        "inputs": {"accel": rec.units[0].describe(Sensor::Accel), "gyro": rec.units[1].describe(Sensor::Gyro), "accel_file_unit": rec.units[0].file.name(), "gyro_file_unit": rec.units[1].file.name(), "lsb": rec.units.map(|u| u.lsb)},
        "device": check.map_or_else(
            || json!({"blob_bytes": Value::Null, "not_written": NO_BLOB}),
            |check| json!({"blob_bytes": check.blob.len(), "accel_f32_vs_f64_m_s2": check.accel, "gyro_f32_vs_f64_rad_s": check.gyro, "accel_rms_m_s2": check.device_accel_rms}),
        ),
    })
}

/// The HTML report.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn html(
    c: &SelfCal,
    rec: &Recording,
    check: Option<&DeviceCheck>,
    serial: &str,
) -> Result<String, String> {
    let (v, notes) = verdict(c, check);
    let word = v.word();
    let t0 = rec.t[0];
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Calibration {0}</title>\n<style>{1}</style>\n</head>\n<body>\n<h1>Calibration of unit {0} without external equipment</h1>\n<p class=\"verdict {2}\">{3}</p>\n",
        esc(serial),
        super::html::STYLE,
        word.to_lowercase(),
        word
    );
    let _ = writeln!(h, "<pre>{}</pre>", esc(&summary(c, rec, check, serial)));
    for n in &notes {
        let _ = writeln!(h, "<p><b>{word}</b>: {}</p>", esc(n));
    }
    // The signal and the poses found. Every k-th sample keeps the figure small.
    let step = (rec.len() / 3000).max(1);
    let names = ["x", "y", "z"];
    let sig: Vec<Vec<(f64, f64)>> = (0..3)
        .map(|j| {
            (0..rec.len())
                .step_by(step)
                .map(|i| (rec.t[i] - t0, rec.acc[i][j]))
                .collect()
        })
        .collect();
    let bands: Vec<(f64, f64)> = c
        .poses
        .iter()
        .map(|r| (rec.t[r.start] - t0, rec.t[r.end - 1] - t0))
        .collect();
    let fig = Figure {
        title: "Accelerometer values and the still poses found",
        x: "time [s]",
        y: rec.units[0].per(Sensor::Accel),
        series: (0..3)
            .map(|j| Series::curve(names[j], &sig[j], j))
            .collect(),
        bands: bands.clone(),
        band_label: "still pose",
        zero_line: false,
    };
    let _ = writeln!(
        h,
        "<h2>Still poses</h2>\n<div class=\"fig\">{}</div>",
        svg(&fig)?
    );
    let threshold = c.trials[c.chosen].multiplier * c.rest_level;
    let meas: Vec<(f64, f64)> = (0..rec.len())
        .step_by(step)
        .map(|i| (rec.t[i] - t0, c.measure[i].max(1e-12).log10()))
        .collect();
    let th = [
        (0.0, threshold.log10()),
        (rec.t[rec.len() - 1] - t0, threshold.log10()),
    ];
    let fig = Figure {
        title: "Still measure (norm of the windowed variances) and the threshold",
        x: "time [s]",
        y: "log10 of the variance",
        series: vec![
            Series::curve("still measure", &meas, 0),
            Series::curve("threshold", &th, 3),
        ],
        bands,
        band_label: "still pose",
        zero_line: false,
    };
    let _ = writeln!(h, "<div class=\"fig\">{}</div>", svg(&fig)?);
    let trials: Vec<(f64, f64)> = c
        .trials
        .iter()
        .filter_map(|t| t.rms.map(|r| (t.multiplier, r * 1e3)))
        .collect();
    let fig = Figure {
        title: "Threshold search: accelerometer RMS at each threshold",
        x: "threshold [x initial rest level]",
        y: "RMS |a| - g [mm/s^2]",
        series: vec![Series::curve("linear fit", &trials, 0)],
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
    };
    let _ = writeln!(h, "<div class=\"fig\">{}</div>", svg(&fig)?);
    let res: Vec<(f64, f64)> = c
        .accel
        .residuals
        .iter()
        .enumerate()
        .map(|(k, r)| ((k + 1) as f64, r * 1e3))
        .collect();
    let fig = Figure {
        title: "Accelerometer: |a| - g at each pose",
        x: "pose",
        y: "mm/s^2",
        series: vec![Series::dots("residual", &res, 0)],
        bands: Vec::new(),
        band_label: "",
        zero_line: true,
    };
    let _ = writeln!(
        h,
        "<h2>Accelerometer</h2>\n<div class=\"fig\">{}</div>",
        svg(&fig)?
    );
    let ang: Vec<(f64, f64)> = c
        .rotations
        .iter()
        .zip(&c.gyro.angles)
        .map(|(k, a)| ((k + 1) as f64, a.to_degrees()))
        .collect();
    let angc: Vec<(f64, f64)> = c
        .rotations
        .iter()
        .zip(&c.constant_bias_angles)
        .map(|(k, a)| ((k + 1) as f64, a.to_degrees()))
        .collect();
    let fig = Figure {
        title: "Gyro: gravity-direction error after each rotation",
        x: "rotation (after pose)",
        y: "degrees",
        series: vec![
            Series::dots("fit", &ang, 0),
            Series::dots("stored constant bias", &angc, 1),
        ],
        bands: Vec::new(),
        band_label: "",
        zero_line: true,
    };
    let _ = writeln!(h, "<h2>Gyro</h2>\n<div class=\"fig\">{}</div>", svg(&fig)?);
    let _ = writeln!(
        h,
        "<h2>Convention</h2>\n<p>{}</p>\n</body>\n</html>",
        esc(CONVENTION)
    );
    Ok(h)
}
