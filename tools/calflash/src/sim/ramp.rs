//! Temperature ramps: a chamber sweeping while the plan's observations are taken, as thermal
//! calibrations are done (PX4, ArduPilot), with what makes them hard: an uneven ramp rate, a
//! sensor that reports its temperature in whole degrees, a sensor lagging the chamber, and
//! self-heating after power-on.

/// A chamber ramp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    /// Chamber temperature at the start, C.
    pub from: f64,
    /// At the end, C.
    pub to: f64,
    /// Duration, seconds; the observations are evenly spaced in time.
    pub seconds: f64,
    /// The chamber moves fast at first and slowly at the end (`1 - e^(-3 u)` of the way at
    /// `u` of the time), so the observations crowd at the end of the range.
    pub uneven: bool,
    /// The sensor's time constant behind the chamber, seconds (0: none).
    pub lag: f64,
    /// Self-heating after power-on: the sensor rises this many C above its surroundings, with
    /// this time constant in seconds.
    pub self_heating: Option<(f64, f64)>,
    /// The sensor reports its temperature in steps of this many C.
    pub step: Option<f64>,
}

/// The temperatures of each observation.
#[derive(Debug, Clone, PartialEq)]
pub struct Temperatures {
    /// Time from the start, seconds.
    pub time: Vec<f64>,
    /// The chamber's temperature, C.
    pub chamber: Vec<f64>,
    /// The sensor's true temperature, C (what its coefficients follow).
    pub sensor: Vec<f64>,
    /// What the sensor reports, C.
    pub reported: Vec<f64>,
}

impl Ramp {
    /// An even ramp from `from` to `to` C over `seconds`, the sensor at the chamber's
    /// temperature and reading it exactly.
    #[must_use]
    pub fn even(from: f64, to: f64, seconds: f64) -> Self {
        Self {
            from,
            to,
            seconds,
            uneven: false,
            lag: 0.0,
            self_heating: None,
            step: None,
        }
    }

    /// The chamber's temperature at `u` of the ramp's time (0 to 1).
    #[must_use]
    pub fn chamber(&self, u: f64) -> f64 {
        let w = if self.uneven {
            (1.0 - (-3.0 * u).exp()) / (1.0 - (-3.0f64).exp())
        } else {
            u
        };
        self.from + (self.to - self.from) * w
    }

    /// The temperatures of `n` observations evenly spaced over the ramp.
    #[must_use]
    pub fn temperatures(&self, n: usize) -> Temperatures {
        let dt = if n > 1 {
            self.seconds / (n - 1) as f64
        } else {
            0.0
        };
        let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let chamber: Vec<f64> = time
            .iter()
            .map(|t| {
                self.chamber(if self.seconds > 0.0 {
                    t / self.seconds
                } else {
                    0.0
                })
            })
            .collect();
        // A first-order lag, stepped exactly for a chamber held over each interval.
        let mut lagged = Vec::with_capacity(n);
        let mut s = chamber.first().copied().unwrap_or(self.from);
        for c in &chamber {
            if self.lag > 0.0 {
                s += (c - s) * (1.0 - (-dt / self.lag).exp());
            } else {
                s = *c;
            }
            lagged.push(s);
        }
        let sensor: Vec<f64> = lagged
            .iter()
            .zip(&time)
            .map(|(s, t)| match self.self_heating {
                Some((rise, tau)) if tau > 0.0 => s + rise * (1.0 - (-t / tau).exp()),
                Some((rise, _)) => s + rise,
                None => *s,
            })
            .collect();
        let reported = sensor
            .iter()
            .map(|s| match self.step {
                Some(q) if q > 0.0 => (s / q).round() * q,
                _ => *s,
            })
            .collect();
        Temperatures {
            time,
            chamber,
            sensor,
            reported,
        }
    }
}

/// A plan's conditions run through a ramp: each at its sensor's true temperature, in order,
/// evenly spaced in time; with the ramp's temperatures.
#[must_use]
pub fn run(
    ramp: &Ramp,
    conditions: &[super::plan::Condition],
) -> (Vec<super::plan::Condition>, Temperatures) {
    let temps = ramp.temperatures(conditions.len());
    let out = conditions
        .iter()
        .zip(&temps.sensor)
        .map(|(c, t)| super::plan::Condition { temp: *t, ..*c })
        .collect();
    (out, temps)
}

/// A `--ramp` or `--self-heating` option that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// `--ramp` not of the form `FROM:TO`.
    #[error("--ramp `{0}`: expected FROM:TO in C, e.g. -40:70")]
    Span(String),
    /// A ramp beyond what a chamber reaches.
    #[error("--ramp `{0}`: a chamber ramps between -100 and 200 C")]
    Unreachable(String),
    /// `--self-heating` not a rise of at most 50 C and a time constant of at least 0 s.
    #[error("--self-heating `{0}`: expected RISE:SECONDS, a rise of at most 50 C, e.g. 3:300")]
    SelfHeating(String),
}

/// Reads `FROM:TO` (C).
///
/// # Errors
/// Not two finite temperatures a chamber reaches (-100 to 200 C).
pub fn span(text: &str) -> Result<(f64, f64), Error> {
    let err = || Error::Span(text.to_string());
    let (a, b) = text.split_once(':').ok_or_else(err)?;
    let a: f64 = a.trim().parse().map_err(|_| err())?;
    let b: f64 = b.trim().parse().map_err(|_| err())?;
    let reached = |t: f64| (-100.0..=200.0).contains(&t);
    if !(reached(a) && reached(b)) {
        return Err(Error::Unreachable(text.to_string()));
    }
    Ok((a, b))
}

/// Reads `RISE:SECONDS`.
///
/// # Errors
/// Not a rise of at most 50 C and a time constant of at least 0 s.
pub fn self_heating(text: &str) -> Result<(f64, f64), Error> {
    let err = || Error::SelfHeating(text.to_string());
    let (a, b) = text.split_once(':').ok_or_else(err)?;
    let rise: f64 = a.trim().parse().map_err(|_| err())?;
    let tau: f64 = b.trim().parse().map_err(|_| err())?;
    if !(rise.is_finite() && rise.abs() <= 50.0 && tau.is_finite() && tau >= 0.0) {
        return Err(err());
    }
    Ok((rise, tau))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lagging_quantised_sensor_behind_an_uneven_ramp() {
        let r = Ramp {
            from: -40.0,
            to: 70.0,
            seconds: 7200.0,
            uneven: true,
            lag: 120.0,
            self_heating: Some((3.0, 300.0)),
            step: Some(1.0),
        };
        let t = r.temperatures(401);
        assert_eq!(t.chamber[0], -40.0);
        assert!((t.chamber[400] - 70.0).abs() < 1e-9);
        // Uneven: half the time covers far more than half the range.
        assert!(t.chamber[200] > 40.0, "{}", t.chamber[200]);
        // The sensor lags behind a rising chamber but carries its self-heating.
        assert!(t.sensor[50] < t.chamber[50] + 3.0);
        assert!((t.sensor[400] - (t.chamber[400] + 3.0)).abs() < 0.5);
        assert!(t.reported.iter().all(|v| v.fract() == 0.0));
        assert!(span("-40:70").is_ok());
        assert_eq!(span("-300:70"), Err(Error::Unreachable("-300:70".into())));
        assert_eq!(span("x"), Err(Error::Span("x".into())));
        assert_eq!(
            span("x").unwrap_err().to_string(),
            "--ramp `x`: expected FROM:TO in C, e.g. -40:70"
        );
        assert_eq!(self_heating("3:300"), Ok((3.0, 300.0)));
        assert_eq!(self_heating("3"), Err(Error::SelfHeating("3".into())));
        assert!(self_heating("99:1").is_err());
    }
}
