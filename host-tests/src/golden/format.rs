//! The vector file format (see the module above): a [`Case`] rendered to text and parsed back,
//! with the line and what was expected when it does not parse.

use std::fmt::Write as _;

use super::{Case, Kind, Step};

/// Renders a case in the vector file format.
#[must_use]
pub fn render(case: &Case) -> String {
    let mut s = String::from(
        "# spincal golden vectors: regenerate with SPINCAL_ACCEPT=1 cargo test -p host-tests --test golden\n",
    );
    writeln!(s, "blob {}", case.blob).unwrap();
    match case.kind {
        Kind::Single => writeln!(s, "kind single").unwrap(),
        Kind::Triad => writeln!(s, "kind triad").unwrap(),
        Kind::Imu(rate, max_acc)
            if max_acc == spincal::correct::DEFAULT_MAX_ANGULAR_ACCELERATION =>
        {
            writeln!(s, "kind imu {rate}").unwrap();
        }
        Kind::Imu(rate, max_acc) => writeln!(s, "kind imu {rate} {max_acc}").unwrap(),
    }
    for step in &case.steps {
        match step {
            Step::Env(t, v) => {
                writeln!(
                    s,
                    "env {:08x} {:08x}  # {t} C, {v} V",
                    t.to_bits(),
                    v.to_bits()
                )
                .unwrap();
            }
            Step::Sample {
                raw,
                expected,
                flags,
                sigma,
            } => {
                let raw: Vec<String> = raw.iter().map(ToString::to_string).collect();
                let out: Vec<String> = expected.iter().map(|b| format!("{b:08x}")).collect();
                let dec: Vec<String> = expected
                    .iter()
                    .map(|b| format!("{:.6e}", f32::from_bits(*b)))
                    .collect();
                let stated = if sigma.is_empty() {
                    String::new()
                } else {
                    let bits: Vec<String> = sigma.iter().map(|b| format!("{b:08x}")).collect();
                    format!(" sigma {}", bits.join(" "))
                };
                writeln!(
                    s,
                    "raw {} => {} flags {flags:02x}{stated}  # {}",
                    raw.join(" "),
                    out.join(" "),
                    dec.join(" ")
                )
                .unwrap();
            }
        }
    }
    s
}

/// A parse failure: the line (1-based) and what was wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// Line number.
    pub line: usize,
    /// What was expected.
    pub message: String,
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

/// Parses the vector file format.
///
/// # Errors
/// The first malformed line.
pub fn parse(text: &str) -> Result<Case, ParseError> {
    let mut blob = None;
    let mut kind = None;
    let mut steps = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let err = |message: &str| ParseError {
            line: i + 1,
            message: message.to_string(),
        };
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut words = line.split_whitespace();
        let hex = |w: Option<&str>| {
            w.and_then(|w| u32::from_str_radix(w, 16).ok())
                .ok_or_else(|| err("expected 8 hex digits"))
        };
        match words.next() {
            Some("blob") => {
                blob = Some(
                    words
                        .next()
                        .ok_or_else(|| err("blob needs a file name"))?
                        .to_string(),
                )
            }
            Some("kind") => {
                kind = Some(match (words.next(), words.next(), words.next()) {
                    (Some("single"), None, None) => Kind::Single,
                    (Some("triad"), None, None) => Kind::Triad,
                    (Some("imu"), Some(rate), max_acc) => Kind::Imu(
                        rate.parse()
                            .map_err(|_| err("imu needs a sample rate in Hz"))?,
                        match max_acc {
                            None => spincal::correct::DEFAULT_MAX_ANGULAR_ACCELERATION,
                            Some(a) => a.parse().map_err(|_| {
                                err("imu's largest angular acceleration is a number (rad/s^2)")
                            })?,
                        },
                    ),
                    _ => {
                        return Err(err(
                            "kind is single, triad or imu <rate> [<largest angular acceleration>]",
                        ));
                    }
                });
            }
            Some("env") => {
                let t = f32::from_bits(hex(words.next())?);
                let v = f32::from_bits(hex(words.next())?);
                steps.push(Step::Env(t, v));
            }
            Some("raw") => {
                let mut raw = Vec::new();
                for w in words.by_ref() {
                    if w == "=>" {
                        break;
                    }
                    raw.push(w.parse().map_err(|_| err("raw codes are integers"))?);
                }
                let mut expected = Vec::new();
                let mut flags = None;
                while let Some(w) = words.next() {
                    if w == "flags" {
                        flags = Some(
                            words
                                .next()
                                .and_then(|f| u8::from_str_radix(f, 16).ok())
                                .ok_or_else(|| err("flags needs 2 hex digits"))?,
                        );
                        break;
                    }
                    expected.push(hex(Some(w))?);
                }
                if expected.len() != raw.len() {
                    return Err(err("as many outputs as raw codes are expected"));
                }
                let flags = flags.ok_or_else(|| err("missing flags"))?;
                let mut sigma = Vec::new();
                match words.next() {
                    None => {}
                    Some("sigma") => {
                        for w in words {
                            sigma.push(hex(Some(w))?);
                        }
                        if sigma.len() != expected.len() {
                            return Err(err("sigma: one 1-sigma per output"));
                        }
                    }
                    Some(_) => return Err(err("after the flags, only `sigma` and its bits")),
                }
                steps.push(Step::Sample {
                    raw,
                    expected,
                    flags,
                    sigma,
                });
            }
            _ => return Err(err("a line starts with blob, kind, env or raw")),
        }
    }
    Ok(Case {
        blob: blob.ok_or(ParseError {
            line: 0,
            message: "no blob line".into(),
        })?,
        kind: kind.ok_or(ParseError {
            line: 0,
            message: "no kind line".into(),
        })?,
        steps,
    })
}
