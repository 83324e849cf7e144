//! A rigid, axially symmetric airframe in free flight: six degrees of freedom over a flat,
//! non-rotating Earth (x downrange, y left, z up; constant gravity), in the standard
//! atmosphere, with the aerodynamics of linear theory (McCoy, *Modern Exterior Ballistics*):
//! drag against Mach with a yaw-drag term, lift, the overturning (or, negative, restoring)
//! moment, pitch damping, spin damping and a roll drive (canted fins), and a thrust along
//! the axis. Integrated by classical Runge-Kutta at the sampling step; the attitude is a unit
//! quaternion, renormalised every step.
//!
//! The unit sits at the centre of mass: it feels the specific force `(F_aero + T) / m` and the
//! body's rate and angular acceleration, all in body axes (x the axis of symmetry, forward).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::atmosphere::{self, G0};
use super::site::Site;

/// An airframe and its aerodynamic coefficients (per radian, reference area `pi d^2 / 4`,
/// reference length `d`).
#[derive(Debug, Clone, PartialEq)]
pub struct Airframe {
    /// Mass at launch, kg.
    pub mass: f64,
    /// Mass when the motor has burnt out, kg (the launch mass for a shell).
    pub burnt_mass: f64,
    /// Diameter, m.
    pub diameter: f64,
    /// Axial moment of inertia, kg m^2.
    pub ix: f64,
    /// Transverse moment of inertia, kg m^2.
    pub iy: f64,
    /// Zero-yaw drag coefficient against Mach: `(Mach, C_D0)`, increasing Mach.
    pub drag: Vec<(f64, f64)>,
    /// Yaw drag, `C_D = C_D0 + C_Da2 sin^2(alpha)`.
    pub yaw_drag: f64,
    /// Lift-force slope `C_La`.
    pub lift: f64,
    /// Overturning moment slope `C_Ma` (positive: spin-stabilised; negative: fin-stable).
    pub overturning: f64,
    /// Pitch damping `C_Mq + C_Ma_dot` (negative damps).
    pub pitch_damping: f64,
    /// Spin damping `C_lp` (per `p d / V`; negative damps).
    pub spin_damping: f64,
    /// Roll drive of canted fins, `C_l_delta delta`.
    pub roll_drive: f64,
    /// Thrust against time since launch: `(s, N)`, linear between; none for a shell.
    pub thrust: Vec<(f64, f64)>,
}

/// Linear interpolation in a table of increasing `x`, held at its ends.
#[must_use]
pub fn interpolate(table: &[(f64, f64)], x: f64) -> f64 {
    match table {
        [] => 0.0,
        [(_, y)] => *y,
        _ => {
            let k = table.partition_point(|p| p.0 <= x);
            if k == 0 {
                return table[0].1;
            }
            if k == table.len() {
                return table[k - 1].1;
            }
            let ((x0, y0), (x1, y1)) = (table[k - 1], table[k]);
            y0 + (y1 - y0) * (x - x0) / (x1 - x0)
        }
    }
}

impl Airframe {
    /// Reference area, m^2.
    #[must_use]
    pub fn area(&self) -> f64 {
        std::f64::consts::PI * self.diameter * self.diameter / 4.0
    }

    /// The thrust at time `t`, N.
    #[must_use]
    pub fn thrust_at(&self, t: f64) -> f64 {
        if self.thrust.is_empty()
            || t < self.thrust[0].0
            || t > self.thrust[self.thrust.len() - 1].0
        {
            return 0.0;
        }
        interpolate(&self.thrust, t)
    }

    /// When the motor burns out, s (0 without one).
    #[must_use]
    pub fn burnout(&self) -> f64 {
        self.thrust.last().map_or(0.0, |p| p.0)
    }

    /// The mass at time `t`: propellant burnt in proportion to the impulse delivered.
    #[must_use]
    pub fn mass_at(&self, t: f64) -> f64 {
        let total = impulse(&self.thrust, f64::INFINITY);
        if total <= 0.0 {
            return self.mass;
        }
        self.mass - (self.mass - self.burnt_mass) * impulse(&self.thrust, t) / total
    }
}

/// The impulse of a thrust table up to time `t`, N s.
fn impulse(table: &[(f64, f64)], t: f64) -> f64 {
    table
        .windows(2)
        .map(|w| {
            let ((a, fa), (b, fb)) = (w[0], w[1]);
            if t <= a {
                0.0
            } else if t >= b {
                0.5 * (fa + fb) * (b - a)
            } else {
                let ft = fa + (fb - fa) * (t - a) / (b - a);
                0.5 * (fa + ft) * (t - a)
            }
        })
        .sum()
}

/// The body's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Position, m (z is height above the launch point).
    pub r: Vector3<f64>,
    /// Velocity, m/s.
    pub v: Vector3<f64>,
    /// Attitude, body to Earth.
    pub q: UnitQuaternion<f64>,
    /// Rate in body axes, rad/s.
    pub w: Vector3<f64>,
}

/// What the unit feels, and the state's rates of change.
#[derive(Debug, Clone, Copy)]
pub struct Felt {
    /// Specific force in body axes, m/s^2.
    pub f: Vector3<f64>,
    /// Angular acceleration in body axes, rad/s^2.
    pub dw: Vector3<f64>,
    /// Acceleration in Earth axes, m/s^2.
    pub a: Vector3<f64>,
}

/// The environment of a flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct World {
    /// Gravity on (off: the linear-theory checks).
    pub gravity: bool,
    /// Height of the launch point above sea level, m.
    pub altitude: f64,
    /// Where on the Earth (its gravity and rotation), or a flat, still Earth.
    pub site: Option<Site>,
}

impl World {
    /// Gravity at `r`, m/s^2, flight frame.
    #[must_use]
    pub fn gravity_at(&self, r: &Vector3<f64>) -> Vector3<f64> {
        match (self.gravity, &self.site) {
            (false, _) => Vector3::zeros(),
            (true, Some(site)) => site.gravity(r),
            (true, None) => Vector3::new(0.0, 0.0, -G0),
        }
    }

    /// The Earth's rate in the flight frame (zero over a still Earth), rad/s.
    #[must_use]
    pub fn earth_rate(&self) -> Vector3<f64> {
        self.site.map_or_else(Vector3::zeros, |s| s.rate())
    }
}

/// What the body feels in state `s` at time `t`.
#[must_use]
pub fn felt(af: &Airframe, world: &World, s: &State, t: f64) -> Felt {
    let g = world.gravity_at(&s.r) - world.earth_rate().cross(&s.v) * 2.0;
    let x = s.q * Vector3::x();
    let speed = s.v.norm();
    let mass = af.mass_at(t);
    let mut force = x * af.thrust_at(t);
    let mut moment = Vector3::zeros();
    if speed > 1e-9 {
        let air = atmosphere::standard(world.altitude + s.r.z);
        let vhat = s.v / speed;
        let qs = 0.5 * air.density * speed * speed * af.area();
        let d = af.diameter;
        let across = x - vhat * x.dot(&vhat);
        let sin2 = across.norm_squared();
        let cd = interpolate(&af.drag, speed / air.sound) + af.yaw_drag * sin2;
        force += -vhat * (qs * cd) + across * (qs * af.lift);
        let w_earth = s.q * s.w;
        let w_across = w_earth - x * w_earth.dot(&x);
        moment += vhat.cross(&x) * (qs * d * af.overturning)
            + w_across * (qs * d * d / speed * af.pitch_damping)
            + x * (qs * d * (af.roll_drive + af.spin_damping * s.w.x * d / speed));
    }
    let m_body = s.q.inverse() * moment;
    let inertia = Vector3::new(af.ix, af.iy, af.iy);
    let gyroscopic = s.w.cross(&inertia.component_mul(&s.w));
    let dw = (m_body - gyroscopic).component_div(&inertia);
    Felt {
        f: s.q.inverse() * (force / mass),
        dw,
        a: force / mass + g,
    }
}

/// The state's rate of change.
fn derivative(af: &Airframe, world: &World, s: &State, t: f64) -> (Felt, [f64; 13]) {
    let felt = felt(af, world, s, t);
    let q = s.q.quaternion();
    let dq = q * Quaternion::from_parts(0.0, s.w) * 0.5;
    let d = [
        s.v.x, s.v.y, s.v.z, felt.a.x, felt.a.y, felt.a.z, dq.w, dq.i, dq.j, dq.k, felt.dw.x,
        felt.dw.y, felt.dw.z,
    ];
    (felt, d)
}

fn pack(s: &State) -> [f64; 13] {
    let q = s.q.quaternion();
    [
        s.r.x, s.r.y, s.r.z, s.v.x, s.v.y, s.v.z, q.w, q.i, q.j, q.k, s.w.x, s.w.y, s.w.z,
    ]
}

fn unpack(y: &[f64; 13]) -> State {
    State {
        r: Vector3::new(y[0], y[1], y[2]),
        v: Vector3::new(y[3], y[4], y[5]),
        q: UnitQuaternion::from_quaternion(Quaternion::new(y[6], y[7], y[8], y[9])),
        w: Vector3::new(y[10], y[11], y[12]),
    }
}

/// The largest turn, rad, one Runge-Kutta step may take: RK4 on the quaternion loses about
/// `(theta/2)^5 / 60` rad per step, so a round at 300 rev/s sampled at 2 kHz (0.94 rad per
/// sample) would drift 1e-4 of its roll against its own rate; at 0.2 rad it is 1e-7.
pub const MAX_TURN: f64 = 0.2;

/// One step of `dt` from `s` at `t` (in Runge-Kutta steps of at most [`MAX_TURN`]): the new
/// state, and what the body felt at the start of the step.
#[must_use]
pub fn step(af: &Airframe, world: &World, s: &State, t: f64, dt: f64) -> (State, Felt) {
    let n = ((s.w.norm() * dt.abs() / MAX_TURN).ceil() as usize).clamp(1, 10_000);
    let h = dt / n as f64;
    let (mut state, felt) = rk4(af, world, s, t, h);
    for k in 1..n {
        state = rk4(af, world, &state, t + k as f64 * h, h).0;
    }
    (state, felt)
}

/// One Runge-Kutta step of `dt` from `s` at `t`.
fn rk4(af: &Airframe, world: &World, s: &State, t: f64, dt: f64) -> (State, Felt) {
    let y0 = pack(s);
    let add = |y: &[f64; 13], k: &[f64; 13], h: f64| -> [f64; 13] {
        std::array::from_fn(|i| y[i] + h * k[i])
    };
    let (felt, k1) = derivative(af, world, s, t);
    let (_, k2) = derivative(af, world, &unpack(&add(&y0, &k1, dt / 2.0)), t + dt / 2.0);
    let (_, k3) = derivative(af, world, &unpack(&add(&y0, &k2, dt / 2.0)), t + dt / 2.0);
    let (_, k4) = derivative(af, world, &unpack(&add(&y0, &k3, dt)), t + dt);
    let y: [f64; 13] =
        std::array::from_fn(|i| y0[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    (unpack(&y), felt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thrust_table_burns_its_propellant_by_impulse() {
        let af = Airframe {
            mass: 30.0,
            burnt_mass: 20.0,
            diameter: 0.1,
            ix: 0.05,
            iy: 5.0,
            drag: vec![(0.0, 0.5)],
            yaw_drag: 0.0,
            lift: 0.0,
            overturning: 0.0,
            pitch_damping: 0.0,
            spin_damping: 0.0,
            roll_drive: 0.0,
            thrust: vec![(0.0, 0.0), (0.1, 2000.0), (3.9, 2000.0), (4.0, 0.0)],
        };
        assert_eq!(af.mass_at(0.0), 30.0);
        assert!((af.mass_at(2.0) - 25.0).abs() < 1e-12);
        assert_eq!(af.mass_at(10.0), 20.0);
        assert_eq!(af.thrust_at(2.0), 2000.0);
        assert_eq!(af.thrust_at(5.0), 0.0);
        assert_eq!(interpolate(&[(0.0, 1.0), (1.0, 3.0)], 0.25), 1.5);
        assert_eq!(interpolate(&[(0.0, 1.0), (1.0, 3.0)], 7.0), 3.0);
    }
}
