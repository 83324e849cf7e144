//! Where the unit history is: a SQLite file on the station (the default) or a PostgreSQL
//! database that several stations share (`postgres://` or `postgresql://` URLs).

use std::ffi::OsString;
use std::fmt;
use std::path::{Path, PathBuf};

/// The unit history's location, as `--db` or `$CALFLASH_DB` gives it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// A SQLite file.
    File(PathBuf),
    /// A PostgreSQL connection URL, password included; shown without it (see [`redact`]).
    Server(String),
}

impl From<OsString> for Location {
    fn from(s: OsString) -> Self {
        match s.to_str() {
            Some(t) if is_server_url(t) => Self::Server(t.to_string()),
            _ => Self::File(PathBuf::from(s)),
        }
    }
}

impl From<&str> for Location {
    fn from(s: &str) -> Self {
        Self::from(OsString::from(s))
    }
}

impl From<&Path> for Location {
    fn from(p: &Path) -> Self {
        Self::File(p.to_path_buf())
    }
}

impl From<&PathBuf> for Location {
    fn from(p: &PathBuf) -> Self {
        Self::File(p.clone())
    }
}

impl From<&Location> for Location {
    fn from(l: &Location) -> Self {
        l.clone()
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File(p) => write!(f, "{}", p.display()),
            Self::Server(url) => f.write_str(&redact(url)),
        }
    }
}

impl Location {
    /// The default: `$CALFLASH_DB`, else `$XDG_DATA_HOME/calflash/units.sqlite`, else
    /// `~/.local/share/calflash/units.sqlite`.
    #[must_use]
    pub fn default_location() -> Self {
        if let Some(p) = std::env::var_os("CALFLASH_DB") {
            return Self::from(p);
        }
        let data = std::env::var_os("XDG_DATA_HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))
            .unwrap_or_else(|| PathBuf::from("."));
        Self::File(data.join("calflash").join("units.sqlite"))
    }

    /// `given`, else the default.
    #[must_use]
    pub fn or_default(given: Option<&Self>) -> Self {
        given.cloned().unwrap_or_else(Self::default_location)
    }

    /// The file, for a SQLite history.
    #[must_use]
    pub fn file(&self) -> Option<&Path> {
        match self {
            Self::File(p) => Some(p),
            Self::Server(_) => None,
        }
    }
}

fn is_server_url(s: &str) -> bool {
    s.starts_with("postgres://") || s.starts_with("postgresql://")
}

/// `url` without its password (the `:password` of the user part and any `password=`
/// parameter), for messages and listings.
#[must_use]
pub fn redact(url: &str) -> String {
    let (scheme, rest) = url.split_once("://").unwrap_or(("", url));
    // The user part ends at the last '@' before the parameters (a password may hold '/').
    let params = rest.find('?').unwrap_or(rest.len());
    let (user, rest) = match rest[..params].rfind('@') {
        Some(at) => (Some(&rest[..at]), &rest[at + 1..]),
        None => (None, rest),
    };
    let end = rest.find(['/', '?', '#']).unwrap_or(rest.len());
    let (host, tail) = rest.split_at(end);
    let authority = match user {
        Some(user) => {
            let user = user.split_once(':').map_or(user, |(u, _)| u);
            format!("{user}@{host}")
        }
        None => host.to_string(),
    };
    let tail = match tail.split_once('?') {
        Some((path, query)) => {
            let kept: Vec<&str> = query
                .split('&')
                .filter(|kv| !kv.to_ascii_lowercase().starts_with("password="))
                .collect();
            if kept.is_empty() {
                path.to_string()
            } else {
                format!("{path}?{}", kept.join("&"))
            }
        }
        None => tail.to_string(),
    };
    format!("{scheme}://{authority}{tail}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_url_is_a_server_and_anything_else_a_file() {
        assert_eq!(
            Location::from("postgres://u@h/db"),
            Location::Server("postgres://u@h/db".into())
        );
        assert_eq!(
            Location::from("postgresql://h/db"),
            Location::Server("postgresql://h/db".into())
        );
        assert_eq!(
            Location::from("units.sqlite"),
            Location::File("units.sqlite".into())
        );
        assert_eq!(
            Location::from("./postgres:/x"),
            Location::File("./postgres:/x".into())
        );
    }

    #[test]
    fn the_password_is_never_shown() {
        for (url, shown) in [
            (
                "postgres://calflash:s3cr:et@db.plant:5432/history",
                "postgres://calflash@db.plant:5432/history",
            ),
            (
                "postgres://calflash:p%40ss@h/history?sslmode=disable&password=x",
                "postgres://calflash@h/history?sslmode=disable",
            ),
            (
                "postgresql://h/history?password=x",
                "postgresql://h/history",
            ),
            ("postgres://u@h", "postgres://u@h"),
            ("postgres://u:pa/ss@h/d", "postgres://u@h/d"),
            ("postgres://h:5433/d", "postgres://h:5433/d"),
        ] {
            assert_eq!(redact(url), shown, "{url}");
            assert_eq!(Location::from(url).to_string(), shown);
        }
    }
}
