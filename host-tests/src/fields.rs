//! Every float of a calibration, with the field it belongs to: for tests that corrupt each field
//! in turn, and for perturbing calibrations in property tests.

use spincal::Field;
use spincal::model::{BoundedVec, CalibrationData, MAX_SETS, Sensor, TriadSet};

/// A float of a calibration and where it is.
pub struct FloatRef<'a> {
    /// The field.
    pub field: Field,
    /// The coefficient set, for table fields.
    pub set: Option<u8>,
    /// The float itself.
    pub value: &'a mut f32,
}

fn triad<'a>(out: &mut Vec<FloatRef<'a>>, t: &'a mut TriadSet, set: u8) {
    for axis in &mut t.axes {
        let a = axis;
        for (field, value) in [
            (Field::Quadratic, &mut a.quadratic),
            (Field::Cubic, &mut a.cubic),
            (Field::OddQuadratic, &mut a.odd_quadratic),
            (Field::Asymmetry, &mut a.asymmetry),
            (Field::AsymmetryBreak, &mut a.asymmetry_break),
        ] {
            out.push(FloatRef {
                field,
                set: Some(set),
                value,
            });
        }
    }
    for value in t.matrix.iter_mut().flatten() {
        out.push(FloatRef {
            field: Field::Matrix,
            set: Some(set),
            value,
        });
    }
    for value in &mut t.offset {
        out.push(FloatRef {
            field: Field::Offset,
            set: Some(set),
            value,
        });
    }
}

fn covariance<'a, C>(
    out: &mut Vec<FloatRef<'a>>,
    table: &'a mut Option<BoundedVec<C, MAX_SETS>>,
    floats: impl Fn(&'a mut C) -> Vec<&'a mut f32>,
) {
    if let Some(table) = table {
        for (i, factor) in table.as_mut_slice().iter_mut().enumerate() {
            for value in floats(factor) {
                out.push(FloatRef {
                    field: Field::Covariance,
                    set: Some(i as u8),
                    value,
                });
            }
        }
    }
}

/// Every float in `data`, in a fixed order.
pub fn floats(data: &mut CalibrationData) -> Vec<FloatRef<'_>> {
    let mut out = Vec::new();
    let env = &mut data.environment;
    for (field, span) in [
        (Field::TemperatureSpan, &mut env.temperature_span),
        (Field::VoltageSpan, &mut env.voltage_span),
    ] {
        let s = span;
        out.push(FloatRef {
            field,
            set: None,
            value: &mut s.lo,
        });
        out.push(FloatRef {
            field,
            set: None,
            value: &mut s.hi,
        });
    }
    for value in env.temperatures.as_mut_slice() {
        out.push(FloatRef {
            field: Field::TemperatureBreakpoint,
            set: None,
            value,
        });
    }
    for value in env.voltages.as_mut_slice() {
        out.push(FloatRef {
            field: Field::VoltageBreakpoint,
            set: None,
            value,
        });
    }
    match &mut data.sensor {
        Sensor::Single {
            channel,
            sets,
            covariance: cov,
            ..
        } => {
            push_channel(&mut out, channel);
            for (i, s) in sets.as_mut_slice().iter_mut().enumerate() {
                let i = i as u8;
                let a = &mut s.axis;
                for (field, value) in [
                    (Field::Quadratic, &mut a.quadratic),
                    (Field::Cubic, &mut a.cubic),
                    (Field::OddQuadratic, &mut a.odd_quadratic),
                    (Field::Asymmetry, &mut a.asymmetry),
                    (Field::AsymmetryBreak, &mut a.asymmetry_break),
                    (Field::Scale, &mut s.scale),
                    (Field::Offset, &mut s.offset),
                ] {
                    out.push(FloatRef {
                        field,
                        set: Some(i),
                        value,
                    });
                }
            }
            covariance(&mut out, cov, |c| c.iter_mut().collect());
        }
        Sensor::Triad {
            channels,
            sets,
            covariance: cov,
            ..
        } => {
            for c in channels {
                push_channel(&mut out, c);
            }
            for (i, s) in sets.as_mut_slice().iter_mut().enumerate() {
                triad(&mut out, s, i as u8);
            }
            covariance(&mut out, cov, |c| c.iter_mut().flatten().collect());
        }
        Sensor::Imu {
            accel,
            gyro,
            lever_arm,
            sets,
            covariance: cov,
            ..
        } => {
            for c in accel.iter_mut().chain(gyro.iter_mut()) {
                push_channel(&mut out, c);
            }
            if let Some(arm) = lever_arm {
                for value in arm.iter_mut().flatten() {
                    out.push(FloatRef {
                        field: Field::LeverArm,
                        set: None,
                        value,
                    });
                }
            }
            for (i, s) in sets.as_mut_slice().iter_mut().enumerate() {
                let i = i as u8;
                triad(&mut out, &mut s.accel, i);
                triad(&mut out, &mut s.gyro, i);
                for value in s.g_sensitivity.iter_mut().flatten() {
                    out.push(FloatRef {
                        field: Field::GSensitivity,
                        set: Some(i),
                        value,
                    });
                }
            }
            covariance(&mut out, cov, |c| {
                c.accel
                    .iter_mut()
                    .chain(c.gyro.iter_mut())
                    .flat_map(|f| f.as_flattened_mut())
                    .collect()
            });
        }
    }
    if let Some(n) = &mut data.noise {
        let terms = n.white.iter_mut().map(|v| (Field::WhiteNoise, v));
        let terms = terms.chain(n.bias_walk.iter_mut().map(|v| (Field::BiasWalk, v)));
        let rest = [
            (Field::Ageing, &mut n.ageing_s),
            (Field::Gravity, &mut n.gravity.lo),
            (Field::Gravity, &mut n.gravity.hi),
            (Field::FalseAlarm, &mut n.false_alarm),
        ];
        for (field, value) in terms.chain(rest) {
            out.push(FloatRef {
                field,
                set: None,
                value,
            });
        }
    }
    out
}

fn push_channel<'a>(out: &mut Vec<FloatRef<'a>>, c: &'a mut spincal::model::Channel) {
    out.push(FloatRef {
        field: Field::Center,
        set: None,
        value: &mut c.center,
    });
    out.push(FloatRef {
        field: Field::InputRange,
        set: None,
        value: &mut c.range.lo,
    });
    out.push(FloatRef {
        field: Field::InputRange,
        set: None,
        value: &mut c.range.hi,
    });
}
