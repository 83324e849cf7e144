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

impl Link {
    /// Opens `spec` with reads that give up after `timeout`.
    ///
    /// # Errors
    /// A message naming the link.
    pub fn open(spec: &str, timeout: Duration) -> Result<Self, String> {
        if let Some(addr) = spec.strip_prefix("tcp://") {
            let s = TcpStream::connect(addr).map_err(|e| format!("{spec}: cannot connect: {e}"))?;
            s.set_read_timeout(Some(timeout))
                .map_err(|e| format!("{spec}: {e}"))?;
            s.set_nodelay(true).map_err(|e| format!("{spec}: {e}"))?;
            Ok(Self::Tcp(s))
        } else {
            let p = serialport::new(spec, 115_200)
                .timeout(timeout)
                .open()
                .map_err(|e| format!("{spec}: cannot open the serial port: {e}"))?;
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
