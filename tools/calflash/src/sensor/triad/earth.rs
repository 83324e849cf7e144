//! The Earth's rate in a gyro triad's fit: added to the reference where the site is known, and
//! the finding that names what leaving it out costs.

use super::{AxisFit, Table, TriadError, WorkflowError, col};
/// Adds the Earth's rate at `station` to the reference rate of every observation
/// (`crate::earth`): a still one needs the fixture's mark `h_*`.
pub(super) fn add_earth_rate(
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
        let e = station.rate_in_body(f, wr, h).map_err(|source| {
            WorkflowError::triad(
                path,
                TriadError::EarthRate {
                    line: table.lines[r],
                    source,
                },
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
pub(super) fn earth_neglected(fits: &[AxisFit; 3]) -> crate::sensor::Finding {
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
        crate::sensor::Finding {
            verdict: crate::sensor::Verdict::Review,
            text: format!(
                "{text}: the bias and misalignment absorb it; give --latitude and --heading, and the fixture's mark h_x h_y h_z of each still position"
            ),
        }
    } else {
        crate::sensor::Finding {
            verdict: crate::sensor::Verdict::Accept,
            text: format!("{text}: below what this gyro resolves"),
        }
    }
}
