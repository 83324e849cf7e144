//! What the device holds of a triad or IMU calibration: its sensor description (channels,
//! coefficient sets, g-sensitivity, lever arms, covariance factors), and the fits per table
//! point as the report and the record show them.

use spincal::model::{BoundedVec, Channel, ImuCovariance, ImuSet, Quantity, Sensor};

use super::super::table::Layout;
use super::super::{Options, PointFit, WorkflowError, blob};
use super::TriadResult;

/// The device's description of the accelerometer triad `accel`, the gyro triad `gyro`, or
/// both (an IMU).
pub(super) fn sensor(
    accel: Option<&TriadResult>,
    gyro: Option<&TriadResult>,
    opts: &Options,
) -> Result<Sensor, WorkflowError> {
    let channels = |t: &TriadResult| -> [Channel; 3] {
        std::array::from_fn(|j| Channel {
            center: t.centers[j] as f32,
            range: t.ranges[j],
        })
    };
    let bv = |n: usize| blob::too_many(&opts.file, n);
    Ok(match (accel, gyro) {
        (Some(a), Some(g)) => Sensor::Imu {
            accel_rails: opts.rails,
            gyro_rails: opts.rails,
            accel: channels(a),
            gyro: channels(g),
            lever_arm: a.lever.map(|r| r.map(|row| row.map(|v| v as f32))),
            sets: BoundedVec::from_slice(
                &a.sets
                    .iter()
                    .zip(&g.sets)
                    .enumerate()
                    .map(|(k, (sa, sg))| ImuSet {
                        accel: *sa,
                        gyro: *sg,
                        g_sensitivity: g
                            .g
                            .get(k)
                            .map_or([[0.0; 3]; 3], |m| m.map(|r| r.map(|v| v as f32))),
                    })
                    .collect::<Vec<_>>(),
            )
            .ok_or_else(|| bv(a.sets.len()))?,
            covariance: Some(
                BoundedVec::from_slice(
                    &a.imu_covs
                        .iter()
                        .zip(&g.imu_covs)
                        .map(|(ca, cg)| ImuCovariance {
                            accel: *ca,
                            gyro: *cg,
                        })
                        .collect::<Vec<_>>(),
                )
                .ok_or_else(|| bv(a.imu_covs.len()))?,
            ),
        },
        (Some(t), None) | (None, Some(t)) => Sensor::Triad {
            quantity: if accel.is_some() {
                Quantity::Acceleration
            } else {
                Quantity::AngularRate
            },
            rails: opts.rails,
            channels: channels(t),
            sets: BoundedVec::from_slice(&t.sets).ok_or_else(|| bv(t.sets.len()))?,
            covariance: Some(BoundedVec::from_slice(&t.covs).ok_or_else(|| bv(t.covs.len()))?),
        },
        (None, None) => unreachable!("every sensor kind has an accelerometer or a gyro triad"),
    })
}

/// Per point of `layout`, the axis fits, inversion errors and noise of every part.
pub(super) fn point_fits(layout: &Layout, parts: &[&TriadResult]) -> Vec<PointFit> {
    let mut points = Vec::new();
    for (k, p) in layout.points.iter().enumerate() {
        let mut pf = PointFit {
            temp: p.temp,
            volt: p.volt,
            axes: Vec::new(),
            inversion_error: Vec::new(),
            noise: Vec::new(),
        };
        for t in parts {
            pf.axes.extend(t.fits[k].iter().cloned());
            pf.inversion_error.extend(t.errors[k]);
            pf.noise.extend(t.noise[k]);
        }
        points.push(pf);
    }
    points
}
