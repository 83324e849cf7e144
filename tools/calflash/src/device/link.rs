//! The byte link to a unit: a serial device or pty by path, or `tcp://host:port` (QEMU's
//! `-serial tcp:...`).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// An open link.
pub enum Link {
    /// A TCP connection.
    Tcp(TcpStream),
    /// A serial port (or pty).
    Serial(Box<dyn serialport::SerialPort>),
}

/// A link that cannot be opened, named as given.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenError {
    /// No TCP connection.
    #[error("{link}: cannot connect: {source}")]
    Connect {
        /// The link as given.
        link: String,
        /// Why.
        source: std::io::Error,
    },
    /// A TCP socket that refuses its options.
    #[error("{link}: {source}")]
    Socket {
        /// The link as given.
        link: String,
        /// Why.
        source: std::io::Error,
    },
    /// A serial port that cannot be opened.
    #[error("{link}: cannot open the serial port: {source}")]
    Serial {
        /// The link as given.
        link: String,
        /// Why.
        source: serialport::Error,
    },
}

impl Link {
    /// Opens `spec` with reads that give up after `timeout`.
    ///
    /// # Errors
    /// A message naming the link.
    pub fn open(spec: &str, timeout: Duration) -> Result<Self, OpenError> {
        let link = || spec.to_string();
        if let Some(addr) = spec.strip_prefix("tcp://") {
            let s = TcpStream::connect(addr).map_err(|source| OpenError::Connect {
                link: link(),
                source,
            })?;
            s.set_read_timeout(Some(timeout))
                .and_then(|()| s.set_nodelay(true))
                .map_err(|source| OpenError::Socket {
                    link: link(),
                    source,
                })?;
            Ok(Self::Tcp(s))
        } else {
            let p = serialport::new(spec, 115_200)
                .timeout(timeout)
                .open()
                .map_err(|source| OpenError::Serial {
                    link: link(),
                    source,
                })?;
            Ok(Self::Serial(p))
        }
    }
}

impl Read for Link {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Self::Tcp(s) => s.read(buf),
            Self::Serial(s) => s.read(buf),
        }
    }
}

impl Write for Link {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Self::Tcp(s) => s.write(buf),
            Self::Serial(s) => s.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Self::Tcp(s) => s.flush(),
            Self::Serial(s) => s.flush(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_that_cannot_be_opened_is_named() {
        // A port nothing listens on: bind one, then free it.
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .unwrap()
            .port();
        let spec = format!("tcp://127.0.0.1:{port}");
        let Err(e) = Link::open(&spec, Duration::from_millis(100)) else {
            panic!("{spec} opened");
        };
        assert!(
            matches!(&e, OpenError::Connect { link, .. } if *link == spec),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .starts_with(&format!("{spec}: cannot connect: "))
        );
        let Err(e) = Link::open("/nonexistent/tty", Duration::from_millis(100)) else {
            panic!("/nonexistent/tty opened");
        };
        assert!(matches!(e, OpenError::Serial { .. }), "{e:?}");
        assert!(
            e.to_string()
                .starts_with("/nonexistent/tty: cannot open the serial port: ")
        );
    }
}
