//! Test plans: the conditions a unit is put through on the bench.
//!
//! A condition is the specific force `f` (m/s^2) at the unit's reference point, the angular
//! rate `w` (rad/s) and angular acceleration `dw` (rad/s^2), in the unit's axes, with the
//! chamber temperature and the supply voltage.
//! A single-axis sensor reads the x component (of `f` for an accelerometer, `w` for a gyro);
//! y and z are its cross axes p and o.
//!
//! Plan items (each a word, combined with `--temps`, `--volts` and `--repeat`):
//!
//! | item | conditions |
//! |---|---|
//! | `head:N` | dividing head: gravity at N angles in the x-z plane, `f = g (cos t, 0, sin t)` |
//! | `tumble:6`, `tumble:12`, `tumble:18`, `tumble:24`, `tumble:26` | gravity along the 6 axes; + 6 diagonals of the xy, yz, zx planes (12); + all 12 edge diagonals (18); 6 axes at 4 headings each (24); + 8 cube corners (26) |
//! | `sphere:N` | gravity along N directions spread evenly over the sphere |
//! | `rate:LO:HI:N` | rate-table steps (rad/s): N rates, about each of the 6 axis directions with that direction up |
//! | `diagonal:LO:HI:N` | the same about the 12 diagonals between two axes (a 45-degree fixture on the rate table): with the axis spins, every lever-arm component is estimable |
//! | `centrifuge:LO:HI:N` | N levels (in g) along each of the 6 axis directions, gravity on the next axis, spin about it (arm 0.5 m) |
//! | `sweep:LO:HI:N` | ascending then descending input along x (hysteresis), with the direction |
//! | `fine:LO:HI:N` | N small steps of the x input near zero (threshold, dead band, resolution) |
//!
//! Single-axis plans use only the first direction of each item (`+x` up for `rate`), but a
//! centrifuge's two (`+x` and `-x` radial: the input axis outward and inward); triads use them
//! all.

use serde::{Deserialize, Serialize};

/// Standard gravity, m/s^2.
pub const G: f64 = 9.806_65;
/// Centrifuge arm, metres.
pub const ARM: f64 = 0.5;

/// One test condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Condition {
    /// Specific force at the reference point, m/s^2.
    pub f: [f64; 3],
    /// Angular rate, rad/s.
    pub w: [f64; 3],
    /// Angular acceleration, rad/s^2 (spin-up, spin-down).
    #[serde(default)]
    pub dw: [f64; 3],
    /// The direction of the fixture's reference mark in the unit's axes (`crate::earth`):
    /// what gives a still position's Earth rate; ignored while the unit turns.
    #[serde(default)]
    pub h: [f64; 3],
    /// Chamber temperature, degrees C.
    pub temp: f64,
    /// Supply voltage, volts.
    pub volt: f64,
    /// +1 ascending, -1 descending, 0 not a sweep.
    pub dir: f64,
}

/// A plan item that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("plan item `{item}`: {why}")]
pub struct PlanError {
    /// The item.
    pub item: String,
    /// What is wrong.
    pub why: String,
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

fn axes() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for k in 0..3 {
        for s in [1.0, -1.0] {
            let mut v = [0.0; 3];
            v[k] = s;
            out.push(v);
        }
    }
    out
}

fn edges() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for (a, b) in [(0, 1), (1, 2), (0, 2)] {
        for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let mut v = [0.0; 3];
            v[a] = sa;
            v[b] = sb;
            out.push(unit(v));
        }
    }
    out
}

/// The gravity directions of a tumble of `n` positions.
fn tumble(n: usize) -> Option<Vec<[f64; 3]>> {
    let e = edges();
    Some(match n {
        6 => axes(),
        12 => {
            let mut v = axes();
            // One diagonal pair per plane: (1,1,0), (-1,-1,0), ...
            v.extend([e[0], e[3], e[4], e[7], e[8], e[11]]);
            v
        }
        18 => axes().into_iter().chain(e).collect(),
        24 => axes().into_iter().flat_map(|d| [d; 4]).collect(),
        26 => {
            let mut v: Vec<[f64; 3]> = axes().into_iter().chain(e).collect();
            for sx in [1.0, -1.0] {
                for sy in [1.0, -1.0] {
                    for sz in [1.0, -1.0] {
                        v.push(unit([sx, sy, sz]));
                    }
                }
            }
            v
        }
        _ => return None,
    })
}

/// `n` directions spread over the sphere (a Fibonacci lattice).
fn sphere(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// A still position with the specific force `f`, laid on the fixture as `earth::mark_for` says.
fn still(f: [f64; 3]) -> Condition {
    Condition {
        f,
        w: [0.0; 3],
        dw: [0.0; 3],
        h: crate::earth::mark_for(f),
        temp: 25.0,
        volt: 0.0,
        dir: 0.0,
    }
}

/// The conditions of one plan item; `single` keeps a single-axis sensor's subset.
///
/// # Errors
/// A [`PlanError`] saying what the item should look like.
pub fn item(text: &str, single: bool) -> Result<Vec<Condition>, PlanError> {
    let err = |why: &str| PlanError {
        item: text.into(),
        why: why.into(),
    };
    let mut parts = text.split(':');
    let kind = parts.next().unwrap_or_default();
    let nums: Vec<&str> = parts.collect();
    let parse_count = |n: &str| -> Result<usize, PlanError> {
        match n.parse::<usize>() {
            Ok(0) => Err(err("the count must be at least 1")),
            Ok(c) if c <= MAX_CONDITIONS => Ok(c),
            _ => Err(err(&format!(
                "`{n}` is not a count from 1 to {MAX_CONDITIONS}"
            ))),
        }
    };
    let range = || -> Result<(f64, f64, usize), PlanError> {
        let [lo, hi, n] = nums[..] else {
            return Err(err("expected KIND:LO:HI:N"));
        };
        let (limit, unit) = match kind {
            "rate" | "diagonal" => (MAX_RATE, "rad/s"),
            "centrifuge" => (MAX_CENTRIFUGE_G, "g"),
            _ => (MAX_FORCE, "m/s^2"),
        };
        let num = |s: &str| match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= limit => Ok(v),
            _ => Err(err(&format!(
                "`{s}` is not a number from -{limit} to {limit} {unit}"
            ))),
        };
        let (lo, hi) = (num(lo)?, num(hi)?);
        if kind == "centrifuge" && lo.min(hi) < 0.0 {
            return Err(err("a centrifuge's radial levels are 0 g or more"));
        }
        Ok((lo, hi, parse_count(n)?))
    };
    let count = || -> Result<usize, PlanError> {
        let [n] = nums[..] else {
            return Err(err("expected KIND:N"));
        };
        parse_count(n)
    };
    let dirs = |all: Vec<[f64; 3]>| {
        if single {
            all.into_iter().take(1).collect()
        } else {
            all
        }
    };
    Ok(match kind {
        "head" => {
            let n = count()?;
            (0..n)
                .map(|i| {
                    let t = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                    // The dividing head turns about its horizontal axis, y.
                    Condition {
                        h: [0.0, 1.0, 0.0],
                        ..still([G * t.cos(), 0.0, G * t.sin()])
                    }
                })
                .collect()
        }
        "tumble" => {
            let n = count()?;
            let d = tumble(n).ok_or_else(|| err("tumbles have 6, 12, 18, 24 or 26 positions"))?;
            let mut out: Vec<Condition> = d.into_iter().map(|u| still(u.map(|c| G * c))).collect();
            if n == 24 {
                // Each up direction at four headings: the fixture turned by 90 degrees.
                for (i, c) in out.iter_mut().enumerate() {
                    let up = c.f.map(|x| x / G);
                    c.h = crate::earth::turn(c.h, up, (i % 4) as f64 * std::f64::consts::FRAC_PI_2);
                }
            }
            out
        }
        "sphere" => sphere(count()?)
            .into_iter()
            .map(|u| still(u.map(|c| G * c)))
            .collect(),
        "rate" | "diagonal" => {
            let (lo, hi, n) = range()?;
            let mut out = Vec::new();
            let about = if kind == "rate" { axes() } else { edges() };
            for up in dirs(about) {
                for r in linspace(lo, hi, n) {
                    // The table's mark matters at rest (a step of 0 rad/s).
                    out.push(Condition {
                        w: up.map(|c| r * c),
                        ..still(up.map(|c| G * c))
                    });
                }
            }
            out
        }
        "centrifuge" => {
            let (lo, hi, n) = range()?;
            let mut out = Vec::new();
            // A single axis is mounted twice, its input axis outward and inward (+x and -x
            // radial): the negative inputs a one-armed centrifuge gives.
            let radials = if single {
                axes().into_iter().take(2).collect()
            } else {
                axes()
            };
            for radial in radials {
                let k = radial.iter().position(|c| *c != 0.0).unwrap_or(0);
                let mut vertical = [0.0; 3];
                vertical[(k + 1) % 3] = 1.0;
                for level in linspace(lo, hi, n) {
                    let spin = (level * G / ARM).sqrt();
                    out.push(Condition {
                        f: std::array::from_fn(|j| level * G * radial[j] + G * vertical[j]),
                        w: vertical.map(|c| spin * c),
                        h: [0.0; 3],
                        ..still([0.0; 3])
                    });
                }
            }
            out
        }
        "sweep" => {
            let (lo, hi, n) = range()?;
            let up = linspace(lo, hi, n);
            let mut out: Vec<Condition> = up
                .iter()
                .map(|x| Condition {
                    dir: 1.0,
                    ..still([*x, 0.0, 0.0])
                })
                .collect();
            out.extend(up.iter().rev().map(|x| Condition {
                dir: -1.0,
                ..still([*x, 0.0, 0.0])
            }));
            out
        }
        "fine" => {
            let (lo, hi, n) = range()?;
            linspace(lo, hi, n)
                .into_iter()
                .map(|x| still([x, 0.0, 0.0]))
                .collect()
        }
        _ => {
            return Err(err(
                "the kinds are head, tumble, sphere, rate, diagonal, centrifuge, sweep and fine",
            ));
        }
    })
}

/// The most conditions a plan may hold, counting every temperature, voltage and repeat: far
/// beyond any test run, and about 200 MB to simulate.
pub const MAX_CONDITIONS: usize = 1_000_000;
/// The largest rate a plan item may name, rad/s (about 16,000 rev/s).
pub const MAX_RATE: f64 = 1.0e5;
/// The largest centrifuge level, g.
pub const MAX_CENTRIFUGE_G: f64 = 1.0e5;
/// The largest specific force a sweep or fine item may name, m/s^2 (about 100,000 g).
pub const MAX_FORCE: f64 = 1.0e6;

fn too_many(items: &[String], n: usize) -> PlanError {
    PlanError {
        item: items.join(" "),
        why: format!(
            "{n} conditions with every temperature, voltage and repeat; a plan holds at most \
             {MAX_CONDITIONS}"
        ),
    }
}

/// A whole plan: every item, at every temperature and supply voltage, `repeat` times.
///
/// # Errors
/// The first bad item.
pub fn plan(
    items: &[String],
    temps: &[f64],
    volts: &[f64],
    repeat: usize,
    single: bool,
) -> Result<Vec<Condition>, PlanError> {
    let mut base = Vec::new();
    for i in items {
        base.extend(item(i, single)?);
        if base.len() > MAX_CONDITIONS {
            return Err(too_many(items, base.len()));
        }
    }
    let total = [temps.len(), volts.len(), repeat]
        .into_iter()
        .try_fold(base.len(), usize::checked_mul)
        .filter(|n| *n <= MAX_CONDITIONS)
        .ok_or_else(|| {
            too_many(
                items,
                base.len()
                    .saturating_mul(temps.len())
                    .saturating_mul(volts.len())
                    .saturating_mul(repeat),
            )
        })?;
    let mut out = Vec::with_capacity(total);
    for &t in temps {
        for &v in volts {
            for _ in 0..repeat {
                out.extend(base.iter().map(|c| Condition {
                    temp: t,
                    volt: v,
                    ..*c
                }));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tumbles_and_spins() {
        for n in [6, 12, 18, 24, 26] {
            let c = item(&format!("tumble:{n}"), false).unwrap();
            assert_eq!(c.len(), n);
            assert!(
                c.iter()
                    .all(|c| ((c.f.iter().map(|x| x * x).sum::<f64>()).sqrt() - G).abs() < 1e-12)
            );
        }
        assert!(item("tumble:7", false).is_err());
        let r = item("rate:-5:5:11", false).unwrap();
        assert_eq!(r.len(), 66);
        let d = item("diagonal:100:200:2", false).unwrap();
        assert_eq!(d.len(), 24);
        // About (1, 1, 0)/sqrt(2), that direction up.
        assert!((d[0].w[0] - 100.0 / 2f64.sqrt()).abs() < 1e-12 && d[0].w[2] == 0.0);
        assert!((d[0].f[1] - G / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(item("rate:-5:5:11", true).unwrap().len(), 11);
        // A single axis on the centrifuge: outward and inward, +-1 to +-10 g.
        let one = item("centrifuge:1:10:4", true).unwrap();
        assert_eq!(one.len(), 8);
        let inputs: Vec<f64> = one.iter().map(|c| (c.f[0] / G).round()).collect();
        assert_eq!(inputs, [1.0, 4.0, 7.0, 10.0, -1.0, -4.0, -7.0, -10.0]);
        let c = item("centrifuge:1:10:4", false).unwrap();
        let last = c[3];
        // 10 g radial along +x, gravity on y, spin about y with w^2 R = 10 g.
        assert!((last.f[0] - 10.0 * G).abs() < 1e-9 && (last.f[1] - G).abs() < 1e-12);
        assert!((last.w[1] * last.w[1] * ARM - 10.0 * G).abs() < 1e-9);
        let s = item("sweep:-1:1:5", true).unwrap();
        assert_eq!(
            s.iter().map(|c| c.dir).collect::<Vec<_>>(),
            [1.0, 1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0, -1.0]
        );
        assert_eq!(
            item("rate:1:2", false).unwrap_err().to_string(),
            "plan item `rate:1:2`: expected KIND:LO:HI:N"
        );
        let p = plan(&["tumble:6".into()], &[-40.0, 85.0], &[3.3], 2, false).unwrap();
        assert_eq!(p.len(), 24);
    }
}
