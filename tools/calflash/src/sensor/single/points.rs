//! A single axis' calibration as the device holds it: its points over temperature, from a
//! continuous thermal fit or per temperature, and the sets the blob carries.

use nalgebra::DMatrix;
use spincal::model::SingleSet;

use super::{
    AxisFit, DeviceSet, DeviceTemperature, Finding, Formula, Layout, Options, PointFit, Table,
    ThermalFit, WorkflowError, bias_slope_cov, col, covariance, fit_axis_weighted, formula, own_at,
    own_of, table, thermal, thermal_device,
};

/// The continuous thermal model (with the supply voltage's terms when it varies) and the
/// device's table points or series nodes that keep its interpolation close to it.
pub(super) struct Continuous {
    /// The device's points.
    pub(super) layout: Layout,
    /// The model at each.
    pub(super) fits: Vec<AxisFit>,
    /// The output at zero input at the middle of the temperature span (the channel's center).
    pub(super) center: f64,
    /// The thermal model.
    pub(super) thermal: ThermalFit,
    /// What the device holds of it.
    pub(super) device: DeviceTemperature,
    /// How closely the device follows the model.
    pub(super) finding: Finding,
}

/// Fits the continuous thermal model of `model` over what the temperatures `support`, on the
/// scaled supply voltage `volts` when it varies, weighted by `weights`; the device's points
/// over the input span `(lo, hi)`.
pub(super) fn continuous_points(
    model: &mut Formula,
    table: &Table,
    (s, volts, weights): (&thermal::Support, Option<&thermal::Scale>, Option<&[f64]>),
    opts: &Options,
    (lo, hi): (f64, f64),
    notes: &mut Vec<String>,
) -> Result<Continuous, WorkflowError> {
    let (path, bp) = (&opts.file, opts.breakpoint);
    if volts.is_some() {
        for t in [
            formula::Term::var(thermal::VOLT),
            formula::Term::var(col::INPUT).times(thermal::VOLT, 1),
        ] {
            if !model.terms.contains(&t) {
                model.terms.push(t);
            }
        }
    }
    let temps = table.column(col::TEMP).unwrap_or_default();
    let tf = thermal::choose(model, (s, temps), opts.alpha, opts.thermal_order, &|f| {
        fit_axis_weighted(f, table, opts.alpha, (path, "all temperatures"), weights)
    })?;
    notes.extend(
        tf.reasons
            .iter()
            .map(|r| format!("temperature order of {r}")),
    );
    let (c0, _) = tf.coefficients_at(s.scale.center());
    let center = own_of(&tf.base.term_names(), &c0, bp).bias;
    // The span as the device holds it (f32), which its series is evaluated over.
    let held = thermal::Scale {
        lo: f64::from(s.scale.lo as f32),
        hi: f64::from(s.scale.hi as f32),
    };
    // The device's voltage points: the two ends of the supply's span.
    let (vs, ys) = match &volts {
        Some(v) => (vec![v.lo, v.hi], vec![-1.0, 1.0]),
        None => (Vec::new(), vec![0.0]),
    };
    let dt = thermal_device::choose(&tf, &held, center, (lo, hi), bp, &ys).map_err(|source| {
        WorkflowError::DeviceTemperature {
            path: path.to_path_buf(),
            source,
        }
    })?;
    let mut fits = Vec::new();
    let mut points = Vec::new();
    for t in &dt.temps {
        let f = tf.at(*t);
        for v in vs
            .iter()
            .map(|v| Some(*v))
            .chain(vs.is_empty().then_some(None))
        {
            fits.push(f.clone());
            points.push(table::Point {
                temp: Some(*t),
                volt: v,
                rows: Vec::new(),
            });
        }
    }
    let layout = Layout {
        temps: dt.temps.clone(),
        volts: vs,
        points,
    };
    Ok(Continuous {
        finding: thermal_device::finding(&dt, &held),
        layout,
        fits,
        center,
        thermal: tf,
        device: dt,
    })
}

/// What the device holds at the table points, in their order.
pub(super) struct DeviceSets {
    /// The linearised sets.
    pub(super) sets: Vec<SingleSet>,
    /// Their covariance factors.
    pub(super) covariances: Vec<[f32; 3]>,
    /// The point fits, as the report shows them.
    pub(super) points: Vec<PointFit>,
}

/// What the device holds at each of the `layout`'s points (the model `fits` there, on the
/// scaled supply voltage `volts`, linearised about `center` over the input span): its sets,
/// their covariance factors, and the point fits as the report shows them.
pub(super) fn device_sets(
    layout: &Layout,
    fits: Vec<AxisFit>,
    volts: Option<&thermal::Scale>,
    center: f64,
    (lo, hi): (f64, f64),
    opts: &Options,
) -> Result<DeviceSets, WorkflowError> {
    let bp = opts.breakpoint;
    let mut sets = Vec::new();
    let mut covs = Vec::new();
    let mut points = Vec::new();
    for (p, f) in layout.points.iter().zip(fits) {
        // The scaled supply voltage of the point, for a model with voltage terms.
        let y = match (volts, p.volt) {
            (Some(s), Some(v)) => s.x(v),
            _ => 0.0,
        };
        let o = own_at(&f.fit.names, &f.fit.coefficients, bp, y);
        let d = DeviceSet::of(&o, center, lo, hi);
        let [vb, cbs, vs] = bias_slope_cov(&f.fit.names, &f.fit.covariance, y);
        let c = DMatrix::from_row_slice(2, 2, &[vb, cbs, cbs, vs]);
        let factor = covariance::single(&c, o.slope, d.offset, d.scale).map_err(|source| {
            WorkflowError::Covariance {
                path: opts.file.clone(),
                outputs: f.output.clone(),
                at: table::describe(p),
                source,
            }
        })?;
        covs.push([factor[0] as f32, factor[1] as f32, factor[2] as f32]);
        sets.push(d.set());
        points.push(PointFit {
            temp: p.temp,
            volt: p.volt,
            noise: vec![f.fit.sigma2.sqrt() / o.slope.abs()],
            inversion_error: vec![d.error],
            axes: vec![f],
        });
    }
    Ok(DeviceSets {
        sets,
        covariances: covs,
        points,
    })
}
