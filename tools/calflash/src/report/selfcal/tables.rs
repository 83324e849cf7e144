//! The self-calibration's summary as HTML tables: what the recording held and how well each
//! fit closes, then each sensor's coefficients with their 1-sigma (the terminal prints the
//! same as text).

use std::fmt::Write as _;

use super::{accel_sd, gyro_sd, plural, quadratic_words};
use crate::nonlinear::selfcal::SelfCal;
use crate::obs::recording::Recording;
use crate::obs::units::Sensor;
use crate::report::page::esc;
use crate::report::terminal::num;
use crate::sensor::selfcal::DeviceCheck;
use crate::sensor::selfcal::record::{NO_BLOB, Temperature};

/// The recording, the poses and rotations found, and each fit's closure, as a two-column
/// table.
pub(super) fn facts(c: &SelfCal, rec: &Recording, check: Option<&DeviceCheck>) -> String {
    let mut rows: Vec<(String, String)> = Vec::new();
    let dur = rec.t[rec.len() - 1] - rec.t[0];
    rows.push((
        "recording".into(),
        format!(
            "{} samples at {:.1} Hz over {dur:.1} s; {} gaps ({} samples dropped)",
            rec.len(),
            rec.rate(),
            rec.gaps.len(),
            rec.gaps.iter().map(|g| g.missing).sum::<usize>()
        ),
    ));
    rows.push((
        "saturated samples left out".into(),
        format!(
            "{} accelerometer, {} gyro",
            rec.saturated_count.0, rec.saturated_count.1
        ),
    ));
    if let Some(t) = Temperature::of(rec) {
        rows.push((
            format!("temperature (column {})", t.column),
            format!(
                "{} to {}, mean {:.2} (carried into the record)",
                t.min, t.max, t.mean
            ),
        ));
    }
    if !c.rest_glitches.is_empty() {
        rows.push((
            "glitches in the initial rest, left out of it (a misread, not motion)".into(),
            c.rest_glitches
                .iter()
                .map(|t| format!("{t:.3} s"))
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    rows.push((
        "still poses found".into(),
        format!(
            "{} at {} &times; the initial rest's level ({} s rest, window {} s, at least {} s still)",
            c.poses.len(),
            c.trials[c.chosen].multiplier,
            c.options.init_rest,
            c.options.window,
            c.options.min_still
        ),
    ));
    rows.push((
        "accelerometer: |a| &minus; g over the poses".into(),
        format!(
            "RMS {:.3} mm/s<sup>2</sup>, max {:.3} mm/s<sup>2</sup> (g = {} m/s<sup>2</sup>)",
            c.accel.rms() * 1e3,
            c.accel.max() * 1e3,
            c.options.g
        ),
    ));
    rows.push((
        format!("accelerometer: held out ({} folds)", c.holdout.folds),
        format!(
            "RMS {:.3} mm/s<sup>2</sup>, max {:.3} mm/s<sup>2</sup>",
            c.holdout.rms * 1e3,
            c.holdout.max * 1e3
        ),
    ));
    if let Some(q) = &c.quadratic_test {
        rows.push(("accelerometer: quadratic terms".into(), quadratic_words(q)));
    }
    if let Some(words) = super::ferraris_words(c) {
        rows.push(("Ferraris session".into(), esc(&words)));
    }
    rows.push((
        format!(
            "gyro: gravity-direction error over {} rotations",
            c.rotations.len()
        ),
        format!(
            "RMS {:.3} deg, max {:.3} deg ({}){}",
            c.gyro.rms_deg(),
            c.gyro.max_deg(),
            c.options.gyro_bias.words(),
            super::stored_bias_words(c),
        ),
    ));
    if let Some(words) = super::turning_words(c) {
        rows.push(("gyro: poses it turned through".into(), esc(&words)));
    }
    for k in &c.skipped {
        rows.push((
            format!("gyro: rotation after pose {} left out", k.pose + 1),
            esc(&k.why),
        ));
    }
    rows.push(match check {
        Some(d) => (
            format!("the device (blob {} bytes)", d.blob.len()),
            format!(
                "its f32 correction against the f64 fit: {:.1e} m/s<sup>2</sup>, {:.1e} rad/s; |a| &minus; g from its corrected samples: RMS {:.3} mm/s<sup>2</sup>",
                d.accel,
                d.gyro,
                d.device_accel_rms * 1e3
            ),
        ),
        None => ("the device".into(), esc(NO_BLOB)),
    });
    let mut t = String::from("<h2>The recording and the fits</h2>\n<table>\n");
    for (what, value) in rows {
        let _ = writeln!(t, "<tr><td>{what}</td><td>{value}</td></tr>");
    }
    t.push_str("</table>\n");
    t
}

/// A value with its 1-sigma (none where the fit does not estimate it).
fn with_sd(v: f64, sd: Option<f64>) -> String {
    match sd {
        Some(s) if s > 0.0 => format!("{} &plusmn; {}", num(v), num(s)),
        _ => num(v),
    }
}

/// One row of a coefficient table: its name, unit and three cells.
fn row(t: &mut String, name: &str, unit: &str, cells: [String; 3]) {
    let _ = writeln!(
        t,
        "<tr><td>{name}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
        esc(unit),
        cells[0],
        cells[1],
        cells[2]
    );
}

/// Each sensor's coefficients with their 1-sigma: the accelerometer's matrix, offset,
/// quadratic terms and centre, the gyro's matrix and bias.
pub(super) fn coefficients(c: &SelfCal, rec: &Recording) -> String {
    let [ua, ug] = rec.units;
    let (pa, pg) = (ua.per(Sensor::Accel), ug.per(Sensor::Gyro));
    let mut t = format!(
        "<h2>Coefficients</h2>\n<p>Inputs: the accelerometer in {}, the gyro in {}. Each cell is the value &plusmn; its 1-sigma; the matrices' rows are the corrected axes x, y, z, their columns the inputs.</p>\n<table class=\"terms\">\n<tr><th>coefficient</th><th>unit</th><th>x</th><th>y</th><th>z</th></tr>\n",
        esc(&ua.describe(Sensor::Accel)),
        esc(&ug.describe(Sensor::Gyro))
    );
    let sd = accel_sd(c);
    let m = &c.accel.model;
    for (i, name) in ["M, row x", "M, row y", "M, row z"].iter().enumerate() {
        row(
            &mut t,
            name,
            &format!("m/s^2 per {pa}"),
            std::array::from_fn(|j| with_sd(m.matrix[i][j], sd.map(|s| s.0[i][j]))),
        );
    }
    row(
        &mut t,
        "offset o",
        "m/s^2",
        std::array::from_fn(|j| with_sd(m.offset[j], sd.map(|s| s.1[j]))),
    );
    if c.accel.params.len() == 12 {
        row(
            &mut t,
            "quadratic q",
            &format!("1/({pa})"),
            std::array::from_fn(|j| with_sd(m.quadratic[j], sd.map(|s| s.2[j]))),
        );
    }
    row(
        &mut t,
        "accelerometer centre",
        plural(pa),
        std::array::from_fn(|j| format!("{}", m.center[j])),
    );
    let gsd = gyro_sd(c);
    for (i, name) in ["G, row x", "G, row y", "G, row z"].iter().enumerate() {
        row(
            &mut t,
            name,
            &format!("rad/s per {pg}"),
            std::array::from_fn(|j| with_sd(c.gyro.matrix[i][j], gsd.map(|s| s[i][j]))),
        );
    }
    row(
        &mut t,
        "gyro bias (stored as its centre)",
        plural(pg),
        std::array::from_fn(|j| format!("{:.5}", c.gyro_bias[j])),
    );
    row(
        &mut t,
        "gyro bias: spread between poses",
        plural(pg),
        std::array::from_fn(|j| format!("{:.5}", c.gyro_bias_spread[j])),
    );
    t.push_str("</table>\n");
    t
}

/// m/s^2 in one mg.
const MG: f64 = 9.806_65e-3;
/// deg/h in one rad/s.
const DEG_PER_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// The calibration in a datasheet's units, each with its 1-sigma where the fit gives one: per
/// axis the scale factor (its error in ppm when the inputs are physical, else counts per g or
/// per deg/s), its misalignment from the other inputs in mrad, the accelerometer's offset in mg
/// and the gyro's bias in deg/h.
pub(super) fn engineering(c: &SelfCal, rec: &Recording) -> String {
    let [ua, ug] = rec.units;
    let sd = accel_sd(c);
    let gsd = gyro_sd(c);
    let m = &c.accel.model;
    let g = &c.gyro.matrix;
    let pm = |v: f64, s: Option<f64>| match s {
        Some(s) if s > 0.0 => format!("{v:+.3} &plusmn; {s:.3}"),
        _ => format!("{v:+.3}"),
    };
    let scale = |d: f64, s: Option<f64>, si: bool, per_count: f64| {
        let sigma_ppm = s.map(|s| s / d.abs() * 1e6);
        if si {
            format!(
                "{:+.0} ppm{}",
                (d - 1.0) * 1e6,
                sigma_ppm.map_or(String::new(), |p| format!(" &plusmn; {p:.0}"))
            )
        } else {
            format!(
                "{} counts{}",
                num(per_count / d),
                sigma_ppm.map_or(String::new(), |p| format!(" (&plusmn; {p:.0} ppm)"))
            )
        }
    };
    let mis = |row: &[f64; 3], i: usize, s: Option<&[f64; 3]>| {
        (0..3)
            .filter(|j| *j != i && row[*j] != 0.0)
            .map(|j| {
                format!(
                    "from {}: {}",
                    ["x", "y", "z"][j],
                    pm(row[j] / row[i] * 1e3, s.map(|s| s[j] / row[i].abs() * 1e3))
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let bias: [f64; 3] =
        std::array::from_fn(|i| (0..3).map(|j| g[i][j] * c.gyro_bias[j]).sum::<f64>() * DEG_PER_H);
    let mut t = format!(
        "<h2>In engineering units</h2>\n<p>Scale factors {}; misalignments in mrad (each row's coupling from the other inputs over its own scale factor); the accelerometer's offset in mg; the gyro's bias in deg/h (its stored bias through its matrix).</p>\n<table>\n<tr><th>axis</th><th>accelerometer scale factor</th><th>accelerometer misalignment (mrad)</th><th>offset (mg)</th><th>gyro scale factor</th><th>gyro misalignment (mrad)</th><th>gyro bias (deg/h)</th></tr>\n",
        match (ua.is_si(), ug.is_si()) {
            (true, true) => "as their error from 1 in ppm",
            (false, false) => "in counts per g and per deg/s",
            _ =>
                "as their error from 1 in ppm for physical inputs, else in counts per g or per deg/s",
        }
    );
    for i in 0..3 {
        let _ = writeln!(
            t,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+.1}</td></tr>",
            ["x", "y", "z"][i],
            scale(m.matrix[i][i], sd.map(|s| s.0[i][i]), ua.is_si(), 9.806_65),
            mis(&m.matrix[i], i, sd.as_ref().map(|s| &s.0[i])),
            pm(m.offset[i] / MG, sd.map(|s| s.1[i] / MG)),
            scale(
                g[i][i],
                gsd.map(|s| s[i][i]),
                ug.is_si(),
                1.0_f64.to_radians()
            ),
            mis(&g[i], i, gsd.as_ref().map(|s| &s[i])),
            bias[i]
        );
    }
    t.push_str("</table>\n");
    t
}
