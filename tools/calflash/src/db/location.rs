//! Where the unit history is: a SQLite file on the station (the default) or a PostgreSQL
//! database that several stations share (`postgres://` or `postgresql://` URLs).

use std::ffi::{OsStr, OsString};
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

/// A `--db` or `$CALFLASH_DB` that names no history calflash can keep records in. The text
/// given is never repeated whole in the message: a mistyped URL may hold a password.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LocationError {
    /// An empty location.
    #[error(
        "the unit history's location is empty (--db \"\" or an empty $CALFLASH_DB): give a \
         SQLite file or a postgres:// URL, or --no-db to record nothing"
    )]
    Empty,
    /// A database in memory, deleted when calflash exits.
    #[error(
        "`{0}` is a database in memory, deleted when calflash exits: nothing would be kept; \
         give a SQLite file or a postgres:// URL, or --no-db to record nothing"
    )]
    Memory(String),
    /// Blanks around the location.
    #[error(
        "the unit history's location begins or ends with a blank: give it without (a file \
         name with such blanks is refused, as a mistyped URL would become one)"
    )]
    Blank,
    /// A URL of a scheme calflash does not speak, or a URL mistyped.
    #[error(
        "`{scheme}:...` (the rest not shown: it may hold a password) is not a history calflash \
         can use: give a SQLite file (./{scheme}... for a file of that name) or a PostgreSQL \
         URL, postgres://USER:PASSWORD@HOST/DB (postgresql:// too)"
    )]
    Scheme {
        /// The text before the first `:`.
        scheme: String,
    },
    /// A path that exists and is not a regular file: a device (`/dev/null`), a directory, a
    /// FIFO. SQLite would open it and write its journal beside it (`/dev/null-journal`).
    #[error(
        "{}: the unit history must be a SQLite file (or a postgres:// URL); this is {kind}:          give a file's path, or --no-db to record nothing",
        .path.display()
    )]
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What it is.
        kind: &'static str,
    },
}

/// A history file's path, refused when it exists and is not a regular file.
fn history_file(path: PathBuf) -> Result<Location, LocationError> {
    match std::fs::metadata(&path) {
        Ok(m) if !m.is_file() => Err(LocationError::NotAFile {
            kind: if m.is_dir() {
                "a directory"
            } else {
                "a device, a FIFO or a socket, not a file"
            },
            path,
        }),
        _ => Ok(Location::File(path)),
    }
}

impl Location {
    /// Reads `--db` or `$CALFLASH_DB`: a `postgres://` or `postgresql://` URL (the scheme in
    /// any case) is a server; a path a SQLite file. Refused: an empty location, `:memory:` and
    /// SQLite's `file:` URIs, blanks around it, and any other `scheme:/...` or `scheme://`
    /// (`postgress://`, `postgres:/`, `mysql://`): a mistyped URL must not become a local file
    /// whose directories carry the password.
    ///
    /// # Errors
    /// [`LocationError`].
    pub fn parse(text: &OsStr) -> Result<Self, LocationError> {
        let Some(t) = text.to_str() else {
            // Not UTF-8: a path, never a URL.
            return history_file(PathBuf::from(text));
        };
        if t.is_empty() {
            return Err(LocationError::Empty);
        }
        if t.trim() != t {
            return Err(LocationError::Blank);
        }
        if t == ":memory:" || t.starts_with("file:") && t.contains("memory") {
            return Err(LocationError::Memory(t.to_string()));
        }
        if let Some((scheme, rest)) = t.split_once(':') {
            let lower = scheme.to_ascii_lowercase();
            let schemelike = scheme.len() >= 2
                && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
                && scheme
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
            if schemelike
                && rest.starts_with("//")
                && matches!(lower.as_str(), "postgres" | "postgresql")
            {
                return Ok(Self::Server(format!("{lower}{}", &t[scheme.len()..])));
            }
            if schemelike && (rest.starts_with('/') || lower == "file" || t.contains('@')) {
                return Err(LocationError::Scheme {
                    scheme: scheme.to_string(),
                });
            }
        }
        history_file(PathBuf::from(t))
    }
}

/// A history's location as `--db` gives it, read by [`Given::location`] (or
/// [`Location::or_default`]) and not by the option parser, whose error would repeat the text
/// given, password and all.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Given(OsString);

impl From<OsString> for Given {
    fn from(s: OsString) -> Self {
        Self(s)
    }
}

impl From<PathBuf> for Given {
    fn from(p: PathBuf) -> Self {
        Self(p.into_os_string())
    }
}

impl Given {
    /// The location.
    ///
    /// # Errors
    /// As [`Location::parse`].
    pub fn location(&self) -> Result<Location, LocationError> {
        Location::parse(&self.0)
    }
}

impl std::str::FromStr for Location {
    type Err = LocationError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(OsStr::new(s))
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
    ///
    /// # Errors
    /// A `$CALFLASH_DB` that names no usable history ([`Location::parse`]).
    pub fn default_location() -> Result<Self, LocationError> {
        if let Some(p) = std::env::var_os("CALFLASH_DB") {
            return Self::parse(&p);
        }
        let data = std::env::var_os("XDG_DATA_HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))
            .unwrap_or_else(|| PathBuf::from("."));
        Ok(Self::File(data.join("calflash").join("units.sqlite")))
    }

    /// `given`, else the default.
    ///
    /// # Errors
    /// As [`Location::parse`] and [`Location::default_location`].
    pub fn or_default(given: Option<&Given>) -> Result<Self, LocationError> {
        given.map_or_else(Self::default_location, Given::location)
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

    fn from(s: &str) -> Location {
        s.parse().unwrap()
    }

    #[test]
    fn a_mistyped_url_or_a_memory_database_is_refused_and_no_password_shown() {
        for bad in [
            "Postgress://u:s3cret@h/db",
            "postgress://u:s3cret@h/db",
            "postgres:/u:s3cret@h/db",
            "mysql://u:s3cret@h/db",
            "sqlite://u:s3cret@h/db",
            "file:units.sqlite?mode=memory",
            " postgres://u:s3cret@h/db",
            "postgres://u:s3cret@h/db ",
            "postgres:u:s3cret@h/db",
            "",
            ":memory:",
        ] {
            let e = bad.parse::<Location>().unwrap_err();
            let m = e.to_string();
            assert!(!m.contains("s3cret"), "{bad}: {m}");
            assert!(!m.is_empty());
        }
        assert_eq!(
            from("Postgres://u@h/db"),
            Location::Server("postgres://u@h/db".into())
        );
        assert_eq!(
            from("C:/units.sqlite"),
            Location::File("C:/units.sqlite".into())
        );
    }

    #[test]
    fn a_device_or_a_directory_is_no_history() {
        for (path, kind) in [("/dev/null", "a device"), ("/tmp", "a directory")] {
            let e = Location::parse(OsStr::new(path)).unwrap_err();
            assert!(matches!(e, LocationError::NotAFile { .. }), "{e}");
            assert!(e.to_string().contains(kind), "{e}");
        }
    }

    #[test]
    fn a_url_is_a_server_and_anything_else_a_file() {
        assert_eq!(
            from("postgres://u@h/db"),
            Location::Server("postgres://u@h/db".into())
        );
        assert_eq!(
            from("postgresql://h/db"),
            Location::Server("postgresql://h/db".into())
        );
        assert_eq!(from("units.sqlite"), Location::File("units.sqlite".into()));
        assert_eq!(
            from("./postgres:/x"),
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
            assert_eq!(from(url).to_string(), shown);
        }
    }
}
