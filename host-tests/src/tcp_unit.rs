//! A unit on a TCP port, in process: the device's protocol handler over a simulated NOR flash,
//! with faults on cue (stop answering after some requests, garble an answer). For the fault
//! tests of `calflash flash`; the real firmware on QEMU is in [`crate::unit`].

use std::io::{Read, Write};
use std::net::TcpListener;
use std::thread::JoinHandle;

use spincal::model::{Rails, Serial};
use spincal::protocol::{Device, MAX_FRAME, UnitSensor};
use spincal::store::Store;

use crate::nor::SimFlash;

/// The bench unit's flash: 4-byte writes, 1 KiB sectors.
pub type Flash = SimFlash<4, 1024>;

/// Bytes per slot of the bench unit.
pub const SLOT: u32 = 16 * 1024;

/// A fresh flash for the bench unit (two slots, the lock sector and the keys sector).
#[must_use]
pub fn blank_flash() -> Flash {
    Flash::new(Store::<Flash>::region_len(SLOT, 1024) as usize)
}

/// The sensor of the bench units: an IMU with the examples' 16-bit converters.
pub const IMU_16_BIT: UnitSensor = UnitSensor::Imu {
    accel_rails: Rails::unsigned(16),
    gyro_rails: Rails::unsigned(16),
};

/// A fresh flash for the bench unit, provisioned with the station `keys` (as a flasher does
/// at manufacture).
///
/// # Panics
/// When the keys do not fit the keys sector (more than four).
#[must_use]
pub fn provisioned_flash(keys: &[spincal::signed::StationKey]) -> Flash {
    let mut store = Store::new(blank_flash(), 0, SLOT).expect("the bench flash holds the store");
    store
        .provision(keys)
        .expect("the bench flash takes the keys");
    let mut flash = store.into_inner();
    flash.reboot();
    flash
}

/// A device over `flash` with serial `unit`, carrying [`IMU_16_BIT`].
///
/// # Panics
/// When the flash is too small for the store.
#[must_use]
pub fn device(flash: Flash, unit: &str) -> Box<Device<Flash>> {
    let store = Store::new(flash, 0, SLOT).expect("the bench flash holds two slots");
    Box::new(Device::new(
        store,
        Serial::new(unit).expect("a short serial"),
        IMU_16_BIT,
        [0, 1, 0],
    ))
}

/// What goes wrong, counted in requests received (the first is 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Nothing.
    None,
    /// From request `n` on, requests are read but neither handled nor answered (a unit that
    /// hangs or a cable pulled on its transmit line).
    SilentFrom(usize),
    /// The answer to request `n` has one byte flipped on the wire.
    GarbleAnswer(usize),
    /// The link is closed on receiving request `n` (a unit reset or a cable pulled).
    CloseAt(usize),
}

/// A unit listening on `127.0.0.1:port` for one connection.
pub struct TcpUnit {
    /// The port.
    pub port: u16,
    thread: JoinHandle<Box<Device<Flash>>>,
}

impl TcpUnit {
    /// Starts serving `device` with `fault`.
    ///
    /// # Panics
    /// When no local port can be bound.
    #[must_use]
    pub fn serve(mut device: Box<Device<Flash>>, fault: Fault) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
        let port = listener.local_addr().expect("bound").port();
        let thread = std::thread::spawn(move || {
            if let Ok((s, _)) = listener.accept() {
                session(&mut device, s, fault);
            }
            device
        });
        Self { port, thread }
    }

    /// Serves `device` to one connection after another, for as long as the process runs (a
    /// unit left on the bench's port); its address.
    ///
    /// # Panics
    /// When no local port can be bound.
    #[must_use]
    pub fn serve_forever(mut device: Box<Device<Flash>>) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
        let port = listener.local_addr().expect("bound").port();
        std::thread::spawn(move || {
            for s in listener.incoming().flatten() {
                session(&mut device, s, Fault::None);
            }
        });
        format!("tcp://127.0.0.1:{port}")
    }

    /// `tcp://127.0.0.1:PORT`.
    #[must_use]
    pub fn address(&self) -> String {
        format!("tcp://127.0.0.1:{}", self.port)
    }

    /// Waits for the client to hang up and returns the device as it is.
    ///
    /// # Panics
    /// When the serving thread panicked.
    #[must_use]
    pub fn finish(self) -> Box<Device<Flash>> {
        self.thread.join().expect("the bench unit's thread")
    }
}

/// Answers the frames of one connection `s` with `device`, with `fault`, until the client
/// hangs up (or the fault closes the link).
fn session(device: &mut Device<Flash>, mut s: std::net::TcpStream, fault: Fault) {
    let mut pending = Vec::new();
    let mut buf = [0u8; 1024];
    let mut n = 0usize;
    loop {
        let k = match s.read(&mut buf) {
            Ok(0) | Err(_) => return,
            Ok(k) => k,
        };
        pending.extend_from_slice(&buf[..k]);
        while let Some(end) = pending.iter().position(|b| *b == 0) {
            let frame: Vec<u8> = pending.drain(..=end).collect();
            n += 1;
            match fault {
                Fault::SilentFrom(m) if n >= m => continue,
                Fault::CloseAt(m) if n >= m => return,
                _ => {}
            }
            let mut out = [0u8; MAX_FRAME];
            let len = device.handle_frame(&frame[..frame.len() - 1], &mut out);
            if fault == Fault::GarbleAnswer(n) && len > 2 {
                out[len / 2] ^= 0x20;
            }
            if s.write_all(&out[..len]).is_err() {
                return;
            }
        }
    }
}
