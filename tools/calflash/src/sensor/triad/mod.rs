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

use spincal::model::{
    BoundedVec, CalibrationData, ImuOutputCovariance, Quantity, Span, TemperatureModel,
    TriadCovariance, TriadSet,
};

mod assemble;
mod earth;
mod error;
mod fit;
mod sets;
mod span;
pub mod stage_two;
pub mod still;
mod thermal;
use earth::{add_earth_rate, earth_neglected};
use span::{calibrated_ranges, temperature_points};

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

#[derive(Clone, Copy)]
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
    /// The correction leaves the nonlinear terms out though the stated error keeps them (an
    /// IMU calibrated with `--linear`, `Options::linear`): the model before the choice adds
    /// them, and its covariance widens by what leaving their estimate out moves.
    stated_nonlinear: bool,
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
            stated_nonlinear: false,
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
            stated_nonlinear: false,
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
    let linear_stated = opts.linear && kind == Kind::Imu && !nonlinear;
    let accel_spec = Spec {
        stated_nonlinear: linear_stated,
        ..Spec::accel(accel_lever, nonlinear)
    };
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
    let gyro_spec = Spec {
        stated_nonlinear: linear_stated,
        ..Spec::gyro(gyro_g, nonlinear)
    };
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
    if let Ok(cal) = spincal::model::Calibration::new(data.clone()) {
        let top = cal.max_sample_rate_hz();
        if top < spincal::model::MAX_SAMPLE_RATE_HZ {
            notes.push(format!(
                "the g-sensitivity feeds the lever term back into the rates, and its tangential part grows with the sample rate: this calibration corrects samples at up to {top:.0} Hz (a corrector at a higher rate is refused)"
            ));
        }
    }
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
mod tests;
