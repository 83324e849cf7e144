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
    /// The id of the next request: each client starts at its own (from the clock and the
    /// process), so that a late reply meant for an earlier connection's request is told apart.
    next_id: u16,
    /// Replies dropped as meant for another request.
    stale: usize,
}

/// A request id no earlier client is likely to have used: the clock's nanoseconds and the
/// process id.
fn first_id() -> u16 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    (nanos ^ std::process::id().rotate_left(16)) as u16
}

impl<L: Read + Write> Client<L> {
    /// A client waiting at most `timeout` for each answer.
    pub fn new(link: L, timeout: Duration) -> Self {
        Self {
            link,
            timeout,
            pending: Vec::new(),
            trust: None,
            next_id: first_id(),
            stale: 0,
        }
    }

    /// How many replies were dropped as meant for another request (a late answer to an
    /// earlier connection's).
    pub const fn stale_replies(&self) -> usize {
        self.stale
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
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        let n =
            protocol::encode_tagged(req, id, &mut frame).map_err(|why| DeviceError::Garbled {
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
                let (reply, tag): (Reply, _) =
                    protocol::decode_tagged(&frame[..frame.len() - 1], &mut scratch).map_err(
                        |why| DeviceError::Garbled {
                            what: what.clone(),
                            why,
                        },
                    )?;
                // Ours: the reply with this request's id, or an untagged refusal of a frame
                // the unit could not read (so not its id either). Anything else was meant
                // for another request, an earlier connection's: dropped.
                let ours = match tag {
                    Some(t) => t == id,
                    None => matches!(
                        reply.response,
                        Response::Error(
                            protocol::Status::BadFrame
                                | protocol::Status::Malformed
                                | protocol::Status::UnknownRequest
                        )
                    ),
                };
                if !ours {
                    self.stale += 1;
                    continue;
                }
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

#[cfg(test)]
mod tests {
    use super::*;
    use spincal::protocol::Status;

    /// A link whose unit answers each request with what `answers` gives for its id: a list
    /// of (id or none, response) frames, sent in that order.
    struct Scripted<F: FnMut(u16) -> Vec<(Option<u16>, Response)>> {
        answers: F,
        out: std::collections::VecDeque<u8>,
    }

    impl<F: FnMut(u16) -> Vec<(Option<u16>, Response)>> Write for Scripted<F> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let mut scratch = [0u8; MAX_FRAME];
            let end = buf.iter().position(|b| *b == 0).unwrap_or(buf.len());
            let (_, id): (Request, _) = protocol::decode_tagged(&buf[..end], &mut scratch).unwrap();
            for (tag, response) in (self.answers)(id.expect("the client tags its requests")) {
                let reply = Reply {
                    trust: Trust::Unprovisioned,
                    response,
                };
                let mut frame = [0u8; MAX_FRAME];
                let n = match tag {
                    Some(t) => protocol::encode_tagged(&reply, t, &mut frame).unwrap(),
                    None => protocol::encode(&reply, &mut frame).unwrap(),
                };
                self.out.extend(&frame[..n]);
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl<F: FnMut(u16) -> Vec<(Option<u16>, Response)>> Read for Scripted<F> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = buf.len().min(self.out.len());
            for (b, o) in buf.iter_mut().zip(self.out.drain(..n)) {
                *b = o;
            }
            if n == 0 {
                return Err(std::io::ErrorKind::WouldBlock.into());
            }
            Ok(n)
        }
    }

    /// Red team four: after a burst, a reply meant for an earlier connection's request reached
    /// the next client, matched by order alone. Replies now carry their request's id: the late
    /// ones are dropped and counted, the client's own is taken.
    #[test]
    fn a_late_reply_meant_for_another_request_is_dropped() {
        let link = Scripted {
            answers: |id: u16| {
                vec![
                    // An earlier connection's request, answered late.
                    (Some(id.wrapping_sub(3)), Response::Error(Status::Locked)),
                    // An earlier (untagged) client's.
                    (None, Response::LockedOk),
                    // This request's.
                    (Some(id), Response::Ready),
                ]
            },
            out: std::collections::VecDeque::new(),
        };
        let mut client = Client::new(link, Duration::from_secs(2));
        assert_eq!(client.call(&Request::Lock).unwrap(), Response::Ready);
        assert_eq!(client.stale_replies(), 2);
        assert_eq!(client.call(&Request::Commit).unwrap(), Response::Ready);
        assert_eq!(client.stale_replies(), 4);
        // An untagged refusal of a frame the unit could not read is this request's answer.
        let link = Scripted {
            answers: |_| vec![(None, Response::Error(Status::BadFrame))],
            out: std::collections::VecDeque::new(),
        };
        let mut client = Client::new(link, Duration::from_secs(2));
        assert_eq!(
            client.call(&Request::Identify).unwrap(),
            Response::Error(Status::BadFrame)
        );
        assert_eq!(client.stale_replies(), 0);
    }
}
