//! A mission's weight on a model: `B = mean_t f(x_t) f(x_t)'` over the flight's samples, each
//! weighted by the time it stands for. A plan with `C = (X'X)^-1` predicts the model at the
//! flight's states with mean standardized variance `n tr(C B)` (I-optimality with the mission as
//! the measure). The samples the equipment cannot reach (beyond the plan's or the candidates'
//! range on a variable the model reads, or the equipment's limits) are extrapolation: they get
//! a weight of their own, reported apart and not averaged into what the bench can vouch for.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::{Profile, Quantity};
use crate::columns as col;
use crate::design::points::{Points, Unit, default_value};
use crate::formula::Formula;

/// Where a model's variable comes from in a profile.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// A quantity of the profile.
    Of(Quantity),
    /// A lever-arm regressor `lever_ik` from the rates and angular accelerations.
    Lever(usize, usize),
    /// What a calibrated axis senses along itself (`sensor::lever::SENSED`).
    Sensed(SensedAxis),
}

/// A calibrated axis, as what it senses along itself is made from a profile's motion: an
/// accelerometer's `n . (f + w x (w x r) + dw x r)`, a gyro's `n . w + g . f`, with `n` its
/// sensitivity row over its own sensitivity (the written model of `spincal::model::rotation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensedAxis {
    /// A gyro.
    pub gyro: bool,
    /// Its sensing direction, its own component one.
    pub direction: [f64; 3],
    /// An accelerometer's lever arm, m.
    pub lever: [f64; 3],
    /// A gyro's g-sensitivity row over its own sensitivity, rad/s per m/s^2.
    pub g: [f64; 3],
}

impl SensedAxis {
    /// What the axis senses under specific force `f`, rate `w` and angular acceleration `dw`.
    #[must_use]
    pub fn sensed(&self, f: &[f64; 3], w: &[f64; 3], dw: &[f64; 3]) -> f64 {
        use spincal::model::rotation::{dot, force_at};
        if self.gyro {
            dot(&self.direction, w) + dot(&self.g, f)
        } else {
            dot(&self.direction, &force_at(f, w, dw, &self.lever))
        }
    }
}

/// A variable the model reads that the profile cannot give.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the model reads `{variable}`, which the mission profile {path} does not give ({why}); it gives {has}"
)]
pub struct Missing {
    /// The variable.
    pub variable: String,
    /// The profile.
    pub path: String,
    /// Why.
    pub why: String,
    /// What it gives.
    pub has: String,
}

/// How far beyond the bench's range, as a share of its span, a flight's moment still counts as
/// reached.
pub const REACH_MARGIN: f64 = 0.01;

/// The range of each variable the equipment reaches.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// `(variable, lowest, highest)`.
    pub bounds: Vec<(String, f64, f64)>,
}

impl Reach {
    /// The range of each of `vars` over `pts`, widened by [`REACH_MARGIN`] of its span (a
    /// recorded flight's own instrument reads 1 g at rest as 9.9 m/s^2 where the bench's
    /// reference is 9.807), then narrowed by `limits` (an equipment's: variable, lowest and
    /// highest value it reaches).
    #[must_use]
    pub fn of(pts: &Points, vars: &[String], limits: &[(&str, f64, f64)]) -> Self {
        let bounds = vars
            .iter()
            .filter(|v| !v.starts_with("lever_"))
            .map(|v| {
                let (mut lo, mut hi) = (0..pts.rows.len())
                    .map(|r| pts.value(r, v))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                        (a.min(x), b.max(x))
                    });
                let margin = REACH_MARGIN * (hi - lo);
                lo -= margin;
                hi += margin;
                for &(_, l_lo, l_hi) in limits.iter().filter(|l| l.0 == v.as_str()) {
                    lo = lo.max(l_lo);
                    hi = hi.min(l_hi);
                }
                (v.clone(), lo, hi)
            })
            .collect();
        Self { bounds }
    }
}

/// The mission's weight on one model.
#[derive(Debug, Clone)]
pub struct Weight {
    /// `mean f f'` over the samples inside the reach (zeros when none are).
    pub inside: DMatrix<f64>,
    /// Over the samples outside it.
    pub outside: DMatrix<f64>,
    /// `mean f f'` over the whole flight.
    pub all: DMatrix<f64>,
    /// Share of the flight's time inside the reach.
    pub share_inside: f64,
    /// Share of the time each bounded variable is beyond its range: `(variable, below, above)`.
    pub beyond: Vec<(String, f64, f64)>,
}

/// Reads the model's variables from a profile.
#[derive(Debug, Clone)]
pub struct Lookup {
    sources: Vec<(String, Source)>,
}

impl Lookup {
    /// Where each variable of `formula` comes from, for a unit of kind `unit` (a single axis
    /// reads the profile's x axis as its `input`, y and z as `input_p` and `input_o`).
    ///
    /// # Errors
    /// A variable the profile does not give.
    pub fn new(p: &Profile, formula: &Formula, unit: Unit) -> Result<Self, Missing> {
        Self::of_axis(p, formula, unit, None)
    }

    /// As [`Lookup::new`], with what a calibrated axis senses (`sensed`) made from the
    /// profile's motion through the axis' estimate.
    ///
    /// # Errors
    /// A variable the profile does not give.
    pub fn of_axis(
        p: &Profile,
        formula: &Formula,
        unit: Unit,
        sensed: Option<SensedAxis>,
    ) -> Result<Self, Missing> {
        let vars: Vec<String> = formula.columns().into_iter().skip(1).collect();
        let mut out = Self::for_variables(
            p,
            &vars
                .iter()
                .filter(|v| !(sensed.is_some() && v.as_str() == crate::sensor::lever::SENSED))
                .cloned()
                .collect::<Vec<_>>(),
            unit,
        )?;
        if let Some(axis) =
            sensed.filter(|_| vars.iter().any(|v| v == crate::sensor::lever::SENSED))
        {
            if p.f.is_none() && p.w.is_none() {
                return Err(Missing {
                    variable: crate::sensor::lever::SENSED.into(),
                    path: p.source.display().to_string(),
                    why: "no motion to make it from".into(),
                    has: String::new(),
                });
            }
            out.sources
                .push((crate::sensor::lever::SENSED.into(), Source::Sensed(axis)));
        }
        Ok(out)
    }

    /// As [`Lookup::new`] for a list of variables.
    ///
    /// # Errors
    /// A variable the profile does not give.
    pub fn for_variables(p: &Profile, vars: &[String], unit: Unit) -> Result<Self, Missing> {
        let mut sources = Vec::new();
        let has = Quantity::all()
            .iter()
            .filter(|q| p.value(0, **q).is_some())
            .map(|q| q.name())
            .collect::<Vec<_>>()
            .join(", ");
        for v in vars {
            let single = |k: usize| match unit {
                Unit::SingleGyro => Some(Quantity::W(k)),
                _ => Some(Quantity::F(k)),
            };
            let source = match v.as_str() {
                col::INPUT => single(0).map(Source::Of),
                col::INPUT_P => single(1).map(Source::Of),
                col::INPUT_O => single(2).map(Source::Of),
                name => Quantity::all()
                    .into_iter()
                    .find(|q| q.name() == name)
                    .map(Source::Of)
                    .or_else(|| {
                        let rest = name.strip_prefix("lever_")?.as_bytes();
                        let axis =
                            |c: u8| (b'x'..=b'z').contains(&c).then(|| usize::from(c - b'x'));
                        match rest {
                            [a, b] => Some(Source::Lever(axis(*a)?, axis(*b)?)),
                            _ => None,
                        }
                    }),
            };
            let missing = |why: &str| Missing {
                variable: v.clone(),
                path: p.source.display().to_string(),
                why: why.to_string(),
                has: has.clone(),
            };
            let source = source.ok_or_else(|| missing("no flight gives it"))?;
            let ok = match source {
                Source::Of(q) => p.value(0, q).is_some(),
                Source::Lever(..) | Source::Sensed(_) => p.w.is_some(),
            };
            if !ok {
                // Temperature and voltage take the bench's defaults when a flight does not log
                // them; motion cannot be assumed.
                match source {
                    Source::Of(Quantity::Temp | Quantity::Volt) => {}
                    _ => return Err(missing("no such column")),
                }
            }
            sources.push((v.clone(), source));
        }
        Ok(Self { sources })
    }

    /// The variables whose value is assumed (the bench's default) for lack of a column.
    #[must_use]
    pub fn assumed(&self, p: &Profile) -> Vec<String> {
        self.sources
            .iter()
            .filter(|(_, s)| matches!(s, Source::Of(q) if p.value(0, *q).is_none()))
            .map(|(v, _)| format!("{v} = {}", default_value(v)))
            .collect()
    }

    /// The value of `name` at sample `i`.
    #[must_use]
    pub fn value(&self, p: &Profile, i: usize, name: &str) -> f64 {
        match self.sources.iter().find(|(v, _)| v == name) {
            Some((_, Source::Of(q))) => p.value(i, *q).unwrap_or_else(|| default_value(name)),
            Some((_, Source::Lever(a, k))) => {
                let mut e = [0.0; 3];
                e[*a] = 1.0;
                let w = p.w.as_ref().map_or([0.0; 3], |w| w[i]);
                let dw = p.dw.as_ref().map_or([0.0; 3], |d| d[i]);
                crate::sensor::lever::gradient(&e, &w, &dw)[*k]
            }
            Some((_, Source::Sensed(axis))) => {
                let f = p.f.as_ref().map_or([0.0; 3], |f| f[i]);
                let w = p.w.as_ref().map_or([0.0; 3], |w| w[i]);
                let dw = p.dw.as_ref().map_or([0.0; 3], |d| d[i]);
                axis.sensed(&f, &w, &dw)
            }
            None => default_value(name),
        }
    }

    /// True when sample `i` is inside `reach`.
    #[must_use]
    pub fn inside(&self, p: &Profile, i: usize, reach: &Reach) -> bool {
        reach.bounds.iter().all(|(v, lo, hi)| {
            let x = self.value(p, i, v);
            (*lo..=*hi).contains(&x)
        })
    }
}

/// The weight of profile `p` on `formula` with the equipment reaching `reach`.
#[must_use]
pub fn weight(p: &Profile, formula: &Formula, lookup: &Lookup, reach: &Reach) -> Weight {
    let dwell = p.dwell();
    let width = formula.width();
    let zero = || {
        (
            DMatrix::<f64>::zeros(width, width),
            DMatrix::<f64>::zeros(width, width),
            0.0f64,
            0.0f64,
            vec![(0.0f64, 0.0f64); reach.bounds.len()],
        )
    };
    let (inside, outside, t_in, t_out, beyond) = (0..p.len())
        .into_par_iter()
        .fold(zero, |mut acc, i| {
            let mut row = Vec::with_capacity(width);
            formula.row(|v| lookup.value(p, i, v), &mut row);
            let d = dwell[i];
            let mut out = false;
            for (k, (v, lo, hi)) in reach.bounds.iter().enumerate() {
                let x = lookup.value(p, i, v);
                if x < *lo {
                    acc.4[k].0 += d;
                    out = true;
                } else if x > *hi {
                    acc.4[k].1 += d;
                    out = true;
                }
            }
            let m = if out { &mut acc.1 } else { &mut acc.0 };
            for a in 0..width {
                let ra = row[a] * d;
                for b in a..width {
                    m[(a, b)] += ra * row[b];
                }
            }
            if out {
                acc.3 += d;
            } else {
                acc.2 += d;
            }
            acc
        })
        .reduce(zero, |mut a, b| {
            a.0 += b.0;
            a.1 += b.1;
            a.2 += b.2;
            a.3 += b.3;
            for (x, y) in a.4.iter_mut().zip(&b.4) {
                x.0 += y.0;
                x.1 += y.1;
            }
            a
        });
    let total = t_in + t_out;
    let symmetric = |mut m: DMatrix<f64>, t: f64| {
        for a in 0..width {
            for b in 0..a {
                m[(a, b)] = m[(b, a)];
            }
        }
        if t > 0.0 { m / t } else { m }
    };
    let all_sum = &inside + &outside;
    Weight {
        inside: symmetric(inside, t_in),
        outside: symmetric(outside, t_out),
        all: symmetric(all_sum, total),
        share_inside: if total > 0.0 { t_in / total } else { 0.0 },
        beyond: reach
            .bounds
            .iter()
            .zip(beyond)
            .map(|((v, _, _), (lo, hi))| (v.clone(), lo / total, hi / total))
            .collect(),
    }
}

/// Mean standardized prediction variance `n tr(C B)` of a plan of `n` observations with
/// `C = (X'X)^-1`, over a weight `b`.
#[must_use]
pub fn mean_variance(unscaled: &DMatrix<f64>, n: usize, b: &DMatrix<f64>) -> f64 {
    n as f64 * (unscaled * b).trace()
}

/// The largest standardized prediction variance `n f' C f` over the flight's samples inside
/// and outside the reach (`0` for a part with no samples).
#[must_use]
pub fn worst_variance(
    p: &Profile,
    formula: &Formula,
    lookup: &Lookup,
    reach: &Reach,
    unscaled: &DMatrix<f64>,
    n: usize,
) -> (f64, f64) {
    let width = formula.width();
    (0..p.len())
        .into_par_iter()
        .fold(
            || (0.0f64, 0.0f64),
            |(a, b), i| {
                let mut row = Vec::with_capacity(width);
                formula.row(|v| lookup.value(p, i, v), &mut row);
                let x = nalgebra::DVector::from_vec(row);
                let d = n as f64 * (x.transpose() * unscaled * &x)[(0, 0)];
                if lookup.inside(p, i, reach) {
                    (a.max(d), b)
                } else {
                    (a, b.max(d))
                }
            },
        )
        .reduce(|| (0.0, 0.0), |x, y| (x.0.max(y.0), x.1.max(y.1)))
}

/// The model rows of at most `max` of the flight's samples inside `reach`, evenly spread over
/// them, with the time each stands for: the states a Monte Carlo check predicts at.
#[must_use]
pub fn inside_rows(
    p: &Profile,
    formula: &Formula,
    lookup: &Lookup,
    reach: &Reach,
    max: usize,
) -> (DMatrix<f64>, Vec<f64>) {
    let dwell = p.dwell();
    let inside: Vec<usize> = (0..p.len())
        .filter(|i| lookup.inside(p, *i, reach))
        .collect();
    let every = inside.len().div_ceil(max.max(1)).max(1);
    let picked: Vec<usize> = inside.iter().step_by(every).copied().collect();
    let mut rows = DMatrix::zeros(picked.len(), formula.width());
    let mut row = Vec::new();
    for (r, i) in picked.iter().enumerate() {
        formula.row(|v| lookup.value(p, *i, v), &mut row);
        for (j, x) in row.iter().enumerate() {
            rows[(r, j)] = *x;
        }
    }
    // Each picked sample stands for the time of the `every` samples from it on.
    let weights = picked
        .iter()
        .enumerate()
        .map(|(k, _)| {
            inside[k * every..((k + 1) * every).min(inside.len())]
                .iter()
                .map(|i| dwell[*i])
                .sum()
        })
        .collect();
    (rows, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_profile(xs: &[f64]) -> Profile {
        let n = xs.len();
        Profile {
            source: "line".into(),
            t: (0..n).map(|i| i as f64).collect(),
            line: (1..=n as u64).collect(),
            f: Some(xs.iter().map(|x| [*x, 0.0, 0.0]).collect()),
            w: None,
            dw: None,
            temp: None,
            volt: None,
            notes: Vec::new(),
        }
    }

    #[test]
    fn the_weight_of_a_line_is_the_flights_moments_split_at_the_reach() {
        let f = crate::formula::parse("output ~ 1 + input").unwrap();
        // Uniform steps: the end samples stand for half a step each.
        let p = line_profile(&[0.0, 1.0, 2.0, 3.0, 4.0]);
        let lookup = Lookup::new(&p, &f, Unit::SingleAccel).unwrap();
        let reach = Reach {
            bounds: vec![("input".into(), 0.0, 2.0)],
        };
        let w = weight(&p, &f, &lookup, &reach);
        // Inside: 0 (0.5 s), 1 (1 s), 2 (1 s); outside: 3 (1 s), 4 (0.5 s).
        assert!((w.share_inside - 2.5 / 4.0).abs() < 1e-12);
        assert!((w.inside[(0, 1)] - (0.0 * 0.5 + 1.0 + 2.0) / 2.5).abs() < 1e-12);
        assert!((w.inside[(1, 1)] - (1.0 + 4.0) / 2.5).abs() < 1e-12);
        assert!((w.outside[(1, 1)] - (9.0 + 16.0 * 0.5) / 1.5).abs() < 1e-12);
        assert_eq!(w.beyond, vec![("input".to_string(), 0.0, 1.5 / 4.0)]);
        // The whole-flight weight is the time-weighted blend of the two parts.
        let blend = &w.inside * w.share_inside + &w.outside * (1.0 - w.share_inside);
        assert!((blend - &w.all).abs().max() < 1e-12);
    }

    #[test]
    fn a_model_reading_what_the_flight_lacks_is_named() {
        let f = crate::formula::parse("out ~ 1 + w_x").unwrap();
        let p = line_profile(&[0.0, 1.0]);
        let e = Lookup::new(&p, &f, Unit::Triad).unwrap_err();
        assert_eq!(e.variable, "w_x");
        assert!(e.to_string().contains("gives f_x, f_y, f_z"), "{e}");
        // Temperature is the bench's 25 C when the flight did not log it.
        let t = crate::formula::parse("out ~ 1 + f_x + temp").unwrap();
        let lookup = Lookup::new(&p, &t, Unit::Triad).unwrap();
        assert_eq!(lookup.assumed(&p), vec!["temp = 25".to_string()]);
    }
}
