//! A shell from our round-Earth simulator as a round's own sensors and receiver give it to
//! `spincal::flight`: the corrected samples straight from the truth (the unit's pre-launch
//! errors taken out exactly, so that only the launch shift, the noise and the random walk are
//! left to find; nothing saturates, so the in-bore samples are all trusted), a shift of the
//! axial accelerometer's bias and scale factor after the setback, and a GNSS fuze's fixes:
//! none before muzzle exit plus an acquisition time, each delivered 80 ms after the instant it
//! describes, its velocity in east, north, up at the receiver, its position carrying a
//! correlated (first-order Gauss-Markov) error beside the white one
//! (`calflash::sim::flight::receivers`).
//!
//! The truth of the navigation comes with every sample, in the filter's level frame at the
//! launch point, so a test can hold the filter's position and velocity against their 1-sigma
//! at every epoch.

use calflash::sim::flight::atmosphere;
use calflash::sim::flight::receivers::{Receiver, write_gnss};
use calflash::sim::flight::spec::Launch;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use spincal::flight::{DelayedFlight, FlightConfig, FlightFilter, Geodetic, GnssFix};
use spincal::nav::filter::index;
use spincal::nav::{NavNoise, Real, STATES, SensorErrors};

use crate::flight_golden::{Input, body_to_flight, true_heading};

/// The sample rate, Hz.
pub const RATE: f64 = 2000.0;

/// The corrected samples' white noise: m/s^2/sqrt(Hz) and rad/s/sqrt(Hz).
pub const NOISE: (f64, f64) = (2e-3, 1e-4);

/// What a flight carries and how its receiver errs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// The shell (a `calflash simulate --flight` spec with its site).
    pub spec: &'static str,
    /// The random draws' seed (noise and receiver).
    pub seed: u64,
    /// The axial accelerometer's shift: bias (m/s^2) and scale factor.
    pub shift: (f64, f64),
    /// The roll gyro's scale-factor shift, at the same instant.
    pub roll_scale_shift: f64,
    /// The shift comes this long after muzzle exit, s.
    pub shift_after_muzzle: f64,
    /// The fixes arrive this long after the instant they describe, us.
    pub latency_us: u64,
    /// The receiver's correlated position error: 1-sigma (m, each axis) and time constant (s).
    pub correlated: (f64, f64),
    /// The first fix comes this long after muzzle exit, s.
    pub acquisition: f64,
    /// The accelerometers' bias random walk, m/s^2/sqrt(s), every axis (the filter is told).
    pub walk: f64,
    /// The samples' white noise as a multiple of [`NOISE`]: accelerometers, gyros (1 and 1;
    /// the filter is told [`NOISE`] whatever this is, to see what the noise does).
    pub noise_scale: (f64, f64),
    /// The unit carries residual errors (per axis each bias and scale factor) drawn from the
    /// filter's prior ([`PRIOR_SIGMA`]) rather than none, from the pad on.
    pub residual: bool,
}

/// The filter's prior of the residual errors, 1-sigma: accelerometer bias (m/s^2), gyro bias
/// (rad/s), accelerometer and gyro scale factors.
pub const PRIOR_SIGMA: (f64, f64, f64, f64) = (0.01, 1e-4, 1e-4, 1e-5);

impl Scenario {
    /// A 155 mm-like shell, 20 s from a site at 48.6 N, its axial accelerometer shifting by
    /// +0.04 m/s^2 and +6e-4 5 ms after muzzle exit, fixes 80 ms late from 0.8 s after the
    /// muzzle with a 1.5 m wander of 45 s (the independent reference shell's receiver), the
    /// biases not walking.
    #[must_use]
    pub fn shell(seed: u64) -> Self {
        Self {
            spec: "shell:lat=48.6,lon=-2.2,azimuth=75,rest=1,seconds=20",
            seed,
            shift: (0.04, 6e-4),
            roll_scale_shift: 0.0,
            shift_after_muzzle: 0.005,
            latency_us: 80_000,
            correlated: (1.5, 45.0),
            acquisition: 0.8,
            walk: 0.0,
            noise_scale: (1.0, 1.0),
            residual: false,
        }
    }
}

/// A simulated flight as the filter receives it, and its truth.
#[derive(Debug, Clone)]
pub struct RoundFlight {
    /// The inputs in the order the unit receives them (a fix when it is delivered).
    pub inputs: Vec<Input>,
    /// At each sample: its time (us), the true position and velocity in the level frame at
    /// the launch point (east, north, up; m, m/s).
    pub truth: Vec<(u64, Vector3<f64>, Vector3<f64>)>,
    /// At each sample, the true attitude (body to the level frame).
    pub attitude: Vec<nalgebra::UnitQuaternion<f64>>,
    /// The unit's true heading at rest (rad, as [`FlightConfig::heading`] counts it).
    pub heading: f64,
    /// The launch point.
    pub origin: Geodetic,
    /// The GNSS antenna from the IMU's reference point, body axes, m.
    pub antenna: Vector3<f64>,
    /// When the shift comes, us.
    pub shift_us: u64,
    /// The axial accelerometer's residual bias and scale factor before the shift
    /// ([`Scenario::residual`]; zero without).
    pub axial_residual: (f64, f64),
    /// The scenario.
    pub scenario: Scenario,
}

/// Flies `scenario`.
///
/// # Panics
/// If the simulator refuses the spec or the receiver's file does not parse (neither does).
#[must_use]
pub fn fly(scenario: &Scenario) -> RoundFlight {
    let mut launch = Launch::parse(scenario.spec).expect("the scenario's spec");
    let site = launch.site_mut().expect("the scenario names its site");
    let flown = launch.fly(1.0 / RATE);
    let muzzle = flown
        .events
        .iter()
        .find(|e| e.0 == "muzzle")
        .map_or(0.0, |e| e.1);
    let to_level = site.to_level();
    let earth_rate = site.rate();
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let per_sample = |density: f64| Normal::new(0.0, density * RATE.sqrt()).expect("sigma");
    let (na, ng, pa) = (
        per_sample(NOISE.0 * scenario.noise_scale.0),
        per_sample(NOISE.1 * scenario.noise_scale.1),
        Normal::new(0.0, 2.0).expect("sigma"),
    );
    let t0 = flown.samples.first().map_or(0.0, |s| s.t);
    let us = |t: f64| ((t - t0) * 1e6).round() as u64;
    let shift_at = muzzle + scenario.shift_after_muzzle;
    let step = Normal::new(0.0, scenario.walk / RATE.sqrt()).expect("sigma");
    let mut walked = Vector3::<f64>::zeros();
    // The residual errors, from draws of their own (the noise's stay as without them).
    let residual = {
        let mut own = ChaCha8Rng::seed_from_u64(scenario.seed ^ 0x005e_ed0f_e770);
        let mut draw = |sigma: f64| {
            let n = Normal::new(0.0, sigma).expect("sigma");
            Vector3::from_fn(|_, _| {
                if scenario.residual {
                    n.sample(&mut own)
                } else {
                    0.0
                }
            })
        };
        let (ab, gb, as_, gs) = PRIOR_SIGMA;
        [draw(ab), draw(gb), draw(as_), draw(gs)]
    };
    // (delivery time, order, input): samples first at a tie, then what arrives with them.
    let mut timed: Vec<(u64, u8, Input)> = Vec::new();
    let mut truth = Vec::with_capacity(flown.samples.len());
    let mut attitude = Vec::with_capacity(flown.samples.len());
    let level = nalgebra::UnitQuaternion::from_matrix(&to_level);
    let mut heading = 0.0;
    for (k, s) in flown.samples.iter().enumerate() {
        let t_us = us(s.t);
        let q = body_to_flight(s.q);
        let mut f = Vector3::from(s.f);
        let mut w = Vector3::from(s.w) + q.inverse() * earth_rate;
        if k == 0 {
            heading = true_heading(&(to_level * q.to_rotation_matrix().into_inner()), &f);
        }
        if s.t >= shift_at {
            f.x = f.x * (1.0 + scenario.shift.1) + scenario.shift.0;
            w.x *= 1.0 + scenario.roll_scale_shift;
        }
        walked += Vector3::from_fn(|_, _| step.sample(&mut rng));
        f += walked;
        let [ab, gb, as_, gs] = &residual;
        f += f.component_mul(as_) + ab;
        w += w.component_mul(gs) + gb;
        let fm: [f32; 3] = core::array::from_fn(|i| (f[i] + na.sample(&mut rng)) as f32);
        let wm: [f32; 3] = core::array::from_fn(|i| (w[i] + ng.sample(&mut rng)) as f32);
        timed.push((t_us, 0, Input::Sample(t_us, fm, wm, [false, false])));
        attitude.push(level * q);
        truth.push((
            t_us,
            to_level * Vector3::from(s.r),
            to_level * Vector3::from(s.v),
        ));
        if k.is_multiple_of(RATE as usize / 100) {
            let p = atmosphere::standard(site.height + s.r[2]).pressure + pa.sample(&mut rng);
            timed.push((t_us, 1, Input::Pressure(t_us, p as f32)));
        }
    }
    let receiver = Receiver {
        outage: muzzle + scenario.acquisition,
        in_flight_only: true,
        correlated: scenario.correlated,
        ..Receiver::default()
    };
    let mut file = Vec::new();
    write_gnss(&flown.samples, &site, &receiver, &mut rng, &mut file).expect("in memory");
    let text = String::from_utf8(file).expect("the receiver writes text");
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.parse().expect("a number"))
            .collect();
        let t_us = us(v[0]);
        timed.push((
            t_us + scenario.latency_us,
            2,
            Input::Fix(GnssFix {
                t_us,
                position: Geodetic {
                    latitude: v[1],
                    longitude: v[2],
                    height: v[3],
                },
                velocity: Some([v[4] as f32, v[5] as f32, v[6] as f32]),
                satellites: 12,
            }),
        ));
    }
    timed.sort_by_key(|e| (e.0, e.1));
    RoundFlight {
        inputs: timed.into_iter().map(|e| e.2).collect(),
        truth,
        attitude,
        heading,
        antenna: Vector3::zeros(),
        origin: Geodetic {
            latitude: site.latitude,
            longitude: site.longitude,
            height: site.height,
        },
        shift_us: us(shift_at),
        axial_residual: (residual[0].x, residual[2].x),
        scenario: *scenario,
    }
}

/// The filter's set-up for `flight`: the receiver as the scenario says (white 2 m / 4 m /
/// 0.1 m/s, the correlated part, the latency), the heading off by 1 degree with a 2-degree
/// sigma, the pre-launch errors' prior small (they were taken out), a launch shift that
/// covers the scenario's.
#[must_use]
pub fn config<T: Real>(flight: &RoundFlight) -> FlightConfig<T> {
    let c = |x: f64| -> T { nalgebra::convert(x) };
    let noise = NavNoise {
        accel_white: c(NOISE.0),
        gyro_white: c(NOISE.1),
        accel_walk: c(flight.scenario.walk.max(1e-5)),
        gyro_walk: c(1e-6),
        scale_walk: c(1e-7),
        baro_walk: c(0.1),
        receiver_sigma: Vector3::zeros(),
        receiver_tau: c(0.0),
    };
    let prior = SensorErrors {
        accel_bias: Vector3::repeat(c(PRIOR_SIGMA.0)),
        gyro_bias: Vector3::repeat(c(PRIOR_SIGMA.1)),
        accel_scale: Vector3::repeat(c(PRIOR_SIGMA.2)),
        gyro_scale: Vector3::repeat(c(PRIOR_SIGMA.3)),
        baro_bias: c(5.0),
    };
    let mut config = FlightConfig::new(
        (c(flight.heading + 1f64.to_radians()), c(2f64.to_radians())),
        noise,
        prior,
    );
    receiver(&mut config, flight);
    config.launch_shift = SensorErrors {
        accel_bias: Vector3::repeat(c(0.1)),
        gyro_bias: Vector3::repeat(c(1e-3)),
        accel_scale: Vector3::repeat(c(2e-3)),
        gyro_scale: Vector3::repeat(c(1e-4)),
        baro_bias: c(5.0),
    };
    config
}

/// How the filter held its own 1-sigma over a flight, from its first GNSS update on.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Held {
    /// Epochs counted.
    pub epochs: usize,
    /// Of them, those with every position axis within 3 sigma of the truth.
    pub position_inside: usize,
    /// Likewise the velocity.
    pub velocity_inside: usize,
    /// Sums of the position's and the velocity's NEES (3 degrees of freedom each).
    pub nees: (f64, f64),
    /// At the end: the position error (m) and velocity error (m/s), 3-D.
    pub end: (f64, f64),
    /// At the end, the same errors' stated 1-sigma (3-D, root of the trace).
    pub end_sigma: (f64, f64),
}

impl Held {
    /// The fractions of epochs inside 3 sigma: position, velocity.
    #[must_use]
    pub fn inside(&self) -> (f64, f64) {
        let n = self.epochs.max(1) as f64;
        (
            self.position_inside as f64 / n,
            self.velocity_inside as f64 / n,
        )
    }
}

impl core::fmt::Display for Held {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (p, v) = self.inside();
        write!(
            f,
            "position within 3 sigma on {:.1} % of {} epochs, velocity {:.1} %; end error {:.2} m \
             (stated {:.2}), {:.3} m/s (stated {:.3})",
            100.0 * p,
            self.epochs,
            100.0 * v,
            self.end.0,
            self.end_sigma.0,
            self.end.1,
            self.end_sigma.1
        )
    }
}

/// Sets `config` up for `flight`'s receiver: the launch point given, its antenna, the fixes' white 2 m /
/// 4 m / 0.1 m/s, their latency, and their correlated wander as the receiver's states.
pub fn receiver<T: Real>(config: &mut FlightConfig<T>, flight: &RoundFlight) {
    let c = |x: f64| -> T { nalgebra::convert(x) };
    let (sigma, tau) = flight.scenario.correlated;
    config.origin = Some(flight.origin);
    config.lever = flight.antenna.map(c);
    config.gnss_sigma = (c(2.0), c(4.0));
    config.gnss_velocity_sigma = c(0.1);
    config.gnss_latency_us = u32::try_from(flight.scenario.latency_us).expect("a latency");
    config.noise.receiver_sigma = Vector3::repeat(c(sigma));
    config.noise.receiver_tau = c(tau);
}

/// A flight filter the harness can feed: [`FlightFilter`] itself, or run on a delayed
/// horizon ([`DelayedFlight`]).
pub trait Flown<T: Real> {
    /// One input.
    fn feed(&mut self, input: &Input);
    /// The filter inside.
    fn filter(&self) -> &FlightFilter<T>;
    /// Everything held, to the filter (the end of the flight).
    fn flush(&mut self) {}
}

impl<T: Real> Flown<T> for FlightFilter<T> {
    fn feed(&mut self, input: &Input) {
        crate::flight_golden::feed(self, input);
    }
    fn filter(&self) -> &FlightFilter<T> {
        self
    }
}

impl<T: Real, const N: usize> Flown<T> for DelayedFlight<T, N> {
    fn feed(&mut self, input: &Input) {
        let c = |x: f32| -> T { nalgebra::convert(f64::from(x)) };
        match input {
            Input::Sample(t, f, w, doubt) => self.sample(
                *t,
                &Vector3::new(c(f[0]), c(f[1]), c(f[2])),
                &Vector3::new(c(w[0]), c(w[1]), c(w[2])),
                *doubt,
            ),
            Input::Fix(fix) => self.gnss(fix),
            Input::Pressure(t, p) => self.pressure(*t, c(*p)),
        }
    }
    fn filter(&self) -> &FlightFilter<T> {
        DelayedFlight::filter(self)
    }
    fn flush(&mut self) {
        DelayedFlight::flush(self);
    }
}

/// The delayed horizon's buffer the round-Earth and reference shells are run on: 1,024 samples
/// (512 ms at 2 kHz, 102 ms at 10 kHz), more than their 80 ms latency at either rate.
pub const HORIZON_SAMPLES: usize = 1024;

/// `flown` over `flight`, the navigation held against the truth at every epoch after the
/// first fix (at the filter's own instant, the horizon's age when it runs delayed); calls
/// `each` after every input, and flushes at the end.
pub fn run<T: Real, F: Flown<T>>(
    flown: &mut F,
    flight: &RoundFlight,
    mut each: impl FnMut(&FlightFilter<T>),
) -> Held {
    let mut held = Held::default();
    let truth = &flight.truth;
    let mut k = 0usize;
    for input in &flight.inputs {
        let before = flown.filter().stats().epochs;
        flown.feed(input);
        let filter = flown.filter();
        each(filter);
        let fixed = filter.stats().taken[spincal::flight::Aiding::Position as usize] > 0;
        let Some(t) = filter.now_us() else {
            continue;
        };
        if filter.stats().epochs == before || !fixed {
            continue;
        }
        // The truth at this sample, between its rows (a reference flight's are 5 ms apart).
        while k + 1 < truth.len() && truth[k + 1].0 <= t {
            k += 1;
        }
        let (Some(a), Some(b)) = (truth.get(k), truth.get(k + 1)) else {
            continue;
        };
        if a.0 > t {
            continue;
        }
        let u = (t - a.0) as f64 / (b.0 - a.0).max(1) as f64;
        let p = a.1 + (b.1 - a.1) * u;
        let v = a.2 + (b.2 - a.2) * u;
        let e = filter.estimate();
        let cov = filter.covariance();
        let dp: Vector3<f64> = Vector3::from_fn(|i, _| p[i] - e.nav.p[i].to_f64());
        let dv: Vector3<f64> = Vector3::from_fn(|i, _| v[i] - e.nav.v[i].to_f64());
        let block = |at: usize| nalgebra::Matrix3::from_fn(|i, j| cov[(at + i, at + j)].to_f64());
        let (pp, pv) = (block(index::POSITION), block(index::VELOCITY));
        let within = |d: &Vector3<f64>, m: &nalgebra::Matrix3<f64>| {
            (0..3).all(|i| d[i].abs() <= 3.0 * m[(i, i)].max(0.0).sqrt())
        };
        let nees = |d: &Vector3<f64>, m: &nalgebra::Matrix3<f64>| {
            m.cholesky().map_or(f64::INFINITY, |c| d.dot(&c.solve(d)))
        };
        held.epochs += 1;
        held.position_inside += usize::from(within(&dp, &pp));
        held.velocity_inside += usize::from(within(&dv, &pv));
        held.nees.0 += nees(&dp, &pp);
        held.nees.1 += nees(&dv, &pv);
        held.end = (dp.norm(), dv.norm());
        held.end_sigma = (pp.trace().sqrt(), pv.trace().sqrt());
    }
    flown.flush();
    held
}

/// The axial accelerometer's estimate against its truth after the shift (the scenario's shift
/// on its residual error), in the filter's own sigma: bias, then scale factor.
#[must_use]
pub fn axial_z<T: Real>(filter: &FlightFilter<T>, flight: &RoundFlight) -> (f64, f64) {
    let s = &filter.estimate().sensors;
    let p = filter.covariance();
    let z = |x: T, at: usize, truth: f64| (x.to_f64() - truth) / p[(at, at)].to_f64().sqrt();
    // The output after the shift: ((1 + k) f + b) (1 + k1) + b1.
    let ((b, k), (b1, k1)) = (flight.axial_residual, flight.scenario.shift);
    (
        z(s.accel_bias.x, index::ACCEL_BIAS, b * (1.0 + k1) + b1),
        z(s.accel_scale.x, index::ACCEL_SCALE, k + k1 + k * k1),
    )
}

/// The roll gyro's scale-factor estimate against the scenario's shift, in the filter's own
/// sigma.
#[must_use]
pub fn roll_scale_z<T: Real>(filter: &FlightFilter<T>, flight: &RoundFlight) -> f64 {
    let x = filter.estimate().sensors.gyro_scale.x.to_f64();
    let p = filter.covariance()[(index::GYRO_SCALE, index::GYRO_SCALE)].to_f64();
    (x - flight.scenario.roll_scale_shift) / p.sqrt()
}

/// The state of `a` against `b` in `b`'s sigma: the largest ratio and the state it is in.
#[must_use]
pub fn departure(a: &FlightFilter<f32>, b: &FlightFilter<f64>) -> (f64, usize) {
    let (ea, eb) = (a.estimate(), b.estimate());
    let mut d = [0.0f64; STATES];
    for i in 0..3 {
        d[index::POSITION + i] = f64::from(ea.nav.p[i]) - eb.nav.p[i];
        d[index::VELOCITY + i] = f64::from(ea.nav.v[i]) - eb.nav.v[i];
        d[index::ACCEL_BIAS + i] = f64::from(ea.sensors.accel_bias[i]) - eb.sensors.accel_bias[i];
        d[index::GYRO_BIAS + i] = f64::from(ea.sensors.gyro_bias[i]) - eb.sensors.gyro_bias[i];
        d[index::ACCEL_SCALE + i] =
            f64::from(ea.sensors.accel_scale[i]) - eb.sensors.accel_scale[i];
        d[index::GYRO_SCALE + i] = f64::from(ea.sensors.gyro_scale[i]) - eb.sensors.gyro_scale[i];
        d[index::RECEIVER + i] = f64::from(ea.receiver[i]) - eb.receiver[i];
    }
    d[index::BARO] = f64::from(ea.sensors.baro_bias) - eb.sensors.baro_bias;
    let qa = ea.nav.attitude().cast::<f64>();
    let turn = (qa * eb.nav.attitude().inverse()).scaled_axis();
    for i in 0..3 {
        d[index::ATTITUDE + i] = turn[i];
    }
    let p = b.covariance();
    (0..STATES)
        .filter(|i| p[(*i, *i)] > 0.0)
        .map(|i| (d[i].abs() / p[(i, i)].sqrt(), i))
        .fold((0.0, 0), |m, x| if x.0 > m.0 { x } else { m })
}
