//! Flights to make a mission profile from: a spin-stabilised shell (in-bore setback with the
//! spin rising with travel, then six degrees of freedom in free flight: drag against Mach,
//! gravity, spin decay, the epicyclic yaw and the yaw of repose) and a fin-stabilised rocket
//! (a launch rail, a thrust curve, a roll from canted fins, burnout, coast). Each gives what
//! the unit at the centre of mass feels, sampled at a fixed rate, and the flight's truth.

pub mod atmosphere;
pub mod body;
pub mod receivers;
pub mod rocket;
pub mod shell;
pub mod site;
pub mod spec;
pub mod theory;

use nalgebra::{UnitQuaternion, Vector3};

use body::{Airframe, State, World};

/// One sample of a flight: what the unit feels and where the body is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time since firing or ignition, s.
    pub t: f64,
    /// Specific force in body axes, m/s^2.
    pub f: [f64; 3],
    /// Rate in body axes, rad/s.
    pub w: [f64; 3],
    /// Angular acceleration in body axes, rad/s^2.
    pub dw: [f64; 3],
    /// The unit's temperature, C.
    pub temp: f64,
    /// Position, m (x downrange, y left, z up from the launch point).
    pub r: [f64; 3],
    /// Velocity, m/s.
    pub v: [f64; 3],
    /// Attitude, body to Earth, `w, x, y, z`.
    pub q: [f64; 4],
}

/// A flight: its samples and its events.
#[derive(Debug, Clone, Default)]
pub struct Flight {
    /// The samples, at a fixed step.
    pub samples: Vec<Sample>,
    /// `(what, when)`: muzzle exit or rail exit, burnout, apogee, impact or the end.
    pub events: Vec<(&'static str, f64)>,
}

/// How the unit's temperature follows the air: it starts at its conditioning and approaches
/// the air's temperature with a time constant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thermal {
    /// The conditioning temperature, C.
    pub conditioned: f64,
    /// The time constant, s.
    pub tau: f64,
}

impl Thermal {
    /// A unit conditioned at `conditioned` C with a 300 s time constant (a unit in its round).
    #[must_use]
    pub fn conditioned_at(conditioned: f64) -> Self {
        Self {
            conditioned,
            tau: 300.0,
        }
    }

    /// The next temperature after `dt` s in air at `air_c` C.
    #[must_use]
    pub fn step(&self, temp: f64, air_c: f64, dt: f64) -> f64 {
        temp + (air_c - temp) * (1.0 - (-dt / self.tau).exp())
    }
}

/// What a free flight starts from and how it is sampled.
#[derive(Debug, Clone, Copy)]
pub struct FreeFlight {
    /// Where and how it starts.
    pub start: State,
    /// Its time then, s.
    pub t0: f64,
    /// The unit's temperature then, C.
    pub temp: f64,
    /// The sampling step, s.
    pub dt: f64,
    /// The flight ends here, s, or at impact.
    pub until: f64,
}

/// Flies `af` freely from `from`, appending one sample per step to `out` and the events.
pub fn fly(af: &Airframe, world: &World, thermal: &Thermal, from: &FreeFlight, out: &mut Flight) {
    let mut s = from.start;
    let mut t = from.t0;
    let mut temp = from.temp;
    let mut climbing = s.v.z > 0.0;
    let burnout = af.burnout();
    let mut burning = burnout > t;
    let mut k: u64 = 0;
    loop {
        let (next, felt) = body::step(af, world, &s, t, from.dt);
        out.samples.push(sample(t, &s, felt.f, felt.dw, temp));
        k += 1;
        let t_next = from.t0 + k as f64 * from.dt;
        let air = atmosphere::standard(world.altitude + s.r.z);
        temp = thermal.step(temp, air.temperature - 273.15, from.dt);
        if burning && t_next >= burnout {
            out.events.push(("burnout", burnout));
            burning = false;
        }
        if climbing && next.v.z <= 0.0 {
            out.events.push(("apogee", t_next));
            climbing = false;
        }
        s = next;
        t = t_next;
        // Without gravity (the checks against linear theory) there is no ground to reach.
        if world.gravity && s.r.z < 0.0 && !climbing {
            out.events.push(("impact", t));
            break;
        }
        if t > from.until {
            out.events.push(("end", t));
            break;
        }
    }
}

/// A sample of state `s`.
#[must_use]
pub fn sample(t: f64, s: &State, f: Vector3<f64>, dw: Vector3<f64>, temp: f64) -> Sample {
    let q = s.q.quaternion();
    Sample {
        t,
        f: f.into(),
        w: s.w.into(),
        dw: dw.into(),
        temp,
        r: s.r.into(),
        v: s.v.into(),
        q: [q.w, q.i, q.j, q.k],
    }
}

/// The attitude of a body whose axis points `elevation` rad above the downrange x axis,
/// rolled by `roll` rad about its axis.
#[must_use]
pub fn pointing(elevation: f64, roll: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -elevation)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), roll)
}

/// The specific force, in body axes, of a body accelerating at `a` m/s^2 along its axis while
/// something (a barrel, a rail, the ground) holds it against gravity `g` (flight frame).
#[must_use]
pub fn held(q: &UnitQuaternion<f64>, a: f64, g: &Vector3<f64>) -> Vector3<f64> {
    Vector3::x() * a - q.inverse() * g
}

/// Writes a flight as CSV: `t`, the true `f_*`, `w_*`, `dw_*`, `temp`, `volt` (the mission
/// profile), then the unit's raw `a_*`, `g_*` codes when given.
///
/// # Errors
/// The writer's.
pub fn write_csv(
    samples: &[Sample],
    volt: f64,
    raw: Option<&[[f64; 6]]>,
    mut w: impl std::io::Write,
) -> std::io::Result<()> {
    use crate::columns as col;
    use std::fmt::Write as _;
    let mut names: Vec<&str> = std::iter::once("t")
        .chain(col::F)
        .chain(col::W)
        .chain(col::DW)
        .chain([col::TEMP, col::VOLT])
        .collect();
    if raw.is_some() {
        names.extend(col::A.iter().chain(&col::GYRO));
    }
    writeln!(w, "{}", names.join(","))?;
    let mut line = String::new();
    for (i, s) in samples.iter().enumerate() {
        line.clear();
        let _ = write!(line, "{}", s.t);
        for v in s.f.iter().chain(&s.w).chain(&s.dw) {
            let _ = write!(line, ",{v}");
        }
        let _ = write!(line, ",{},{volt}", s.temp);
        if let Some(raw) = raw {
            for v in &raw[i] {
                let _ = write!(line, ",{v}");
            }
        }
        writeln!(w, "{line}")?;
    }
    Ok(())
}

/// Writes the flight's truth as CSV: `t`, position `x y z` (m), velocity `vx vy vz` (m/s),
/// attitude `qw qx qy qz` (body to Earth; x downrange, y left, z up).
///
/// # Errors
/// The writer's.
pub fn write_truth(samples: &[Sample], mut w: impl std::io::Write) -> std::io::Result<()> {
    use std::fmt::Write as _;
    writeln!(w, "t,x,y,z,vx,vy,vz,qw,qx,qy,qz")?;
    let mut line = String::new();
    for s in samples {
        line.clear();
        let _ = write!(line, "{}", s.t);
        for v in s.r.iter().chain(&s.v).chain(&s.q) {
            let _ = write!(line, ",{v}");
        }
        writeln!(w, "{line}")?;
    }
    Ok(())
}

#[cfg(test)]
mod checks;
