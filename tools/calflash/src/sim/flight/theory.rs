//! The linear theory of a spinning projectile's yaw (McCoy, *Modern Exterior Ballistics*,
//! ch. 9-10): with `P = (Ix / Iy) p d / V` and `M = rho S d^3 C_Ma / (2 Iy)` (per calibre of
//! travel), the complex yaw is the sum of two rotating arms, the fast (nutation) and slow
//! (precession) modes, turning at `phi'_{f,s} = (P +- sqrt(P^2 - 4 M)) / 2` radians per calibre;
//! the gyroscopic stability factor is `Sg = P^2 / (4 M)` (stable above 1). Without Magnus
//! forces the arms decay at `lambda_{f,s} = -(H -+ P (2T - H) / sqrt(P^2 - 4 M)) / 2` with
//! `H = rho S d / (2 m) (C_La - C_D - k_y^-2 C_Mq)` and `T = rho S d / (2 m) C_La`.

use super::body::Airframe;

/// The epicyclic motion linear theory predicts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epicyclic {
    /// Gyroscopic stability factor.
    pub sg: f64,
    /// Fast mode's rate, rad/s.
    pub fast: f64,
    /// Slow mode's rate, rad/s.
    pub slow: f64,
    /// Fast mode's damping exponent, 1/s (negative decays).
    pub fast_damping: f64,
    /// Slow mode's.
    pub slow_damping: f64,
}

/// The linear theory of `af` flying at `speed` m/s, spinning at `spin` rad/s, in air of
/// `density` kg/m^3, with zero-yaw drag `cd`; `None` when it is not gyroscopically stable
/// (`Sg <= 1`, or a restoring moment: fin-stable airframes have no epicyclic spin modes).
#[must_use]
pub fn epicyclic(af: &Airframe, speed: f64, spin: f64, density: f64, cd: f64) -> Option<Epicyclic> {
    let d = af.diameter;
    let s = af.area();
    let m = af.mass;
    let p = af.ix / af.iy * spin * d / speed;
    let big_m = density * s * d * d * d * af.overturning / (2.0 * af.iy);
    if big_m <= 0.0 || p * p <= 4.0 * big_m {
        return None;
    }
    let root = (p * p - 4.0 * big_m).sqrt();
    let per_calibre = speed / d;
    let k = density * s * d / (2.0 * m);
    let ky2 = m * d * d / af.iy;
    let h = k * (af.lift - cd - ky2 * af.pitch_damping);
    let t = k * af.lift;
    Some(Epicyclic {
        sg: p * p / (4.0 * big_m),
        fast: 0.5 * (p + root) * per_calibre,
        slow: 0.5 * (p - root) * per_calibre,
        fast_damping: -0.5 * (h - p * (2.0 * t - h) / root) * per_calibre,
        slow_damping: -0.5 * (h + p * (2.0 * t - h) / root) * per_calibre,
    })
}
