//! The report's section on a unit calibrated under rotation (a spin rig): the accelerometers'
//! lever arms with their 1-sigma in millimetres, and each output's residuals against the spin
//! rate, where a rate-dependent error the model misses shows as a trend.

use std::collections::HashMap;
use std::fmt::Write as _;

use super::Error;
use super::page::esc;
use super::plot::{Figure, Series, figure};
use super::terminal::num;
use crate::columns as col;
use crate::sensor::{Calibrated, lever};

/// The section, empty when the plan did not spin the unit.
///
/// # Errors
/// A figure that cannot be drawn.
pub fn section(c: &Calibrated) -> Result<String, Error> {
    let reference = &c.points[c.reference];
    let Some(rates) = spin_rates(&c.table) else {
        return Ok(String::new());
    };
    if rates.values().all(|w| *w == 0.0) {
        return Ok(String::new());
    }
    let mut h = String::from("<h2>Under rotation</h2>\n");
    lever_table(&mut h, c);
    for (sensor, outputs) in [("Accelerometer", &col::A), ("Gyro", &col::GYRO)] {
        let pts: Vec<(String, Vec<(f64, f64)>)> = reference
            .axes
            .iter()
            .filter(|a| outputs.contains(&a.output.as_str()))
            .map(|a| {
                // In the output's unit: each residual count over its scale factor.
                let scale = a.coef(&a.own);
                let p = a
                    .lines
                    .iter()
                    .zip(&a.fit.residuals)
                    .filter_map(|(l, r)| rates.get(l).map(|w| (*w, *r / scale)))
                    .collect();
                (a.output.clone(), p)
            })
            .collect();
        if pts.is_empty() {
            continue;
        }
        let title = format!("{sensor} residuals against the spin rate");
        // The sensor's outputs share a unit (one figure per sensor).
        let unit = reference
            .axes
            .iter()
            .position(|a| outputs.contains(&a.output.as_str()))
            .and_then(|i| c.units.get(i))
            .copied()
            .unwrap_or("");
        let y = format!("residual ({unit})");
        figure(
            &mut h,
            &Figure {
                title: &title,
                x: "spin rate |w| (rad/s)",
                y: &y,
                series: pts
                    .iter()
                    .enumerate()
                    .map(|(k, (name, p))| Series::dots(name, p, k))
                    .collect(),
                bands: Vec::new(),
                band_label: "",
                zero_line: true,
                x_names: None,
            },
        )?;
    }
    Ok(h)
}

/// The magnitude of the reference rate of each observation, by its file line; `None` when the
/// table has no rate columns.
fn spin_rates(table: &crate::obs::Table) -> Option<HashMap<u64, f64>> {
    let w: Vec<&[f64]> = col::W
        .iter()
        .map(|n| table.column(n))
        .collect::<Option<_>>()?;
    Some(
        table
            .lines
            .iter()
            .enumerate()
            .map(|(r, l)| (*l, w.iter().map(|c| c[r] * c[r]).sum::<f64>().sqrt()))
            .collect(),
    )
}

/// The lever arms as fitted (rows: accelerometer axes; columns: the arm's components), in mm
/// with their 1-sigma, and which the plan could not estimate.
fn lever_table(h: &mut String, c: &Calibrated) {
    let reference = &c.points[c.reference];
    let mut rows = String::new();
    let mut any = false;
    for (i, output) in col::A.iter().enumerate() {
        let Some(axis) = reference.axes.iter().find(|a| a.output == *output) else {
            continue;
        };
        let _ = write!(rows, "<tr><td>{}</td>", esc(output));
        for k in 0..3 {
            let name = lever::column(i, k);
            match axis.fit.names.iter().position(|n| *n == name) {
                Some(j) => {
                    any = true;
                    let _ = write!(
                        rows,
                        "<td>{} &#177; {}</td>",
                        num(axis.fit.coefficients[j] * 1e3),
                        num(axis.fit.std_errors[j] * 1e3)
                    );
                }
                None => rows.push_str("<td>not estimated (0)</td>"),
            }
        }
        rows.push_str("</tr>\n");
    }
    if !any {
        return;
    }
    let _ = writeln!(
        h,
        "<p>Lever arms of the accelerometer axes from the IMU's reference point, in mm with their 1-sigma (the fit's; a component the plan cannot estimate is left at 0 and the device applies 0):</p>\n<table><tr><th>axis</th><th>r_x (mm)</th><th>r_y (mm)</th><th>r_z (mm)</th></tr>\n{rows}</table>"
    );
}
