//! Reports of a calibration without equipment: the terminal summary and the HTML report with
//! its figures (the JSON record is [`crate::sensor::selfcal::record`]).

use super::Error;
use std::fmt::Write as _;

mod tables;

use super::page::esc;
use super::plot::{Figure, Series, figure, svg};
use super::terminal::{num, pval};
use crate::nonlinear::selfcal::SelfCal;
use crate::obs::recording::Recording;
use crate::obs::units::Sensor;
use crate::sensor::selfcal::DeviceCheck;
use crate::sensor::selfcal::acceptance::verdict;
use crate::sensor::selfcal::record::{CONVENTION, NO_BLOB, Temperature, rms_deg};

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
    recording_lines(&mut s, rec);
    if !c.rest_glitches.is_empty() {
        let at: Vec<String> = c
            .rest_glitches
            .iter()
            .map(|t| format!("{t:.3} s"))
            .collect();
        let _ = writeln!(
            s,
            "  rest         {} glitch sample(s) in the initial rest left out of it (at {}): a misread, not motion",
            at.len(),
            at.join(", ")
        );
    }
    accel_lines(&mut s, c, rec);
    gyro_lines(&mut s, c, rec);
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

/// The recording: its samples, rate, gaps, saturation and temperature.
fn recording_lines(s: &mut String, rec: &Recording) {
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
    if let Some(Temperature {
        column: name,
        min: lo,
        mean,
        max: hi,
    }) = Temperature::of(rec)
    {
        let _ = writeln!(
            s,
            "  temperature  column {name}: {lo} to {hi}, mean {mean:.2} (carried into the record)"
        );
    }
}

/// The poses found, the accelerometer's fit to gravity and its coefficients.
fn accel_lines(s: &mut String, c: &SelfCal, rec: &Recording) {
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
        let _ = writeln!(s, "    quadratic terms: {}", quadratic_words(q));
    }
    if let Some(words) = ferraris_words(c) {
        let _ = writeln!(s, "  Ferraris session  {words}");
    }
    let sd = accel_sd(c);
    let m = &c.accel.model;
    let [ua, ug] = rec.units;
    let pa = ua.per(Sensor::Accel);
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
}

/// The gyro's fit to the rotations between poses, its coefficients, bias and the rotations
/// left out.
fn gyro_lines(s: &mut String, c: &SelfCal, rec: &Recording) {
    let pg = rec.units[1].per(Sensor::Gyro);
    let _ = writeln!(
        s,
        "  gyro  gravity-direction error over {} rotations: RMS {:.3} deg, max {:.3} deg ({}){}",
        c.rotations.len(),
        c.gyro.rms_deg(),
        c.gyro.max_deg(),
        c.options.gyro_bias.words(),
        stored_bias_words(c),
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
    if let Some(words) = turning_words(c) {
        let _ = writeln!(s, "    the gyro turned through {words}");
    }
    for k in &c.skipped {
        let _ = writeln!(
            s,
            "    rotation after pose {} left out: {}",
            k.pose + 1,
            k.why
        );
    }
}

/// What a Ferraris session's section list gave, in words.
pub(super) fn ferraris_words(c: &SelfCal) -> Option<String> {
    let s = c.options.sections.as_ref()?;
    Some(format!(
        "the section list's 6 faces (samples {}-{} to {}-{}) give the accelerometer's cross-axis terms, held while its scales and offsets fit |a| = g at every pose; its turns of {} deg about {} give the gyro's scales with the rotations between poses",
        s.faces[0].start,
        s.faces[0].end,
        s.faces[5].start,
        s.faces[5].end,
        s.angle_deg,
        ["x", "y", "z"]
            .iter()
            .zip(&s.turns)
            .filter(|(_, t)| t.is_some())
            .map(|(a, _)| *a)
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// The rotations' error as a device with the stored calibration sees it between the poses'
/// means (the reference tools' measure).
pub(super) fn stored_bias_words(c: &SelfCal) -> String {
    format!(
        "; with the stored constant bias between the poses' means: RMS {:.3} deg",
        rms_deg(&c.constant_bias_angles)
    )
}

/// The poses the gyro turned through and what was done with them, in words (numbered from 1);
/// `None` when there are none.
fn turning_words(c: &SelfCal) -> Option<String> {
    (!c.turning_poses.is_empty()).then(|| {
        format!(
            "pose(s) {} (its mean far from the other poses'): left out of the bias, the rotations on either side take the constant bias there",
            c.turning_poses
                .iter()
                .map(|k| (k + 1).to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// The accelerometer's quadratic terms' test in words.
fn quadratic_words(q: &crate::nonlinear::selfcal::QuadraticTest) -> String {
    let held = match q.holdout {
        Some([l, h]) => format!(
            "; poses held out: RMS {:.3} mm/s^2 without them, {:.3} with",
            l * 1e3,
            h * 1e3
        ),
        None => "; a hold-out fold's poses could not fit them".into(),
    };
    format!(
        "F = {}, p = {}{held}: {}",
        num(q.f),
        pval(q.p),
        if q.kept {
            "kept"
        } else if q.p < 0.05 {
            "significant, but not better on the poses held out: not kept"
        } else {
            "not significant, not kept"
        }
    )
}

/// `count` -> `counts`; a unit stays as it is.
fn plural(per: &str) -> &str {
    if per == "count" { "counts" } else { per }
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
) -> Result<String, Error> {
    let (v, notes) = verdict(c, check);
    let word = v.word();
    let t0 = rec.t[0];
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>Calibration {0}</title>\n<style>{1}</style>\n</head>\n<body>\n<h1>Calibration of unit {0} without external equipment</h1>\n<p class=\"verdict {2}\">{3}</p>\n",
        esc(serial),
        super::page::STYLE,
        word.to_lowercase(),
        word
    );
    for n in &notes {
        let _ = writeln!(h, "<p><b>{word}</b>: {}</p>", esc(n));
    }
    let _ = writeln!(h, "<p>From {}.</p>", esc(&rec.source));
    h.push_str(&tables::facts(c, rec, check));
    h.push_str(&tables::engineering(c, rec));
    h.push_str(&tables::coefficients(c, rec));
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
        x_names: None,
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
        x_names: None,
    };
    figure(&mut h, &fig)?;
    let trials: Vec<(f64, f64)> = c
        .trials
        .iter()
        .filter_map(|t| t.rms.map(|r| (t.multiplier, r * 1e3)))
        .collect();
    let fig = Figure {
        title: "Threshold search: accelerometer RMS at each threshold",
        x: "threshold [x initial rest level]",
        y: "RMS |a| - g [mm/s^2]",
        series: vec![Series::curve(
            "RMS of |a| - g over the poses found",
            &trials,
            0,
        )],
        bands: Vec::new(),
        band_label: "",
        zero_line: false,
        x_names: None,
    };
    figure(&mut h, &fig)?;
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
        x_names: None,
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
        x_names: None,
    };
    let _ = writeln!(h, "<h2>Gyro</h2>\n<div class=\"fig\">{}</div>", svg(&fig)?);
    let _ = writeln!(
        h,
        "<h2>Convention</h2>\n<p>{}</p>\n</body>\n</html>",
        esc(CONVENTION)
    );
    Ok(super::page::with_contents(&h))
}
