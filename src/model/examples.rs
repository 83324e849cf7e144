//! Example calibrations for documentation, tests, golden vectors and benchmarks.
//!
//! Realistic magnitudes, not any real unit: a 16-bit converter, an accelerometer at about
//! 412 counts per m/s^2, a gyro at about 900 counts per rad/s, temperature drift of bias and
//! scale, small misalignment, g-sensitivity and lever arms of a few millimetres.
#![expect(
    clippy::indexing_slicing,
    reason = "fixed, in-bounds indices in example constructors; not on the device path"
)]

use super::{
    AxisNonlinearity, BoundedVec, CalibrationData, Channel, Environment, Identity, ImuCovariance,
    ImuSet, NoiseTerms, Quantity, Rails, Sensor, Serial, SingleSet, Span, TemperatureModel,
    TriadSet,
};

use super::sets::Blend;

const G: f32 = 9.806_65;

fn identity(serial: &str) -> Identity {
    Identity {
        serial: Serial::new(serial).unwrap_or_default(),
        created_unix_s: 1_795_000_000,
        data_hash: [
            0x5a, 0x1c, 0x07, 0xe2, 0x9b, 0x44, 0x30, 0xd1, 0x6f, 0x88, 0x02, 0xa7, 0x3e, 0xc5,
            0x91, 0x0b,
        ],
        tool_version: [0, 1, 0],
        fit_rejected: false,
    }
}

fn table<T: Clone, const N: usize>(items: &[T]) -> BoundedVec<T, N> {
    BoundedVec::from_slice(items).unwrap_or_default()
}

fn accel_channels() -> [Channel; 3] {
    [
        Channel {
            center: 32_768.0 + 341.5,
            range: Span::new(-75.0, 75.0),
        },
        Channel {
            center: 32_768.0 + 561.25,
            range: Span::new(-75.0, 75.0),
        },
        Channel {
            center: 32_768.0 + 3_659.0,
            range: Span::new(-75.0, 75.0),
        },
    ]
}

fn gyro_channels() -> [Channel; 3] {
    [
        Channel {
            center: 32_768.0 + 18.0,
            range: Span::new(-35.0, 35.0),
        },
        Channel {
            center: 32_768.0 - 338.5,
            range: Span::new(-35.0, 35.0),
        },
        Channel {
            center: 32_768.0 - 250.75,
            range: Span::new(-35.0, 35.0),
        },
    ]
}

fn accel_set(t: f32, nonlinear: bool) -> TriadSet {
    let dt = t - 25.0;
    let s = 1.0 / 412.0 * (1.0 + 80e-6 * dt);
    // Every axis has its own terms, so a coefficient applied to the wrong axis shows.
    let axis = |q: f32, k: f32, o: f32, a: f32, b: f32| AxisNonlinearity {
        quadratic: if nonlinear {
            q * (1.0 + 0.002 * dt)
        } else {
            0.0
        },
        cubic: if nonlinear { k } else { 0.0 },
        odd_quadratic: if nonlinear { o } else { 0.0 },
        asymmetry: if nonlinear { a } else { 0.0 },
        asymmetry_break: if nonlinear { b } else { 0.0 },
    };
    let matrix = [
        [s * 1.002, s * 1.5e-3, -s * 0.8e-3],
        [0.0, s * 0.997, s * 2.1e-3],
        [0.0, 0.0, s * 1.004],
    ];
    let bias = [12.0 + 0.35 * dt, -8.0 + 0.2 * dt, 30.0 - 0.5 * dt];
    let offset = core::array::from_fn(|i| {
        -(matrix[i][0] * bias[0] + matrix[i][1] * bias[1] + matrix[i][2] * bias[2])
    });
    TriadSet {
        axes: [
            axis(3.0e-7, 1.0e-12, 2.0e-8, 4.0e-4, 0.0),
            axis(-2.0e-7, 0.0, -1.5e-8, 3.0e-4, 15.0),
            axis(1.5e-7, -2.0e-12, 3.0e-8, 5.0e-4, -20.0),
        ],
        matrix,
        offset,
    }
}

/// A packed factor over the [`IMU_FEATURES`](super::IMU_FEATURES) features of output `i`:
/// independent sigmas for bias, the own and the cross components of the sensitivity row, the
/// lever arm (or g-sensitivity) row and the nonlinear terms, and a correlation of the bias with
/// the g-squared term.
fn imu_output_factor(i: usize, sigma: [f32; 5]) -> super::ImuOutputCovariance {
    let [bias, own, cross, lever, k2] = sigma;
    let diag = [
        bias,
        if i == 0 { own } else { cross },
        if i == 1 { own } else { cross },
        if i == 2 { own } else { cross },
        lever,
        lever,
        lever,
        k2,
        // The kink, a tenth of the own scale factor's; the cubic and odd-quadratic terms.
        0.1 * own,
        k2 * 1e-2,
        k2 * 0.5,
    ];
    let mut packed = [0.0f32; 66];
    for (r, d) in diag.iter().enumerate() {
        packed[r * (r + 1) / 2 + r] = *d;
    }
    // Row 7 (x^2), column 0 (bias).
    packed[28] = -0.3 * k2;
    let mut out = [[0.0; 11]; 6];
    for (k, v) in packed.iter().enumerate() {
        out[k / 11][k % 11] = *v;
    }
    out
}

fn imu_covariance(t: f32) -> ImuCovariance {
    let dt = t - 25.0;
    let grow = 1.0 + 0.004 * dt.abs();
    ImuCovariance {
        accel: core::array::from_fn(|i| {
            imu_output_factor(i, [2.0e-2 * grow, 1.5e-4, 3.0e-5, 2.0e-7, 1.0e-9])
        }),
        gyro: core::array::from_fn(|i| {
            imu_output_factor(i, [1.0e-3 * grow, 2.0e-4, 5.0e-5, 1.0e-6, 2.0e-9])
        }),
    }
}

fn gyro_set(t: f32, nonlinear: bool) -> TriadSet {
    let dt = t - 25.0;
    let s = 1.0 / 900.0 * (1.0 - 120e-6 * dt);
    let axis = |q: f32, k: f32, o: f32, a: f32, b: f32| AxisNonlinearity {
        quadratic: if nonlinear { q } else { 0.0 },
        cubic: if nonlinear { k } else { 0.0 },
        odd_quadratic: if nonlinear { o } else { 0.0 },
        asymmetry: if nonlinear { a } else { 0.0 },
        asymmetry_break: if nonlinear { b } else { 0.0 },
    };
    let matrix = [
        [s * 0.998, s * 3.0e-3, s * 1.0e-3],
        [-s * 2.5e-3, s * 1.003, s * 4.0e-3],
        [s * 1.2e-3, -s * 3.5e-3, s * 1.001],
    ];
    let bias = [-4.0 + 0.8 * dt, 6.0 - 0.3 * dt, 2.5 + 0.1 * dt];
    let offset = core::array::from_fn(|i| {
        -(matrix[i][0] * bias[0] + matrix[i][1] * bias[1] + matrix[i][2] * bias[2])
    });
    TriadSet {
        axes: [
            axis(1.0e-7, 4.0e-13, 1.0e-8, -2.5e-4, 40.0),
            axis(-1.2e-7, -3.0e-13, 0.0, -1.5e-4, -30.0),
            axis(0.5e-7, 2.0e-13, -2.0e-8, 2.0e-4, 10.0),
        ],
        matrix,
        offset,
    }
}

fn imu_set(t: f32, full: bool) -> ImuSet {
    let dt = t - 25.0;
    ImuSet {
        accel: accel_set(t, full),
        gyro: gyro_set(t, full),
        g_sensitivity: if full {
            [
                [2.0e-4 + 1e-6 * dt, -1.0e-4, 0.5e-4],
                [0.8e-4, 1.5e-4, -0.3e-4],
                [-0.2e-4, 0.6e-4, 3.0e-4],
            ]
        } else {
            [[0.0; 3]; 3]
        },
    }
}

impl CalibrationData {
    /// A single-axis accelerometer (spin axis, +-50 g) with a 3-point temperature table and a
    /// 2-point voltage table (bilinear), every nonlinear term and a covariance factor.
    #[must_use]
    pub fn example_single() -> Self {
        let temperatures = [-40.0, 25.0, 85.0];
        let voltages = [4.5, 5.5];
        let mut sets = [SingleSet {
            axis: AxisNonlinearity::LINEAR,
            scale: 0.0,
            offset: 0.0,
        }; 6];
        for (ti, t) in temperatures.iter().enumerate() {
            for (vi, v) in voltages.iter().enumerate() {
                let dt = t - 25.0;
                let dv = v - 5.0;
                let scale = 50.0 * G / 32_000.0 * (1.0 + 60e-6 * dt + 2e-3 * dv);
                sets[ti * 2 + vi] = SingleSet {
                    axis: AxisNonlinearity {
                        quadratic: 2.0e-7 + 1.0e-9 * dt,
                        cubic: 1.0e-12,
                        odd_quadratic: -5.0e-8,
                        asymmetry: 1.0e-3 + 1.0e-4 * dv,
                        asymmetry_break: 25.0,
                    },
                    scale,
                    offset: -scale * (4.0 * dt + 20.0 * dv),
                };
            }
        }
        CalibrationData {
            identity: identity("SPN-A-000123"),
            environment: Environment {
                temperature_span: Span::new(-40.0, 85.0),
                voltage_span: Span::new(4.5, 5.5),
                temperatures: table(&temperatures),
                voltages: table(&voltages),
                temperature_model: TemperatureModel::Table,
            },
            sensor: Sensor::Single {
                quantity: Quantity::Acceleration,
                rails: Rails::unsigned(16),
                channel: Channel {
                    center: 32_768.0 + 211.25,
                    range: Span::new(-45.0 * G, 45.0 * G),
                },
                sets: table(&sets),
                covariance: Some(table(&[[0.02, 1.0e-6, 3.0e-7]; 6])),
            },
            noise: None,
        }
    }

    /// A single-axis accelerometer whose coefficients follow the temperature as a Chebyshev
    /// series of 6 terms over -40 to 70 C (a bias with a step near 10 C, a drifting scale
    /// factor and g-squared term), at 2 supply voltages, with covariance factors alike.
    #[must_use]
    pub fn example_single_series() -> Self {
        let voltages = [4.5, 5.5];
        let scale = 50.0 * G / 32_000.0;
        // Per term: relative scale, offset (SI), quadratic.
        let terms: [(f32, f32, f32); 6] = [
            (1.0, -0.35, 2.0e-7),
            (3.3e-3, 0.21, 4.0e-9),
            (-4.0e-4, -0.02, -1.0e-9),
            (1.5e-4, -0.045, 0.0),
            (-2.0e-5, 0.006, 0.0),
            (6.0e-6, 0.011, 0.0),
        ];
        let mut sets = [SingleSet {
            axis: AxisNonlinearity::LINEAR,
            scale: 0.0,
            offset: 0.0,
        }; 12];
        let mut covariance = [[0.0f32; 3]; 12];
        for (k, (s, o, q)) in terms.iter().enumerate() {
            for (vi, v) in voltages.iter().enumerate() {
                let dv = v - 5.0;
                let first = k == 0;
                sets[k * 2 + vi] = SingleSet {
                    axis: AxisNonlinearity {
                        quadratic: *q,
                        cubic: if first { 1.0e-12 } else { 0.0 },
                        odd_quadratic: 0.0,
                        asymmetry: 0.0,
                        asymmetry_break: 0.0,
                    },
                    scale: scale * s * if first { 1.0 + 2e-3 * dv } else { 1.0 },
                    offset: o + if first { -0.08 * dv } else { 0.0 },
                };
                covariance[k * 2 + vi] = if first {
                    [0.02, 1.0e-6, 3.0e-7]
                } else {
                    [0.002 / (k as f32), 1.0e-7, 0.0]
                };
            }
        }
        CalibrationData {
            identity: identity("SPN-T-000042"),
            environment: Environment {
                temperature_span: Span::new(-40.0, 70.0),
                voltage_span: Span::new(4.5, 5.5),
                temperatures: BoundedVec::new(),
                voltages: table(&voltages),
                temperature_model: TemperatureModel::Chebyshev(6),
            },
            sensor: Sensor::Single {
                quantity: Quantity::Acceleration,
                rails: Rails::unsigned(16),
                channel: Channel {
                    center: 32_768.0 - 97.5,
                    range: Span::new(-45.0 * G, 45.0 * G),
                },
                sets: table(&sets),
                covariance: Some(table(&covariance)),
            },
            noise: None,
        }
    }

    /// An accelerometer triad with 1 count = 0.01 m/s^2, small misalignment, no table.
    #[must_use]
    pub fn example_triad() -> Self {
        let set = TriadSet {
            axes: [AxisNonlinearity::LINEAR; 3],
            matrix: [
                [0.01, 1.0e-4, -5.0e-5],
                [0.0, 0.0101, 8.0e-5],
                [0.0, 0.0, 0.0099],
            ],
            offset: [0.0, 0.02, -0.015],
        };
        let channel = Channel {
            center: 32_768.0,
            range: Span::new(-150.0, 150.0),
        };
        CalibrationData {
            identity: identity("TRI-7"),
            environment: Environment::fixed(Span::new(15.0, 35.0), Span::new(3.0, 3.6)),
            sensor: Sensor::Triad {
                quantity: Quantity::Acceleration,
                rails: Rails::unsigned(16),
                channels: [channel; 3],
                sets: table(&[set]),
                covariance: None,
            },
            noise: None,
        }
    }

    /// A full IMU: an 8-point temperature table from -40 to 85 C, every nonlinear term on both
    /// triads, misalignment, g-sensitivity, lever arms and covariance factors.
    #[must_use]
    pub fn example_imu() -> Self {
        Self::imu(true)
    }

    /// [`example_imu`](Self::example_imu) without the asymmetric scale: the spinning round's
    /// full model (polynomial, misalignment, g-sensitivity, lever arm) over the same table.
    #[must_use]
    pub fn example_imu_polynomial() -> Self {
        let mut data = Self::imu(true);
        data.identity = identity("IMU-POLY-0042");
        if let Sensor::Imu { sets, .. } = &mut data.sensor {
            for set in sets.as_mut_slice() {
                for axis in set.accel.axes.iter_mut().chain(set.gyro.axes.iter_mut()) {
                    axis.asymmetry = 0.0;
                    axis.asymmetry_break = 0.0;
                }
            }
        }
        data
    }

    /// [`example_imu`](Self::example_imu) without the lever arm, its temperature dependence a
    /// 5-term Chebyshev series over -40 to 85 C (the interpolant of the table's sets and
    /// covariance factors at the series' nodes) instead of a table.
    #[must_use]
    pub fn example_imu_series() -> Self {
        const TERMS: usize = 5;
        let (lo, hi) = (-40.0f32, 85.0f32);
        let angle =
            |k: usize, j: usize| core::f32::consts::PI * k as f32 * (j as f32 + 0.5) / TERMS as f32;
        let node = |j: usize| 0.5 * (lo + hi) + 0.5 * (hi - lo) * libm::cosf(angle(1, j));
        let weight = |k: usize, j: usize| {
            (if k == 0 { 1.0 } else { 2.0 }) / TERMS as f32 * libm::cosf(angle(k, j))
        };
        let values: [ImuSet; TERMS] = core::array::from_fn(|j| imu_set(node(j), true));
        let factors: [ImuCovariance; TERMS] = core::array::from_fn(|j| imu_covariance(node(j)));
        let sets: [ImuSet; TERMS] = core::array::from_fn(|k| {
            values.iter().enumerate().skip(1).fold(
                values[0].lincomb(weight(k, 0), &values[0], 0.0),
                |acc, (j, v)| acc.lincomb(1.0, v, weight(k, j)),
            )
        });
        let covariance: [ImuCovariance; TERMS] = core::array::from_fn(|k| {
            let mut c = factors[0];
            for (o, f) in c.floats_mut().zip(factors[0].floats()) {
                *o = weight(k, 0) * f;
            }
            for (j, fj) in factors.iter().enumerate().skip(1) {
                for (o, f) in c.floats_mut().zip(fj.floats()) {
                    *o += weight(k, j) * f;
                }
            }
            c
        });
        let mut data = Self::imu(true);
        data.identity = identity("IMU-SERIES-0042");
        data.environment.temperatures = BoundedVec::new();
        data.environment.temperature_span = Span::new(lo, hi);
        data.environment.temperature_model = TemperatureModel::Chebyshev(TERMS as u8);
        if let Sensor::Imu {
            lever_arm,
            sets: s,
            covariance: c,
            ..
        } = &mut data.sensor
        {
            *lever_arm = None;
            *s = table(&sets);
            *c = Some(table(&covariance));
        }
        data
    }

    /// An IMU with bias and scale-misalignment only (no nonlinear terms, no g-sensitivity, no
    /// lever arm), at one temperature.
    #[must_use]
    pub fn example_imu_linear() -> Self {
        Self::imu(false)
    }

    fn imu(full: bool) -> Self {
        let temperatures = [-40.0, -20.0, 0.0, 15.0, 30.0, 50.0, 70.0, 85.0];
        let points: &[f32] = if full { &temperatures } else { &[] };
        let sets: heapless::Vec<ImuSet, 8> = if full {
            temperatures.iter().map(|t| imu_set(*t, true)).collect()
        } else {
            core::iter::once(imu_set(25.0, false)).collect()
        };
        CalibrationData {
            identity: identity(if full {
                "IMU-FULL-0042"
            } else {
                "IMU-LIN-0042"
            }),
            environment: Environment {
                temperature_span: Span::new(-40.0, 85.0),
                voltage_span: Span::new(3.0, 3.6),
                temperatures: table(points),
                voltages: BoundedVec::new(),
                temperature_model: TemperatureModel::Table,
            },
            sensor: Sensor::Imu {
                accel_rails: Rails::unsigned(16),
                gyro_rails: Rails::unsigned(16),
                accel: accel_channels(),
                gyro: gyro_channels(),
                lever_arm: if full {
                    Some([
                        [0.006, 0.001, -0.002],
                        [-0.001, 0.0055, 0.0015],
                        [0.002, -0.0025, 0.004],
                    ])
                } else {
                    None
                },
                sets: table(&sets),
                covariance: if full {
                    Some(table(&temperatures.map(imu_covariance)))
                } else {
                    None
                },
            },
            noise: full.then_some(imu_noise()),
        }
    }
}

/// A tactical MEMS IMU's noise: white noise of 0.047 m/s^2 and 6.3e-3 rad/s per sample at
/// 1 kHz; bias walks that move the biases by 0.8 of their stated 1-sigma at 25 C over the
/// ageing time of about 12 days.
fn imu_noise() -> NoiseTerms {
    NoiseTerms {
        white: [1.5e-3, 1.5e-3, 1.5e-3, 2.0e-4, 2.0e-4, 2.0e-4],
        bias_walk: [1.6e-5, 1.6e-5, 1.6e-5, 8.0e-7, 8.0e-7, 8.0e-7],
        ageing_s: 1.0e6,
        gravity: Span::new(9.80, 9.82),
        false_alarm: 1.0e-3,
    }
}
