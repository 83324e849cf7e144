//! A fin-stabilised sounding rocket (about the size of the Hedy flight in `../shared/data`: 30
//! kg, 156 mm, a 6 s motor of 1.8 kN): it waits on its launch rail until the thrust lifts it,
//! runs up the rail, then flies freely (`body`): canted fins roll it towards the steady rate
//! where their drive and the roll damping balance, `p = -C_l_delta delta V / (C_lp d)`; the
//! motor burns out and it coasts past apogee. No recovery system is modelled.

use nalgebra::Vector3;

use super::body::{self, Airframe, State, World};
use super::{Flight, FreeFlight, Thermal, fly, held, pointing, sample};

/// A rocket's launch.
#[derive(Debug, Clone, PartialEq)]
pub struct Rocket {
    /// The rocket.
    pub airframe: Airframe,
    /// Launch rail's elevation, degrees.
    pub elevation: f64,
    /// Rail length, m.
    pub rail: f64,
    /// The flight ends after this many seconds, or at impact.
    pub seconds: f64,
    /// The unit's conditioning temperature, C.
    pub conditioned: f64,
    /// Height of the pad above sea level, m.
    pub altitude: f64,
    /// Gravity on.
    pub gravity: bool,
    /// Where on the Earth it is launched (a flat, still Earth without).
    pub site: Option<super::site::Site>,
    /// Time on the rail before ignition, s (a still stretch at the start).
    pub waiting: f64,
}

/// A rocket whose thrust never lifts it along its rail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "a thrust of {peak} N never leaves its rail: the rocket's {mass} kg weigh {along:.0} N along a rail at {elevation} degrees; give thrust= above that"
)]
pub struct Grounded {
    /// Its peak thrust, N.
    pub peak: f64,
    /// Its mass, kg.
    pub mass: f64,
    /// Its weight along the rail, N.
    pub along: f64,
    /// The rail's elevation, degrees.
    pub elevation: f64,
}

impl Rocket {
    /// Refuses a rocket that cannot fly: its peak thrust does not lift its weight along the
    /// rail (it would sit on the rail until the simulation ends).
    ///
    /// # Errors
    /// [`Grounded`]: its weight along the rail and its peak thrust.
    pub fn flies(&self) -> Result<(), Grounded> {
        let peak = self.airframe.thrust.iter().map(|p| p.1).fold(0.0, f64::max);
        let along = self.airframe.mass * super::atmosphere::G0 * self.elevation.to_radians().sin();
        if peak <= along {
            return Err(Grounded {
                peak,
                mass: self.airframe.mass,
                along,
                elevation: self.elevation,
            });
        }
        Ok(())
    }
}

impl Default for Rocket {
    fn default() -> Self {
        Self {
            airframe: Airframe {
                mass: 30.0,
                burnt_mass: 24.0,
                diameter: 0.156,
                ix: 0.09,
                iy: 22.5,
                drag: vec![
                    (0.0, 0.45),
                    (0.8, 0.47),
                    (0.9, 0.52),
                    (1.0, 0.65),
                    (1.2, 0.60),
                    (2.0, 0.45),
                ],
                yaw_drag: 5.0,
                lift: 12.0,
                overturning: -25.0,
                pitch_damping: -600.0,
                spin_damping: -5.0,
                roll_drive: 0.077,
                thrust: vec![(0.0, 0.0), (0.05, 1_800.0), (5.9, 1_800.0), (6.0, 0.0)],
            },
            elevation: 84.0,
            rail: 12.0,
            seconds: 300.0,
            conditioned: 25.0,
            altitude: 0.0,
            gravity: true,
            site: None,
            waiting: 0.0,
        }
    }
}

/// Steps the rail phase takes per sampling step.
const RAIL_SUBSTEPS: usize = 20;

impl Rocket {
    /// Launches the rocket, sampling every `dt` s.
    #[must_use]
    pub fn launch(&self, dt: f64) -> Flight {
        let q = pointing(self.elevation.to_radians(), 0.0);
        let axis = q * Vector3::x();
        let world = World {
            gravity: self.gravity,
            altitude: self.altitude,
            site: self.site,
        };
        let thermal = Thermal::conditioned_at(self.conditioned);
        let mut out = Flight::default();
        // On the rail: along its axis only, held against gravity across it.
        let along = |t: f64, x: f64, v: f64| {
            let s = State {
                r: axis * x,
                v: axis * v,
                q,
                w: Vector3::zeros(),
            };
            let a = body::felt(&self.airframe, &world, &s, t).a.dot(&axis);
            if v <= 0.0 && a <= 0.0 { 0.0 } else { a }
        };
        let mut k: i64 = -((self.waiting / dt).round() as i64);
        let (mut t, mut x, mut v) = (k as f64 * dt, 0.0f64, 0.0f64);
        let h = dt / RAIL_SUBSTEPS as f64;
        while x < self.rail && t < self.seconds {
            let a = along(t, x, v);
            let s = State {
                r: axis * x,
                v: axis * v,
                q,
                w: Vector3::zeros(),
            };
            out.samples.push(sample(
                t,
                &s,
                held(&q, a, &world.gravity_at(&s.r)),
                Vector3::zeros(),
                self.conditioned,
            ));
            for j in 0..RAIL_SUBSTEPS {
                // Runge-Kutta on (x, v).
                let tj = t + j as f64 * h;
                let (k1x, k1v) = (v, along(tj, x, v));
                let (k2x, k2v) = (
                    v + 0.5 * h * k1v,
                    along(tj + 0.5 * h, x + 0.5 * h * k1x, v + 0.5 * h * k1v),
                );
                let (k3x, k3v) = (
                    v + 0.5 * h * k2v,
                    along(tj + 0.5 * h, x + 0.5 * h * k2x, v + 0.5 * h * k2v),
                );
                let (k4x, k4v) = (v + h * k3v, along(tj + h, x + h * k3x, v + h * k3v));
                x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                v = (v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)).max(0.0);
            }
            k += 1;
            t = k as f64 * dt;
        }
        out.events.push(("rail exit", t));
        let from = FreeFlight {
            start: State {
                r: axis * x,
                v: axis * v,
                q,
                w: Vector3::zeros(),
            },
            t0: t,
            temp: self.conditioned,
            dt,
            until: self.seconds,
        };
        fly(&self.airframe, &world, &thermal, &from, &mut out);
        out
    }
}
