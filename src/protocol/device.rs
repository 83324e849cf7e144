//! The device's side of the update protocol: requests in, responses out, over a [`Store`].

use embedded_storage::nor_flash::NorFlash;

use super::{
    FrameError, Identity, MAX_CHUNK, MAX_FRAME, PROTOCOL_VERSION, Reply, Request, Response, Status,
    Trust, UnitSensor,
};
use crate::blob;
use crate::correct::{AnyAxisCorrector, AnyImuCorrector, AnyTriadCorrector, Overlay};
use crate::health::RestMonitor;
use crate::model::{Calibration, CalibrationData, Sensor, Serial};
use crate::signed::{self, MAX_SIGNED_LEN, SignError};
use crate::store::{Provisioning, SlotInfo, Store, StoreError};

/// Bytes of the buffer the store needs (a signed record padded to any write size).
pub const SLOT_BUFFER: usize = MAX_SIGNED_LEN + 16;

/// Sample rate assumed for the IMU's lever-arm derivative in test vectors, Hz.
const VECTOR_RATE_HZ: f32 = 1000.0;

/// The device: its store, the validated RAM copy of the current calibration, and the state of
/// a transfer. About 75 KB: keep it in a `static`.
#[derive(Debug)]
pub struct Device<F> {
    store: Store<F>,
    /// The station keys, read once at power-on (the keys sector is written once, at
    /// manufacture).
    provisioning: Provisioning,
    /// Why no slot was trusted at the last load, when one was refused for its signature.
    refused: Option<SignError>,
    unit: Serial,
    sensor: UnitSensor,
    firmware: [u16; 3],
    cal: CalibrationData,
    loaded: Option<SlotInfo>,
    scratch: CalibrationData,
    rx: [u8; MAX_SIGNED_LEN],
    transfer: Option<(u32, u32)>,
    next: u32,
    buf: [u8; SLOT_BUFFER],
    frame: [u8; MAX_FRAME],
    /// The health check of the running stream (in RAM only: a power cut or a new calibration
    /// starts it afresh, and it never touches the store).
    health: Health,
    /// The flight filter's last snapshot, as the firmware's flight loop published it.
    flight: Option<crate::flight::FlightReport>,
}

/// The running IMU stream's health check and what it gave the corrector: the corrector
/// borrows the calibration, so it is rebuilt per request with this state.
#[derive(Debug, Default)]
struct Health {
    monitor: Option<RestMonitor>,
    overlay: Option<Overlay>,
    suspect: bool,
}

impl<F: NorFlash> Device<F> {
    /// A device over `store` for the unit `unit` carrying `sensor` (it commits only
    /// calibrations of that sensor), reading its station keys and loading the current
    /// calibration (if any; a provisioned unit only one signed for it by a held key). A keys
    /// sector that cannot be read counts as damaged: the unit trusts no key.
    pub fn new(mut store: Store<F>, unit: Serial, sensor: UnitSensor, firmware: [u16; 3]) -> Self {
        let provisioning = store.provisioning().unwrap_or(Provisioning::Damaged);
        let mut d = Self {
            store,
            provisioning,
            refused: None,
            unit,
            sensor,
            firmware,
            cal: CalibrationData::empty(),
            loaded: None,
            scratch: CalibrationData::empty(),
            rx: [0; MAX_SIGNED_LEN],
            transfer: None,
            next: 0,
            buf: [0; SLOT_BUFFER],
            frame: [0; MAX_FRAME],
            health: Health::default(),
            flight: None,
        };
        d.reload();
        d
    }

    fn reload(&mut self) {
        let policy = self.provisioning.policy(&self.unit);
        let loaded = self.store.load(&mut self.buf, &mut self.cal, policy);
        self.refused = match loaded {
            Err(StoreError::Refused(why)) => Some(why),
            _ => None,
        };
        self.loaded = loaded.ok().map(|(_, info)| info);
        // A new calibration is judged afresh.
        self.health = Health::default();
    }

    /// The current calibration (the validated RAM copy), if any.
    pub fn calibration(&self) -> Option<&Calibration> {
        self.loaded?;
        Calibration::validate_in_place(&self.cal).ok()
    }

    /// The store, giving up the device (to inspect the flash after a session).
    pub fn into_store(self) -> Store<F> {
        self.store
    }

    /// The unit's serial.
    pub const fn unit(&self) -> &Serial {
        &self.unit
    }

    /// Whether the unit checks signatures (every answer says so).
    pub const fn trust(&self) -> Trust {
        match self.provisioning {
            Provisioning::Unprovisioned => Trust::Unprovisioned,
            Provisioning::Provisioned(_) => Trust::Provisioned,
            Provisioning::Damaged => Trust::KeysDamaged,
        }
    }

    /// The station keys the unit holds.
    pub fn provisioning(&self) -> &Provisioning {
        &self.provisioning
    }

    /// The current calibration's slot (its sequence number, record length, counter and
    /// signing key), if one is loaded.
    pub const fn loaded(&self) -> Option<SlotInfo> {
        self.loaded
    }

    /// Why the unit booted with no calibration although a slot holds one: its signature,
    /// key, serial (or none) was refused.
    pub const fn refused(&self) -> Option<SignError> {
        self.refused
    }

    /// Handles one frame (without its terminator) and writes the response frame into `out`;
    /// returns its length (0 if `out` is too small for it).
    pub fn handle_frame(&mut self, frame: &[u8], out: &mut [u8]) -> usize {
        let (response, id) = match super::decode_tagged::<Request>(frame, &mut self.frame) {
            Ok((req, id)) => (self.handle(req), id),
            Err(FrameError::Message) if super::unknown_request(frame, &mut self.frame) => {
                (Response::Error(Status::UnknownRequest), None)
            }
            Err(FrameError::Message) => (Response::Error(Status::Malformed), None),
            Err(_) => (Response::Error(Status::BadFrame), None),
        };
        let reply = Reply {
            trust: self.trust(),
            response,
        };
        // The reply carries the request's id, when it had one.
        match id {
            Some(id) => super::encode_tagged(&reply, id, out).unwrap_or(0),
            None => super::encode(&reply, out).unwrap_or(0),
        }
    }

    /// Handles one request.
    pub fn handle(&mut self, req: Request) -> Response {
        match req {
            Request::Identify => self.identify(),
            Request::ReadBlob { offset, len } => self.read_blob(offset, len),
            Request::WriteBegin { len, crc } => self.begin(len, crc),
            Request::WriteChunk { offset, data } => self.chunk(offset, &data),
            Request::Commit => self.commit(),
            Request::RunVectors {
                temperature,
                voltage,
                raw,
            } => self.vectors(temperature, voltage, &raw),
            Request::Lock => match self.store.lock() {
                Ok(()) => Response::LockedOk,
                Err(_) => Response::Error(Status::StoreFailed),
            },
            Request::ObserveRest {
                temperature,
                voltage,
                raw,
            } => self.observe_rest(temperature, voltage, &raw),
            Request::ReadHealth => self.read_health(),
            Request::ReadFlight => Response::Flight(self.flight),
        }
    }

    /// Publishes the flight filter's snapshot for [`Request::ReadFlight`] (the firmware's
    /// flight loop calls this as often as it likes; the last one is answered).
    pub fn publish_flight(&mut self, report: crate::flight::FlightReport) {
        self.flight = Some(report);
    }

    fn observe_rest(&mut self, temperature: f32, voltage: f32, raw: &[[i32; 6]]) -> Response {
        let (cal, monitor) = match health_check(&self.cal, self.loaded, &mut self.health.monitor) {
            Ok(both) => both,
            Err(status) => return Response::Error(status),
        };
        let Ok(mut c) = AnyImuCorrector::new(cal, VECTOR_RATE_HZ) else {
            return Response::Error(Status::NoCalibration);
        };
        c.set_overlay(self.health.overlay);
        c.set_suspect(self.health.suspect);
        c.set_environment(temperature, voltage);
        let mut out = heapless::Vec::new();
        for r in raw {
            let o = c.correct(*r);
            c.observe_rest(monitor, &o);
            let _ = out.push((o.values, o.flags.bits()));
        }
        self.health.overlay = c.overlay();
        self.health.suspect = monitor.health().verdict == crate::health::Verdict::Suspect;
        Response::Vectors { out }
    }

    fn read_health(&mut self) -> Response {
        match health_check(&self.cal, self.loaded, &mut self.health.monitor) {
            Ok((_, m)) => Response::Health(m.health()),
            Err(status) => Response::Error(status),
        }
    }

    fn identify(&mut self) -> Response {
        let policy = self.provisioning.policy(&self.unit);
        let slots = self.store.scan(&mut self.buf, &mut self.scratch, policy);
        let locked = self.store.is_locked();
        let (Ok(slots), Ok(locked)) = (slots, locked) else {
            return Response::Error(Status::StoreFailed);
        };
        Response::Identity(Identity {
            unit: self.unit.clone(),
            sensor: self.sensor,
            firmware: self.firmware,
            format: blob::FORMAT_VERSION,
            protocol: PROTOCOL_VERSION,
            slots,
            calibration: self.loaded.map(|_| self.cal.identity.serial.clone()),
            blob_len: self.loaded.map_or(0, |i| i.len),
            locked,
            capacity: self.store.capacity() as u32,
            trust: self.trust(),
            station_keys: self
                .provisioning
                .keys()
                .iter()
                .map(crate::signed::StationKey::id)
                .collect(),
            counter: self.loaded.map_or(0, |i| i.counter),
            signed_by: self.loaded.and_then(|i| i.signed_by),
            refused: self.refused,
        })
    }

    fn read_blob(&mut self, offset: u32, len: u16) -> Response {
        let Some(info) = self.loaded else {
            return Response::Error(Status::NoCalibration);
        };
        let end = u64::from(offset) + u64::from(len);
        if usize::from(len) > MAX_CHUNK || end > u64::from(info.len) {
            return Response::Error(Status::OutOfRange);
        }
        let mut data = heapless::Vec::<u8, MAX_CHUNK>::new();
        if data.resize(usize::from(len), 0).is_err() {
            return Response::Error(Status::OutOfRange);
        }
        match self.store.read_slot(&info, offset, &mut data) {
            Ok(()) => Response::Blob { offset, data },
            Err(_) => Response::Error(Status::StoreFailed),
        }
    }

    fn begin(&mut self, len: u32, crc: u32) -> Response {
        match self.store.is_locked() {
            Ok(true) => return Response::Error(Status::Locked),
            Ok(false) => {}
            Err(_) => return Response::Error(Status::StoreFailed),
        }
        if len as usize > MAX_SIGNED_LEN || len as usize > self.store.capacity() || len == 0 {
            return Response::Error(Status::TooLarge);
        }
        self.transfer = Some((len, crc));
        self.next = 0;
        Response::Ready
    }

    fn chunk(&mut self, offset: u32, data: &[u8]) -> Response {
        let Some((len, _)) = self.transfer else {
            return Response::Error(Status::NoTransfer);
        };
        let end = offset as usize + data.len();
        if offset != self.next || end > len as usize {
            return Response::Error(Status::OutOfOrder);
        }
        match self.rx.get_mut(offset as usize..end) {
            Some(dst) => dst.copy_from_slice(data),
            None => return Response::Error(Status::OutOfOrder),
        }
        self.next = end as u32;
        Response::ChunkOk { next: self.next }
    }

    fn commit(&mut self) -> Response {
        let Some((len, crc)) = self.transfer.take() else {
            return Response::Error(Status::NoTransfer);
        };
        if self.next != len {
            return Response::Error(Status::OutOfOrder);
        }
        let record = self.rx.get(..len as usize).unwrap_or_default();
        if super::checksum(record) != crc {
            return Response::Error(Status::CrcMismatch);
        }
        // A calibration for another sensor never reaches the store.
        match blob::decode_in(signed::parts(record).0, &mut self.scratch) {
            Ok(cal) => {
                let kind = UnitSensor::of(cal.data());
                if kind != self.sensor {
                    return Response::Error(Status::WrongSensor { blob: kind });
                }
            }
            Err(e) => return Response::Error(Status::InvalidBlob(e)),
        }
        let policy = self.provisioning.policy(&self.unit);
        match self
            .store
            .update(record, &mut self.buf, &mut self.scratch, policy)
        {
            Ok(info) => {
                self.reload();
                Response::Committed {
                    seq: info.seq,
                    counter: info.counter,
                }
            }
            Err(StoreError::InvalidBlob(e)) => Response::Error(Status::InvalidBlob(e)),
            Err(StoreError::Refused(why)) => Response::Error(Status::Refused(why)),
            Err(StoreError::Locked) => Response::Error(Status::Locked),
            Err(StoreError::BlobTooLarge { .. }) => Response::Error(Status::TooLarge),
            Err(_) => {
                // Whatever the store managed, the RAM copy is reloaded from what is committed.
                self.reload();
                Response::Error(Status::StoreFailed)
            }
        }
    }

    fn vectors(&mut self, temperature: f32, voltage: f32, raw: &[[i32; 6]]) -> Response {
        let Some(cal) = self.calibration() else {
            return Response::Error(Status::NoCalibration);
        };
        let mut out = heapless::Vec::new();
        match &cal.data().sensor {
            Sensor::Single { .. } => {
                let Ok(mut c) = AnyAxisCorrector::new(cal) else {
                    return Response::Error(Status::NoCalibration);
                };
                c.set_environment(temperature, voltage);
                for r in raw {
                    let o = c.correct(r[0]);
                    let [v] = o.values;
                    let _ = out.push(([v, 0.0, 0.0, 0.0, 0.0, 0.0], o.flags.bits()));
                }
            }
            Sensor::Triad { .. } => {
                let Ok(mut c) = AnyTriadCorrector::new(cal) else {
                    return Response::Error(Status::NoCalibration);
                };
                c.set_environment(temperature, voltage);
                for r in raw {
                    let o = c.correct([r[0], r[1], r[2]]);
                    let [a, b, d] = o.values;
                    let _ = out.push(([a, b, d, 0.0, 0.0, 0.0], o.flags.bits()));
                }
            }
            Sensor::Imu { .. } => {
                let Ok(mut c) = AnyImuCorrector::new(cal, VECTOR_RATE_HZ) else {
                    return Response::Error(Status::NoCalibration);
                };
                c.set_environment(temperature, voltage);
                for r in raw {
                    let o = c.correct(*r);
                    let _ = out.push((o.values, o.flags.bits()));
                }
            }
        }
        Response::Vectors { out }
    }
}

/// The current calibration, validated once, and its health check's monitor, made for it when
/// first needed.
fn health_check<'a>(
    cal: &'a CalibrationData,
    loaded: Option<SlotInfo>,
    monitor: &'a mut Option<RestMonitor>,
) -> Result<(&'a Calibration, &'a mut RestMonitor), Status> {
    loaded.ok_or(Status::NoCalibration)?;
    let cal = Calibration::validate_in_place(cal).map_err(|_| Status::NoCalibration)?;
    let monitor = match monitor {
        Some(m) => m,
        empty => {
            empty.insert(RestMonitor::new(cal, VECTOR_RATE_HZ).map_err(Status::HealthUnavailable)?)
        }
    };
    Ok((cal, monitor))
}

/// The sample rate the device assumes for test vectors of an IMU (the host must use the same).
pub const fn vector_rate_hz() -> f32 {
    VECTOR_RATE_HZ
}
