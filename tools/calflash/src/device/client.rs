//! The host's side of the update protocol: one request, one response, with a time limit.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use spincal::protocol::{self, MAX_FRAME, Request, Response, Status};

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
    #[error("the unit refused {what}: {status:?}")]
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

fn name(r: &Request) -> String {
    match r {
        Request::Identify => "Identify".into(),
        Request::ReadBlob { offset, .. } => format!("a read at byte {offset}"),
        Request::WriteBegin { len, .. } => format!("the start of a {len}-byte transfer"),
        Request::WriteChunk { offset, .. } => format!("the chunk at byte {offset}"),
        Request::Commit => "Commit".into(),
        Request::RunVectors { .. } => "the test vectors".into(),
        Request::Lock => "Lock".into(),
    }
}

/// A protocol client over any byte link.
pub struct Client<L> {
    link: L,
    timeout: Duration,
    /// Bytes received past the last frame (kept for the next answer).
    pending: Vec<u8>,
}

impl<L: Read + Write> Client<L> {
    /// A client waiting at most `timeout` for each answer.
    pub fn new(link: L, timeout: Duration) -> Self {
        Self {
            link,
            timeout,
            pending: Vec::new(),
        }
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
                return protocol::decode(&frame[..frame.len() - 1], &mut scratch)
                    .map_err(|why| DeviceError::Garbled { what, why });
            }
            if start.elapsed() > self.timeout {
                return Err(DeviceError::Timeout {
                    what,
                    secs: self.timeout.as_secs_f64(),
                });
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

    /// The unit's identity.
    ///
    /// # Errors
    /// As `ask`.
    pub fn identify(&mut self) -> Result<protocol::Identity, DeviceError> {
        match self.ask(&Request::Identify)? {
            Response::Identity(i) => Ok(i),
            other => Err(DeviceError::Unexpected {
                what: "Identify".into(),
                got: format!("{other:?}"),
            }),
        }
    }
}
