//! One pass of the filter over a flight: the launch found, the unit levelled at rest (zero
//! velocity and position updates on the pad), the heading found from the GNSS track, then the
//! strapdown navigation with its error-state filter, GNSS and barometer updates, and a record
//! of every epoch for the smoother.

use nalgebra::Vector3;
use spincal::nav::filter::{Doubt, Estimate, StateMatrix, index};
use spincal::nav::{Earth, ErrorFilter, NavNoise, Navigation, Prior, SensorErrors, StateVector};

use super::frame::{level_position, level_velocity, pad_height, pressure_height};
use super::input::{Fix, ImuSeries, Pressure};
use super::launch::{levelled, spin_axis};
use crate::sim::flight::atmosphere;

/// How the filter is set up beyond its inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The GNSS antenna from the IMU, body axes, m.
    pub lever: [f64; 3],
    /// 1-sigma of a GNSS fix, m: horizontal (each axis) and vertical.
    pub gnss_noise: (f64, f64),
    /// 1-sigma of a GNSS velocity, m/s.
    pub gnss_velocity_noise: f64,
    /// How late each fix is stamped, s.
    pub gnss_latency: f64,
    /// The receiver's slowly varying position error, 1-sigma, m (see `flight
    /// --gnss-correlated`): carried into the smoothed track's 1-sigma.
    pub gnss_correlated: f64,
    /// 1-sigma of a barometric height, m.
    pub baro_noise: f64,
    /// Barometer updates per second at most.
    pub baro_rate: f64,
    /// Longest covariance step, s.
    pub max_step: f64,
    /// Specific force that marks the launch, m/s^2.
    pub launch_force: f64,
    /// Innovations beyond this many sigma are refused (and counted).
    pub gate: f64,
    /// What a flagged sample may hide, 1-sigma: specific force (m/s^2) and rate (rad/s).
    pub doubt: (f64, f64),
    /// The barometer is not used from this Mach number up (the shock wave on its port).
    pub baro_mach: f64,
    /// The static port's pressure coefficient, 1-sigma: a port on a moving body reads the
    /// static pressure off by `Cp q`, a height error of `Cp v^2 / 2g` (15 m at 100 m/s for
    /// 0.03) added to the barometer's own.
    pub baro_cp: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            lever: [0.0; 3],
            gnss_noise: (2.5, 5.0),
            gnss_velocity_noise: 0.2,
            gnss_latency: 0.0,
            gnss_correlated: 1.5,
            baro_noise: 1.5,
            baro_rate: 10.0,
            max_step: 0.01,
            launch_force: 2.0 * atmosphere::G0,
            gate: 5.0,
            doubt: (1.0e5, 100.0),
            baro_mach: 0.8,
            baro_cp: 0.03,
        }
    }
}

/// The prior 1-sigma of the pad's position (each axis) and of the barometer's offset, m, when
/// no fix was made on the pad: a shell's first fix comes most of a kilometre downrange.
pub const PAD_UNKNOWN: f64 = 2_000.0;

/// The filter's start: the launch point and the errors' prior and noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    /// Latitude, longitude (degrees) and height (m) of the level frame's origin.
    pub origin: (f64, f64, f64),
    /// The prior of the sensor errors (the rest of the matrix is the filter's to set).
    pub prior: StateMatrix<f64>,
    /// The process noise.
    pub noise: NavNoise<f64>,
    /// Heading of the unit at rest, and its 1-sigma, rad (from the GNSS track).
    pub heading: (f64, f64),
    /// The sensor errors the pass starts from (zero: the calibration holds).
    pub sensors: SensorErrors<f64>,
    /// How the sensor errors change at launch: the transition `T` and the added covariance
    /// `W` ([`InFlight::at_launch`](super::prior::InFlight::at_launch)).
    pub launch: Option<(StateMatrix<f64>, StateMatrix<f64>)>,
}

/// What one measurement said.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Said {
    /// Time, s.
    pub t: f64,
    /// Which measurement.
    pub kind: Kind,
    /// Innovation (measured minus predicted).
    pub value: f64,
    /// Its predicted 1-sigma.
    pub sigma: f64,
    /// Taken (false: beyond the gate).
    pub taken: bool,
}

/// The kinds of measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// On the pad: zero velocity and position.
    Pad,
    /// GNSS position along east, north, up.
    Position(usize),
    /// GNSS velocity.
    Velocity(usize),
    /// Barometric height.
    Baro,
}

/// One epoch of the forward pass: the prediction into it and the estimate after its updates.
#[derive(Debug, Clone)]
pub struct Epoch {
    /// Time, s.
    pub t: f64,
    /// The transition from the previous epoch.
    pub phi: StateMatrix<f64>,
    /// Predicted estimate and covariance.
    pub predicted: (Estimate<f64>, StateMatrix<f64>),
    /// After this epoch's updates.
    pub filtered: (Estimate<f64>, StateMatrix<f64>),
}

/// A pass over the flight.
#[derive(Debug, Clone)]
pub struct Pass {
    /// Every epoch.
    pub epochs: Vec<Epoch>,
    /// Every innovation.
    pub said: Vec<Said>,
    /// Seconds of flagged samples navigated on doubt.
    pub flagged_seconds: f64,
    /// Seconds the barometer was left out near and beyond Mach 1.
    pub baro_skipped_seconds: f64,
    /// The launch, s.
    pub launch: f64,
    /// The prior the pass started from.
    pub p0: StateMatrix<f64>,
    /// The covariance at the last epoch before launch: what the pad taught.
    pub at_launch: StateMatrix<f64>,
    /// When a fix put the navigation back on GNSS after it lost track (its velocity's 1-sigma
    /// over [`spincal::flight::LOST_VELOCITY`], as after a saturated setback), s: as the
    /// device's filter does, where an update would ask the covariance to fall by orders of
    /// magnitude at once.
    pub resets: Vec<f64>,
}

/// The whole prior: the sensor errors' from `start`, the rest from the levelling and the pad.
fn prior(start: &Start, pad_sigma: (f64, f64)) -> StateMatrix<f64> {
    let mut p = start.prior;
    let g = atmosphere::G0;
    let tilt2 = (0..3)
        .map(|i| p[(index::ACCEL_BIAS + i, index::ACCEL_BIAS + i)])
        .fold(0.0, f64::max)
        / (g * g)
        + 1e-6;
    let set = |p: &mut StateMatrix<f64>, i: usize, v: f64| p[(i, i)] = v;
    for i in 0..3 {
        let h = if i == 2 { pad_sigma.1 } else { pad_sigma.0 };
        set(&mut p, index::POSITION + i, h * h);
        set(&mut p, index::VELOCITY + i, 1e-4);
        set(
            &mut p,
            index::ATTITUDE + i,
            if i == 2 {
                start.heading.1.powi(2)
            } else {
                tilt2
            },
        );
    }
    p
}

/// The sensor errors' change at launch (`x = T x + w`, [`Start::launch`]), as an epoch of its
/// own so that the smoother carries it: the covariance is stepped to the launch, the
/// transition and the added covariance applied, and the pass's prior and what the pad taught
/// become the flight's.
fn change_at_launch(
    filter: &mut ErrorFilter<f64>,
    (t, w): &(StateMatrix<f64>, StateMatrix<f64>),
    pass: &mut Pass,
    at: f64,
    since: Option<StateMatrix<f64>>,
) {
    let step = filter.covariance_step().matrix();
    let phi = t * since.map_or(step, |before| step * before);
    // The sensor errors as a state vector (their departure from none), moved by `T - I`.
    let none = Estimate {
        sensors: SensorErrors::default(),
        ..filter.estimate
    };
    let x = filter.estimate.minus(&none);
    filter.estimate = filter.estimate.plus(&((t - StateMatrix::identity()) * x));
    let p = t * filter.covariance * t.transpose() + w;
    filter.covariance = (p + p.transpose()) * 0.5;
    pass.p0 = t * pass.p0 * t.transpose() + w;
    pass.at_launch = filter.covariance;
    let now = (filter.estimate, filter.covariance);
    pass.epochs.push(Epoch {
        t: at,
        phi,
        predicted: now,
        filtered: now,
    });
}

/// Runs the filter over the flight.
#[must_use]
pub fn forward(
    imu: &ImuSeries,
    fixes: &[Fix],
    baro: &[Pressure],
    start: &Start,
    opts: &Options,
    (rest_end, launch_at): (usize, usize),
) -> Pass {
    let earth = Earth::new(start.origin.0.to_radians(), start.origin.2);
    let q0 = levelled(imu, rest_end, start.heading.0);
    let nav = Navigation::at_rest(q0, spin_axis(imu, launch_at));
    let estimate = Estimate {
        nav,
        sensors: start.sensors,
        receiver: Vector3::zeros(),
    };
    let pad_fix = fixes
        .iter()
        .any(|f| imu.t.get(launch_at).is_some_and(|t| f.t < *t));
    // Without a fix on the pad (a GNSS fuze acquires in flight), where the pad is is not known
    // from anything but what the navigation carries back from the first fixes: its prior is
    // wide, the position is not held on the pad, and the barometer's offset is the flight's to
    // learn (its readings are heights above the pad, the frame's origin is a fix's).
    let pad_sigma = if pad_fix {
        (opts.gnss_noise.0, 1.0)
    } else {
        (PAD_UNKNOWN, PAD_UNKNOWN)
    };
    let mut p0 = prior(start, pad_sigma);
    if !pad_fix {
        p0[(index::BARO, index::BARO)] = PAD_UNKNOWN * PAD_UNKNOWN;
    }
    let mut filter = ErrorFilter::new(estimate, &Prior { covariance: p0 }, earth, start.noise);
    let t_launch = imu.t.get(launch_at).copied().unwrap_or(0.0);
    let baro_ref = pad_height(baro, t_launch);
    // An epoch at most per fix, per pressure and per 50 ms on the pad (and one at the launch):
    // kept in place, not copied as the list grows (an epoch is three 25 x 25 matrices).
    let on_pad_s = imu
        .t
        .get(rest_end)
        .zip(imu.t.first())
        .map_or(0.0, |(b, a)| b - a);
    let expected = fixes.len() + baro.len() + (on_pad_s / 0.05).ceil() as usize + 2;
    let mut pass = Pass {
        epochs: Vec::with_capacity(expected),
        said: Vec::new(),
        flagged_seconds: 0.0,
        baro_skipped_seconds: 0.0,
        launch: t_launch,
        p0,
        at_launch: p0,
        resets: Vec::new(),
    };
    let lever = Vector3::from(opts.lever);
    // The antenna's velocity about the unit, `C (w x l)`, summed since the last fix: a fix's
    // velocity is the unit's plus that turn, which a receiver takes over its own short
    // integration somewhere in the fix's interval (a rolling rocket's arm turns through a
    // revolution or more between fixes). The filter predicts the turn's mean over the interval
    // and adds its spread there to the velocity's variance, so a fix taken at any instant of
    // the interval, or averaged over it, fits.
    let (mut arm_v, mut arm_sq, mut arm_n) = (Vector3::zeros(), Vector3::zeros(), 0.0);
    let (mut next_fix, mut next_baro) = (0usize, 0usize);
    let mut last_baro = f64::NEG_INFINITY;
    let mut last_epoch = imu.t.first().copied().unwrap_or(0.0);
    let (doubt_f, doubt_w) = opts.doubt;
    // The transition since the last epoch kept: a covariance step with no measurement is not
    // kept as an epoch of its own but composed into the next (the smoother's gain over the
    // composed step is the same), so that what a pass keeps grows with the flight's fixes and
    // pressures, not its samples.
    let mut phi_since: Option<StateMatrix<f64>> = None;
    for i in 0..imu.t.len() {
        let t = imu.t[i];
        let dt = if i == 0 { 0.0 } else { t - imu.t[i - 1] };
        if i == launch_at
            && i > 0
            && let Some(change) = &start.launch
        {
            change_at_launch(&mut filter, change, &mut pass, t, phi_since.take());
        }
        let [accel, gyro] = imu.flagged[i];
        if accel || gyro {
            pass.flagged_seconds += dt;
        }
        if lever != Vector3::zeros() {
            let turn = filter.estimate.nav.attitude() * Vector3::from(imu.w[i]).cross(&lever);
            arm_v += turn;
            arm_sq += turn.component_mul(&turn);
            arm_n += 1.0;
        }
        filter.sample(
            &Vector3::from(imu.f[i]),
            &Vector3::from(imu.w[i]),
            spincal::nav::Interval::seconds(dt),
            (accel || gyro).then_some(Doubt::of([accel, gyro], doubt_f, doubt_w)),
        );
        let fix_due = fixes
            .get(next_fix)
            .is_some_and(|f| f.t - opts.gnss_latency <= t);
        let baro_due = baro.get(next_baro).is_some_and(|b| b.t <= t);
        let on_pad = i < rest_end && t - last_epoch >= 0.05;
        if !(fix_due || baro_due || on_pad || filter.pending() >= opts.max_step) || i == 0 {
            continue;
        }
        last_epoch = t;
        let step = filter.covariance_step().matrix();
        let phi = phi_since.take().map_or(step, |before| step * before);
        let predicted = (filter.estimate, filter.covariance);
        let (said_before, resets_before) = (pass.said.len(), pass.resets.len());
        if on_pad {
            for axis in 0..3 {
                let h = ErrorFilter::velocity_row(axis);
                let v = filter.estimate.nav.v[axis];
                take(
                    &mut filter,
                    &mut pass.said,
                    (t, Kind::Pad),
                    &h,
                    -v,
                    1e-4,
                    opts.gate,
                );
                if !pad_fix {
                    continue;
                }
                let (h, at) = filter.antenna_row(&Vector3::zeros(), axis);
                take(
                    &mut filter,
                    &mut pass.said,
                    (t, Kind::Pad),
                    &h,
                    -at,
                    1e-4,
                    opts.gate,
                );
            }
        }
        while let Some(fix) = fixes.get(next_fix).filter(|f| f.t - opts.gnss_latency <= t) {
            next_fix += 1;
            let (arm, spread) = if arm_n > 0.0 {
                let mean = arm_v / arm_n;
                (
                    mean,
                    (arm_sq / arm_n - mean.component_mul(&mean)).map(|x| x.max(0.0)),
                )
            } else {
                (Vector3::zeros(), Vector3::zeros())
            };
            (arm_v, arm_sq, arm_n) = (Vector3::zeros(), Vector3::zeros(), 0.0);
            let z = level_position(fix, start.origin);
            // The fix describes an instant up to a sample before this one.
            let back = t - (fix.t - opts.gnss_latency);
            let velocity = level_velocity(fix, start.origin);
            if let Some(vel) = velocity
                && fix.height.is_some()
                && filter.velocity_lost(spincal::flight::LOST_VELOCITY)
            {
                let (h, v) = (opts.gnss_noise.0, opts.gnss_noise.1);
                let r = opts.gnss_velocity_noise;
                let vel = Vector3::from(vel) - arm;
                let offset = filter.estimate.nav.attitude() * lever;
                let at = Vector3::from(z) + vel * back - offset;
                filter.reset_position_velocity(
                    &at,
                    &vel,
                    [
                        h * h,
                        h * h,
                        v * v,
                        r * r + spread.x,
                        r * r + spread.y,
                        r * r + spread.z,
                    ],
                );
                pass.resets.push(t);
                continue;
            }
            let v = filter.estimate.nav.v;
            let axes = if fix.height.is_some() { 3 } else { 2 };
            for (axis, zi) in z.iter().enumerate().take(axes) {
                let (h, at) = filter.antenna_row(&lever, axis);
                let r = if axis == 2 {
                    opts.gnss_noise.1
                } else {
                    opts.gnss_noise.0
                };
                let nu = zi - (at - v[axis] * back);
                take(
                    &mut filter,
                    &mut pass.said,
                    (t, Kind::Position(axis)),
                    &h,
                    nu,
                    r * r,
                    opts.gate,
                );
            }
            if let Some(vel) = velocity {
                // v_true + C_true a = v + dv + C a + psi x (C a): -[(C a) x] psi.
                let m = -arm.cross_matrix();
                for (axis, vi) in vel.iter().enumerate() {
                    let mut h = ErrorFilter::velocity_row(axis);
                    for j in 0..3 {
                        h[index::ATTITUDE + j] = m[(axis, j)];
                    }
                    let nu = vi - (filter.estimate.nav.v[axis] + arm[axis]);
                    let r = opts.gnss_velocity_noise;
                    take(
                        &mut filter,
                        &mut pass.said,
                        (t, Kind::Velocity(axis)),
                        &h,
                        nu,
                        r * r + spread[axis],
                        opts.gate,
                    );
                }
            }
        }
        while let Some(b) = baro.get(next_baro).filter(|b| b.t <= t) {
            next_baro += 1;
            if b.t - last_baro < 1.0 / opts.baro_rate {
                continue;
            }
            let height = start.origin.2 + filter.estimate.nav.p.z;
            let sound = atmosphere::standard(height).sound;
            if filter.estimate.nav.v.norm() >= opts.baro_mach * sound {
                pass.baro_skipped_seconds += (b.t - last_baro).min(1.0 / opts.baro_rate);
                last_baro = b.t;
                continue;
            }
            last_baro = b.t;
            let z = pressure_height(b.pa) - baro_ref;
            let (h, at) = filter.baro_row();
            let v2 = filter.estimate.nav.v.norm_squared();
            let port = opts.baro_cp * v2 / (2.0 * atmosphere::G0);
            let r2 = opts.baro_noise * opts.baro_noise + port * port;
            take(
                &mut filter,
                &mut pass.said,
                (t, Kind::Baro),
                &h,
                z - at,
                r2,
                opts.gate,
            );
        }
        if t < t_launch {
            pass.at_launch = filter.covariance;
        }
        if pass.said.len() == said_before && pass.resets.len() == resets_before {
            // Nothing measured (a covariance step alone, or readings left out): composed into
            // the next epoch kept.
            phi_since = Some(phi);
            continue;
        }
        filter.feedback();
        if t < t_launch {
            pass.at_launch = filter.covariance;
        }
        pass.epochs.push(Epoch {
            t,
            phi,
            predicted,
            filtered: (filter.estimate, filter.covariance),
        });
    }
    pass
}

/// The negative log-likelihood of a pass's aiding innovations up to `until` s: the sum of
/// `nu^2 / s + ln s`, each refused innovation counted at the gate.
#[must_use]
pub fn misfit(pass: &Pass, until: f64, gate: f64) -> f64 {
    pass.said
        .iter()
        .filter(|s| s.kind != Kind::Pad && s.t <= until && s.sigma > 0.0)
        .map(|s| (s.value / s.sigma).powi(2).min(gate * gate) + 2.0 * s.sigma.ln())
        .sum()
}

/// Gates and takes one scalar measurement, recording what it said.
fn take(
    filter: &mut ErrorFilter<f64>,
    said: &mut Vec<Said>,
    (t, kind): (f64, Kind),
    h: &StateVector<f64>,
    innovation: f64,
    variance: f64,
    gate: f64,
) {
    let peek = filter.innovation(h, innovation, variance);
    let sigma = peek.variance.max(0.0).sqrt();
    let taken =
        peek.value.abs() <= gate * sigma && filter.update(h, innovation, variance).is_some();
    said.push(Said {
        t,
        kind,
        value: peek.value,
        sigma,
        taken,
    });
}

/// The heading of the unit at rest: the strapdown navigated from the levelled attitude at
/// heading zero without aiding, its horizontal track against the GNSS track at the first fix
/// at least `min_distance` m from the origin. Returns the heading and its 1-sigma, rad, or
/// `None` when the flight never gets that far.
#[must_use]
pub fn heading(
    imu: &ImuSeries,
    fixes: &[Fix],
    origin: (f64, f64, f64),
    (rest_end, launch_at): (usize, usize),
    noise_h: f64,
    min_distance: f64,
) -> Option<(f64, f64)> {
    let t_launch = *imu.t.get(launch_at)?;
    let pad: Vec<[f64; 3]> = fixes
        .iter()
        .filter(|f| f.t < t_launch)
        .map(|f| level_position(f, origin))
        .collect();
    let start = if pad.is_empty() {
        [0.0; 3]
    } else {
        let n = pad.len() as f64;
        [
            pad.iter().map(|p| p[0]).sum::<f64>() / n,
            pad.iter().map(|p| p[1]).sum::<f64>() / n,
            0.0,
        ]
    };
    // Without a fix on the pad the track is taken from the first fix after launch (where the
    // pad is is not known), the navigation's from its own position then.
    let first = pad
        .is_empty()
        .then(|| fixes.iter().find(|f| f.t > t_launch))
        .flatten();
    let start = first.map_or(start, |f| level_position(f, origin));
    let target = fixes.iter().find(|f| {
        let p = level_position(f, origin);
        f.t > t_launch && (p[0] - start[0]).hypot(p[1] - start[1]) >= min_distance
    })?;
    let earth = Earth::new(origin.0.to_radians(), origin.2);
    let mut nav = Navigation::at_rest(levelled(imu, rest_end, 0.0), spin_axis(imu, launch_at));
    let mut k = 1;
    let mut from = Vector3::zeros();
    while k < imu.t.len() && imu.t[k] <= target.t {
        if first.is_some_and(|f| imu.t[k - 1] < f.t && imu.t[k] >= f.t) {
            from = nav.p;
        }
        let step = spincal::nav::Step {
            w: [Vector3::from(imu.w[k - 1]), Vector3::from(imu.w[k])],
            f: [Vector3::from(imu.f[k - 1]), Vector3::from(imu.f[k])],
            dt: spincal::nav::Interval::seconds(imu.t[k] - imu.t[k - 1]),
        };
        nav.propagate(&earth, &step);
        k += 1;
    }
    let p = level_position(target, origin);
    let (ge, gn) = (p[0] - start[0], p[1] - start[1]);
    let (ie, inn) = (nav.p.x - from.x, nav.p.y - from.y);
    let d = ge.hypot(gn);
    let yaw = gn.atan2(ge) - inn.atan2(ie);
    let mismatch = (d - ie.hypot(inn)).abs();
    let sigma = ((3.0 * noise_h + mismatch) / d).max(2f64.to_radians());
    Some((yaw.sin().atan2(yaw.cos()), sigma))
}
