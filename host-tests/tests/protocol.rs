//! The update protocol against the device's handler over a simulated flash: a whole update,
//! read-back, test vectors bit-identical to the host's correction, and refusals that change
//! nothing (corrupt, truncated and unknown frames, out-of-order chunks, bad CRC, invalid blob,
//! a locked unit).

use host_tests::golden;
use host_tests::nor::SimFlash;
use spincal::model::{Calibration, CalibrationData, Serial};
use spincal::protocol::{self, Device, MAX_CHUNK, MAX_FRAME, Request, Response, Status};
use spincal::store::{SlotState, Store};

type Flash = SimFlash<4, 1024>;

fn device() -> Device<Flash> {
    let store = Store::new(
        host_tests::tcp_unit::blank_flash(),
        0,
        host_tests::tcp_unit::SLOT,
    )
    .unwrap();
    Device::new(
        store,
        Serial::new("UNIT-1").unwrap(),
        host_tests::tcp_unit::IMU_16_BIT,
        [0, 1, 0],
    )
}

/// Sends a request through the frame encoder and the device's frame handler.
fn call(d: &mut Device<Flash>, req: &Request) -> Response {
    let mut frame = [0u8; MAX_FRAME];
    let n = protocol::encode(req, &mut frame).unwrap();
    raw_call(d, &frame[..n - 1])
}

fn raw_call(d: &mut Device<Flash>, frame: &[u8]) -> Response {
    let mut out = [0u8; MAX_FRAME];
    let n = d.handle_frame(frame, &mut out);
    assert!(n > 0 && out[n - 1] == 0);
    let mut scratch = [0u8; MAX_FRAME];
    let reply: protocol::Reply = protocol::decode(&out[..n - 1], &mut scratch).unwrap();
    assert_eq!(
        reply.trust,
        d.trust(),
        "every answer says whether the unit checks signatures"
    );
    reply.response
}

fn crc(b: &[u8]) -> u32 {
    crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(b)
}

fn write(d: &mut Device<Flash>, blob: &[u8]) -> Response {
    assert_eq!(
        call(
            d,
            &Request::WriteBegin {
                len: blob.len() as u32,
                crc: crc(blob)
            }
        ),
        Response::Ready
    );
    for (k, chunk) in blob.chunks(MAX_CHUNK).enumerate() {
        let r = call(
            d,
            &Request::WriteChunk {
                offset: (k * MAX_CHUNK) as u32,
                data: heapless::Vec::from_slice(chunk).unwrap(),
            },
        );
        assert!(matches!(r, Response::ChunkOk { .. }), "{r:?}");
    }
    call(d, &Request::Commit)
}

fn identity(d: &mut Device<Flash>) -> protocol::Identity {
    match call(d, &Request::Identify) {
        Response::Identity(i) => i,
        r => panic!("{r:?}"),
    }
}

fn read_back(d: &mut Device<Flash>, len: usize) -> Vec<u8> {
    let mut out = Vec::new();
    while out.len() < len {
        let n = (len - out.len()).min(MAX_CHUNK) as u16;
        match call(
            d,
            &Request::ReadBlob {
                offset: out.len() as u32,
                len: n,
            },
        ) {
            Response::Blob { data, .. } => out.extend_from_slice(&data),
            r => panic!("{r:?}"),
        }
    }
    out
}

#[test]
fn update_read_back_and_vectors() {
    let mut d = device();
    let id = identity(&mut d);
    assert_eq!(
        (id.calibration, id.locked, id.unit.as_str()),
        (None, false, "UNIT-1")
    );
    assert_eq!(id.slots, [SlotState::Empty; 2].map(|_| SlotState::Invalid));
    let blob = golden::encode(&CalibrationData::example_imu());
    assert_eq!(
        write(&mut d, &blob),
        Response::Committed { seq: 1, counter: 0 }
    );
    let id = identity(&mut d);
    assert_eq!(id.calibration.unwrap().as_str(), "IMU-FULL-0042");
    assert_eq!(id.blob_len as usize, blob.len());
    assert!(matches!(id.slots[0], SlotState::Valid { seq: 1, .. }));
    assert_eq!(read_back(&mut d, blob.len()), blob);
    // Test vectors: the device's outputs are the host's, bit for bit.
    let raw: Vec<[i32; 6]> = (0..16)
        .map(|i| std::array::from_fn(|a| 31_000 + i * 311 + a as i32 * 977))
        .collect();
    let resp = call(
        &mut d,
        &Request::RunVectors {
            temperature: 31.5,
            voltage: 3.3,
            raw: heapless::Vec::from_slice(&raw).unwrap(),
        },
    );
    let Response::Vectors { out } = resp else {
        panic!("{resp:?}")
    };
    let cal = Calibration::new(CalibrationData::example_imu()).unwrap();
    let mut host =
        spincal::correct::AnyImuCorrector::new(&cal, protocol::vector_rate_hz()).unwrap();
    host.set_environment(31.5, 3.3);
    for (r, (v, f)) in raw.iter().zip(&out) {
        let h = host.correct(*r);
        assert_eq!(h.values.map(f32::to_bits), v.map(f32::to_bits));
        assert_eq!(h.flags.bits(), *f);
    }
    // A second update goes to the other slot.
    let blob2 = golden::encode(&CalibrationData::example_imu_polynomial());
    assert_eq!(
        write(&mut d, &blob2),
        Response::Committed { seq: 2, counter: 0 }
    );
    assert_eq!(
        identity(&mut d).calibration.unwrap().as_str(),
        "IMU-POLY-0042"
    );
}

#[test]
fn a_blob_for_another_sensor_is_never_committed() {
    let mut d = device();
    let good = golden::encode(&CalibrationData::example_imu());
    assert_eq!(
        write(&mut d, &good),
        Response::Committed { seq: 1, counter: 0 }
    );
    let before = identity(&mut d);
    assert_eq!(before.sensor, host_tests::tcp_unit::IMU_16_BIT);
    // A triad, a single axis, an IMU of 18-bit converters and one whose codes come as i16.
    let mut other_rails = CalibrationData::example_imu_linear();
    if let spincal::model::Sensor::Imu {
        accel_rails,
        gyro_rails,
        ..
    } = &mut other_rails.sensor
    {
        *accel_rails = spincal::model::Rails::unsigned(18);
        *gyro_rails = spincal::model::Rails::unsigned(18);
    }
    for data in [
        CalibrationData::example_triad(),
        CalibrationData::example_single(),
        other_rails,
        golden::in_format(
            CalibrationData::example_imu_linear(),
            spincal::model::SampleFormat::I16,
        ),
    ] {
        let kind = protocol::UnitSensor::of(&data);
        assert_eq!(
            write(&mut d, &golden::encode(&data)),
            Response::Error(Status::WrongSensor { blob: kind })
        );
        assert_eq!(identity(&mut d), before, "{kind}");
    }
}

#[test]
fn refusals_change_nothing() {
    let mut d = device();
    let old = golden::encode(&CalibrationData::example_imu_linear());
    assert_eq!(
        write(&mut d, &old),
        Response::Committed { seq: 1, counter: 0 }
    );
    let before = identity(&mut d);
    let new = golden::encode(&CalibrationData::example_imu_polynomial());

    // Corrupt, truncated and unknown frames.
    let mut frame = [0u8; MAX_FRAME];
    let n = protocol::encode(
        &Request::WriteBegin {
            len: new.len() as u32,
            crc: crc(&new),
        },
        &mut frame,
    )
    .unwrap();
    let mut bad = frame[..n - 1].to_vec();
    bad[2] ^= 0x40;
    assert_eq!(raw_call(&mut d, &bad), Response::Error(Status::BadFrame));
    assert_eq!(
        raw_call(&mut d, &frame[..n / 2]),
        Response::Error(Status::BadFrame)
    );
    assert_eq!(raw_call(&mut d, &[]), Response::Error(Status::BadFrame));
    let unknown = {
        // Variant 42 of the request enum, with a good CRC.
        let body = [42u8];
        let mut raw = body.to_vec();
        raw.extend_from_slice(&crc(&body).to_le_bytes());
        let mut out = [0u8; 16];
        let k = cobs::encode(&raw, &mut out);
        out[..k].to_vec()
    };
    assert_eq!(
        raw_call(&mut d, &unknown),
        Response::Error(Status::UnknownRequest)
    );
    let malformed = {
        let body = [2u8, 0xff];
        let mut raw = body.to_vec();
        raw.extend_from_slice(&crc(&body).to_le_bytes());
        let mut out = [0u8; 16];
        let k = cobs::encode(&raw, &mut out);
        out[..k].to_vec()
    };
    assert_eq!(
        raw_call(&mut d, &malformed),
        Response::Error(Status::Malformed)
    );

    // Protocol misuse.
    assert_eq!(
        call(&mut d, &Request::Commit),
        Response::Error(Status::NoTransfer)
    );
    assert_eq!(
        call(
            &mut d,
            &Request::WriteChunk {
                offset: 0,
                data: heapless::Vec::from_slice(&new[..10]).unwrap()
            }
        ),
        Response::Error(Status::NoTransfer)
    );
    assert_eq!(
        call(
            &mut d,
            &Request::WriteBegin {
                len: 1_000_000,
                crc: 0
            }
        ),
        Response::Error(Status::TooLarge)
    );
    assert_eq!(
        call(
            &mut d,
            &Request::WriteBegin {
                len: new.len() as u32,
                crc: crc(&new)
            }
        ),
        Response::Ready
    );
    assert_eq!(
        call(
            &mut d,
            &Request::WriteChunk {
                offset: 5,
                data: heapless::Vec::from_slice(&new[5..10]).unwrap()
            }
        ),
        Response::Error(Status::OutOfOrder)
    );
    assert_eq!(
        call(&mut d, &Request::Commit),
        Response::Error(Status::OutOfOrder)
    );
    // A wrong CRC, then an invalid blob with a right one.
    assert_eq!(
        call(
            &mut d,
            &Request::WriteBegin {
                len: new.len() as u32,
                crc: crc(&new) ^ 1
            }
        ),
        Response::Ready
    );
    for (k, chunk) in new.chunks(MAX_CHUNK).enumerate() {
        call(
            &mut d,
            &Request::WriteChunk {
                offset: (k * MAX_CHUNK) as u32,
                data: heapless::Vec::from_slice(chunk).unwrap(),
            },
        );
    }
    assert_eq!(
        call(&mut d, &Request::Commit),
        Response::Error(Status::CrcMismatch)
    );
    let mut invalid = new.clone();
    invalid[30] ^= 1;
    let r = write(&mut d, &invalid);
    assert!(
        matches!(
            r,
            Response::Error(Status::InvalidBlob(spincal::Error::ChecksumMismatch { .. }))
        ),
        "{r:?}"
    );
    // A transfer never committed.
    assert_eq!(
        call(
            &mut d,
            &Request::WriteBegin {
                len: new.len() as u32,
                crc: crc(&new)
            }
        ),
        Response::Ready
    );
    assert_eq!(identity(&mut d), before, "nothing changed");
    assert_eq!(read_back(&mut d, old.len()), old);

    // Locked: writes refused, the calibration kept.
    assert_eq!(call(&mut d, &Request::Lock), Response::LockedOk);
    assert!(identity(&mut d).locked);
    assert_eq!(
        call(
            &mut d,
            &Request::WriteBegin {
                len: new.len() as u32,
                crc: crc(&new)
            }
        ),
        Response::Error(Status::Locked)
    );
    assert_eq!(read_back(&mut d, old.len()), old);
    assert_eq!(
        call(
            &mut d,
            &Request::ReadBlob {
                offset: old.len() as u32 - 2,
                len: 10
            }
        ),
        Response::Error(Status::OutOfRange)
    );
}

#[test]
fn a_new_unit_answers_without_a_calibration() {
    let mut d = device();
    let r = call(
        &mut d,
        &Request::RunVectors {
            temperature: 25.0,
            voltage: 3.3,
            raw: heapless::Vec::new(),
        },
    );
    assert_eq!(r, Response::Error(Status::NoCalibration));
    assert_eq!(
        call(&mut d, &Request::ReadBlob { offset: 0, len: 4 }),
        Response::Error(Status::NoCalibration)
    );
}

/// A tagged request's reply carries its id (a client tells its answer from a late one meant
/// for another request); an untagged request's reply is untagged, as before; a frame with
/// anything after the message but one id is refused as malformed and gets an untagged reply.
#[test]
fn a_reply_carries_its_requests_id() {
    let mut d = device();
    let ask = |d: &mut Device<Flash>, frame: &[u8]| {
        let mut out = [0u8; MAX_FRAME];
        let n = d.handle_frame(frame, &mut out);
        let mut scratch = [0u8; MAX_FRAME];
        let (reply, id): (protocol::Reply, _) =
            protocol::decode_tagged(&out[..n - 1], &mut scratch).unwrap();
        (reply.response, id)
    };
    let mut frame = [0u8; MAX_FRAME];
    let n = protocol::encode_tagged(&Request::Identify, 0xBEEF, &mut frame).unwrap();
    let (response, id) = ask(&mut d, &frame[..n - 1]);
    assert!(matches!(response, Response::Identity(_)), "{response:?}");
    assert_eq!(id, Some(0xBEEF));
    let n = protocol::encode(&Request::Identify, &mut frame).unwrap();
    let (response, id) = ask(&mut d, &frame[..n - 1]);
    assert!(matches!(response, Response::Identity(_)));
    assert_eq!(id, None);
    // Two ids: malformed, untagged.
    let mut raw = postcard::to_allocvec(&Request::Identify).unwrap();
    raw.extend(postcard::to_allocvec(&7u16).unwrap());
    raw.extend(postcard::to_allocvec(&8u16).unwrap());
    raw.extend(crc(&raw).to_le_bytes());
    let framed = cobs::encode_vec(&raw);
    let (response, id) = ask(&mut d, &framed);
    assert_eq!(response, Response::Error(Status::Malformed));
    assert_eq!(id, None);
}
