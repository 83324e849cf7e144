//! The golden flight, as `build.rs` wrote it from `host_tests::flight_golden`: the events
//! (decoded here, the encoding documented there), the expected checkpoints and the set-up;
//! the raw codes go through the spinning round's calibration (`imu_spin.blob`).

use nalgebra::Vector3;
use spincal::correct::AnyImuCorrector;
use spincal::flight::{
    FlightConfig, FlightFilter, FlightReport, Geodetic, GnssFix, Round, doubted,
};
use spincal::model::{Calibration, Rails, Sensor};
use spincal::nav::{NavNoise, SensorErrors};

/// The spinning round's calibration blob.
pub static BLOB: &[u8] = include_bytes!("../../host-tests/golden/imu_spin.blob");

/// The golden flight's sample rate, Hz (`host_tests::flight_golden::RATE`).
pub const RATE: f32 = 2000.0;

include!(concat!(env!("OUT_DIR"), "/flight_config.rs"));

/// The events' bytes.
pub static EVENTS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/flight.events"));

/// The checkpoints' bits, little-endian `u32`s, `VALUES` per checkpoint.
pub static EXPECTED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/flight.expected"));

/// Values per checkpoint (`host_tests::flight_golden::CHECKPOINT_VALUES`).
pub const VALUES: usize = 23 + spincal::nav::STATES;

/// Samples between two checkpoints (`host_tests::flight_golden::CHECKPOINT_EVERY`).
pub const EVERY: usize = 200;

/// What the unit receives.
pub enum Event {
    /// Time (us), raw codes.
    Sample(u64, [i32; 6]),
    /// Temperature (C), supply (V).
    Environment(f32, f32),
    /// A GNSS fix.
    Fix(GnssFix),
    /// Time (us), pressure (Pa).
    Pressure(u64, f32),
}

/// One input of the flight filter.
pub enum Input {
    /// Time (us), specific force, rate, doubt of the accelerometer and the gyro.
    Sample(u64, Vector3<f32>, Vector3<f32>, [bool; 2]),
    /// A GNSS fix.
    Fix(GnssFix),
    /// Time (us), pressure (Pa).
    Pressure(u64, f32),
}

/// The converters' rails of an IMU calibration.
pub fn rails(cal: &Calibration) -> Option<(Rails, Rails)> {
    match cal.data().sensor {
        Sensor::Imu {
            accel_rails,
            gyro_rails,
            ..
        } => Some((accel_rails, gyro_rails)),
        _ => None,
    }
}

/// The events through the corrector `imu`: the flight filter's inputs.
pub fn inputs<'a, 'c>(
    imu: &'a mut AnyImuCorrector<'c>,
    (accel, gyro): (Rails, Rails),
) -> impl Iterator<Item = Input> + 'a {
    events().filter_map(move |e| match e {
        Event::Sample(t, raw) => {
            let out = imu.correct(raw);
            let [ax, ay, az, gx, gy, gz] = out.values;
            Some(Input::Sample(
                t,
                Vector3::new(ax, ay, az),
                Vector3::new(gx, gy, gz),
                doubted(&raw, out.flags, accel, gyro),
            ))
        }
        Event::Environment(t, v) => {
            imu.set_environment(t, v);
            None
        }
        Event::Fix(f) => Some(Input::Fix(f)),
        Event::Pressure(t, p) => Some(Input::Pressure(t, p)),
    })
}

/// Gives the flight filter one input.
pub fn feed(filter: &mut FlightFilter<f32>, input: Input) {
    match input {
        Input::Sample(t, f, w, doubt) => filter.sample(t, &f, &w, doubt),
        Input::Fix(fix) => filter.gnss(&fix),
        Input::Pressure(t, p) => filter.pressure(t, p),
    }
}

/// The round's flight loop over the recorded flight in flash: its raw codes through `cal`
/// (the unit's own calibration), with its fixes and pressures, through the flight filter and
/// the flight's lines ([`Round`]), the calibration's own error at rest its sensor errors'
/// prior; the snapshot at the end, its verdict carrying the calibration's own change of line
/// into the flight. `None` for a calibration that is not an
/// IMU's.
pub fn fly(cal: &Calibration) -> Option<FlightReport> {
    let (accel, gyro) = rails(cal)?;
    let mut imu = AnyImuCorrector::new(cal, RATE).ok()?;
    // The calibration's own error at rest is the sensor errors' prior, at the flight's
    // first temperature and supply.
    if let Some(Event::Environment(t, v)) = events().find(|e| matches!(e, Event::Environment(..))) {
        imu.set_environment(t, v);
    }
    let mut config = flight_config();
    if let Some(factors) = imu.covariance_factors() {
        config.take_calibration_prior(factors);
    }
    let mut round = Round::new(FlightFilter::try_new(config).ok()?);
    for e in events() {
        match e {
            Event::Sample(t, raw) => {
                let out = imu.correct(raw);
                let doubt = doubted(&raw, out.flags, accel, gyro);
                round.sample(t, &out.values, doubt, || imu.error_features(&out.values));
            }
            Event::Environment(t, v) => imu.set_environment(t, v),
            Event::Fix(fix) => round.filter.gnss(&fix),
            Event::Pressure(t, p) => round.filter.pressure(t, p),
        }
    }
    Some(round.report(imu.covariance_factors()))
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
    fn i32(&mut self) -> Option<i32> {
        self.take::<4>().map(i32::from_le_bytes)
    }
}

/// The events in order; stops at the first that does not decode.
pub fn events() -> impl Iterator<Item = Event> {
    let mut r = Reader { bytes: EVENTS };
    core::iter::from_fn(move || match r.u8()? {
        0 => {
            let t = r.t()?;
            let raw = [r.i32()?, r.i32()?, r.i32()?, r.i32()?, r.i32()?, r.i32()?];
            Some(Event::Sample(t, raw))
        }
        3 => Some(Event::Environment(r.f32()?, r.f32()?)),
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
