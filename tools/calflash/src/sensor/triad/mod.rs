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

use nalgebra::Matrix3;
use spincal::model::{
    BoundedVec, CalibrationData, ImuOutputCovariance, MAX_TEMPERATURES, Quantity, Span,
    TemperatureModel, TriadCovariance, TriadSet,
};

mod assemble;
mod error;
mod fit;
mod sets;
pub mod stage_two;
pub mod still;
mod thermal;

pub use self::error::TriadError;
use self::fit::fit_triad;
use self::sets::device_sets;
use super::table::{self, Layout};
use super::thermal::{self as continuous, ThermalFit};
use super::{AxisFit, Calibrated, Options, Thermal, WorkflowError, blob, lever};
use crate::columns as col;
use crate::obs::{self, Table};

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
    /// Per axis, the continuous temperature model.
    thermal: Option<[ThermalFit; 3]>,
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

impl Spec<'static> {
    /// The accelerometer triad's: lever arms when the plan spins the unit.
    fn accel(lever: bool, nonlinear: bool) -> Self {
        Self {
            outputs: col::A,
            inputs: col::F,
            gyro: false,
            g_sens: false,
            lever,
            nonlinear,
        }
    }

    /// The gyro triad's: g-sensitivity when the specific force varies in all three axes.
    fn gyro(g_sens: bool, nonlinear: bool) -> Self {
        Self {
            outputs: col::GYRO,
            inputs: col::W,
            gyro: true,
            g_sens,
            lever: false,
            nonlinear,
        }
    }
}

/// Whether the plan turns the unit (some reference rate not zero): the accelerometers' lever
/// arms are estimable only then.
fn spins(table: &Table) -> bool {
    col::W
        .iter()
        .any(|w| table.column(w).is_some_and(|c| c.iter().any(|v| *v != 0.0)))
}

/// The note of a plan that does not spin the unit.
const NO_SPIN: &str = "the plan does not spin the unit: no lever arms (size effect) are estimated";

/// How a triad's coefficients follow the temperature.
enum Temperature {
    /// A fit at each point of the table.
    Points(Layout),
    /// One fit over every observation, each coefficient a polynomial in the temperature
    /// (`sensor::thermal`).
    Continuous(continuous::Prepared),
}

/// Where a continuous model's fits are said to be.
const ALL: &str = "all temperatures";

/// A triad's fitted model, before the device's sets.
struct TriadModel {
    /// Per table point, per axis; empty for a continuous model.
    fits: Vec<[AxisFit; 3]>,
    /// Per axis, the continuous temperature model.
    thermal: Option<[ThermalFit; 3]>,
    /// Lever arms (reference point), accelerometer only.
    lever: Option<[[f64; 3]; 3]>,
    centers: [f64; 3],
    ranges: [Span; 3],
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

/// How the temperature enters the model: along a ramp (`--thermal continuous`, or `auto` when
/// the temperatures are not held at setpoints), with the table prepared for the continuous
/// model; else at the table's points (temperature and voltage setpoints). `has` says whether
/// the table has a temperature and a voltage column.
fn temperature_points(
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
    notes.extend(super::thermal::unused_order(
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

/// The observations `kind` needs from the file, with the references, temperature and voltage
/// it has; the outputs at or beyond the rails taken out, and said; and a note when the file
/// also has the other triad's outputs, which `kind` leaves uncalibrated.
fn read(
    opts: &Options,
    kind: Kind,
) -> Result<(Table, Option<super::Finding>, Option<String>), WorkflowError> {
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
        return Err(WorkflowError::triad(
            path,
            TriadError::MissingColumns {
                missing: missing.iter().map(ToString::to_string).collect(),
                found: header.join(", "),
            },
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
    let other = match kind {
        Kind::Accel => Some(("gyro", col::GYRO)),
        Kind::Gyro => Some(("accelerometer", col::A)),
        Kind::Imu => None,
    };
    let ignored = other
        .filter(|(_, names)| names.iter().all(|n| has(n)))
        .map(|(what, names)| {
            format!(
                "the file also has the {what}'s outputs {}: not calibrated here (--sensor imu calibrates both)",
                names.join(" ")
            )
        });
    Ok((table, beyond, ignored))
}

/// Adds to `table` what the references lack: the still ramp's observations (`--still-ramp`),
/// and the Earth's rate in every reference rate (`--latitude`), saying so in `notes`.
fn add_references(
    table: &mut Table,
    opts: &Options,
    kind: Kind,
    notes: &mut Vec<String>,
) -> Result<(), WorkflowError> {
    if let Some(recording) = &opts.still_ramp {
        if opts.earth.is_some() {
            return Err(WorkflowError::triad(
                recording,
                TriadError::StillRampWithLatitude,
            ));
        }
        let still = still::observations(recording, kind, table, opts, notes)?;
        table.append(&still);
    }
    if let Some(station) = &opts.earth {
        add_earth_rate(table, station, &opts.file)?;
        notes.push(format!(
            "the Earth's rate at latitude {} deg with the fixture's mark at heading {} deg ({:.3e} rad/s) is in every observation's reference rate",
            station.latitude_deg,
            station.heading_deg,
            crate::earth::RATE
        ));
    }
    Ok(())
}

/// The temperatures the device holds a continuous model at (`p` prepared it): the table or
/// Chebyshev series `thermal::choose` finds for the triads `parts`, as a layout of points, with
/// the series' terms (`None` for a table) and the finding that states how well it follows the
/// model.
fn held_layout(
    p: &continuous::Prepared,
    parts: &[(&Spec<'_>, &TriadModel)],
    series: bool,
    path: &std::path::Path,
    notes: &mut Vec<String>,
) -> Result<(Layout, Option<usize>, super::Finding), WorkflowError> {
    let held = continuous::Scale {
        lo: f64::from(p.support.scale.lo as f32),
        hi: f64::from(p.support.scale.hi as f32),
    };
    let choice = thermal::choose(parts, &held, series, path)?;
    let finding = continuous::device::finding(
        &continuous::device::DeviceTemperature {
            temps: choice.temps.clone(),
            series: choice.series,
            sets: Vec::new(),
            covariances: Vec::new(),
            ratio: (choice.worst.departure, choice.worst.at),
            sigma_error: Some(choice.worst.sigma),
            other: choice.other,
        },
        &held,
    );
    if !series {
        notes.push("an IMU with lever arms: the device gets a table (it proves the lever term's sensing directions per set of one)".into());
    }
    let temps = choice.temps;
    let layout = Layout {
        points: temps
            .iter()
            .map(|t| table::Point {
                temp: Some(*t),
                volt: None,
                rows: Vec::new(),
            })
            .collect(),
        temps,
        volts: Vec::new(),
    };
    Ok((layout, choice.series, finding))
}

/// The names, units and calibrated ranges of the outputs of `accel` and `gyro`, in that order,
/// with notes on the g-sensitivity (at point `reference`) and the lever arms.
fn described(
    accel: Option<&TriadResult>,
    gyro: Option<&TriadResult>,
    reference: usize,
    notes: &mut Vec<String>,
) -> (Vec<String>, Vec<&'static str>, Vec<Span>) {
    let mut names = Vec::new();
    let mut units = Vec::new();
    let mut ranges = Vec::new();
    if let Some(a) = accel {
        names.extend(col::A.map(String::from));
        units.extend([blob::unit(Quantity::Acceleration); 3]);
        ranges.extend(a.ranges);
    }
    if let Some(g) = gyro {
        names.extend(col::GYRO.map(String::from));
        units.extend([blob::unit(Quantity::AngularRate); 3]);
        ranges.extend(g.ranges);
        if let Some(gm) = g.g.get(reference) {
            notes.push(format!(
                "g-sensitivity at the reference point (rad/s per m/s^2, device form): {:?}",
                gm.map(|r| r.map(|v| (v * 1e6).round() / 1e6))
            ));
        }
    }
    if let Some(r) = accel.and_then(|a| a.lever) {
        notes.push(format!(
            "lever arms (m), rows = accelerometer axes: {:?}",
            r.map(|row| row.map(|v| (v * 1e5).round() / 1e5))
        ));
    }
    (names, units, ranges)
}

/// Calibrates a triad or an IMU from the observations in `opts.file`.
///
/// # Errors
/// A [`WorkflowError`] naming the file, column, term or table point.
pub fn calibrate(opts: &Options, kind: Kind, nonlinear: bool) -> Result<Calibrated, WorkflowError> {
    let path = &opts.file;
    let (mut table, beyond, ignored) = read(opts, kind)?;
    let (has_temp, has_volt) = (
        table.column(col::TEMP).is_some(),
        table.column(col::VOLT).is_some(),
    );
    let mut notes: Vec<String> = ignored.into_iter().collect();
    add_references(&mut table, opts, kind, &mut notes)?;
    let accel_lever = spins(&table) && kind != Kind::Gyro;
    if !accel_lever && kind != Kind::Gyro {
        notes.push(NO_SPIN.into());
    }
    let f_varies = col::F.iter().all(|c| table.varies(c));
    let temperature = temperature_points(&mut table, opts, (has_temp, has_volt), &mut notes)?;
    let accel_spec = Spec::accel(accel_lever, nonlinear);
    let accel = (kind != Kind::Gyro)
        .then(|| fit_triad(&accel_spec, &table, &temperature, opts, &mut notes))
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
    let gyro_spec = Spec::gyro(gyro_g, nonlinear);
    let gyro = (kind != Kind::Accel)
        .then(|| fit_triad(&gyro_spec, &table, &temperature, opts, &mut notes))
        .transpose()?;
    let mut extra_findings = Vec::new();
    let mut series_terms: Option<usize> = None;
    // The points the device holds: the table's, or the temperatures its interpolation of the
    // continuous model needs.
    let layout = match temperature {
        Temperature::Points(l) => l,
        Temperature::Continuous(p) => {
            let parts: Vec<(&Spec<'_>, &TriadModel)> = accel
                .iter()
                .map(|m| (&accel_spec, m))
                .chain(gyro.iter().map(|m| (&gyro_spec, m)))
                .collect();
            // The device proves an IMU's lever-arm directions per set of a table.
            let series = accel
                .as_ref()
                .is_none_or(|a| a.lever.is_none() || gyro.is_none());
            let (layout, terms, finding) = held_layout(&p, &parts, series, path, &mut notes)?;
            series_terms = terms;
            extra_findings.push(finding);
            layout
        }
    };
    let sets_of = |spec: &Spec<'_>, model: TriadModel| {
        let points = match &model.thermal {
            Some(tfs) => layout
                .points
                .iter()
                .map(|p| {
                    let t = p.temp.unwrap_or_default();
                    (
                        [tfs[0].at(t), tfs[1].at(t), tfs[2].at(t)],
                        table::describe(p),
                        table.clone(),
                    )
                })
                .collect(),
            None => model
                .fits
                .iter()
                .zip(&layout.points)
                .map(|(f, p)| (f.clone(), table::describe(p), table.select(&p.rows)))
                .collect(),
        };
        device_sets(spec, model, points, path)
    };
    let as_series = |r: TriadResult| match series_terms {
        Some(_) => r.into_series(),
        None => r,
    };
    let accel = accel
        .map(|m| sets_of(&accel_spec, m).map(as_series))
        .transpose()?;
    let gyro = gyro
        .map(|m| sets_of(&gyro_spec, m).map(as_series))
        .transpose()?;

    finish(
        opts,
        table,
        &layout,
        (accel, gyro),
        (series_terms, None),
        notes,
        beyond.into_iter().chain(extra_findings).collect(),
    )
}

/// The calibration from the device's sets of the triads `parts` (accelerometer, gyro) at the
/// points of `layout` (a series of `series_terms` when given; over the temperature span
/// `span` when given, else the data's): the blob, checked, and the findings, `findings_in`
/// among them.
fn finish(
    opts: &Options,
    table: Table,
    layout: &Layout,
    (accel, gyro): (Option<TriadResult>, Option<TriadResult>),
    (series_terms, span): (Option<usize>, Option<Span>),
    mut notes: Vec<String>,
    findings_in: Vec<super::Finding>,
) -> Result<Calibrated, WorkflowError> {
    let path = &opts.file;
    let mut env = blob::environment(&table, layout, opts)?;
    if let Some(span) = span {
        env.temperature_span = span;
    }
    if let Some(n) = series_terms {
        env.temperatures = BoundedVec::new();
        env.temperature_model = TemperatureModel::Chebyshev(n as u8);
    }
    let identity = blob::identity(opts)?;
    let sensor = assemble::sensor(accel.as_ref(), gyro.as_ref(), opts)?;
    let data = CalibrationData {
        identity,
        environment: env,
        sensor,
        noise: None,
    };
    let parts: Vec<&TriadResult> = accel.iter().chain(gyro.iter()).collect();
    let points = assemble::point_fits(layout, &parts);
    let blob::Built {
        blob,
        output_errors,
        refused,
    } = blob::build_or_reject(path, &data, &points)?;
    let device_error = output_errors.iter().copied().fold(0.0, f64::max);
    let (names, units, ranges) = described(
        accel.as_ref(),
        gyro.as_ref(),
        layout.reference(),
        &mut notes,
    );
    let mut findings = super::findings(&points, &names, &units, opts, &output_errors);
    findings.extend(refused);
    findings.extend(findings_in);
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
        thermal: accel
            .iter()
            .chain(gyro.iter())
            .filter_map(|t| t.thermal.clone())
            .flatten()
            .collect(),
        table,
        mission: None,
        stages: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn written(name: &str, text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join(name);
        std::fs::write(&file, text).unwrap();
        (dir, file)
    }

    #[test]
    fn a_file_or_plan_the_triad_workflow_cannot_use_is_a_typed_error() {
        let (_dir, file) = written("nogyro.csv", "f_x,f_y,f_z,a_x,a_y,a_z\n0,0,9.8,1,2,3\n");
        let e = calibrate(&Options::new(&file, "U-1"), Kind::Gyro, false).unwrap_err();
        match &e {
            WorkflowError::Triad {
                source: TriadError::MissingColumns { missing, .. },
                ..
            } => assert_eq!(missing, &["w_x", "w_y", "w_z", "g_x", "g_y", "g_z"]),
            other => panic!("{other:?}"),
        }
        assert!(e.to_string().contains("missing the columns w_x"), "{e}");

        // Six positions that never turn the unit about y's input: f_y is always zero.
        let mut text = String::from("f_x,f_y,f_z,a_x,a_y,a_z\n");
        for (fx, fz) in [
            (9.8, 0.0),
            (-9.8, 0.0),
            (0.0, 9.8),
            (0.0, -9.8),
            (6.9, 6.9),
            (-6.9, 6.9),
        ] {
            for k in 0..3 {
                let n = f64::from(k) * 0.01;
                text += &format!(
                    "{fx},0,{fz},{},{},{}\n",
                    32768.0 + 1000.0 * fx + n,
                    32768.0 + n,
                    32768.0 + 1000.0 * fz - n
                );
            }
        }
        let (_dir, file) = written("flat.csv", &text);
        let e = calibrate(&Options::new(&file, "U-1"), Kind::Accel, false).unwrap_err();
        assert!(
            matches!(
                &e,
                WorkflowError::Fit {
                    source: crate::stats::FitError::RankDeficient { .. },
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .ends_with("a_x at the single table point: f_y is not observable: it is 0 for every observation"),
            "{e}"
        );

        // A still ramp's pose has no known heading: the error names the recording.
        let mut opts = Options::new(&file, "U-1");
        opts.still_ramp = Some("still.csv".into());
        opts.earth = Some(crate::earth::Station::new(45.0, 0.0).unwrap());
        let e = calibrate(&opts, Kind::Accel, false).unwrap_err();
        assert!(
            matches!(
                &e,
                WorkflowError::Triad {
                    path,
                    source: TriadError::StillRampWithLatitude,
                } if path == std::path::Path::new("still.csv")
            ),
            "{e:?}"
        );
    }
}
