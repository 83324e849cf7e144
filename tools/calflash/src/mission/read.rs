//! Reading a mission profile: a CSV file with a header naming its columns (lines starting with
//! `#` skipped; columns no role takes, such as an `id`, ignored), each value checked as it is
//! read, then the whole for time order, physical possibility and jumps no airframe makes.

use std::path::Path;

use super::columns::{self, Column, Role};
use super::{
    Impossible, Jump, MAX_ANGULAR_ACCELERATION, MAX_JERK, MAX_RATE, MAX_SPECIFIC_FORCE,
    MissionError, Profile, TEMPERATURES, VOLTAGES,
};
use crate::obs::fields::{LONGEST_HEAD_LINE, number};

/// The most samples a profile may hold (1,000 s at 10 kHz).
pub const MAX_SAMPLES: usize = 10_000_000;

/// Reads and checks the profile in `path`; `chosen` are `--mission-columns` (may be empty).
///
/// # Errors
/// A file that cannot be read, columns that cannot be found, a value that is not a number or
/// not physically possible, time not increasing, a jump no airframe makes: each named by
/// line and column.
pub fn read(path: &Path, chosen: &str) -> Result<Profile, MissionError> {
    read_at_most(path, chosen, MAX_SAMPLES)
}

/// [`read`], refusing more than `max` samples (`calflash flight --max-samples`).
///
/// # Errors
/// As [`read`].
pub fn read_at_most(path: &Path, chosen: &str, max: usize) -> Result<Profile, MissionError> {
    let io = |source| MissionError::Io {
        path: path.to_path_buf(),
        source,
    };
    let chosen = columns::parse(chosen)?;
    let file = std::fs::File::open(path).map_err(io)?;
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(crate::files::LineBound::new(file, LONGEST_HEAD_LINE));
    let csv_error = |e: csv::Error| match e.into_kind() {
        csv::ErrorKind::Io(e) => io(e),
        other => io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{other:?}"),
        )),
    };
    let header: Vec<String> = reader
        .headers()
        .map_err(csv_error)?
        .iter()
        .map(str::to_string)
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(MissionError::Empty {
            path: path.to_path_buf(),
        });
    }
    let found = assign(path, &header, &chosen)?;
    let (mut notes, scales) = units(&found);
    let width = header.len();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); found.len()];
    let mut lines = Vec::new();
    let mut record = csv::ByteRecord::new();
    while reader.read_byte_record(&mut record).map_err(csv_error)? {
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != width {
            return Err(MissionError::Width {
                path: path.to_path_buf(),
                line,
                found: record.len(),
                expected: width,
            });
        }
        if lines.len() == max {
            return Err(MissionError::TooLong {
                path: path.to_path_buf(),
                max,
            });
        }
        for ((k, c), out) in found.iter().enumerate().zip(cols.iter_mut()) {
            let field = &record[c.1];
            let v = number(field).ok_or_else(|| MissionError::NotNumber {
                path: path.to_path_buf(),
                line,
                column: found[k].0.name.clone(),
                text: crate::obs::shorten(&String::from_utf8_lossy(field)),
            })?;
            out.push(v * scales[k]);
        }
        lines.push(line);
    }
    if lines.len() < 2 {
        return Err(MissionError::TooShort {
            path: path.to_path_buf(),
            count: lines.len(),
        });
    }
    let take = |role: Role| found.iter().position(|(c, _)| c.role == role);
    let triad = |roles: [Role; 3]| -> Option<Vec<[f64; 3]>> {
        let idx: Vec<usize> = roles.iter().filter_map(|r| take(*r)).collect();
        (idx.len() == 3).then(|| {
            (0..lines.len())
                .map(|i| [cols[idx[0]][i], cols[idx[1]][i], cols[idx[2]][i]])
                .collect()
        })
    };
    let t = cols[take(Role::T).unwrap_or(0)].clone();
    let w = triad([Role::W(0), Role::W(1), Role::W(2)]);
    let mut dw = triad([Role::Dw(0), Role::Dw(1), Role::Dw(2)]);
    if dw.is_none()
        && let Some(w) = &w
    {
        dw = Some(differentiate(&t, w));
        notes
            .push("dw: no angular acceleration columns; differentiated from the rates".to_string());
    }
    if let (Some(w), Some(dw), false) = (&w, &dw, notes.iter().any(|n| n.starts_with("dw:"))) {
        degrees_against_radians(path, &t, w, dw)?;
    }
    let f = triad([Role::F(0), Role::F(1), Role::F(2)]);
    let profile = Profile {
        source: path.to_path_buf(),
        t,
        line: lines,
        f,
        w,
        dw,
        temp: take(Role::Temp).map(|k| cols[k].clone()),
        volt: take(Role::Volt).map(|k| cols[k].clone()),
        notes,
    };
    check(&profile, &found)?;
    Ok(profile)
}

/// The columns of each role found: the chosen ones, then the header's names for the others.
fn assign(
    path: &Path,
    header: &[String],
    chosen: &[Column],
) -> Result<Vec<(Column, usize)>, MissionError> {
    let mut found: Vec<(Column, usize)> = Vec::new();
    for c in chosen {
        let k =
            header
                .iter()
                .position(|h| *h == c.name)
                .ok_or_else(|| MissionError::NoSuchColumn {
                    path: path.to_path_buf(),
                    name: c.name.clone(),
                    role: c.role.name(),
                    has: header.join(", "),
                })?;
        found.push((c.clone(), k));
    }
    // The observation files' own names first (`f_x`, `w_x`, `dw_x`): beside them, `a_x` and
    // `g_x` are a unit's raw codes, not the profile.
    let canonical = |name: &str| {
        crate::mission::Quantity::all()
            .iter()
            .any(|q| q.name() == name)
    };
    let mut order: Vec<usize> = (0..header.len()).collect();
    order.sort_by_key(|k| !canonical(&header[*k]));
    for k in order {
        let name = &header[k];
        if found.iter().any(|(_, j)| *j == k) {
            continue;
        }
        let Some(c) = columns::recognise(name) else {
            continue;
        };
        if chosen.iter().any(|x| x.role == c.role) {
            continue;
        }
        if let Some((first, _)) = found.iter().find(|(f, _)| f.role == c.role)
            && canonical(&first.name)
        {
            continue;
        }
        if let Some((first, _)) = found.iter().find(|(f, _)| f.role == c.role) {
            return Err(MissionError::TwoColumns {
                path: path.to_path_buf(),
                role: c.role.name(),
                first: first.name.clone(),
                second: c.name,
            });
        }
        found.push((c, k));
    }
    if !found.iter().any(|(c, _)| c.role == Role::T) {
        return Err(MissionError::NoTime {
            path: path.to_path_buf(),
        });
    }
    let mut any = false;
    for (what, roles) in [
        ("the specific force", [Role::F(0), Role::F(1), Role::F(2)]),
        ("the rate", [Role::W(0), Role::W(1), Role::W(2)]),
        (
            "the angular acceleration",
            [Role::Dw(0), Role::Dw(1), Role::Dw(2)],
        ),
    ] {
        let has: Vec<bool> = roles
            .iter()
            .map(|r| found.iter().any(|(c, _)| c.role == *r))
            .collect();
        let names = |want: bool| {
            roles
                .iter()
                .zip(&has)
                .filter(|(_, h)| **h == want)
                .map(|(r, _)| r.name())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if has.iter().any(|h| *h) && !has.iter().all(|h| *h) {
            return Err(MissionError::PartTriad {
                path: path.to_path_buf(),
                what,
                found: names(true),
                missing: names(false),
            });
        }
        any |= has[0] && !matches!(roles[0], Role::Dw(_));
    }
    if !any {
        return Err(MissionError::Nothing {
            path: path.to_path_buf(),
            has: header.join(", "),
        });
    }
    found.sort_by_key(|(c, _)| columns::ROLES.iter().position(|r| *r == c.role));
    Ok(found)
}

/// The scale to SI of each column, and a note for each quantity whose unit was assumed.
fn units(found: &[(Column, usize)]) -> (Vec<String>, Vec<f64>) {
    let mut notes: Vec<String> = Vec::new();
    let scales = found
        .iter()
        .map(|(c, _)| {
            if let Some((s, _)) = c.unit {
                return s;
            }
            let what = match c.role {
                Role::F(_) => "specific force",
                Role::W(_) => "rate",
                Role::Dw(_) => "angular acceleration",
                // One unit each: nothing to assume.
                Role::Temp | Role::Volt | Role::T => return 1.0,
            };
            let note = format!(
                "{what}: no unit stated, read as {} (SI); state one as --mission-columns {}={}:UNIT",
                c.role.si(),
                c.role.name(),
                c.name
            );
            if !notes.iter().any(|n| n.starts_with(what)) {
                notes.push(note);
            }
            1.0
        })
        .collect();
    (notes, scales)
}

/// The derivative of `w` by central differences (one-sided at the ends).
/// Refuses rates and angular accelerations whose units differ by a degree's factor: the
/// least-squares ratio of the rates' own change over time to the `dw` columns, over samples
/// that turn, near 180/pi (rates in deg/s under SI names) or its inverse, with the two in step
/// (correlation above 0.9, so noise alone never trips it).
fn degrees_against_radians(
    path: &Path,
    t: &[f64],
    w: &[[f64; 3]],
    dw: &[[f64; 3]],
) -> Result<(), MissionError> {
    let slope = differentiate(t, w);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (d, x) in slope.iter().zip(dw) {
        for k in 0..3 {
            sxy += d[k] * x[k];
            sxx += x[k] * x[k];
            syy += d[k] * d[k];
        }
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return Ok(());
    }
    let (ratio, correlation) = (sxy / sxx, sxy / (sxx * syy).sqrt());
    let degree = 180.0 / std::f64::consts::PI;
    let which = if (ratio / degree - 1.0).abs() < 0.1 {
        "the rates look like deg/s read as rad/s"
    } else if (ratio * degree - 1.0).abs() < 0.1 {
        "the angular accelerations look like deg/s^2 read as rad/s^2"
    } else {
        return Ok(());
    };
    if correlation < 0.9 {
        return Ok(());
    }
    Err(MissionError::RateUnits {
        path: path.to_path_buf(),
        ratio,
        which,
    })
}

fn differentiate(t: &[f64], w: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = t[b] - t[a];
            std::array::from_fn(|k| (w[b][k] - w[a][k]) / dt)
        })
        .collect()
}

/// Time order, physical possibility and jumps.
fn check(p: &Profile, found: &[(Column, usize)]) -> Result<(), MissionError> {
    let path = || p.source.clone();
    let column = |role: Role| {
        found
            .iter()
            .find(|(c, _)| c.role == role)
            .map_or_else(|| role.name(), |(c, _)| c.name.clone())
    };
    for i in 1..p.len() {
        if p.t[i] <= p.t[i - 1] {
            return Err(MissionError::TimeBackwards {
                path: path(),
                line: p.line[i],
                t: p.t[i],
                before: p.t[i - 1],
            });
        }
    }
    let unstated = |role: Role| {
        found
            .iter()
            .any(|(c, _)| c.role == role && c.unit.is_none())
    };
    let bound = |role: Role, v: f64, i: usize, lo: f64, hi: f64, limit: String| {
        if (lo..=hi).contains(&v) {
            return Ok(());
        }
        let hint = match role {
            Role::F(_) | Role::W(_) | Role::Dw(_) if unstated(role) => format!(
                "; its unit was not stated and {} was assumed: state it as --mission-columns {}={}:UNIT",
                role.si(),
                role.name(),
                column(role)
            ),
            _ => String::new(),
        };
        Err(MissionError::Impossible(Box::new(Impossible {
            path: path(),
            line: p.line[i],
            column: column(role),
            value: v,
            unit: role.si(),
            limit,
            hint,
        })))
    };
    type Triad<'a> = (&'a Option<Vec<[f64; 3]>>, fn(usize) -> Role, f64, f64);
    let triads: [Triad; 3] = [
        (&p.f, Role::F, MAX_SPECIFIC_FORCE, MAX_JERK),
        (&p.w, Role::W, MAX_RATE, MAX_ANGULAR_ACCELERATION),
        (&p.dw, Role::Dw, MAX_ANGULAR_ACCELERATION, f64::INFINITY),
    ];
    for (series, role, max, max_rate) in triads {
        let Some(s) = series else { continue };
        for (i, v) in s.iter().enumerate() {
            for (k, x) in v.iter().enumerate() {
                bound(
                    role(k),
                    *x,
                    i,
                    -max,
                    max,
                    format!("at most {max:.3e} {}", role(k).si()),
                )?;
                if i > 0 {
                    let dt = p.t[i] - p.t[i - 1];
                    let rate = (x - s[i - 1][k]).abs() / dt;
                    if rate > max_rate {
                        return Err(MissionError::Jump(Box::new(Jump {
                            path: path(),
                            line: p.line[i],
                            column: column(role(k)),
                            from: s[i - 1][k],
                            to: *x,
                            dt,
                            rate,
                            unit: role(k).si(),
                            limit: max_rate,
                        })));
                    }
                }
            }
        }
    }
    for (series, role, (lo, hi)) in [
        (&p.temp, Role::Temp, TEMPERATURES),
        (&p.volt, Role::Volt, VOLTAGES),
    ] {
        if let Some(s) = series {
            for (i, v) in s.iter().enumerate() {
                bound(role, *v, i, lo, hi, format!("{lo} to {hi} {}", role.si()))?;
            }
        }
    }
    Ok(())
}
