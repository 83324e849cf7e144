//! The device's calibration from a calibration without equipment: one IMU coefficient set
//! (accelerometer and gyro triads in the correction form), written with the firmware crate's
//! encoder and checked against the f64 fit through the device's own f32 correction.
//!
//! Convention (also in the JSON record): raw counts `r` per axis, `v = r - center`;
//! accelerometer `a = M (v + q * v^2) + o` in m/s^2 with `M` upper triangular, rows and columns
//! in x, y, z order (the body frame is the accelerometer frame: x along the accelerometer's x
//! axis, y in its x-y plane); gyro `w = G v` in rad/s with `G` full (it also rotates the gyro
//! axes into the body frame) and `center` the gyro bias in counts.

pub mod acceptance;
pub mod record;

use nalgebra::{DMatrix, Matrix3};
use spincal::correct::AnyImuCorrector;
use spincal::model::{
    AxisNonlinearity, BoundedVec, CalibrationData, Channel, Environment, Identity, ImuCovariance,
    ImuOutputCovariance, ImuSet, Rails, Sensor, Span, TriadSet,
};

use super::covariance;
use crate::nonlinear::selfcal::SelfCal;
use crate::obs::recording::Recording;

fn f32s<const N: usize>(x: [f64; N]) -> [f32; N] {
    x.map(|v| v as f32)
}

/// The calibration the device stores.
#[must_use]
pub fn calibration_data(
    c: &SelfCal,
    rec: &Recording,
    identity: Identity,
    rails: Rails,
    temp: Span,
    volt: Span,
) -> CalibrationData {
    let g = c.options.g;
    // Calibrated ranges: what the poses and rotations showed, with a tenth of the span added.
    let poses: Vec<[f64; 3]> = c
        .pose_means
        .iter()
        .map(|m| c.accel.model.apply(*m))
        .collect();
    let accel_range: [Span; 3] = std::array::from_fn(|j| {
        let (lo, hi) = poses.iter().fold((-0.1 * g, 0.1 * g), |(lo, hi), a| {
            (lo.min(a[j]), hi.max(a[j]))
        });
        let pad = 0.1 * (hi - lo);
        Span::new((lo - pad) as f32, (hi + pad) as f32)
    });
    let m = c.gyro.matrix;
    let mut wmax = [0.0f64; 3];
    for &k in &c.rotations {
        for i in c.poses[k].end..c.poses[k + 1].start {
            let v: [f64; 3] = std::array::from_fn(|j| rec.gyro[i][j] - c.gyro_bias[j]);
            for (a, w) in wmax.iter_mut().enumerate() {
                *w = w.max((0..3).map(|j| m[a][j] * v[j]).sum::<f64>().abs());
            }
        }
    }
    let gyro_range: [Span; 3] = wmax.map(|w| Span::new((-1.1 * w) as f32, (1.1 * w) as f32));
    let channel = |center: f64, range: Span| Channel {
        center: center as f32,
        range,
    };
    let accel_set = TriadSet {
        axes: std::array::from_fn(|j| AxisNonlinearity {
            quadratic: c.accel.model.quadratic[j] as f32,
            ..AxisNonlinearity::LINEAR
        }),
        matrix: c.accel.model.matrix.map(f32s),
        offset: f32s(c.accel.model.offset),
    };
    let gyro_set = TriadSet {
        axes: [AxisNonlinearity::LINEAR; 3],
        matrix: m.map(f32s),
        offset: [0.0; 3],
    };
    let mut sets = BoundedVec::new();
    let _ = sets.push(ImuSet {
        accel: accel_set,
        gyro: gyro_set,
        g_sensitivity: [[0.0; 3]; 3],
    });
    CalibrationData {
        identity,
        environment: Environment {
            temperature_span: temp,
            voltage_span: volt,
            temperatures: BoundedVec::new(),
            voltages: BoundedVec::new(),
            temperature_model: spincal::model::TemperatureModel::Table,
        },
        sensor: Sensor::Imu {
            accel_rails: rails,
            gyro_rails: rails,
            accel: std::array::from_fn(|j| channel(c.accel.model.center[j], accel_range[j])),
            gyro: std::array::from_fn(|j| channel(c.gyro_bias[j], gyro_range[j])),
            lever_arm: None,
            sets,
            covariance: covariance_factors(c).and_then(|f| BoundedVec::from_slice(&[f])),
        },
        noise: None,
    }
}

/// The covariance factors the device stores (see [`spincal::model::ImuCovariance`]): per
/// output, the covariance of its offset and matrix row, over the features `[1, u0, u1, u2]` of
/// the correction form and then over the output's own features. Accelerometer: from the fit's
/// covariance (the structural zeros of the upper-triangular `M` have none). Gyro: the matrix
/// rows from the fit's covariance, and the offset from the stored bias's error (the pose means'
/// RMS about it, [`SelfCal::gyro_bias_rms`]) through `G`, as `w = G (raw - bias)`. `None` when
/// a fit has no covariance.
#[must_use]
pub fn covariance_factors(c: &SelfCal) -> Option<ImuCovariance> {
    let ca = c.accel.covariance.as_ref()?;
    let cg = c.gyro.covariance.as_ref()?;
    // Accelerometer parameters: M11 M12 M13 M22 M23 M33 o1 o2 o3 [q1 q2 q3].
    let accel_index: [[Option<usize>; 4]; 3] = [
        [Some(6), Some(0), Some(1), Some(2)],
        [Some(7), None, Some(3), Some(4)],
        [Some(8), None, None, Some(5)],
    ];
    let ma = Matrix3::from_fn(|i, j| c.accel.model.matrix[i][j]);
    let accel = accel_index.map(|idx| {
        let q = DMatrix::from_fn(4, 4, |r, s| match (idx[r], idx[s]) {
            (Some(a), Some(b)) => ca[(a, b)],
            _ => 0.0,
        });
        covariance::imu_output_from_triad(&q, &ma, &c.accel.model.offset).ok()
    });
    let g = c.gyro.matrix;
    let mg = Matrix3::from_fn(|i, j| g[i][j]);
    let gyro = std::array::from_fn(|i| {
        let mut q = DMatrix::zeros(4, 4);
        q[(0, 0)] = (0..3)
            .map(|j| (g[i][j] * c.gyro_bias_rms[j]).powi(2))
            .sum::<f64>();
        for r in 0..3 {
            for s in 0..3 {
                q[(r + 1, s + 1)] = cg[(3 * i + r, 3 * i + s)];
            }
        }
        covariance::imu_output_from_triad(&q, &mg, &[0.0; 3]).ok()
    });
    let all = |f: [Option<ImuOutputCovariance>; 3]| -> Option<[ImuOutputCovariance; 3]> {
        let [a, b, c] = f;
        Some([a?, b?, c?])
    };
    Some(ImuCovariance {
        accel: all(accel)?,
        gyro: all(gyro)?,
    })
}

/// What the device computes, checked: the blob, and the largest differences between the
/// device's f32 correction and the f64 fit over the poses (m/s^2) and over every sample of the
/// rotations (rad/s).
#[derive(Debug, Clone)]
pub struct DeviceCheck {
    /// The blob.
    pub blob: Vec<u8>,
    /// Largest accelerometer difference at the poses, m/s^2.
    pub accel: f64,
    /// Largest gyro difference during the rotations, rad/s.
    pub gyro: f64,
    /// RMS of `|a| - g` at the poses, from the mean of the device's corrected samples, m/s^2.
    pub device_accel_rms: f64,
}
/// Why the self-calibration's blob cannot be built or played back as the device would.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    /// It does not become a blob the device reads back.
    #[error(transparent)]
    Blob(#[from] super::blob::BlobError),
    /// The device's corrector refuses it.
    #[error(transparent)]
    Device(#[from] spincal::Error),
}

/// Validates and encodes `data`, then corrects the recording's poses and rotations through the
/// decoded blob with the device's correction.
///
/// # Errors
/// When the calibration does not validate.
pub fn build_and_check(
    data: &CalibrationData,
    c: &SelfCal,
    rec: &Recording,
) -> Result<DeviceCheck, CheckError> {
    let (buf, back) = super::blob::encode_checked(data)?;
    let mut dev = AnyImuCorrector::new(&back, rec.rate() as f32)?;
    let env = &data.environment;
    dev.set_environment(
        0.5 * (env.temperature_span.lo + env.temperature_span.hi),
        0.5 * (env.voltage_span.lo + env.voltage_span.hi),
    );
    let (mut worst_a, mut worst_g, mut sq) = (0.0f64, 0.0f64, 0.0f64);
    let gm = nalgebra::Matrix3::from_fn(|i, j| c.gyro.matrix[i][j]);
    let raw_at = |i: usize| -> [i32; 6] {
        std::array::from_fn(|j| {
            if j < 3 {
                rec.acc[i][j]
            } else {
                rec.gyro[i][j - 3]
            }
            .round() as i32
        })
    };
    for r in &c.poses {
        let mut sum = [0.0f64; 3];
        dev.reset();
        for i in r.clone() {
            let raw = raw_at(i);
            let out = dev.correct(raw).values;
            let host = c
                .accel
                .model
                .apply(std::array::from_fn(|j| f64::from(raw[j])));
            for j in 0..3 {
                worst_a = worst_a.max((f64::from(out[j]) - host[j]).abs());
                sum[j] += f64::from(out[j]);
            }
        }
        let norm = sum
            .iter()
            .map(|s| (s / r.len() as f64).powi(2))
            .sum::<f64>()
            .sqrt();
        sq += (norm - c.options.g).powi(2);
    }
    for &k in &c.rotations {
        for i in c.poses[k].end..c.poses[k + 1].start {
            let raw = raw_at(i);
            let out = dev.correct(raw).values;
            let v = nalgebra::Vector3::from_fn(|j, _| f64::from(raw[j + 3]) - c.gyro_bias[j]);
            let host = gm * v;
            for j in 0..3 {
                worst_g = worst_g.max((f64::from(out[j + 3]) - host[j]).abs());
            }
        }
    }
    Ok(DeviceCheck {
        blob: buf,
        accel: worst_a,
        gyro: worst_g,
        device_accel_rms: (sq / c.poses.len() as f64).sqrt(),
    })
}
