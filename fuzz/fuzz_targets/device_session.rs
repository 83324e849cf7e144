//! The device's protocol handler driven through whole sessions: the input is a program of
//! requests (identify, begin a transfer of one of the records, send the next chunk, possibly
//! damaged, commit, read back, run vectors, lock, or a raw garbage frame). The unit is an IMU:
//! the single-axis and triad blobs must be refused. The first byte chooses an unprovisioned
//! unit (even) or one provisioned with a station key (odd); the records are blobs and signed
//! blobs (growing counters, a downgrade, another station's key, another unit's serial). A model
//! tracks what a correct unit holds: the last record whose commit was answered `Committed`,
//! which must be one the unit's policy accepts. After every step the device holds exactly
//! that, read-back returns its bytes, and a reboot loads it again.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::blob;
use spincal::model::{Calibration, CalibrationData, Serial};
use spincal::protocol::{self, Device, MAX_CHUNK, MAX_FRAME, Request, Response};
use spincal::store::Store;
use spincal_fuzz::RamNor;

/// The unit's sensor: the IMU examples' (the single-axis and triad blobs are refused).
const IMU: protocol::UnitSensor = protocol::UnitSensor::Imu {
    accel_rails: spincal::model::Rails::unsigned(16),
    gyro_rails: spincal::model::Rails::unsigned(16),
};

const SLOT: u32 = 16 * 1024;

fn encode(data: CalibrationData) -> Vec<u8> {
    let cal = Calibration::new(data).expect("example validates");
    let mut out = vec![0u8; blob::MAX_BLOB_LEN];
    let n = blob::encode(&cal, &mut out).expect("encodes");
    out.truncate(n);
    out
}

/// A record offered to the unit: its bytes, and what a provisioned unit makes of it.
struct Offer {
    bytes: Vec<u8>,
    /// An IMU calibration (the unit's sensor).
    imu: bool,
    /// Signed by the unit's station for the unit: its counter and whether a downgrade.
    signed: Option<(u32, bool)>,
}

fn offers() -> Vec<Offer> {
    let (key, _) = spincal_fuzz::station();
    let other = ed25519_dalek::SigningKey::from_bytes(&[3; 32]);
    let mut imu = CalibrationData::example_imu();
    imu.identity.serial = Serial::new("FUZZ-1").expect("serial");
    let mut stranger = imu.clone();
    stranger.identity.serial = Serial::new("OTHER-9").expect("serial");
    let imu = encode(imu);
    let stranger = encode(stranger);
    let plain = |bytes: Vec<u8>, imu: bool| Offer {
        bytes,
        imu,
        signed: None,
    };
    let signed = |counter: u32, downgrade: bool| Offer {
        bytes: spincal_fuzz::sign(&imu, &key, counter, downgrade),
        imu: true,
        signed: Some((counter, downgrade)),
    };
    vec![
        plain(encode(CalibrationData::example_single()), false),
        plain(encode(CalibrationData::example_triad()), false),
        plain(imu.clone(), true),
        signed(1, false),
        signed(2, false),
        signed(4, false),
        signed(2, true),
        // Another station's key; another unit's serial.
        plain(spincal_fuzz::sign(&imu, &other, 9, false), true),
        plain(spincal_fuzz::sign(&stranger, &key, 9, false), true),
    ]
}

/// Whether the unit commits `o`, holding `held` (the record's index) under its policy.
fn accepts(offers: &[Offer], k: usize, provisioned: bool, held: Option<usize>) -> bool {
    let o = &offers[k];
    if !o.imu {
        return false;
    }
    if !provisioned {
        return true;
    }
    let counter = held.and_then(|h| offers[h].signed).map_or(0, |(c, _)| c);
    match o.signed {
        None => false,
        _ if held == Some(k) => true,
        Some((c, true)) => c == counter,
        Some((c, false)) => c > counter,
    }
}

fn call(d: &mut Device<RamNor>, req: &Request) -> Response {
    let mut frame = [0u8; MAX_FRAME];
    let n = protocol::encode(req, &mut frame).expect("a request frames");
    raw(d, &frame[..n - 1])
}

fn raw(d: &mut Device<RamNor>, frame: &[u8]) -> Response {
    let mut out = [0u8; MAX_FRAME];
    let n = d.handle_frame(frame, &mut out);
    assert!(n > 0 && out[n - 1] == 0);
    let mut s = [0u8; MAX_FRAME];
    let reply: protocol::Reply =
        protocol::decode(&out[..n - 1], &mut s).expect("the reply decodes");
    assert_eq!(reply.trust, d.trust());
    reply.response
}

fn held(d: &Device<RamNor>) -> Option<CalibrationData> {
    d.calibration().map(|c| c.data().clone())
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, data)) = data.split_first() else {
        return;
    };
    let offers = offers();
    let blobs: Vec<&[u8]> = offers.iter().map(|o| o.bytes.as_slice()).collect();
    let provisioned = mode & 1 == 1;
    let mut store = Store::new(
        RamNor {
            mem: vec![0xff; Store::<RamNor>::region_len(SLOT, 1024) as usize],
        },
        0,
        SLOT,
    )
    .expect("layout");
    if provisioned {
        store
            .provision(&[spincal_fuzz::station().1])
            .expect("a RAM flash provisions");
    }
    let mut d = Box::new(Device::new(
        store,
        Serial::new("FUZZ-1").expect("serial"),
        IMU,
        [0, 1, 0],
    ));
    let mut expected: Option<usize> = None;
    let mut transfer: Option<(usize, usize)> = None; // (blob, next offset)
    let mut locked = false;
    let mut it = data.iter().copied();
    while let Some(op) = it.next() {
        let mut arg = || it.next().unwrap_or(0);
        match op % 8 {
            0 => {
                let Response::Identity(id) = call(&mut d, &Request::Identify) else {
                    panic!("identify")
                };
                assert_eq!(id.locked, locked);
                assert_eq!(id.blob_len as usize, expected.map_or(0, |k| blobs[k].len()));
                assert_eq!(id.trust == protocol::Trust::Provisioned, provisioned);
                let counter = expected.map_or(0, |k| {
                    spincal::signed::parts(blobs[k]).1.map_or(0, |t| t.counter)
                });
                assert_eq!(id.counter, counter);
            }
            1 => {
                let k = usize::from(arg()) % blobs.len();
                let damage = arg();
                let crc = protocol::checksum(blobs[k]) ^ u32::from(damage == 0xAA);
                let r = call(
                    &mut d,
                    &Request::WriteBegin {
                        len: blobs[k].len() as u32,
                        crc,
                    },
                );
                if r == Response::Ready {
                    transfer = (damage != 0xAA).then_some((k, 0));
                } else {
                    assert!(locked || damage == 0xAA, "{r:?}");
                    transfer = None;
                }
            }
            2 => {
                let skew = arg();
                if let Some((k, at)) = transfer {
                    let b = blobs[k];
                    let end = (at + MAX_CHUNK).min(b.len());
                    let mut chunk = b[at..end].to_vec();
                    let offset = if skew == 0x55 { at + 1 } else { at };
                    let damaged = skew == 0x66 && !chunk.is_empty();
                    if damaged {
                        chunk[0] ^= 1;
                    }
                    let r = call(
                        &mut d,
                        &Request::WriteChunk {
                            offset: offset as u32,
                            data: heapless::Vec::from_slice(&chunk).expect("chunk"),
                        },
                    );
                    match r {
                        Response::ChunkOk { .. } if damaged => transfer = None, // the blob is damaged: its CRC will fail
                        Response::ChunkOk { .. } => transfer = Some((k, end)),
                        _ => assert!(skew == 0x55 || at >= b.len(), "{r:?}"),
                    }
                }
            }
            3 => {
                let r = call(&mut d, &Request::Commit);
                match (transfer, r) {
                    (Some((k, at)), Response::Committed { .. }) => {
                        assert_eq!(at, blobs[k].len());
                        assert!(
                            accepts(&offers, k, provisioned, expected),
                            "committed record {k} (provisioned: {provisioned}, holding {expected:?})"
                        );
                        expected = Some(k);
                    }
                    (_, Response::Committed { .. }) => {
                        panic!("committed an incomplete or damaged transfer")
                    }
                    (Some((k, at)), r) => assert!(
                        at < blobs[k].len()
                            || locked
                            || (!accepts(&offers, k, provisioned, expected)
                                && matches!(
                                    r,
                                    Response::Error(
                                        protocol::Status::WrongSensor { .. }
                                            | protocol::Status::Refused(_)
                                    )
                                )),
                        "record {k}: {r:?}"
                    ),
                    _ => {}
                }
                transfer = None;
            }
            4 => {
                let (offset, len) = (u32::from(arg()) * 37, u16::from(arg()) * 3);
                match (call(&mut d, &Request::ReadBlob { offset, len }), expected) {
                    (Response::Blob { data, .. }, Some(k)) => {
                        let o = offset as usize;
                        assert_eq!(&data[..], &blobs[k][o..o + data.len()]);
                    }
                    (Response::Blob { .. }, None) => panic!("read a blob from an empty unit"),
                    _ => {}
                }
            }
            5 => {
                let raw: Vec<[i32; 6]> = (0..usize::from(arg() % 17))
                    .map(|i| [i as i32 * 977 + i32::from(arg()) * 131; 6])
                    .collect();
                let t = f32::from(arg()) - 60.0;
                let r = call(
                    &mut d,
                    &Request::RunVectors {
                        temperature: t,
                        voltage: 3.3,
                        raw: heapless::Vec::from_slice(&raw).expect("16 at most"),
                    },
                );
                if expected.is_some() {
                    assert!(matches!(r, Response::Vectors { .. }), "{r:?}");
                }
            }
            6 => {
                if arg() == 0x77 {
                    assert_eq!(call(&mut d, &Request::Lock), Response::LockedOk);
                    locked = true;
                    transfer = None;
                }
            }
            _ => {
                let n = usize::from(arg() % 64);
                let frame: Vec<u8> = (0..n).map(|_| arg()).filter(|b| *b != 0).collect();
                if !matches!(raw(&mut d, &frame), Response::Error(_)) {
                    // A garbage frame that happens to be a valid request: the model no longer knows.
                    return;
                }
            }
        }
        assert_eq!(
            held(&d),
            expected.map(|k| {
                blob::decode(spincal::signed::parts(blobs[k]).0)
                    .expect("blob")
                    .data()
                    .clone()
            })
        );
    }
    // A reboot loads the same.
    let expect = held(&d);
    let flash = d.into_store().into_inner();
    let d = Box::new(Device::new(
        Store::new(flash, 0, SLOT).expect("layout"),
        Serial::new("FUZZ-1").expect("serial"),
        IMU,
        [0, 1, 0],
    ));
    assert_eq!(held(&d), expect);
});
