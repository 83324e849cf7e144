//! A spin-stabilised shell: a 155 mm projectile of the M107's mass properties and
//! aerodynamics (McCoy, *Modern Exterior Ballistics*, ch. 11, rounded), fired from a rifled
//! barrel. In the bore it accelerates along the barrel with a pressure-curve pulse to the
//! stated peak setback, its spin rising with its speed (the rifling's twist) to the muzzle
//! spin; from the muzzle it flies freely (`body`), a small tip-off rate starting its epicyclic
//! yaw.

use nalgebra::Vector3;

use super::body::{Airframe, State, World};
use super::{Flight, FreeFlight, Thermal, atmosphere::G0, fly, held, pointing, sample};

/// A shell's firing.
#[derive(Debug, Clone, PartialEq)]
pub struct Shell {
    /// The projectile.
    pub airframe: Airframe,
    /// Peak setback, g.
    pub setback_g: f64,
    /// Muzzle velocity, m/s.
    pub muzzle_velocity: f64,
    /// Muzzle spin, rev/s.
    pub muzzle_spin: f64,
    /// Quadrant elevation, degrees.
    pub elevation: f64,
    /// Transverse rate at the muzzle (tip-off), rad/s.
    pub tip_off: f64,
    /// The flight ends after this many seconds, or at impact.
    pub seconds: f64,
    /// The unit's conditioning temperature, C.
    pub conditioned: f64,
    /// Height of the gun above sea level, m.
    pub altitude: f64,
    /// Gravity on.
    pub gravity: bool,
    /// Where on the Earth it is fired (a flat, still Earth without).
    pub site: Option<super::site::Site>,
    /// Time loaded in the gun before firing, s (a still stretch at the start).
    pub loaded: f64,
}

/// The M107's zero-yaw drag against Mach (McCoy, table 11.2, rounded).
pub const M107_DRAG: [(f64, f64); 13] = [
    (0.0, 0.136),
    (0.8, 0.136),
    (0.85, 0.137),
    (0.9, 0.139),
    (0.93, 0.148),
    (0.95, 0.175),
    (1.0, 0.339),
    (1.05, 0.375),
    (1.1, 0.379),
    (1.2, 0.369),
    (1.6, 0.327),
    (2.0, 0.297),
    (2.5, 0.270),
];

impl Default for Shell {
    fn default() -> Self {
        Self {
            airframe: Airframe {
                mass: 43.09,
                burnt_mass: 43.09,
                diameter: 0.154_71,
                ix: 0.1444,
                iy: 1.2353,
                drag: M107_DRAG.to_vec(),
                yaw_drag: 3.0,
                lift: 1.9,
                overturning: 4.0,
                pitch_damping: -10.0,
                spin_damping: -0.025,
                roll_drive: 0.0,
                thrust: Vec::new(),
            },
            setback_g: 15_000.0,
            muzzle_velocity: 800.0,
            muzzle_spin: 300.0,
            elevation: 45.0,
            tip_off: 5.0,
            seconds: 60.0,
            conditioned: 21.0,
            altitude: 0.0,
            gravity: true,
            site: None,
            loaded: LOADED,
        }
    }
}

/// The pressure curve's shape `u^2 (1 - u)^4` over the time in the bore `u = t / T`, scaled to
/// a peak of 1 (at `u = 1/3`): its value, its integral and its double integral from 0.
fn pulse(u: f64) -> (f64, f64, f64) {
    const PEAK: f64 = 16.0 / 729.0;
    let v = u * u * (1.0 - u).powi(4);
    let i1 =
        u.powi(3) / 3.0 - u.powi(4) + 1.2 * u.powi(5) - 2.0 * u.powi(6) / 3.0 + u.powi(7) / 7.0;
    let i2 = u.powi(4) / 12.0 - u.powi(5) / 5.0 + u.powi(6) / 5.0 - 2.0 * u.powi(7) / 21.0
        + u.powi(8) / 56.0;
    (v / PEAK, i1 / PEAK, i2 / PEAK)
}

/// Time the shell rests in the loaded gun before firing unless told, s.
pub const LOADED: f64 = 0.02;

impl Shell {
    /// The time in the bore, s, and the barrel's length, m.
    #[must_use]
    pub fn bore(&self) -> (f64, f64) {
        let a = self.setback_g * G0;
        let (_, one, two) = pulse(1.0);
        let time = self.muzzle_velocity / (a * one);
        (time, a * time * time * two)
    }

    /// Fires the shell, sampling every `dt` s.
    #[must_use]
    pub fn fire(&self, dt: f64) -> Flight {
        let elevation = self.elevation.to_radians();
        let peak = self.setback_g * G0;
        let (bore_time, barrel) = self.bore();
        let spin_per_speed = std::f64::consts::TAU * self.muzzle_spin / self.muzzle_velocity;
        let thermal = Thermal::conditioned_at(self.conditioned);
        let mut out = Flight::default();
        let world = World {
            gravity: self.gravity,
            altitude: self.altitude,
            site: self.site,
        };
        let mut k: i64 = -((self.loaded / dt).round() as i64);
        // Loaded and in the bore: along the barrel, the spin following the speed.
        loop {
            let t = k as f64 * dt;
            if t >= bore_time {
                break;
            }
            let u = (t / bore_time).max(0.0);
            let (shape, one, two) = pulse(u);
            let (a, v, x) = if t < 0.0 {
                (0.0, 0.0, 0.0)
            } else {
                (
                    peak * shape,
                    peak * bore_time * one,
                    peak * bore_time * bore_time * two,
                )
            };
            // The roll angle: the spin times the distance travelled per speed.
            let q = pointing(elevation, spin_per_speed * x);
            let s = State {
                r: q * Vector3::x() * x,
                v: q * Vector3::x() * v,
                q,
                w: Vector3::new(spin_per_speed * v, 0.0, 0.0),
            };
            out.samples.push(sample(
                t,
                &s,
                held(&q, a, &world.gravity_at(&s.r)),
                Vector3::new(spin_per_speed * a, 0.0, 0.0),
                self.conditioned,
            ));
            k += 1;
        }
        out.events.push(("muzzle", bore_time));
        let q = pointing(elevation, spin_per_speed * barrel);
        let start = State {
            r: q * Vector3::x() * barrel,
            v: q * Vector3::x() * self.muzzle_velocity,
            q,
            w: Vector3::new(std::f64::consts::TAU * self.muzzle_spin, self.tip_off, 0.0),
        };
        // From the muzzle to the next sampling instant.
        let t0 = k as f64 * dt;
        let (start, _) =
            super::body::step(&self.airframe, &world, &start, bore_time, t0 - bore_time);
        let from = FreeFlight {
            start,
            t0,
            temp: self.conditioned,
            dt,
            until: self.seconds,
        };
        fly(&self.airframe, &world, &thermal, &from, &mut out);
        out
    }
}
