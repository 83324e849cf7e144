//! The single-axis workflow: IEEE Std 1293-style forward model, term selection, asymmetry and
//! hysteresis tests, a coefficient set per temperature and voltage point, the correction.

use spincal::model::{
    BoundedVec, CalibrationData, Channel, MAX_TEMPERATURES, Quantity, Sensor, Span,
    TemperatureModel,
};

pub mod coefficients;
mod decide;
mod error;
mod points;
use points::{DeviceSets, continuous_points, device_sets};

use coefficients::{bias_slope_cov, own_at, own_of};
use decide::{asymmetry, hysteresis, select_terms};
pub use error::SingleError;

use super::table::{self, Layout};
use super::thermal;
use super::thermal::ThermalFit;
use super::thermal::device::{self as thermal_device, DeviceSet, DeviceTemperature};
use super::{
    AxisFit, Calibrated, Decision, Finding, Options, PointFit, Thermal, WorkflowError, blob,
    covariance,
};
use crate::columns as col;
use crate::formula::{self, Formula};
use crate::obs::{self, Table};

/// The derived column holding `|input - breakpoint| - |breakpoint|`.
pub const KINK: &str = "input_kink";

/// The terms of the IEEE 1293-style preset: bias, scale, g-squared, cubic, odd-quadratic, and
/// the cross-axis and cross-coupling terms of the cross inputs the file has.
#[must_use]
pub fn preset(cross: &[&str]) -> String {
    let mut f = String::from("output ~ 1 + input + input^2 + input^3 + input:abs(input)");
    for c in cross {
        f.push_str(&format!(" + {c} + input:{c}"));
    }
    f
}

/// Terms the device applies (the others are reported only).
fn applied(term: &str) -> bool {
    matches!(
        term,
        "1" | "input" | "input^2" | "input^3" | "input:abs(input)"
    ) || term == KINK
}

fn fit_axis(
    formula: &Formula,
    table: &Table,
    alpha: f64,
    path: &std::path::Path,
    where_: &str,
) -> Result<AxisFit, WorkflowError> {
    fit_axis_weighted(formula, table, alpha, (path, where_), None)
}

fn fit_axis_weighted(
    formula: &Formula,
    table: &Table,
    alpha: f64,
    at: (&std::path::Path, &str),
    weights: Option<&[f64]>,
) -> Result<AxisFit, WorkflowError> {
    let mut fit = AxisFit::fit_weighted(formula, table, col::INPUT, alpha, at, false, weights)?;
    fit.dir = table.column(col::DIR).map(<[f64]>::to_vec);
    Ok(fit)
}

fn sub(table: &Table, rows: &[usize]) -> Table {
    table.select(rows)
}

/// The observations of a single-axis file: the columns of those the workflow reads that the
/// file has, with the outputs beyond the rails excluded (and the finding that says so), and
/// the kink column [`KINK`] about the breakpoint.
fn observations(opts: &Options) -> Result<(Table, Option<Finding>), WorkflowError> {
    let path = &opts.file;
    let header = obs::header(path, opts.format)?;
    for need in [col::INPUT, col::OUTPUT] {
        if !header.iter().any(|h| h == need) {
            return Err(SingleError::MissingColumn {
                path: path.clone(),
                column: need,
                what: if need == col::INPUT {
                    "the reference input, SI units"
                } else {
                    "the sensor output, counts"
                },
                header: header.join(", "),
            }
            .into());
        }
    }
    let has = |c: &str| header.iter().any(|h| h == c);
    let mut wanted: Vec<String> = vec![col::INPUT.into(), col::OUTPUT.into()];
    for c in [
        col::INPUT_P,
        col::INPUT_O,
        col::TEMP,
        col::VOLT,
        col::DIR,
        col::CHAMBER_TEMP,
        col::TIME,
    ] {
        if has(c) {
            wanted.push(c.into());
        }
    }
    let mut table = obs::read_columns(path, &wanted, opts.format)?;
    let beyond = super::exclude_beyond_rails(&mut table, &[col::OUTPUT], &opts.rails, path)?;
    let input = table.column(col::INPUT).unwrap_or_default();
    let bp = opts.breakpoint;
    let kink = input.iter().map(|x| (x - bp).abs() - bp.abs()).collect();
    table.push_column(KINK, kink);
    Ok((table, beyond))
}

/// The model to fit: `--model`, checked against the file and the device, or the preset for the
/// cross inputs that vary; whether it was the preset (whose terms are then selected).
fn model(
    opts: &Options,
    table: &Table,
    notes: &mut Vec<String>,
) -> Result<(Formula, bool), WorkflowError> {
    let path = &opts.file;
    let cross: Vec<&str> = [col::INPUT_P, col::INPUT_O]
        .into_iter()
        .filter(|c| table.varies(c))
        .collect();
    let (model, chosen) = match &opts.model {
        Some(m) => (formula::parse(m)?, false),
        None => {
            let text = preset(&cross);
            notes.push(format!("preset ieee-single expands to: {text}"));
            (formula::parse(&text)?, true)
        }
    };
    if model.response != col::OUTPUT {
        return Err(SingleError::Response {
            model: model.to_string(),
        }
        .into());
    }
    if !model.terms.iter().any(|t| t.name() == col::INPUT) {
        return Err(SingleError::NoScaleFactor {
            model: model.to_string(),
        }
        .into());
    }
    for t in &model.terms {
        let name = t.name();
        if t.variables()
            .iter()
            .any(|v| !table.names.iter().any(|n| n == v))
        {
            return Err(SingleError::TermColumn {
                path: path.clone(),
                term: name,
            }
            .into());
        }
    }
    let model = if chosen {
        observable(model, table, notes)
    } else {
        model
    };
    Ok((model, chosen))
}

/// The preset without the terms the plan cannot estimate (each a combination of the terms
/// before it over these observations, or at one of the temperatures: symmetric levels make
/// `input:abs(input)` one of `input` and `input^3`), each dropped with the reason, as
/// insignificant terms are. The preset is the tool's own choice; a term the user asked for by
/// formula is never dropped (the fit then says why it cannot be estimated). `1` and `input`
/// are never dropped.
fn observable(mut model: Formula, table: &Table, notes: &mut Vec<String>) -> Formula {
    use crate::stats::{self, FitError};
    // The whole table, then each temperature's observations (a table point's own fit).
    let mut parts = vec![(table.clone(), String::new())];
    if let Some(temps) = table.column(col::TEMP) {
        let mut levels: Vec<f64> = temps.to_vec();
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        if levels.len() > 1 {
            for t in levels {
                let rows: Vec<usize> = (0..temps.len()).filter(|&i| temps[i] == t).collect();
                parts.push((table.select(&rows), format!(" at {t} C")));
            }
        }
    }
    'terms: loop {
        for (part, at) in &parts {
            let d = model.design(part);
            let opts = stats::Options::default();
            let Err(FitError::RankDeficient {
                column,
                combination,
            }) = stats::fit(&d.x, &d.y, d.names.clone(), d.intercept, &opts)
            else {
                continue;
            };
            let name = d.names[column].clone();
            if name == "1" || name == col::INPUT {
                return model;
            }
            let why = model.explain_rank_deficiency(part, column, &combination);
            notes.push(format!("dropped {name} from the preset{at}: {why}"));
            model = model.without(&name);
            continue 'terms;
        }
        return model;
    }
}

/// Calibrates a single-axis sensor from the observations in `opts.file`.
///
/// # Errors
/// A [`WorkflowError`] naming the file, column, term or table point.
/// How the temperature enters a single axis' model: at the table's points, or one continuous
/// model over every observation (then one point holding every row), with the temperatures'
/// support, the ramp's weights and the supply voltage's scale.
struct Setting {
    layout: Layout,
    support: Option<thermal::data::Support>,
    weights: Option<Vec<f64>>,
    volts: Option<thermal::Scale>,
}

impl Setting {
    /// `--thermal`'s choice for `table`, where `width` is the model's number of terms: `auto`
    /// takes the continuous model when the temperatures vary and are not a table of
    /// well-filled exact setpoints.
    fn of(
        table: &mut Table,
        opts: &Options,
        width: usize,
        notes: &mut Vec<String>,
    ) -> Result<Self, WorkflowError> {
        let has = |c: &'static str| table.column(c).is_some().then_some(c);
        let layout = table::layout(table, has(col::TEMP), has(col::VOLT));
        let continuous = match opts.thermal {
            Thermal::Table => false,
            Thermal::Continuous => true,
            Thermal::Auto => {
                table.varies(col::TEMP)
                    && layout.as_ref().map_or(true, |l| {
                        l.temps.len() > MAX_TEMPERATURES
                            || l.points.iter().any(|p| p.rows.len() <= 2 * width)
                            || !table::exact_setpoints(table, col::TEMP, l)
                    })
            }
        };
        notes.extend(thermal::unused_order(
            opts.thermal_order,
            continuous,
            table.varies(col::TEMP),
        ));
        if !continuous {
            return Ok(Self {
                layout: layout.map_err(|source| WorkflowError::Grid {
                    path: opts.file.clone(),
                    source,
                })?,
                support: None,
                weights: None,
                volts: None,
            });
        }
        let prepared = thermal::prepare(table, notes)?;
        Ok(Self {
            layout: Layout {
                temps: Vec::new(),
                volts: Vec::new(),
                points: vec![table::Point {
                    temp: None,
                    volt: None,
                    rows: (0..table.len()).collect(),
                }],
            },
            support: Some(prepared.support),
            weights: prepared.weights,
            volts: prepared.volts,
        })
    }
}

/// The model's terms decided at the reference point of `layout`: the full model checked, the
/// terms the data support kept (when the model is the preset, `chosen`, and not every term is
/// kept), then the asymmetry and hysteresis tests; the terms the device does not apply are
/// said in `notes`. With a continuous model (`support`) the bias and the scale factor follow
/// the temperature meanwhile at the highest order the observations can estimate.
fn decide_model(
    (mut model, chosen): (Formula, bool),
    table: &Table,
    layout: &Layout,
    (support, weights): (Option<&thermal::data::Support>, Option<&[f64]>),
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<(Formula, Vec<Decision>), WorkflowError> {
    let path = &opts.file;
    let input = table.column(col::INPUT).unwrap_or_default();
    // While terms and tests are decided, the bias and the scale factor follow the temperature
    // at the highest order the observations can estimate.
    let caps = match support {
        Some(s) => {
            let all = |f: &Formula| {
                fit_axis_weighted(f, table, opts.alpha, (path, "all temperatures"), weights)
            };
            let base = formula::parse(&format!("{} ~ 1 + {}", col::OUTPUT, col::INPUT))?;
            let bias = thermal::estimable(&base, 0, s.max_order, &[], &all);
            (
                bias,
                thermal::estimable(&base, 1, s.max_order, &[bias], &all),
            )
        }
        None => (0, 0),
    };
    let provisional = |m: &Formula| match support {
        Some(_) => {
            let orders: Vec<u32> = m
                .term_names()
                .iter()
                .map(|n| match n.as_str() {
                    "1" => caps.0,
                    col::INPUT => caps.1,
                    _ => 0,
                })
                .collect();
            thermal::expand(m, &orders)
        }
        None => m.clone(),
    };
    let reference = layout.reference();
    let ref_rows = &layout.points[reference].rows;
    let ref_table = sub(table, ref_rows);
    let ref_where = match support {
        Some(_) => "all temperatures".to_string(),
        None => table::describe(&layout.points[reference]),
    };
    let decide = |m: &Formula| fit_axis(&provisional(m), &ref_table, opts.alpha, path, &ref_where);
    // Check the full model can be estimated, then keep the terms the data support.
    decide(&model)?;
    if chosen && !opts.keep_all_terms {
        model = thermal::base_of(&select_terms(
            &provisional(&model),
            &ref_table,
            opts.alpha,
            notes,
        )?);
        notes.push(format!(
            "model after term selection at {ref_where}: {model}"
        ));
    }

    let mut decisions = Vec::new();
    if let Some((d, m)) = asymmetry(&model, input, opts, &decide, (&ref_table, &ref_where))? {
        decisions.push(d);
        model = m;
    }
    if table.varies(col::DIR) {
        decisions.push(hysteresis(&model, &decide)?);
    }
    for t in &model.terms {
        if !applied(&t.name()) {
            notes.push(format!(
                "{t} is estimated and reported but not applied: the single-axis device does not see the cross-axis inputs"
            ));
        }
    }

    Ok((model, decisions))
}

pub fn calibrate(opts: &Options, quantity: Quantity) -> Result<Calibrated, WorkflowError> {
    let path = &opts.file;
    let (mut table, beyond) = observations(opts)?;
    let input = table.column(col::INPUT).unwrap_or_default().to_vec();
    let bp = opts.breakpoint;

    let mut notes = Vec::new();
    let (model, chosen) = model(opts, &table, &mut notes)?;
    let Setting {
        layout,
        support,
        weights,
        volts,
    } = Setting::of(&mut table, opts, model.width(), &mut notes)?;
    let (mut model, decisions) = decide_model(
        (model, chosen),
        &table,
        &layout,
        (support.as_ref(), weights.as_deref()),
        opts,
        &mut notes,
    )?;

    // The model at each table point: a fit per setpoint, or the continuous model at the
    // breakpoints that keep the device's interpolation close to it.
    let lo = input.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = input.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let own = |f: &AxisFit| own_of(&f.fit.names, &f.fit.coefficients, bp);
    let mut findings_extra = Vec::new();
    let (layout, fits, center, thermal_fit, device_temp) = match &support {
        None => {
            let mut fits = Vec::with_capacity(layout.points.len());
            for p in &layout.points {
                let t = sub(&table, &p.rows);
                fits.push(fit_axis(&model, &t, opts.alpha, path, &table::describe(p))?);
            }
            let center = own(&fits[layout.reference()]).bias;
            (layout, fits, center, None, None)
        }
        Some(s) => {
            let c = continuous_points(
                &mut model,
                &table,
                (s, volts.as_ref(), weights.as_deref()),
                opts,
                (lo, hi),
                &mut notes,
            )?;
            findings_extra.push(c.finding);
            (c.layout, c.fits, c.center, Some(c.thermal), Some(c.device))
        }
    };
    let reference = layout.reference();
    let DeviceSets {
        mut sets,
        covariances: mut covs,
        points,
    } = device_sets(&layout, fits, volts.as_ref(), center, (lo, hi), opts)?;
    let mut env = blob::environment(&table, &layout, opts)?;
    if let Some(dt) = &device_temp {
        sets.clone_from(&dt.sets);
        covs.clone_from(&dt.covariances);
        if let Some(n) = dt.series {
            env.temperatures = BoundedVec::new();
            env.temperature_model = TemperatureModel::Chebyshev(n as u8);
        }
    }
    let range = Span::new(lo as f32, hi as f32);
    let data = CalibrationData {
        identity: blob::identity(opts)?,
        environment: env,
        sensor: Sensor::Single {
            quantity,
            rails: opts.rails,
            channel: Channel {
                center: center as f32,
                range,
            },
            sets: BoundedVec::from_slice(&sets).ok_or_else(|| blob::too_many(path, sets.len()))?,
            covariance: Some(
                BoundedVec::from_slice(&covs).ok_or_else(|| blob::too_many(path, covs.len()))?,
            ),
        },
        noise: None,
    };
    let blob::Built {
        blob,
        output_errors,
        refused,
    } = blob::build_or_reject(path, &data, &points)?;
    let device_error = output_errors.iter().copied().fold(0.0, f64::max);
    let unit = blob::unit(quantity);
    let mut findings = super::findings(
        &points,
        &["output".to_string()],
        &[unit],
        opts,
        &output_errors,
    );
    findings.extend(refused);
    findings.extend(findings_extra);
    findings.extend(beyond);
    Ok(Calibrated {
        data,
        blob,
        points,
        temps: layout.temps.clone(),
        volts: layout.volts.clone(),
        reference,
        notes,
        breakpoint: bp,
        decisions,
        ranges: vec![range],
        units: vec![unit],
        device_error,
        findings,
        earth: None,
        thermal: thermal_fit.into_iter().collect(),
        table,
        mission: None,
        stages: None,
    })
}

#[cfg(test)]
mod tests;
