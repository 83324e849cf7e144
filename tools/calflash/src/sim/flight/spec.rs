//! `--flight KIND[:KEY=VALUE,...]`: which flight, and what differs from its defaults.

use super::Flight;
use super::rocket::Rocket;
use super::shell::Shell;
use super::site::Site;

/// Where a flight is launched when a key names only part of it (or a receiver needs one):
/// 45 N, 0 E, sea level, fired north.
pub const DEFAULT_SITE: Site = Site {
    latitude: 45.0,
    longitude: 0.0,
    height: 0.0,
    azimuth: 0.0,
};

/// A flight to simulate.
#[derive(Debug, Clone, PartialEq)]
pub enum Launch {
    /// A spin-stabilised shell.
    Shell(Box<Shell>),
    /// A fin-stabilised rocket.
    Rocket(Box<Rocket>),
}

/// A `--flight` that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--flight `{text}`: {why}")]
pub struct SpecError {
    /// The text.
    pub text: String,
    /// What is wrong.
    pub why: String,
}

/// Why one `KEY=VALUE` of a `--flight` cannot be set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum KeyError {
    /// A value beyond its key's range.
    #[error("{what} must be from {lo} to {hi}")]
    OutOfRange {
        what: &'static str,
        lo: f64,
        hi: f64,
    },
    /// A key the kind of flight does not have.
    #[error("a {kind} has no `{key}`; its keys: {keys}")]
    NoKey {
        kind: &'static str,
        key: String,
        keys: &'static str,
    },
}

/// The keys of a shell and what they set.
pub const SHELL_KEYS: &str = "setback (g, 15000), velocity (muzzle, m/s, 800), spin (muzzle, rev/s, 300), elevation (degrees, 45), tip-off (rad/s, 5), seconds (60), conditioned (C, 21), altitude (m, 0), rest (s loaded before firing, 0.02); and where: lat, lon (degrees), azimuth (of fire, degrees from north)";
/// The keys of a rocket.
pub const ROCKET_KEYS: &str = "thrust (N, 1800), burn (s, 6), elevation (degrees, 84), rail (m, 12), cant (the fins' roll drive C_l_delta delta, 0.077), seconds (300), conditioned (C, 25), altitude (m, 0), rest (s on the rail before ignition, 0); and where: lat, lon (degrees), azimuth (of fire, degrees from north)";

impl Launch {
    /// Reads `shell` or `rocket`, then `:KEY=VALUE` pairs separated by commas.
    ///
    /// # Errors
    /// An unknown kind or key, a value that is not a number or is out of its range.
    pub fn parse(text: &str) -> Result<Self, SpecError> {
        let bad = |why: String| SpecError {
            text: text.to_string(),
            why,
        };
        let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
        let mut launch = match kind.trim() {
            "shell" => Self::Shell(Box::default()),
            "rocket" => Self::Rocket(Box::default()),
            other => {
                return Err(bad(format!(
                    "`{other}` is not a flight; expected shell or rocket, then :KEY=VALUE,..."
                )));
            }
        };
        let mut seen: Vec<&str> = Vec::new();
        for item in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| bad(format!("`{item}`: expected KEY=VALUE")))?;
            if seen.contains(&key.trim()) {
                return Err(bad(format!(
                    "`{}` is given twice; give each key once",
                    key.trim()
                )));
            }
            seen.push(key.trim());
            let value: f64 = value
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| bad(format!("`{item}`: `{}` is not a number", value.trim())))?;
            launch
                .set(key.trim(), value)
                .map_err(|why| bad(format!("`{item}`: {why}")))?;
        }
        if let Self::Rocket(r) = &launch {
            r.flies().map_err(|e| bad(e.to_string()))?;
        }
        Ok(launch)
    }

    fn set(&mut self, key: &str, v: f64) -> Result<(), KeyError> {
        let within = |lo: f64, hi: f64, what: &'static str| {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(KeyError::OutOfRange { what, lo, hi })
            }
        };
        let place = match key {
            "lat" => Some(within(-89.0, 89.0, "the latitude (degrees)")?),
            "lon" => Some(within(-180.0, 180.0, "the longitude (degrees)")?),
            "azimuth" => Some(within(-360.0, 360.0, "the azimuth (degrees)")?),
            _ => None,
        };
        if let Some(v) = place {
            let altitude = match self {
                Self::Shell(s) => s.altitude,
                Self::Rocket(r) => r.altitude,
            };
            let site = self.site_mut().get_or_insert(Site {
                height: altitude,
                ..DEFAULT_SITE
            });
            match key {
                "lat" => site.latitude = v,
                "lon" => site.longitude = v,
                _ => site.azimuth = v,
            }
            return Ok(());
        }
        match self {
            Self::Shell(s) => match key {
                "setback" => s.setback_g = within(100.0, 100_000.0, "the setback (g)")?,
                "velocity" => {
                    s.muzzle_velocity = within(50.0, 2_000.0, "the muzzle velocity (m/s)")?
                }
                "spin" => s.muzzle_spin = within(1.0, 1_000.0, "the muzzle spin (rev/s)")?,
                "elevation" => s.elevation = within(0.0, 89.0, "the elevation (degrees)")?,
                "tip-off" => s.tip_off = within(0.0, 50.0, "the tip-off rate (rad/s)")?,
                "seconds" => s.seconds = within(0.01, 1_000.0, "the duration (s)")?,
                "conditioned" => s.conditioned = within(-60.0, 80.0, "the conditioning (C)")?,
                "altitude" => s.altitude = within(-400.0, 5_000.0, "the altitude (m)")?,
                "rest" => s.loaded = within(0.0, 600.0, "the rest (s)")?,
                other => {
                    return Err(KeyError::NoKey {
                        kind: "shell",
                        key: other.to_string(),
                        keys: SHELL_KEYS,
                    });
                }
            },
            Self::Rocket(r) => match key {
                "thrust" => {
                    let f = within(10.0, 1.0e6, "the thrust (N)")?;
                    let burn = r.airframe.burnout() - 0.1;
                    r.airframe.thrust = thrust(f, burn);
                }
                "burn" => {
                    let b = within(0.2, 600.0, "the burn (s)")?;
                    let f = r.airframe.thrust.get(1).map_or(1_800.0, |p| p.1);
                    r.airframe.thrust = thrust(f, b);
                }
                "elevation" => r.elevation = within(10.0, 90.0, "the elevation (degrees)")?,
                "rail" => r.rail = within(0.1, 100.0, "the rail (m; a rocket leaves a rail)")?,
                "cant" => r.airframe.roll_drive = within(-1.0, 1.0, "the roll drive")?,
                "seconds" => r.seconds = within(0.01, 3_600.0, "the duration (s)")?,
                "conditioned" => r.conditioned = within(-60.0, 80.0, "the conditioning (C)")?,
                "altitude" => r.altitude = within(-400.0, 5_000.0, "the altitude (m)")?,
                "rest" => r.waiting = within(0.0, 600.0, "the rest (s)")?,
                other => {
                    return Err(KeyError::NoKey {
                        kind: "rocket",
                        key: other.to_string(),
                        keys: ROCKET_KEYS,
                    });
                }
            },
        }
        Ok(())
    }

    /// Where it is launched: `None` over a flat, still Earth.
    pub fn site_mut(&mut self) -> &mut Option<Site> {
        match self {
            Self::Shell(s) => &mut s.site,
            Self::Rocket(r) => &mut r.site,
        }
    }

    /// The time at rest before launch, s.
    #[must_use]
    pub fn rest(&self) -> f64 {
        match self {
            Self::Shell(s) => s.loaded,
            Self::Rocket(r) => r.waiting,
        }
    }

    /// The flight's longest duration, s.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        match self {
            Self::Shell(s) => s.seconds,
            Self::Rocket(r) => r.seconds,
        }
    }

    /// The sampling rate a flight of this kind is simulated at unless told, Hz.
    #[must_use]
    pub fn default_rate(&self) -> f64 {
        match self {
            Self::Shell(_) => 10_000.0,
            Self::Rocket(_) => 1_000.0,
        }
    }

    /// Flies it, sampling every `dt` s.
    #[must_use]
    pub fn fly(&self, dt: f64) -> Flight {
        match self {
            Self::Shell(s) => s.fire(dt),
            Self::Rocket(r) => r.launch(dt),
        }
    }
}

/// A thrust curve of `force` N for `burn` s, rising and falling over 0.05 and 0.1 s.
fn thrust(force: f64, burn: f64) -> Vec<(f64, f64)> {
    vec![
        (0.0, 0.0),
        (0.05, force),
        (burn.max(0.1), force),
        (burn.max(0.1) + 0.1, 0.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flight_reads_its_kind_and_keys_and_names_what_it_cannot_read() {
        let Launch::Shell(s) = Launch::parse("shell:setback=20000, spin=250").unwrap() else {
            panic!()
        };
        assert_eq!(
            (s.setback_g, s.muzzle_spin, s.muzzle_velocity),
            (20_000.0, 250.0, 800.0)
        );
        let Launch::Rocket(r) = Launch::parse("rocket:thrust=2500,burn=4").unwrap() else {
            panic!()
        };
        assert_eq!(r.airframe.thrust[1].1, 2_500.0);
        assert!((r.airframe.burnout() - 4.1).abs() < 1e-12);
        for (text, says) in [
            ("mortar", "is not a flight"),
            ("shell:spin", "expected KEY=VALUE"),
            ("shell:spin=fast", "is not a number"),
            ("shell:spin=nan", "is not a number"),
            ("shell:spin=5000", "must be from 1 to 1000"),
            ("shell:thrust=5", "a shell has no `thrust`"),
            (
                "rocket:rail=0",
                "the rail (m; a rocket leaves a rail) must be from 0.1",
            ),
            ("rocket:thrust=10", "never leaves its rail"),
            ("rocket:burn=2,burn=3", "`burn` is given twice"),
        ] {
            let e = Launch::parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }
}
