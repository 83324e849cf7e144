//! The one checking gate for calibration data: after it passes, nothing in the correction can
//! panic or produce a non-finite value for a raw code inside the rails.

use super::interval::{Bound, affine_bound, axis_bound};
use super::series;
use super::sets::{AxisNonlinearity, ImuSet, SingleSet, TriadSet};
use super::{
    BoundedVec, CalibrationData, Channel, Environment, Rails, Sensor, Span, TemperatureModel,
};
use crate::Error;
use crate::error::{Field, Part};

mod bounds;
mod lever;

use bounds::{check_bounded, triad_output_bound};
pub(crate) use lever::Feedback;
use lever::{validate_lever_arm, validate_lever_feedback, validate_sensing_directions};

/// Largest corrected magnitude a validated calibration may produce inside its rails. Far above
/// any physical value, and small enough that the lever-arm term (`w^2 r`, `dw/dt r`) stays
/// finite in single precision.
pub(crate) const OUTPUT_LIMIT: f32 = 1e15;

pub(super) fn validate(data: &CalibrationData) -> Result<(), Error> {
    let serial = &data.identity.serial;
    if serial.overflowed() {
        return Err(Error::InvalidCapacity {
            field: Field::Serial,
            capacity: super::SERIAL_CAPACITY,
        });
    }
    if !serial.is_valid() {
        return Err(Error::InvalidSerial);
    }
    validate_environment(&data.environment)?;
    if let Some(noise) = &data.noise {
        if !matches!(data.sensor, Sensor::Imu { .. }) {
            return Err(Error::InvalidNoiseTerm {
                field: Field::Sets,
                index: None,
            });
        }
        noise.validate()?;
    }
    let expected = data.environment.temperature_points() * data.environment.voltage_points();
    match &data.sensor {
        Sensor::Single {
            rails,
            channel,
            sets,
            covariance,
            ..
        } => {
            validate_rails(rails, Part::Sensor)?;
            validate_channels(core::slice::from_ref(channel), rails, Part::Sensor)?;
            validate_table(sets, expected)?;
            if data.environment.temperature_model == TemperatureModel::Table {
                for (i, set) in sets.iter().enumerate() {
                    validate_single_set(set, i as u8, rails, channel)?;
                }
            } else {
                validate_single_series(sets, data.environment.voltage_points(), rails, channel)?;
            }
            validate_covariance(covariance.as_ref(), sets.len(), Part::Sensor, |c| c.iter())
        }
        Sensor::Triad {
            rails,
            channels,
            sets,
            covariance,
            ..
        } => {
            validate_rails(rails, Part::Sensor)?;
            validate_channels(channels, rails, Part::Sensor)?;
            validate_table(sets, expected)?;
            let table = data.environment.temperature_model == TemperatureModel::Table;
            for (i, set) in sets.iter().enumerate() {
                validate_triad_terms(set, i as u8, Part::Sensor, table)?;
                if table {
                    let bound = triad_output_bound(set, channels, rails);
                    check_bounded(&bound, Part::Sensor, i as u8)?;
                }
            }
            if !table {
                let nv = data.environment.voltage_points();
                for v in 0..nv {
                    let at = (Part::Sensor, v as u8);
                    let series = series::terms(sets, v, nv);
                    let bound = series::triad_bound(series, channels, rails, at)?;
                    check_bounded(&bound, Part::Sensor, v as u8)?;
                }
            }
            validate_covariance(covariance.as_ref(), sets.len(), Part::Sensor, |c| {
                c.iter().flatten()
            })
        }
        Sensor::Imu {
            lever_arm: Some(_), ..
        } if data.environment.temperature_model != TemperatureModel::Table => {
            // The lever term's sensing directions are proven per set of a table.
            Err(Error::InvalidTemperatureSeries)
        }
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            lever_arm,
            sets,
            covariance,
        } => {
            validate_rails(accel_rails, Part::Accelerometer)?;
            validate_rails(gyro_rails, Part::Gyro)?;
            if accel_rails.format != gyro_rails.format {
                return Err(Error::InvalidMixedFormats);
            }
            validate_channels(accel, accel_rails, Part::Accelerometer)?;
            validate_channels(gyro, gyro_rails, Part::Gyro)?;
            if let Some(arm) = lever_arm {
                validate_lever_arm(arm)?;
            }
            validate_table(sets, expected)?;
            if data.environment.temperature_model == TemperatureModel::Table {
                for (i, set) in sets.iter().enumerate() {
                    validate_imu_set(set, i as u8, accel, accel_rails, gyro, gyro_rails)?;
                    if lever_arm.is_some() {
                        validate_sensing_directions(&set.accel.matrix, i as u8)?;
                    }
                }
            } else {
                validate_imu_series(
                    sets,
                    data.environment.voltage_points(),
                    accel,
                    accel_rails,
                    gyro,
                    gyro_rails,
                )?;
            }
            if let Some(arm) = lever_arm {
                validate_lever_feedback(sets, arm, (accel, accel_rails), (gyro, gyro_rails))?;
            }
            validate_covariance(covariance.as_ref(), sets.len(), Part::Accelerometer, |c| {
                c.accel.iter().chain(&c.gyro).flat_map(|f| f.as_flattened())
            })
        }
    }
}

fn finite(
    x: f32,
    field: Field,
    part: Option<Part>,
    set: Option<u8>,
    index: Option<u8>,
) -> Result<(), Error> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidNonFinite {
            field,
            part,
            set,
            index,
        })
    }
}

pub(super) fn finite_all<'a>(
    xs: impl IntoIterator<Item = &'a f32>,
    field: Field,
    part: Option<Part>,
    set: Option<u8>,
) -> Result<(), Error> {
    for (i, x) in xs.into_iter().enumerate() {
        finite(*x, field, part, set, Some(i as u8))?;
    }
    Ok(())
}

fn validate_span(
    span: &Span,
    field: Field,
    part: Option<Part>,
    index: Option<u8>,
) -> Result<(), Error> {
    finite(span.lo, field, part, None, index)?;
    finite(span.hi, field, part, None, index)?;
    if span.lo > span.hi {
        return Err(Error::InvalidSpanOrder { field, part, index });
    }
    Ok(())
}

fn validate_breakpoints<const N: usize>(
    points: &BoundedVec<f32, N>,
    span: &Span,
    field: Field,
) -> Result<(), Error> {
    if points.overflowed() {
        return Err(Error::InvalidCapacity { field, capacity: N });
    }
    finite_all(points.iter(), field, None, None)?;
    for (i, pair) in points.windows(2).enumerate() {
        if let [a, b] = pair
            && b <= a
        {
            return Err(Error::InvalidBreakpointOrder {
                field,
                index: (i + 1) as u8,
            });
        }
    }
    for (i, p) in points.iter().enumerate() {
        if !span.contains(*p) {
            return Err(Error::InvalidBreakpointOutsideSpan {
                field,
                index: i as u8,
            });
        }
    }
    Ok(())
}

fn validate_environment(env: &Environment) -> Result<(), Error> {
    validate_span(&env.temperature_span, Field::TemperatureSpan, None, None)?;
    validate_span(&env.voltage_span, Field::VoltageSpan, None, None)?;
    validate_breakpoints(
        &env.temperatures,
        &env.temperature_span,
        Field::TemperatureBreakpoint,
    )?;
    validate_breakpoints(&env.voltages, &env.voltage_span, Field::VoltageBreakpoint)?;
    match env.temperature_model {
        TemperatureModel::Table => Ok(()),
        TemperatureModel::Chebyshev(n) => {
            let span = &env.temperature_span;
            if n == 0
                || usize::from(n) > super::MAX_SETS
                || !env.temperatures.is_empty()
                || span.hi - span.lo <= 0.0
            {
                Err(Error::InvalidTemperatureSeries)
            } else {
                Ok(())
            }
        }
    }
}

fn validate_rails(rails: &Rails, part: Part) -> Result<(), Error> {
    let (min, max) = rails.format.limits();
    if i64::from(rails.lo) + 1 >= i64::from(rails.hi) || rails.lo < min || rails.hi > max {
        return Err(Error::InvalidRails { part });
    }
    Ok(())
}

fn validate_channels(channels: &[Channel], rails: &Rails, part: Part) -> Result<(), Error> {
    for (i, ch) in channels.iter().enumerate() {
        let index = Some(i as u8);
        finite(ch.center, Field::Center, Some(part), None, index)?;
        // The comparison is made in f64 so that rails beyond 2^24 are compared exactly.
        let c = f64::from(ch.center);
        if c <= f64::from(rails.lo) || c >= f64::from(rails.hi) {
            return Err(Error::InvalidCenter {
                part,
                axis: i as u8,
            });
        }
        validate_span(&ch.range, Field::InputRange, Some(part), index)?;
        if ch.range.lo == ch.range.hi {
            return Err(Error::InvalidSpanOrder {
                field: Field::InputRange,
                part: Some(part),
                index,
            });
        }
    }
    Ok(())
}

fn validate_table<T, const N: usize>(
    sets: &BoundedVec<T, N>,
    expected: usize,
) -> Result<(), Error> {
    if sets.overflowed() {
        return Err(Error::InvalidCapacity {
            field: Field::Sets,
            capacity: N,
        });
    }
    if sets.len() != expected {
        return Err(Error::InvalidTableShape {
            expected,
            found: sets.len(),
        });
    }
    Ok(())
}

/// A covariance table: one finite factor per coefficient set.
fn validate_covariance<'a, C: 'a, const N: usize, I: Iterator<Item = &'a f32>>(
    table: Option<&'a BoundedVec<C, N>>,
    sets: usize,
    part: Part,
    floats: impl Fn(&'a C) -> I,
) -> Result<(), Error> {
    let Some(table) = table else {
        return Ok(());
    };
    if table.overflowed() {
        return Err(Error::InvalidCapacity {
            field: Field::Covariance,
            capacity: N,
        });
    }
    if table.len() != sets {
        return Err(Error::InvalidCovarianceIncomplete);
    }
    for (i, factor) in table.iter().enumerate() {
        for (k, x) in floats(factor).enumerate() {
            finite(
                *x,
                Field::Covariance,
                Some(part),
                Some(i as u8),
                Some(k as u8),
            )?;
        }
    }
    Ok(())
}

fn validate_axis(n: &AxisNonlinearity, part: Part, set: u8, axis: u8) -> Result<(), Error> {
    let fields = [
        (n.quadratic, Field::Quadratic),
        (n.cubic, Field::Cubic),
        (n.odd_quadratic, Field::OddQuadratic),
        (n.asymmetry, Field::Asymmetry),
        (n.asymmetry_break, Field::AsymmetryBreak),
    ];
    for (x, field) in fields {
        finite(x, field, Some(part), Some(set), Some(axis))?;
    }
    Ok(())
}

fn validate_single_set(
    set: &SingleSet,
    i: u8,
    rails: &Rails,
    channel: &Channel,
) -> Result<(), Error> {
    let part = Part::Sensor;
    validate_axis(&set.axis, part, i, 0)?;
    finite(set.scale, Field::Scale, Some(part), Some(i), None)?;
    finite(set.offset, Field::Offset, Some(part), Some(i), None)?;
    if set.scale == 0.0 {
        return Err(Error::InvalidSingularMatrix { part, set: i });
    }
    let (v_lo, v_hi) = channel.rail_offsets(rails);
    let bound = Bound::point(set.offset).add(axis_bound(&set.axis, v_lo, v_hi).scale(set.scale));
    check_bounded(&[bound], part, i)
}

/// A single axis' temperature series (the sets of each voltage point are the coefficients of
/// `T_0 ... T_(n-1)`): every coefficient finite, and for every temperature, since
/// `|T_k(x)| <= 1`, a scale factor that cannot reach zero (`|scale_0|` above the sum of the
/// others' magnitudes) and an output bounded over the rails (offset, scale and nonlinearity
/// each bounded by the sum of their coefficients' magnitudes).
fn validate_single_series(
    sets: &[SingleSet],
    voltages: usize,
    rails: &Rails,
    channel: &Channel,
) -> Result<(), Error> {
    let part = Part::Sensor;
    for (i, set) in sets.iter().enumerate() {
        validate_axis(&set.axis, part, i as u8, 0)?;
        finite(set.scale, Field::Scale, Some(part), Some(i as u8), None)?;
        finite(set.offset, Field::Offset, Some(part), Some(i as u8), None)?;
    }
    let (v_lo, v_hi) = channel.rail_offsets(rails);
    for v in 0..voltages {
        let series = series::terms(sets, v, voltages);
        let first = v as u8;
        let sum = |f: fn(&SingleSet) -> f32| series.clone().map(|s| libm::fabsf(f(s))).sum::<f32>();
        let head = sets.get(v).map_or(0.0, |s| libm::fabsf(s.scale));
        // Values are finite here, so the comparison is total.
        if head <= sum(|s| s.scale) - head {
            return Err(Error::InvalidSingularMatrix { part, set: first });
        }
        let axes = series.clone().map(|s| &s.axis);
        let u = series::axis_magnitude(
            &series::axis_envelope(axes.clone()),
            series::break_sum(axes),
            v_lo,
            v_hi,
        );
        let mag = sum(|s| s.offset) + sum(|s| s.scale) * u;
        check_bounded(&[series::symmetric(mag)], part, first)?;
    }
    Ok(())
}

/// A triad set's values finite and, in a table, its matrix invertible (a series' terms are
/// proven together, [`series::triad_bound`]).
fn validate_triad_terms(set: &TriadSet, i: u8, part: Part, table: bool) -> Result<(), Error> {
    for (a, axis) in set.axes.iter().enumerate() {
        validate_axis(axis, part, i, a as u8)?;
    }
    finite_all(
        set.matrix.iter().flatten(),
        Field::Matrix,
        Some(part),
        Some(i),
    )?;
    finite_all(set.offset.iter(), Field::Offset, Some(part), Some(i))?;
    if table && !invertible(&set.matrix) {
        return Err(Error::InvalidSingularMatrix { part, set: i });
    }
    Ok(())
}

/// An IMU's series: every term finite, and at each voltage point both triads invertible and
/// bounded at any temperature, the gyro's bound with the g-sensitivity's envelope.
fn validate_imu_series(
    sets: &[ImuSet],
    voltages: usize,
    accel: &[Channel; 3],
    accel_rails: &Rails,
    gyro: &[Channel; 3],
    gyro_rails: &Rails,
) -> Result<(), Error> {
    for (i, set) in sets.iter().enumerate() {
        validate_triad_terms(&set.accel, i as u8, Part::Accelerometer, false)?;
        validate_triad_terms(&set.gyro, i as u8, Part::Gyro, false)?;
        finite_all(
            set.g_sensitivity.iter().flatten(),
            Field::GSensitivity,
            Some(Part::Gyro),
            Some(i as u8),
        )?;
    }
    for v in 0..voltages {
        let series = series::terms(sets, v, voltages);
        let at = |part| (part, v as u8);
        let a = series::triad_bound(
            series.clone().map(|s| &s.accel),
            accel,
            accel_rails,
            at(Part::Accelerometer),
        )?;
        check_bounded(&a, Part::Accelerometer, v as u8)?;
        let w = series::triad_bound(
            series.clone().map(|s| &s.gyro),
            gyro,
            gyro_rails,
            at(Part::Gyro),
        )?;
        let w = series::g_sensitivity_bound(series, w, &a);
        check_bounded(&w, Part::Gyro, v as u8)?;
    }
    Ok(())
}

fn validate_imu_set(
    set: &ImuSet,
    i: u8,
    accel: &[Channel; 3],
    accel_rails: &Rails,
    gyro: &[Channel; 3],
    gyro_rails: &Rails,
) -> Result<(), Error> {
    validate_triad_terms(&set.accel, i, Part::Accelerometer, true)?;
    validate_triad_terms(&set.gyro, i, Part::Gyro, true)?;
    finite_all(
        set.g_sensitivity.iter().flatten(),
        Field::GSensitivity,
        Some(Part::Gyro),
        Some(i),
    )?;
    let a = triad_output_bound(&set.accel, accel, accel_rails);
    check_bounded(&a, Part::Accelerometer, i)?;
    let mut w = triad_output_bound(&set.gyro, gyro, gyro_rails);
    for (wi, g_row) in w.iter_mut().zip(set.g_sensitivity.iter()) {
        *wi = wi.add(affine_bound(&g_row.map(|g| -g), 0.0, &a));
    }
    check_bounded(&w, Part::Gyro, i)
}

/// A scale-misalignment matrix is invertible when its determinant is not negligible against
/// the product of its row lengths (Hadamard's bound): a ratio of 1 is orthogonal, 0 singular.
pub(crate) fn invertible(m: &[[f32; 3]; 3]) -> bool {
    let a = nalgebra::Matrix3::from_fn(|i, j| {
        f64::from(m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0))
    });
    let det = a.determinant();
    let hadamard: f64 = a.row_iter().map(|r| r.norm()).product();
    hadamard > 0.0 && (det / hadamard).abs() > 1e-6
}
