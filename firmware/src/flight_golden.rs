//! The golden flight, as `build.rs` wrote it from `host_tests::flight_golden`: the events
//! (decoded here, the encoding documented there), the expected checkpoints and the set-up.

use nalgebra::Vector3;
use spincal::flight::{FlightConfig, Geodetic, GnssFix};
use spincal::nav::{NavNoise, SensorErrors};

include!(concat!(env!("OUT_DIR"), "/flight_config.rs"));

/// The events' bytes.
pub static EVENTS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/flight.events"));

/// The checkpoints' bits, little-endian `u32`s, `VALUES` per checkpoint.
pub static EXPECTED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/flight.expected"));

/// Values per checkpoint (`host_tests::flight_golden::CHECKPOINT_VALUES`).
pub const VALUES: usize = 45;

/// Samples between two checkpoints (`host_tests::flight_golden::CHECKPOINT_EVERY`).
pub const EVERY: usize = 200;

/// One input of the flight filter.
pub enum Event {
    /// Time (us), specific force, rate, doubt of the accelerometer and the gyro.
    Sample(u64, [f32; 3], [f32; 3], [bool; 2]),
    /// A GNSS fix.
    Fix(GnssFix),
    /// Time (us), pressure (Pa).
    Pressure(u64, f32),
}

struct Reader<'a> {
    bytes: &'a [u8],
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, rest) = self.bytes.split_at_checked(N)?;
        self.bytes = rest;
        head.try_into().ok()
    }
    fn u8(&mut self) -> Option<u8> {
        self.take::<1>().map(|b| b[0])
    }
    fn t(&mut self) -> Option<u64> {
        self.take::<4>().map(|b| u64::from(u32::from_le_bytes(b)))
    }
    fn f32(&mut self) -> Option<f32> {
        self.take::<4>().map(f32::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.take::<8>().map(f64::from_le_bytes)
    }
    fn three(&mut self) -> Option<[f32; 3]> {
        Some([self.f32()?, self.f32()?, self.f32()?])
    }
}

/// The events in order; stops at the first that does not decode.
pub fn events() -> impl Iterator<Item = Event> {
    let mut r = Reader { bytes: EVENTS };
    core::iter::from_fn(move || match r.u8()? {
        0 => {
            let (t, f, w, d) = (r.t()?, r.three()?, r.three()?, r.u8()?);
            Some(Event::Sample(t, f, w, [d & 1 != 0, d & 2 != 0]))
        }
        1 => {
            let t_us = r.t()?;
            let position = Geodetic {
                latitude: r.f64()?,
                longitude: r.f64()?,
                height: r.f64()?,
            };
            let v = r.three()?;
            let satellites = r.u8()?;
            Some(Event::Fix(GnssFix {
                t_us,
                position,
                velocity: v.iter().all(|x| x.is_finite()).then_some(v),
                satellites,
            }))
        }
        2 => Some(Event::Pressure(r.t()?, r.f32()?)),
        _ => None,
    })
}
