//! The blob's checking gate: every corruption class gives its own error, decoding arbitrary
//! bytes never panics, and encode/decode round-trips every valid calibration.

use host_tests::fields;
use host_tests::golden;
use proptest::prelude::*;
use spincal::blob::{self, HEADER_LEN, MAX_BLOB_LEN};
use spincal::model::{BoundedVec, Calibration, CalibrationData, Sensor, Serial};
use spincal::{Error, Field, Part};

/// Frames a payload exactly as the format says, independently of `blob::encode`, so that
/// invalid calibrations can be put in well-formed blobs.
fn frame(payload: &[u8]) -> Vec<u8> {
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
    let mut out = b"SCAL\x06".to_vec();
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    let mut digest = crc.digest();
    digest.update(&out);
    digest.update(payload);
    out.extend_from_slice(&digest.finalize().to_le_bytes());
    out.extend_from_slice(payload);
    out
}

fn framed(data: &CalibrationData) -> Vec<u8> {
    frame(&postcard::to_allocvec(data).unwrap())
}

fn examples() -> Vec<(&'static str, CalibrationData)> {
    golden::examples()
        .into_iter()
        .map(|(n, d, _)| (n, d))
        .collect()
}

#[test]
fn independent_framing_matches_encode() {
    for (name, data) in examples() {
        assert_eq!(framed(&data), golden::encode(&data), "{name}");
    }
}

#[test]
fn every_single_bit_flip_is_refused() {
    for (name, data) in examples() {
        let good = golden::encode(&data);
        for bit in 0..good.len() * 8 {
            let mut bad = good.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let err = blob::decode(&bad).expect_err(&format!("{name}: flip of bit {bit} accepted"));
            let expected_class = match bit / 8 {
                0..=3 => matches!(err, Error::HeaderBadMagic { .. }),
                4 => matches!(err, Error::HeaderUnsupportedVersion { .. }),
                5 | 6 => matches!(
                    err,
                    Error::LengthTruncated { .. } | Error::LengthTrailingBytes { .. }
                ),
                _ => matches!(err, Error::ChecksumMismatch { .. }),
            };
            assert!(expected_class, "{name}: bit {bit} gave {err:?}");
        }
    }
}

#[test]
fn truncation_at_every_length_is_refused() {
    for (name, data) in examples() {
        let good = golden::encode(&data);
        for len in 0..good.len() {
            let err = blob::decode(&good[..len]).unwrap_err();
            if len < HEADER_LEN {
                assert_eq!(
                    err,
                    Error::HeaderTruncated { found: len },
                    "{name} at {len}"
                );
            } else {
                assert_eq!(
                    err,
                    Error::LengthTruncated {
                        declared: good.len(),
                        found: len
                    },
                    "{name} at {len}"
                );
            }
        }
    }
}

#[test]
fn trailing_bytes_are_refused() {
    let good = golden::encode(&CalibrationData::example_triad());
    for extra in [vec![0u8], vec![0xff; 7], vec![0; 1000]] {
        let mut bad = good.clone();
        bad.extend_from_slice(&extra);
        assert_eq!(
            blob::decode(&bad),
            Err(Error::LengthTrailingBytes {
                declared: good.len(),
                found: bad.len()
            })
        );
    }
    // Bytes inside the declared length that the payload does not use.
    let mut payload = postcard::to_allocvec(&CalibrationData::example_triad()).unwrap();
    payload.extend_from_slice(&[0, 0, 0]);
    assert_eq!(
        blob::decode(&frame(&payload)),
        Err(Error::PayloadTrailingBytes { unread: 3 })
    );
}

#[test]
fn wrong_magic_version_and_length_are_refused() {
    let good = golden::encode(&CalibrationData::example_single());
    let mut bad = good.clone();
    bad[..4].copy_from_slice(b"SCAM");
    assert_eq!(
        blob::decode(&bad),
        Err(Error::HeaderBadMagic { found: *b"SCAM" })
    );
    // The previous formats (their IMU covariance and lever term mean other things, or they
    // lack a field) and the next.
    for version in [1, 2, 3, 4, 5, 7] {
        let mut bad = good.clone();
        bad[4] = version;
        assert_eq!(
            blob::decode(&bad),
            Err(Error::HeaderUnsupportedVersion { found: version })
        );
    }
    let mut bad = good.clone();
    bad[5] = bad[5].wrapping_add(1);
    assert!(matches!(
        blob::decode(&bad),
        Err(Error::LengthTruncated { .. })
    ));
    let mut bad = good.clone();
    bad[5] = bad[5].wrapping_sub(1);
    assert!(matches!(
        blob::decode(&bad),
        Err(Error::LengthTrailingBytes { .. })
    ));
    // A consistent header over a payload that is not a calibration.
    assert_eq!(
        blob::decode(&frame(&[0xff; 40])),
        Err(Error::PayloadMalformed)
    );
    assert_eq!(blob::decode(&frame(&[])), Err(Error::PayloadMalformed));
}

#[test]
fn nan_and_infinity_in_every_float_field_give_that_fields_error() {
    let mut fields_seen = std::collections::BTreeSet::new();
    for (name, data) in examples() {
        let count = fields::floats(&mut data.clone()).len();
        for i in 0..count {
            for bad_value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                let mut bad = data.clone();
                let mut all = fields::floats(&mut bad);
                let target = &mut all[i];
                let (field, set) = (target.field, target.set);
                *target.value = bad_value;
                drop(all);
                let err = blob::decode(&framed(&bad)).unwrap_err();
                match err {
                    Error::InvalidNonFinite {
                        field: f, set: s, ..
                    } => {
                        assert_eq!((f, s), (field, set), "{name} float {i}: {err}");
                    }
                    other => panic!("{name} float {i} ({field}) = {bad_value}: {other:?}"),
                }
                fields_seen.insert(format!("{field:?}"));
            }
        }
    }
    // Every kind of float field was corrupted at least once.
    assert_eq!(fields_seen.len(), 22, "{fields_seen:?}");
}

#[test]
fn unsorted_or_duplicate_breakpoints_are_refused() {
    let mut data = CalibrationData::example_imu();
    data.environment.temperatures.as_mut_slice().swap(2, 3);
    assert_eq!(
        blob::decode(&framed(&data)),
        Err(Error::InvalidBreakpointOrder {
            field: Field::TemperatureBreakpoint,
            index: 3
        })
    );
    let mut data = CalibrationData::example_single();
    let v = data.environment.voltages.as_mut_slice();
    v[1] = v[0];
    assert_eq!(
        blob::decode(&framed(&data)),
        Err(Error::InvalidBreakpointOrder {
            field: Field::VoltageBreakpoint,
            index: 1
        })
    );
    let mut data = CalibrationData::example_single();
    data.environment.temperatures.as_mut_slice()[2] = 90.0;
    assert_eq!(
        blob::decode(&framed(&data)),
        Err(Error::InvalidBreakpointOutsideSpan {
            field: Field::TemperatureBreakpoint,
            index: 2
        })
    );
}

#[test]
fn each_validation_rule_has_its_own_error() {
    type Corruption = (&'static str, Box<dyn Fn(&mut CalibrationData)>, Error);
    let cases: Vec<Corruption> = vec![
        (
            "inverted span",
            Box::new(|d| d.environment.voltage_span = spincal::model::Span::new(5.0, 3.0)),
            Error::InvalidSpanOrder {
                field: Field::VoltageSpan,
                part: None,
                index: None,
            },
        ),
        (
            "table shape",
            Box::new(|d| {
                let _ = d.environment.temperatures.push(86.0);
                d.environment.temperature_span.hi = 90.0;
            }),
            Error::InvalidTableShape {
                expected: 9,
                found: 8,
            },
        ),
        (
            "rails",
            Box::new(|d| {
                if let Sensor::Imu { gyro_rails, .. } = &mut d.sensor {
                    gyro_rails.hi = gyro_rails.lo + 1;
                }
            }),
            Error::InvalidRails { part: Part::Gyro },
        ),
        (
            "rails beyond the sample format",
            Box::new(|d| {
                if let Sensor::Imu { accel_rails, .. } = &mut d.sensor {
                    accel_rails.hi = 70_000;
                }
            }),
            Error::InvalidRails {
                part: Part::Accelerometer,
            },
        ),
        (
            "gyro samples in another format",
            Box::new(|d| {
                if let Sensor::Imu { gyro_rails, .. } = &mut d.sensor {
                    *gyro_rails = gyro_rails.in_format(spincal::model::SampleFormat::I32);
                }
            }),
            Error::InvalidMixedFormats,
        ),
        (
            "center outside rails",
            Box::new(|d| {
                if let Sensor::Imu { accel, .. } = &mut d.sensor {
                    accel[2].center = 70_000.0;
                }
            }),
            Error::InvalidCenter {
                part: Part::Accelerometer,
                axis: 2,
            },
        ),
        (
            "empty input range",
            Box::new(|d| {
                if let Sensor::Imu { gyro, .. } = &mut d.sensor {
                    gyro[1].range.hi = gyro[1].range.lo;
                }
            }),
            Error::InvalidSpanOrder {
                field: Field::InputRange,
                part: Some(Part::Gyro),
                index: Some(1),
            },
        ),
        (
            "singular matrix",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    let m = &mut sets.as_mut_slice()[5].gyro.matrix;
                    m[2] = m[0];
                }
            }),
            Error::InvalidSingularMatrix {
                part: Part::Gyro,
                set: 5,
            },
        ),
        (
            "covariance in some sets only",
            Box::new(|d| {
                if let Sensor::Imu {
                    covariance: Some(c),
                    ..
                } = &mut d.sensor
                {
                    let first = c[0];
                    *c = BoundedVec::from_slice(&[first; 7]).unwrap();
                }
            }),
            Error::InvalidCovarianceIncomplete,
        ),
        (
            "lever arm",
            Box::new(|d| {
                if let Sensor::Imu {
                    lever_arm: Some(r), ..
                } = &mut d.sensor
                {
                    r[1] = [8.0, 8.0, 0.0];
                }
            }),
            Error::InvalidLeverArm { axis: 1 },
        ),
        (
            "an accelerometer axis sensing along another",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    // Axis 2 of set 3 senses mostly along y: its lever term is undefined.
                    let m = &mut sets.as_mut_slice()[3].accel.matrix;
                    *m = [
                        [m[0][0], 0.0, 0.0],
                        [0.0, m[0][0], 0.0],
                        [0.0, 3.0 * m[0][0], m[0][0]],
                    ];
                }
            }),
            Error::InvalidSensingDirection { set: 3, axis: 2 },
        ),
        (
            "unbounded output",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    sets.as_mut_slice()[0].accel.axes[0].cubic = 1e10;
                }
            }),
            Error::InvalidUnboundedOutput {
                part: Part::Accelerometer,
                set: 0,
            },
        ),
        (
            "serial",
            Box::new(|d| d.identity.serial = Serial::new("bad\nserial").unwrap()),
            Error::InvalidSerial,
        ),
        (
            "empty serial",
            Box::new(|d| d.identity.serial = Serial::new("").unwrap()),
            Error::InvalidSerial,
        ),
    ];
    for (what, corrupt, expected) in cases {
        let mut data = CalibrationData::example_imu();
        corrupt(&mut data);
        assert_eq!(blob::decode(&framed(&data)), Err(expected), "{what}");
        assert_eq!(
            Calibration::new(data),
            Err(expected),
            "{what}: Calibration::new"
        );
    }
    // Temperature series: the scale factor must stay away from zero at every temperature,
    // the output bounded, the shape right.
    use spincal::model::TemperatureModel;
    let series: Vec<Corruption> = vec![
        (
            "a series term that can cancel the scale factor",
            Box::new(|d| {
                if let Sensor::Single { sets, .. } = &mut d.sensor {
                    let s = sets.as_slice()[0].scale;
                    sets.as_mut_slice()[5].scale = -1.1 * s;
                }
            }),
            Error::InvalidSingularMatrix {
                part: Part::Sensor,
                set: 1,
            },
        ),
        (
            "a series term that makes the output unbounded",
            Box::new(|d| {
                if let Sensor::Single { sets, .. } = &mut d.sensor {
                    sets.as_mut_slice()[7].axis.cubic = 1e10;
                }
            }),
            Error::InvalidUnboundedOutput {
                part: Part::Sensor,
                set: 1,
            },
        ),
        (
            "a series with breakpoints",
            Box::new(|d| {
                let _ = d.environment.temperatures.push(0.0);
            }),
            Error::InvalidTemperatureSeries,
        ),
        (
            "a series of no terms",
            Box::new(|d| d.environment.temperature_model = TemperatureModel::Chebyshev(0)),
            Error::InvalidTemperatureSeries,
        ),
        (
            "a series over a span of no width",
            Box::new(|d| d.environment.temperature_span = spincal::model::Span::new(25.0, 25.0)),
            Error::InvalidTemperatureSeries,
        ),
        (
            "a series of the wrong length",
            Box::new(|d| d.environment.temperature_model = TemperatureModel::Chebyshev(5)),
            Error::InvalidTableShape {
                expected: 10,
                found: 12,
            },
        ),
    ];
    for (what, corrupt, expected) in series {
        let mut data = CalibrationData::example_single_series();
        assert!(
            Calibration::new(data.clone()).is_ok(),
            "the example is valid"
        );
        corrupt(&mut data);
        assert_eq!(blob::decode(&framed(&data)), Err(expected), "{what}");
    }
    // A triad's and an IMU's series: invertible and bounded at every temperature, or refused.
    let mut triad = CalibrationData::example_triad();
    triad.environment.temperature_model = TemperatureModel::Chebyshev(2);
    if let Sensor::Triad { sets, .. } = &mut triad.sensor {
        let mut second = sets.as_slice()[0];
        second.matrix = second.matrix.map(|r| r.map(|v| 0.01 * v));
        let _ = sets.push(second);
    }
    assert!(Calibration::new(triad.clone()).is_ok(), "a triad's series");
    if let Sensor::Triad { sets, .. } = &mut triad.sensor {
        let head = sets.as_slice()[0].matrix;
        sets.as_mut_slice()[1].matrix = head.map(|r| r.map(|v| -1.2 * v));
    }
    assert_eq!(
        Calibration::new(triad),
        Err(Error::InvalidSingularMatrix {
            part: Part::Sensor,
            set: 0
        }),
        "a triad's series term that can cancel its matrix"
    );
    let imu: Vec<Corruption> = vec![
        (
            "an accelerometer term that can cancel the matrix",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    let head = sets.as_slice()[0].accel.matrix;
                    sets.as_mut_slice()[3].accel.matrix = head.map(|r| r.map(|v| 1.5 * v));
                }
            }),
            Error::InvalidSingularMatrix {
                part: Part::Accelerometer,
                set: 0,
            },
        ),
        (
            "a gyro term that makes the output unbounded",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    sets.as_mut_slice()[4].gyro.axes[1].cubic = 1e10;
                }
            }),
            Error::InvalidUnboundedOutput {
                part: Part::Gyro,
                set: 0,
            },
        ),
        (
            "a g-sensitivity term that makes the rate unbounded",
            Box::new(|d| {
                if let Sensor::Imu { sets, .. } = &mut d.sensor {
                    sets.as_mut_slice()[2].g_sensitivity[0][0] = 1e14;
                }
            }),
            Error::InvalidUnboundedOutput {
                part: Part::Gyro,
                set: 0,
            },
        ),
        (
            "an IMU's series with a lever arm",
            Box::new(|d| {
                if let Sensor::Imu { lever_arm, .. } = &mut d.sensor {
                    *lever_arm = Some([[0.002, 0.0, 0.0], [0.0, 0.002, 0.0], [0.0, 0.0, 0.002]]);
                }
            }),
            Error::InvalidTemperatureSeries,
        ),
    ];
    for (what, corrupt, expected) in imu {
        let mut data = CalibrationData::example_imu_series();
        assert!(
            Calibration::new(data.clone()).is_ok(),
            "the example is valid"
        );
        corrupt(&mut data);
        assert_eq!(blob::decode(&framed(&data)), Err(expected), "{what}");
    }
    // A zero scale factor of a single axis.
    let mut data = CalibrationData::example_single();
    if let Sensor::Single { sets, .. } = &mut data.sensor {
        sets.as_mut_slice()[4].scale = 0.0;
    }
    assert_eq!(
        blob::decode(&framed(&data)),
        Err(Error::InvalidSingularMatrix {
            part: Part::Sensor,
            set: 4
        })
    );
}

#[test]
fn capacities_are_enforced_with_their_own_error() {
    // Sequences longer than the capacity, written with plain vectors of the same wire shape.
    #[derive(serde::Serialize)]
    struct Env {
        temperature_span: spincal::model::Span,
        voltage_span: spincal::model::Span,
        temperatures: Vec<f32>,
        voltages: Vec<f32>,
        temperature_model: spincal::model::TemperatureModel,
    }
    #[derive(serde::Serialize)]
    struct Data<'a> {
        identity: &'a spincal::model::Identity,
        environment: Env,
        sensor: &'a Sensor,
        noise: Option<u8>,
    }
    let base = CalibrationData::example_triad();
    let env = |t: usize, v: usize| Env {
        temperature_span: spincal::model::Span::new(-100.0, 100.0),
        voltage_span: spincal::model::Span::new(0.0, 100.0),
        temperatures: (0..t).map(|i| i as f32).collect(),
        voltages: (0..v).map(|i| i as f32).collect(),
        temperature_model: spincal::model::TemperatureModel::Table,
    };
    let blob_of = |environment| {
        frame(
            &postcard::to_allocvec(&Data {
                identity: &base.identity,
                environment,
                sensor: &base.sensor,
                noise: None,
            })
            .unwrap(),
        )
    };
    assert_eq!(
        blob::decode(&blob_of(env(17, 0))),
        Err(Error::InvalidCapacity {
            field: Field::TemperatureBreakpoint,
            capacity: 16
        })
    );
    assert_eq!(
        blob::decode(&blob_of(env(1, 9))),
        Err(Error::InvalidCapacity {
            field: Field::VoltageBreakpoint,
            capacity: 8
        })
    );
    // 17 coefficient sets.
    let mut data = CalibrationData::example_triad();
    if let Sensor::Triad { sets, .. } = &data.sensor {
        let many: Vec<_> = std::iter::repeat_n(sets[0], 17).collect();
        let bytes = postcard::to_allocvec(&data).unwrap();
        let one = postcard::to_allocvec(&sets[0]).unwrap();
        // The sets come last but for the covariance and noise tags (None, 0 each): replace
        // their length prefix (1) and the one set.
        assert_eq!(bytes.last(), Some(&0));
        let cut = bytes.len() - one.len() - 3;
        let mut payload = bytes[..cut].to_vec();
        payload.push(17);
        for s in &many {
            payload.extend_from_slice(&postcard::to_allocvec(s).unwrap());
        }
        payload.extend_from_slice(&[0, 0]);
        assert_eq!(
            blob::decode(&frame(&payload)),
            Err(Error::InvalidCapacity {
                field: Field::Sets,
                capacity: 16
            })
        );
    }
    // A 17-byte serial.
    data.identity.serial = Serial::new("0123456789ABCDEF").unwrap();
    let bytes = postcard::to_allocvec(&data).unwrap();
    let mut payload = vec![17u8];
    payload.extend_from_slice(b"0123456789ABCDEFG");
    payload.extend_from_slice(&bytes[17..]);
    assert_eq!(
        blob::decode(&frame(&payload)),
        Err(Error::InvalidCapacity {
            field: Field::Serial,
            capacity: 16
        })
    );
}

#[test]
fn the_largest_calibration_fits_and_the_framing_is_small() {
    // 16 temperature points, a full-length serial, covariance on both triads.
    let mut data = CalibrationData::example_imu();
    data.identity.serial = Serial::new("ABCDEFGHIJKLMNOP").unwrap();
    data.identity.created_unix_s = u64::MAX;
    data.identity.tool_version = [u16::MAX; 3];
    data.environment.temperatures =
        BoundedVec::from_slice(&(0..16).map(|i| -40.0 + 8.0 * i as f32).collect::<Vec<_>>())
            .unwrap();
    data.environment.temperature_span = spincal::model::Span::new(-40.0, 85.0);
    if let Sensor::Imu {
        sets,
        covariance: Some(cov),
        ..
    } = &mut data.sensor
    {
        let first = sets[0];
        *sets = BoundedVec::from_slice(&[first; 16]).unwrap();
        let first = cov[0];
        *cov = BoundedVec::from_slice(&[first; 16]).unwrap();
    }
    let cal = Calibration::new(data.clone()).unwrap();
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let n = blob::encode(&cal, &mut buf).unwrap();
    assert!(n <= MAX_BLOB_LEN);
    println!("largest calibration: {n} bytes");
    let floats = fields::floats(&mut data).len();
    // The 16-byte serial, the largest time and version add 28 bytes to the examples' framing.
    assert!(
        n - 4 * floats <= 73 + 28,
        "framing {} bytes",
        n - 4 * floats
    );
    // One byte short is refused, and nothing is claimed written.
    assert_eq!(
        blob::encode(&cal, &mut buf[..n - 1]),
        Err(Error::EncodeBufferTooSmall { available: n - 1 })
    );
    assert_eq!(
        blob::encode(&cal, &mut buf[..5]),
        Err(Error::EncodeBufferTooSmall { available: 5 })
    );
}

#[test]
fn framing_overhead_of_the_examples_is_at_most_73_bytes() {
    for (name, mut data) in examples() {
        let n = golden::encode(&data).len();
        let floats = fields::floats(&mut data).len();
        let overhead = n - 4 * floats;
        println!("{name}: {n} bytes, {floats} floats, {overhead} bytes over the raw payload");
        // 64 until the identity said whether the fit was rejected (one byte), 65 until each
        // of the IMU's rails stated its sample format (one byte each); a two's-complement
        // rail at -32768 takes three varint bytes where 0 takes one (71 for an i16 IMU), and
        // one more since the environment says how the sets follow the temperature, one more
        // since a calibration says whether it has noise terms.
        assert!(overhead <= 73, "{name}: {overhead}");
    }
}

fn perturbed(
    case: usize,
    factors: &[f32],
    serial: &str,
    time: u64,
    hash: [u8; 16],
) -> CalibrationData {
    let mut data = examples().swap_remove(case).1;
    for (f, k) in fields::floats(&mut data)
        .into_iter()
        .zip(factors.iter().cycle())
    {
        // Breakpoints and spans stay ordered; centers stay in their rails.
        if !matches!(
            f.field,
            Field::TemperatureSpan
                | Field::VoltageSpan
                | Field::TemperatureBreakpoint
                | Field::VoltageBreakpoint
                | Field::InputRange
                | Field::Gravity
        ) {
            *f.value *= 1.0 + k;
        }
    }
    data.identity.serial = Serial::new(serial).unwrap();
    data.identity.created_unix_s = time;
    data.identity.data_hash = hash;
    data
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn encode_decode_round_trips(
        case in 0usize..3,
        factors in proptest::collection::vec(-0.01f32..0.01, 1..50),
        serial in "[A-Za-z0-9 _-]{1,16}",
        time in any::<u64>(),
        hash in any::<[u8; 16]>(),
    ) {
        let data = perturbed(case, &factors, &serial, time, hash);
        let cal = Calibration::new(data.clone()).unwrap();
        let mut buf = vec![0u8; MAX_BLOB_LEN];
        let n = blob::encode(&cal, &mut buf).unwrap();
        let back = blob::decode(&buf[..n]).unwrap();
        prop_assert_eq!(back.data(), &data);
    }

    #[test]
    fn decoding_arbitrary_bytes_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = blob::decode(&bytes);
        // With a valid header and CRC, the bytes reach the payload decoder and validation.
        let _ = blob::decode(&frame(&bytes));
    }

    #[test]
    fn mutated_golden_payloads_never_panic(
        case in 0usize..3,
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
    ) {
        let good = golden::encode(&examples().swap_remove(case).1);
        let mut payload = good[HEADER_LEN..].to_vec();
        for (at, byte) in edits {
            let i = at % payload.len();
            payload[i] = byte;
        }
        if let Ok(cal) = blob::decode(&frame(&payload)) {
            // Whatever validates can be corrected without panicking.
            let mut runner = golden::Runner::new(&cal, golden::examples()[case].2);
            runner.set_environment(20.0, 3.3);
            let n = match case { 0 => 1, 1 => 3, _ => 6 };
            for code in [0, 1, 32_768, 65_535, i32::MIN, i32::MAX] {
                let (v, _, _) = runner.correct(&vec![code; n]);
                prop_assert!(v.iter().all(|x| x.is_finite()));
            }
        }
    }
}

#[test]
fn decode_in_reuses_one_slot_across_kinds_and_failures() {
    let mut slot = CalibrationData::empty();
    let blobs: Vec<(CalibrationData, Vec<u8>)> = examples()
        .into_iter()
        .map(|(_, d)| {
            let b = golden::encode(&d);
            (d, b)
        })
        .collect();
    for order in [[0, 1, 2], [2, 0, 1], [1, 2, 0], [2, 2, 1]] {
        for i in order {
            let (data, bytes) = &blobs[i];
            // A corrupt blob first: refused, and the next good one decodes fully anyway.
            let mut bad = bytes.clone();
            let last = bad.len() - 1;
            bad[last] ^= 1;
            assert!(blob::decode_in(&bad, &mut slot).is_err());
            let cal = blob::decode_in(bytes, &mut slot).unwrap();
            assert_eq!(cal.data(), data);
        }
    }
    // The placeholder itself does not validate.
    assert!(Calibration::validate_in_place(&CalibrationData::empty()).is_err());
}
