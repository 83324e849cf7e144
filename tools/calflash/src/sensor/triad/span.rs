//! What a triad's calibration covers: each output's calibrated range (what the device
//! range-checks) and the temperatures its table holds.

use nalgebra::Matrix3;
use spincal::model::{MAX_TEMPERATURES, Span};

use super::{
    Options, Spec, Table, Temperature, Thermal, TriadError, WorkflowError, col, continuous, table,
};

/// The calibrated range of each output: what the device range-checks. For a gyro, the
/// reference rates; for an accelerometer, the sensor-domain force `f + e(w, dw)` the axes
/// sensed (`spincal::model::rotation`), centripetal included, over every observation: a rate
/// table that drove an axis past the centrifuge's levels calibrated it there.
pub(super) fn calibrated_ranges(
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

/// How the temperature enters the model: along a ramp (`--thermal continuous`, or `auto` when
/// the temperatures are not held at setpoints), with the table prepared for the continuous
/// model; else at the table's points (temperature and voltage setpoints). `has` says whether
/// the table has a temperature and a voltage column.
pub(super) fn temperature_points(
    table: &mut Table,
    opts: &Options,
    has: (bool, bool),
    notes: &mut Vec<String>,
) -> Result<Temperature, WorkflowError> {
    let path = &opts.file;
    let (has_temp, has_volt) = has;
    let layout = table::layout(
        table,
        has_temp.then_some(col::TEMP),
        has_volt.then_some(col::VOLT),
    );
    let spread = || {
        let temps = table.column(col::TEMP).unwrap_or_default();
        temps
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(*t), b.max(*t))
            })
    };
    let setpoints = layout.as_ref().is_ok_and(|l| {
        l.temps.len() <= MAX_TEMPERATURES && table::exact_setpoints(table, col::TEMP, l)
    });
    let continuous = match opts.thermal {
        Thermal::Table => {
            if !setpoints && table.varies(col::TEMP) {
                let (lo, hi) = spread();
                return Err(WorkflowError::triad(
                    path,
                    TriadError::NotSetpoints { lo, hi },
                ));
            }
            false
        }
        Thermal::Continuous => true,
        Thermal::Auto => table.varies(col::TEMP) && !setpoints,
    };
    notes.extend(crate::sensor::thermal::unused_order(
        opts.thermal_order,
        continuous,
        table.varies(col::TEMP),
    ));
    if continuous {
        if table.varies(col::VOLT) {
            return Err(WorkflowError::triad(path, TriadError::VoltageVaries));
        }
        return Ok(Temperature::Continuous(continuous::prepare(table, notes)?));
    }
    layout
        .map(Temperature::Points)
        .map_err(|source| WorkflowError::Grid {
            path: path.to_path_buf(),
            source,
        })
}
