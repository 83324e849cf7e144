//! The host's side of the update protocol: one request, one response, with a time limit.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use spincal::protocol::{self, MAX_FRAME, Reply, Request, Response, Status, Trust};

/// What can go wrong talking to a unit.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// No complete answer within the time limit.
    #[error("the unit did not answer {what} within {secs:.1} s")]
    Timeout {
        /// The request.
        what: String,
        /// The limit.
        secs: f64,
    },
    /// Bytes came within the time limit, but no frame of the protocol: something else answers
    /// (another device, a console, a wrong baud rate).
    #[error(
        "the link answered {what} with {bytes} bytes that are no frame of the calflash protocol \
         within {secs:.1} s: is a calflash unit on it, at the right baud rate?"
    )]
    NotAFrame {
        /// The request.
        what: String,
        /// The bytes received.
        bytes: usize,
        /// The limit.
        secs: f64,
    },
    /// The link failed.
    #[error("the link failed during {what}: {source}")]
    Io {
        /// The request.
        what: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The answer was not a valid frame.
    #[error("the unit's answer to {what} was garbled ({why:?})")]
    Garbled {
        /// The request.
        what: String,
        /// The frame error.
        why: protocol::FrameError,
    },
    /// The unit refused.
    #[error("the unit refused {what}: {}", describe(status))]
    Refused {
        /// The request.
        what: String,
        /// Its status.
        status: Status,
    },
    /// An answer of the wrong kind.
    #[error("the unit answered {what} with {got}")]
    Unexpected {
        /// The request.
        what: String,
        /// The answer.
        got: String,
    },
}

/// A refusal in words: a signature refusal says why and what to do.
fn describe(status: &Status) -> String {
    match status {
        Status::Refused(why) => why.to_string(),
        Status::HealthUnavailable(e) => {
            format!("its calibration gives the health check nothing to run on: {e}")
        }
        Status::InvalidBlob(e) => format!("the blob is not a valid calibration: {e}"),
        Status::NoCalibration => "it holds no valid calibration".into(),
        Status::Locked => "it is locked against writes".into(),
        Status::TooLarge => "the blob is longer than a slot holds".into(),
        Status::CrcMismatch => "the blob it received differs from the one sent (CRC)".into(),
        Status::StoreFailed => {
            "its store failed to commit; the previous calibration stays current".into()
        }
        other => format!("{other:?}"),
    }
}

fn name(r: &Request) -> String {
    match r {
        Request::Identify => "Identify".into(),
        Request::ReadBlob { offset, .. } => format!("a read at byte {offset}"),
        Request::WriteBegin { len, .. } => format!("the start of a {len}-byte transfer"),
        Request::WriteChunk { offset, .. } => format!("the chunk at byte {offset}"),
        Request::Commit => "Commit".into(),
        Request::RunVectors { .. } => "the test vectors".into(),
        Request::Lock => "Lock".into(),
        Request::ObserveRest { .. } => "samples for the health check".into(),
        Request::ReadHealth => "the health read".into(),
        Request::ReadFlight => "the flight filter's read".into(),
    }
}

/// A protocol client over any byte link.
pub struct Client<L> {
    link: L,
    timeout: Duration,
    /// Bytes received past the last frame (kept for the next answer).
    pending: Vec<u8>,
    /// Whether the unit checks signatures, as its last answer said.
    trust: Option<Trust>,
}

impl<L: Read + Write> Client<L> {
    /// A client waiting at most `timeout` for each answer.
    pub fn new(link: L, timeout: Duration) -> Self {
        Self {
            link,
            timeout,
            pending: Vec::new(),
            trust: None,
        }
    }

    /// Whether the unit checks signatures, as its last answer said (`None` before one came).
    pub const fn trust(&self) -> Option<Trust> {
        self.trust
    }

    /// Sends a request and waits for its response; a refusal is an `Ok(Response::Error)`.
    ///
    /// # Errors
    /// Time-out, link failure or a garbled answer.
    pub fn call(&mut self, req: &Request) -> Result<Response, DeviceError> {
        let what = name(req);
        let mut frame = [0u8; MAX_FRAME];
        let n = protocol::encode(req, &mut frame).map_err(|why| DeviceError::Garbled {
            what: what.clone(),
            why,
        })?;
        self.link
            .write_all(&frame[..n])
            .and_then(|()| self.link.flush())
            .map_err(|source| DeviceError::Io {
                what: what.clone(),
                source,
            })?;
        let start = Instant::now();
        let mut byte = [0u8; 256];
        loop {
            if let Some(end) = self.pending.iter().position(|b| *b == 0) {
                let frame: Vec<u8> = self.pending.drain(..=end).collect();
                let mut scratch = [0u8; MAX_FRAME];
                let reply: Reply = protocol::decode(&frame[..frame.len() - 1], &mut scratch)
                    .map_err(|why| DeviceError::Garbled { what, why })?;
                self.trust = Some(reply.trust);
                return Ok(reply.response);
            }
            if start.elapsed() > self.timeout {
                let secs = self.timeout.as_secs_f64();
                if !self.pending.is_empty() {
                    let bytes = self.pending.len();
                    self.pending.clear();
                    return Err(DeviceError::NotAFrame { what, bytes, secs });
                }
                return Err(DeviceError::Timeout { what, secs });
            }
            // A stream that never ends a frame is not read on without bound.
            if self.pending.len() > 4 * MAX_FRAME {
                let bytes = self.pending.len();
                self.pending.clear();
                let secs = start.elapsed().as_secs_f64();
                return Err(DeviceError::NotAFrame { what, bytes, secs });
            }
            match self.link.read(&mut byte) {
                Ok(0) => {
                    return Err(DeviceError::Io {
                        what,
                        source: std::io::Error::new(
                            std::io::ErrorKind::UnexpectedEof,
                            "the link closed",
                        ),
                    });
                }
                Ok(k) => self.pending.extend_from_slice(&byte[..k]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(source) => return Err(DeviceError::Io { what, source }),
            }
        }
    }

    /// Like [`Client::call`], with a refusal as an error.
    ///
    /// # Errors
    /// As `call`, and [`DeviceError::Refused`].
    pub fn ask(&mut self, req: &Request) -> Result<Response, DeviceError> {
        match self.call(req)? {
            Response::Error(status) => Err(DeviceError::Refused {
                what: name(req),
                status,
            }),
            r => Ok(r),
        }
    }

    /// The first `total` bytes of the unit's current blob, chunk by chunk.
    ///
    /// # Errors
    /// As `ask`, or an answer that is not a chunk.
    pub fn read_blob(&mut self, total: usize) -> Result<Vec<u8>, DeviceError> {
        let mut back = Vec::with_capacity(total);
        while back.len() < total {
            let len = (total - back.len()).min(protocol::MAX_CHUNK) as u16;
            match self.ask(&Request::ReadBlob {
                offset: back.len() as u32,
                len,
            })? {
                Response::Blob { data, .. } if !data.is_empty() => back.extend_from_slice(&data),
                other => {
                    return Err(DeviceError::Unexpected {
                        what: "ReadBlob".into(),
                        got: format!("{other:?}"),
                    });
                }
            }
        }
        Ok(back)
    }

    /// The unit's health at rest.
    ///
    /// # Errors
    /// As `ask` (a unit whose calibration gives the check nothing to run on refuses with
    /// `HealthUnavailable` and the reason).
    pub fn health(&mut self) -> Result<spincal::health::Health, DeviceError> {
        match self.ask(&Request::ReadHealth)? {
            Response::Health(h) => Ok(h),
            other => Err(DeviceError::Unexpected {
                what: "the health read".into(),
                got: format!("{other:?}"),
            }),
        }
    }

    /// The unit's flight filter, as its flight loop last published it (`None`: nothing since
    /// power-on).
    ///
    /// # Errors
    /// As `ask`.
    pub fn flight(&mut self) -> Result<Option<spincal::flight::FlightReport>, DeviceError> {
        match self.ask(&Request::ReadFlight)? {
            Response::Flight(r) => Ok(r),
            other => Err(DeviceError::Unexpected {
                what: "the flight filter's read".into(),
                got: format!("{other:?}"),
            }),
        }
    }

    /// Gives the unit raw samples for its health check (at most 16 per call).
    ///
    /// # Errors
    /// As `ask`.
    pub fn observe_rest(
        &mut self,
        temperature: f32,
        voltage: f32,
        raw: &[[i32; 6]],
    ) -> Result<(), DeviceError> {
        let raw = heapless::Vec::from_slice(raw).map_err(|_| DeviceError::Unexpected {
            what: "samples for the health check".into(),
            got: format!("{} samples, more than one request holds", raw.len()),
        })?;
        match self.ask(&Request::ObserveRest {
            temperature,
            voltage,
            raw,
        })? {
            Response::Vectors { .. } => Ok(()),
            other => Err(DeviceError::Unexpected {
                what: "samples for the health check".into(),
                got: format!("{other:?}"),
            }),
        }
    }

    /// The unit's identity.
    ///
    /// # Errors
    /// As `ask`.
    pub fn identify(&mut self) -> Result<protocol::Identity, DeviceError> {
        // A client that left half a frame on the link (a cable pulled, a probe) makes the
        // unit's first frame from this one bad: the unit answers BadFrame, has dropped those
        // bytes with it and keeps its calibration, so Identify is asked once more.
        let first = match self.ask(&Request::Identify) {
            Err(DeviceError::Refused {
                status: protocol::Status::BadFrame,
                ..
            }) => self.ask(&Request::Identify),
            other => other,
        };
        match first? {
            Response::Identity(i) => Ok(i),
            other => Err(DeviceError::Unexpected {
                what: "Identify".into(),
                got: format!("{other:?}"),
            }),
        }
    }
}
