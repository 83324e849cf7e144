//! The golden flight: a simulated shell's raw IMU codes, GNSS fixes and pressures, as the
//! device receives them, and the flight filter's state at checkpoints.
//!
//! The flight comes from `calflash`'s simulator (a 155 mm-like shell spinning at 300 rev/s
//! from a site at 39.4 N, 1 s on the pad, 4 s of flight) through the spinning round's IMU
//! (`ImuTruth::spinning_round`: its noise, its accelerometers saturating at setback), with a
//! launch shift of the x accelerometer's bias (0.3 m/s^2) and a heading known to 1 degree. The
//! codes go through the round's calibration (`golden/imu_spin.blob`) and the same events go
//! through `FlightFilter<f32>` on the host and on the Cortex-M4F (`firmware/src/bin/flight.rs`,
//! the bytes made by `firmware/build.rs`), which must agree bit for bit, and through
//! `FlightFilter<f64>` (`tests/flight_device.rs`).
//!
//! Encoding, little-endian, one record after another: a sample `0, t_us: u32, codes: [i32; 6]`;
//! a fix `1, t_us: u32, latitude, longitude, height: f64, velocity: [f32; 3], satellites: u8`;
//! a pressure `2, t_us: u32, pa: f32`; an environment `3, temperature: f32, voltage: f32`.
//! Checkpoints are [`CHECKPOINT_VALUES`] `u32` bit patterns each.

use calflash::sim::flight::atmosphere;
use calflash::sim::flight::spec::Launch;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use spincal::correct::AnyImuCorrector;
use spincal::flight::{FlightConfig, FlightFilter, Geodetic, GnssFix, doubted};
use spincal::model::{Calibration, Sensor};
use spincal::nav::{NavNoise, Real, SensorErrors};

/// What the unit receives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// Raw IMU codes at a time (us).
    Sample(u64, [i32; 6]),
    /// The unit's temperature (C) and supply (V), when they change.
    Environment(f32, f32),
    /// A GNSS fix.
    Fix(GnssFix),
    /// A static pressure: time (us), Pa.
    Pressure(u64, f32),
}

/// What the flight filter receives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input {
    /// A corrected sample: time (us), specific force, rate, which sensors are in doubt.
    Sample(u64, [f32; 3], [f32; 3], [bool; 2]),
    /// A GNSS fix.
    Fix(GnssFix),
    /// A static pressure: time (us), Pa.
    Pressure(u64, f32),
}

/// A simulated flight as the unit receives it.
#[derive(Debug, Clone)]
pub struct Flight {
    /// The events, in order.
    pub events: Vec<Event>,
    /// The unit's true heading at rest (rad, as [`FlightConfig::heading`] counts it).
    pub heading: f64,
    /// The corrected samples' white-noise densities on the pad: m/s^2/sqrt(Hz), rad/s/sqrt(Hz).
    pub noise: (f64, f64),
}

/// The spinning round's calibration (`golden/imu_spin.blob`).
///
/// # Panics
/// If the golden blob is missing or does not decode.
#[must_use]
pub fn calibration() -> Calibration {
    let path = crate::golden::dir().join(format!("{}.blob", crate::golden::SPIN_CASE));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    spincal::blob::decode(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The converters' rails of the golden flight's IMU calibration.
fn rails(cal: &Calibration) -> (spincal::model::Rails, spincal::model::Rails) {
    let Sensor::Imu {
        accel_rails,
        gyro_rails,
        ..
    } = cal.data().sensor
    else {
        panic!("the golden flight's calibration is an IMU's");
    };
    (accel_rails, gyro_rails)
}

/// The events through the unit's corrector: what the flight filter receives.
///
/// # Panics
/// If the calibration is not an IMU's.
#[must_use]
pub fn inputs(cal: &Calibration, events: &[Event]) -> Vec<Input> {
    let (accel_rails, gyro_rails) = rails(cal);
    let mut imu = AnyImuCorrector::new(cal, RATE as f32).expect("an IMU corrector");
    events
        .iter()
        .filter_map(|e| match e {
            Event::Sample(t, raw) => {
                let out = imu.correct(*raw);
                let v = out.values;
                Some(Input::Sample(
                    *t,
                    [v[0], v[1], v[2]],
                    [v[3], v[4], v[5]],
                    doubted(raw, out.flags, accel_rails, gyro_rails),
                ))
            }
            Event::Environment(t, v) => {
                imu.set_environment(*t, *v);
                None
            }
            Event::Fix(f) => Some(Input::Fix(*f)),
            Event::Pressure(t, p) => Some(Input::Pressure(*t, *p)),
        })
        .collect()
}

/// The samples between two checkpoints.
pub const CHECKPOINT_EVERY: usize = 200;

/// Values per checkpoint: position, velocity, attitude (w x y z), the 13 sensor errors, the
/// variances of every state.
pub const CHECKPOINT_VALUES: usize = 3 + 3 + 4 + 13 + spincal::nav::STATES;

/// The sample rate, Hz.
pub const RATE: f64 = 2000.0;

/// The launch point.
pub const ORIGIN: Geodetic = Geodetic {
    latitude: 39.4,
    longitude: -8.3,
    height: 0.0,
};

/// The launch shift the flight carries: the x accelerometer's bias, m/s^2.
pub const SHIFT_AX: f64 = 0.3;

/// The golden flight.
///
/// # Panics
/// If the simulator refuses the flight (it does not).
#[must_use]
pub fn flight() -> Flight {
    flight_of("shell:lat=39.4,lon=-8.3,azimuth=60,rest=1,seconds=4")
}

/// The flight `spec` (a `calflash simulate --flight` spec with its site named), simulated as
/// [`flight`] is.
///
/// # Panics
/// If the simulator refuses the spec.
#[must_use]
pub fn flight_of(spec: &str) -> Flight {
    let mut launch = Launch::parse(spec).expect("the golden flight's spec");
    let site = launch.site_mut().expect("the golden flight names its site");
    let flown = launch.fly(1.0 / RATE);
    let to_level = site.to_level();
    let earth_rate = site.rate();
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let truth = calflash::sim::truth::ImuTruth::spinning_round();
    let cal = calibration();
    let (accel_rails, gyro_rails) = rails(&cal);
    const VOLT: f32 = 5.0;
    let (gh, gv, gvel, pa) = (
        Normal::new(0.0, 2.0).expect("sigma"),
        Normal::new(0.0, 4.0).expect("sigma"),
        Normal::new(0.0, 0.1).expect("sigma"),
        Normal::new(0.0, 2.0).expect("sigma"),
    );
    let t0 = flown.samples.first().map_or(0.0, |s| s.t);
    let mut events = Vec::new();
    let mut heading = 0.0;
    let mut last_temp = f32::NAN;
    let mut pad_truth = Vec::new();
    for (k, s) in flown.samples.iter().enumerate() {
        let t_us = ((s.t - t0) * 1e6).round() as u64;
        let q = body_to_flight(s.q);
        let mut f = Vector3::from(s.f);
        let w = Vector3::from(s.w) + q.inverse() * earth_rate;
        if s.t > 0.0 {
            f.x += SHIFT_AX;
        }
        // The environment in steps of 0.1 C, as `calflash flight` reads a recording.
        let temp = s.temp as f32;
        if last_temp.is_nan() || (temp - last_temp).abs() >= 0.1 {
            events.push(Event::Environment(temp, VOLT));
            last_temp = temp;
        }
        let codes = truth.codes(
            (f.into(), w.into(), s.dw),
            (s.temp, f64::from(VOLT)),
            &mut rng,
        );
        let rails = |i: usize| if i < 3 { accel_rails } else { gyro_rails };
        let raw: [i32; 6] = core::array::from_fn(|i| {
            codes[i].clamp(f64::from(rails(i).lo), f64::from(rails(i).hi)) as i32
        });
        events.push(Event::Sample(t_us, raw));
        if s.t < -0.1 {
            pad_truth.push((t_us, f, w));
        }
        if k == 0 {
            heading = true_heading(&(to_level * q.to_rotation_matrix().into_inner()), &f);
        }
        if k.is_multiple_of(RATE as usize / 10) && (s.t < 0.0 || s.t >= 1.0) {
            let level = to_level * Vector3::from(s.r);
            let noisy = level
                + Vector3::new(
                    gh.sample(&mut rng),
                    gh.sample(&mut rng),
                    gv.sample(&mut rng),
                );
            let (latitude, longitude, height) = site.geodetic(&(to_level.transpose() * noisy));
            // East, north, up at the receiver, as receivers give it.
            let v = site.local_enu(latitude, longitude) * Vector3::from(s.v);
            events.push(Event::Fix(GnssFix {
                t_us,
                position: Geodetic {
                    latitude,
                    longitude,
                    height,
                },
                velocity: Some([0, 1, 2].map(|i| (v[i] + gvel.sample(&mut rng)) as f32)),
                satellites: 12,
            }));
        }
        if k.is_multiple_of(RATE as usize / 100) {
            let p = atmosphere::standard(site.height + s.r[2]).pressure + pa.sample(&mut rng);
            events.push(Event::Pressure(t_us, p as f32));
        }
    }
    let noise = pad_noise(&inputs(&cal, &events), &pad_truth);
    Flight {
        events,
        heading,
        noise,
    }
}

/// The white-noise densities of the corrected samples against the truth on the pad.
fn pad_noise(inputs: &[Input], truth: &[(u64, Vector3<f64>, Vector3<f64>)]) -> (f64, f64) {
    let mut at = truth.iter().peekable();
    let (mut sa, mut sg, mut n) = (0.0, 0.0, 0.0);
    for i in inputs {
        if let Input::Sample(t, f, w, _) = i
            && let Some((_, tf, tw)) = at.next_if(|(tt, _, _)| tt == t)
        {
            for k in 0..3 {
                sa += (f64::from(f[k]) - tf[k]).powi(2);
                sg += (f64::from(w[k]) - tw[k]).powi(2);
            }
            n += 3.0;
        }
    }
    let n = f64::max(n, 1.0);
    ((sa / n / RATE).sqrt(), (sg / n / RATE).sqrt())
}

pub(crate) fn body_to_flight(q: [f64; 4]) -> UnitQuaternion<f64> {
    let [w, x, y, z] = q;
    UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
}

/// The heading the filter should level to: the turn about the vertical between the attitude
/// levelled from gravity alone and the true one.
pub(crate) fn true_heading(body_to_level: &Matrix3<f64>, f: &Vector3<f64>) -> f64 {
    let up = spincal::nav::real::rotation_between(f, &Vector3::z());
    let truth = UnitQuaternion::from_matrix(body_to_level);
    let turn = truth * up.inverse();
    let x = turn * Vector3::x();
    x.y.atan2(x.x)
}

/// The filter's set-up for a flight: heading off by 1 degree with a 2-degree sigma, the
/// corrected samples' noise on the pad, priors that cover the shift.
#[must_use]
pub fn config<T: Real>(flight: &Flight) -> FlightConfig<T> {
    let c = |x: f64| -> T { nalgebra::convert(x) };
    let heading = flight.heading;
    let noise = NavNoise {
        accel_white: c(flight.noise.0),
        gyro_white: c(flight.noise.1),
        accel_walk: c(1e-4),
        gyro_walk: c(1e-6),
        scale_walk: c(1e-7),
        baro_walk: c(0.1),
        // The golden flight's receiver errs white.
        receiver_sigma: Vector3::zeros(),
        receiver_tau: c(0.0),
    };
    let prior = SensorErrors {
        accel_bias: Vector3::repeat(c(0.2)),
        gyro_bias: Vector3::repeat(c(2e-3)),
        accel_scale: Vector3::repeat(c(2e-3)),
        gyro_scale: Vector3::repeat(c(1e-5)),
        baro_bias: c(5.0),
    };
    let mut config: FlightConfig<T> = FlightConfig::new(
        (c(heading + 1f64.to_radians()), c(2f64.to_radians())),
        noise,
        prior,
    );
    config.origin = Some(ORIGIN);
    config.launch_shift.accel_bias = Vector3::repeat(c(0.3));
    config
}

/// Runs `inputs` through `filter`, calling `checkpoint` every [`CHECKPOINT_EVERY`] samples and
/// after the last.
pub fn run<T: Real>(
    filter: &mut FlightFilter<T>,
    inputs: &[Input],
    mut checkpoint: impl FnMut(&FlightFilter<T>),
) {
    let mut samples = 0usize;
    for i in inputs {
        feed(filter, i);
        if matches!(i, Input::Sample(..)) {
            samples += 1;
            if samples.is_multiple_of(CHECKPOINT_EVERY) {
                checkpoint(filter);
            }
        }
    }
    checkpoint(filter);
}

/// The round's flight loop on `events` through `cal`, as the example round runs it
/// (`spincal_firmware::flight_golden::fly`): the calibration's own error at rest its sensor
/// errors' prior, the filter with the flight's lines beside it, the snapshot at the end with its
/// verdict carrying the calibration's change of line. `added` is added to the axial
/// accelerometer's corrected output from the end of the setback on (a shift of the test's own;
/// zero for the recorded flight).
///
/// # Panics
/// If the calibration is not an IMU's or the set-up is refused.
#[must_use]
pub fn round(
    cal: &Calibration,
    events: &[Event],
    flight: &Flight,
    added: f32,
) -> spincal::flight::FlightReport {
    let (round, factors) = round_flown(cal, events, flight, added);
    round.report(factors.as_ref())
}

/// [`round`]'s loop at the end of the flight, and the calibration's covariance factors at the
/// flight's last temperature.
///
/// # Panics
/// As [`round`].
#[must_use]
pub fn round_flown(
    cal: &Calibration,
    events: &[Event],
    flight: &Flight,
    added: f32,
) -> (
    spincal::flight::Round<f32>,
    Option<spincal::model::ImuCovariance>,
) {
    let (accel, gyro) = rails(cal);
    let mut imu = AnyImuCorrector::new(cal, RATE as f32).expect("an IMU corrector");
    if let Some(Event::Environment(t, v)) =
        events.iter().find(|e| matches!(e, Event::Environment(..)))
    {
        imu.set_environment(*t, *v);
    }
    let mut config = config::<f32>(flight);
    if let Some(factors) = imu.covariance_factors() {
        config.take_calibration_prior(factors);
    }
    let filter = FlightFilter::<f32>::try_new(config).expect("the golden set-up");
    let mut round = spincal::flight::Round::new(filter);
    for e in events {
        match e {
            Event::Sample(t, raw) => {
                let out = imu.correct(*raw);
                let doubt = doubted(raw, out.flags, accel, gyro);
                let mut values = out.values;
                if round.filter.setback_end_us().is_some() {
                    values[0] += added;
                }
                round.sample(*t, &values, doubt, || imu.error_features(&values));
            }
            Event::Environment(t, v) => imu.set_environment(*t, *v),
            Event::Fix(f) => round.filter.gnss(f),
            Event::Pressure(t, p) => round.filter.pressure(*t, *p),
        }
    }
    let factors = imu.covariance_factors().copied();
    (round, factors)
}

/// One input into `filter`.
pub fn feed<T: Real>(filter: &mut FlightFilter<T>, input: &Input) {
    let c = |x: f32| -> T { nalgebra::convert(f64::from(x)) };
    match input {
        Input::Sample(t, f, w, doubt) => filter.sample(
            *t,
            &Vector3::new(c(f[0]), c(f[1]), c(f[2])),
            &Vector3::new(c(w[0]), c(w[1]), c(w[2])),
            *doubt,
        ),
        Input::Fix(fix) => filter.gnss(fix),
        Input::Pressure(t, p) => filter.pressure(*t, c(*p)),
    }
}

/// A checkpoint's values: position, velocity, attitude, sensor errors, variances.
#[must_use]
pub fn values<T: Real>(filter: &FlightFilter<T>) -> [T; CHECKPOINT_VALUES] {
    let e = filter.estimate();
    let s = &e.sensors;
    let q = e.nav.attitude();
    let mut out = [T::zero(); CHECKPOINT_VALUES];
    let quaternion = [q.w, q.i, q.j, q.k];
    let variances = filter.covariance().diagonal();
    let head = e
        .nav
        .p
        .iter()
        .chain(e.nav.v.iter())
        .chain(quaternion.iter())
        .chain(s.accel_bias.iter())
        .chain(s.gyro_bias.iter())
        .chain(s.accel_scale.iter())
        .chain(s.gyro_scale.iter())
        .chain(core::iter::once(&s.baro_bias))
        .chain(variances.iter());
    for (o, v) in out.iter_mut().zip(head) {
        *o = *v;
    }
    out
}

/// The events as bytes (the module's encoding).
#[must_use]
pub fn encode(events: &[Event]) -> Vec<u8> {
    let mut out = Vec::new();
    let t32 = |t: u64| u32::try_from(t).expect("a golden flight lasts less than an hour");
    for e in events {
        match e {
            Event::Sample(t, raw) => {
                out.push(0);
                out.extend(t32(*t).to_le_bytes());
                for x in raw {
                    out.extend(x.to_le_bytes());
                }
            }
            Event::Environment(t, v) => {
                out.push(3);
                out.extend(t.to_le_bytes());
                out.extend(v.to_le_bytes());
            }
            Event::Fix(fix) => {
                out.push(1);
                out.extend(t32(fix.t_us).to_le_bytes());
                for x in [
                    fix.position.latitude,
                    fix.position.longitude,
                    fix.position.height,
                ] {
                    out.extend(x.to_le_bytes());
                }
                for x in fix.velocity.unwrap_or([f32::NAN; 3]) {
                    out.extend(x.to_le_bytes());
                }
                out.push(fix.satellites);
            }
            Event::Pressure(t, p) => {
                out.push(2);
                out.extend(t32(*t).to_le_bytes());
                out.extend(p.to_le_bytes());
            }
        }
    }
    out
}

/// Rust source of a function `flight_config()` that builds `config` bit for bit
/// (the firmware's `build.rs` writes it for the device's run of the golden flight).
#[must_use]
pub fn config_source(c: &FlightConfig<f32>) -> String {
    let f = |x: f32| format!("f32::from_bits({:#010x})", x.to_bits());
    let d = |x: f64| format!("f64::from_bits({:#018x})", x.to_bits());
    let v = |x: &Vector3<f32>| format!("Vector3::new({}, {}, {})", f(x.x), f(x.y), f(x.z));
    let errors = |s: &SensorErrors<f32>| {
        format!(
            "SensorErrors {{ accel_bias: {}, gyro_bias: {}, accel_scale: {}, gyro_scale: {}, baro_bias: {} }}",
            v(&s.accel_bias),
            v(&s.gyro_bias),
            v(&s.accel_scale),
            v(&s.gyro_scale),
            f(s.baro_bias)
        )
    };
    let n = &c.noise;
    let origin = c.origin.map_or("None".to_string(), |o| {
        format!(
            "Some(Geodetic {{ latitude: {}, longitude: {}, height: {} }})",
            d(o.latitude),
            d(o.longitude),
            d(o.height)
        )
    });
    format!(
        "/// The golden flight's set-up, bit for bit the host's.
pub fn flight_config() -> FlightConfig<f32> {{
    FlightConfig {{
        origin: {origin},
        heading: ({}, {}),
        spin_axis: {},
        lever: {},
        gnss_sigma: ({}, {}),
        gnss_velocity_sigma: {},
        gnss_latency_us: {},
        min_satellites: {},
        baro_sigma: {},
        baro_cp: {},
        baro_mach: {},
        baro_interval_us: {},
        gate: {},
        covariance_interval_us: {},
        navigation_interval_us: {},
        pad_interval_us: {},
        level_us: {},
        launch_force: {},
        doubt: ({}, {}),
        noise: NavNoise {{ accel_white: {}, gyro_white: {}, accel_walk: {}, gyro_walk: {}, scale_walk: {}, baro_walk: {}, receiver_sigma: {}, receiver_tau: {} }},
        sensor_sigma: {},
        launch_shift: {},
    }}
}}
",
        f(c.heading.0),
        f(c.heading.1),
        v(&c.spin_axis),
        v(&c.lever),
        f(c.gnss_sigma.0),
        f(c.gnss_sigma.1),
        f(c.gnss_velocity_sigma),
        c.gnss_latency_us,
        c.min_satellites,
        f(c.baro_sigma),
        f(c.baro_cp),
        f(c.baro_mach),
        c.baro_interval_us,
        f(c.gate),
        c.covariance_interval_us,
        c.navigation_interval_us,
        c.pad_interval_us,
        c.level_us,
        f(c.launch_force),
        f(c.doubt.0),
        f(c.doubt.1),
        f(n.accel_white),
        f(n.gyro_white),
        f(n.accel_walk),
        f(n.gyro_walk),
        f(n.scale_walk),
        f(n.baro_walk),
        v(&n.receiver_sigma),
        f(n.receiver_tau),
        errors(&c.sensor_sigma),
        errors(&c.launch_shift),
    )
}

/// What the firmware's `build.rs` writes for the device's golden flight: the events, the
/// expected checkpoints and the set-up's source.
#[must_use]
pub fn device_files() -> (Vec<u8>, Vec<u8>, String) {
    let flight = flight();
    let config = config::<f32>(&flight);
    let mut filter = FlightFilter::<f32>::new(config);
    let mut bits = Vec::new();
    run(&mut filter, &inputs(&calibration(), &flight.events), |f| {
        for v in values(f) {
            bits.extend(v.to_bits().to_le_bytes());
        }
    });
    (encode(&flight.events), bits, config_source(&config))
}
