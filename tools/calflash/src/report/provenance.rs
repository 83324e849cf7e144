//! Where a report comes from, on the page (issue 68): when it was made, by which calflash
//! (version and git commit), on which station and by which operator, with which command line,
//! from which input files and for which blob (each by its SHA-256), and the page's own seal. A
//! reviewer who signs a page can tie it to the bytes that went into the unit:
//! `calflash verify-report PAGE --blob B --data D` says whether the page belongs to them.
//!
//! The block is a table a person reads and the same facts as JSON in
//! `<script type="application/json" id="calflash-provenance">`; the seal is the SHA-256 of
//! the whole page with the seal's own digits written as zeros.

use std::io::Read as _;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::Digest as _;

use super::page::esc;
use crate::sensor::record::hex;

/// The schema of the provenance JSON.
pub const SCHEMA: &str = "calflash.report-provenance/1";

/// The git commit calflash was built from (`unknown` outside a git checkout).
pub const GIT_COMMIT: &str = env!("CALFLASH_GIT_COMMIT");

/// The seal's stand-in while the page is hashed.
const UNSEALED: &str = "0000000000000000000000000000000000000000000000000000000000000000";

/// One file the report was made from (or the blob it describes).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileHash {
    /// What the file is to the command (`data`, `--mission`, `blob`).
    pub role: String,
    /// Its path as given.
    pub path: String,
    /// Its SHA-256, hex.
    pub sha256: String,
    /// Its length, bytes.
    pub bytes: u64,
}

impl FileHash {
    /// The hash of the file at `path`.
    ///
    /// # Errors
    /// The file cannot be read.
    pub fn of_file(role: &str, path: &Path) -> std::io::Result<Self> {
        let mut f = std::fs::File::open(path)?;
        let mut h = sha2::Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = f.read(&mut buf)?;
            if n == 0 {
                break;
            }
            h.update(&buf[..n]);
            bytes += n as u64;
        }
        Ok(Self {
            role: role.into(),
            path: path.display().to_string(),
            sha256: hex(&h.finalize()),
            bytes,
        })
    }

    /// The hash of `bytes`, to be (or read back) at `path`.
    #[must_use]
    pub fn of_bytes(role: &str, path: &str, bytes: &[u8]) -> Self {
        Self {
            role: role.into(),
            path: path.into(),
            sha256: hex(&sha2::Sha256::digest(bytes)),
            bytes: bytes.len() as u64,
        }
    }
}

/// What a page says of where it comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// [`SCHEMA`].
    pub schema: String,
    /// When the page was made, UTC (`YYYY-MM-DD HH:MM:SS`).
    pub generated_utc: String,
    /// calflash's version.
    pub tool_version: String,
    /// The git commit it was built from.
    pub git_commit: String,
    /// The station (`$CALFLASH_STATION`, else the host name).
    pub station: String,
    /// The operator (`$CALFLASH_OPERATOR`, else the login name).
    pub operator: String,
    /// The command line, as run: it carries every threshold and level given; the others are
    /// this version's defaults.
    pub command: String,
    /// The unit's serial, where the page is one unit's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    /// The input files.
    pub inputs: Vec<FileHash>,
    /// The blob written (or read and described), when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blob: Option<FileHash>,
    /// The unit history's record of what the page describes (`db:12 in PATH`), where it was
    /// recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub record: Option<String>,
    /// The page's seal: the SHA-256 of the page with these digits as zeros.
    pub page_sha256: String,
}

impl Provenance {
    /// The provenance of a page this process makes now.
    #[must_use]
    pub fn now() -> Self {
        let operator = ["CALFLASH_OPERATOR", "USER", "LOGNAME"]
            .iter()
            .find_map(|k| std::env::var(k).ok().filter(|v| !v.trim().is_empty()))
            .unwrap_or_else(|| "unknown".into());
        let command = std::env::args()
            .map(|a| {
                if a.is_empty() || a.contains(char::is_whitespace) {
                    format!("'{a}'")
                } else {
                    a
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
        Self {
            schema: SCHEMA.into(),
            generated_utc: utc_now(),
            tool_version: env!("CARGO_PKG_VERSION").into(),
            git_commit: GIT_COMMIT.into(),
            station: crate::db::station(),
            operator,
            command,
            serial: None,
            inputs: Vec::new(),
            blob: None,
            record: None,
            page_sha256: UNSEALED.into(),
        }
    }

    /// With input file `path` (its role to the command), hashed now; a file that cannot be
    /// read (a FIFO read already) is named with no hash.
    #[must_use]
    pub fn input(mut self, role: &str, path: &Path) -> Self {
        let h = if crate::files::is_special(path) {
            None
        } else {
            FileHash::of_file(role, path).ok()
        };
        self.inputs.push(h.unwrap_or_else(|| FileHash {
            role: role.into(),
            path: path.display().to_string(),
            sha256: "not hashed (not a regular file)".into(),
            bytes: 0,
        }));
        self
    }

    /// With the blob `bytes` (written to, or read from, `path`).
    #[must_use]
    pub fn blob(mut self, path: &str, bytes: &[u8]) -> Self {
        self.blob = Some(FileHash::of_bytes("blob", path, bytes));
        self
    }

    /// With the inputs `files` that were given (role, path).
    #[must_use]
    pub fn inputs(self, files: &[(&str, Option<&Path>)]) -> Self {
        files.iter().fold(self, |p, (role, path)| match path {
            Some(path) => p.input(role, path),
            None => p,
        })
    }

    /// With the blob file at `path` (the calibration the page describes).
    #[must_use]
    pub fn blob_file(mut self, path: &Path) -> Self {
        self.blob = FileHash::of_file("blob", path).ok();
        self
    }

    /// With the unit's serial.
    #[must_use]
    pub fn serial(mut self, serial: &str) -> Self {
        self.serial = Some(serial.into());
        self
    }

    /// `html` with this provenance before its `</body>` (at its end without one), sealed.
    #[must_use]
    pub fn stamp(&self, html: &str) -> String {
        let mut p = self.clone();
        p.page_sha256 = UNSEALED.into();
        let block = p.block();
        let page = match html.rfind("</body>") {
            Some(at) => format!("{}{block}{}", &html[..at], &html[at..]),
            None => format!("{html}{block}"),
        };
        let seal = hex(&sha2::Sha256::digest(page.as_bytes()));
        page.replace(UNSEALED, &seal)
    }

    /// The block: a table and the JSON.
    fn block(&self) -> String {
        let mut rows = vec![
            ("made", format!("{} UTC", self.generated_utc)),
            (
                "by",
                format!(
                    "calflash {} (commit {}), station {}, operator {}",
                    self.tool_version, self.git_commit, self.station, self.operator
                ),
            ),
            ("command", self.command.clone()),
        ];
        if let Some(s) = &self.serial {
            rows.push(("unit", s.clone()));
        }
        for f in self.inputs.iter().chain(&self.blob) {
            rows.push((
                if f.role == "blob" { "blob" } else { "input" },
                format!(
                    "{} {} ({} bytes), SHA-256 {}",
                    f.role, f.path, f.bytes, f.sha256
                ),
            ));
        }
        if let Some(r) = &self.record {
            rows.push(("history record", r.clone()));
        }
        rows.push(("page seal", self.page_sha256.clone()));
        let table: String = rows
            .iter()
            .map(|(k, v)| {
                format!(
                    "<tr><td>{}</td><td class=\"prov\">{}</td></tr>",
                    esc(k),
                    esc(v)
                )
            })
            .collect();
        // `</` never appears inside the JSON (escaped), so the script cannot be closed early.
        let json = serde_json::to_string(self)
            .unwrap_or_default()
            .replace("</", "<\\/");
        format!(
            "<section id=\"provenance\"><h3>Where this page comes from</h3><table class=\"provenance\">{table}</table>\
<p>Check a page against the bytes: <code>calflash verify-report PAGE --blob BLOB --data FILE</code>.</p></section>\n\
<style>td.prov{{text-align:left;overflow-wrap:anywhere;font-size:.85em}}</style>\n\
<script type=\"application/json\" id=\"calflash-provenance\">{json}</script>\n"
        )
    }
}

/// Why a page does not belong to the bytes it is checked against.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotItsPage {
    /// No provenance block.
    #[error(
        "the page has no provenance block (made by a calflash before 0.1 of 2026-12-07, or not by calflash)"
    )]
    NoBlock,
    /// A block that does not read.
    #[error("its provenance block does not read: {0}")]
    Unreadable(String),
    /// The page was changed after it was made.
    #[error(
        "the page was changed after calflash made it: its seal is {stated}, its content hashes to {found}"
    )]
    Changed {
        /// The seal the page states.
        stated: String,
        /// What its content hashes to.
        found: String,
    },
    /// A file that is not the one the page names.
    #[error("{path}: SHA-256 {found}; the page was made from {role} with SHA-256 {stated}{named}")]
    OtherFile {
        /// The file checked.
        path: String,
        /// Its role on the page.
        role: String,
        /// The page's hash.
        stated: String,
        /// The file's.
        found: String,
        /// The page's path for it, in words.
        named: String,
    },
    /// A blob given for a page that describes none.
    #[error("the page names no blob")]
    NoBlob,
}

/// The provenance `html` states, once its seal is checked.
///
/// # Errors
/// [`NotItsPage`]: no block, or a page changed since it was made.
pub fn read(html: &str) -> Result<Provenance, NotItsPage> {
    const OPEN: &str = "<script type=\"application/json\" id=\"calflash-provenance\">";
    let at = html.rfind(OPEN).ok_or(NotItsPage::NoBlock)?;
    let rest = &html[at + OPEN.len()..];
    let end = rest.find("</script>").ok_or(NotItsPage::NoBlock)?;
    let json = rest[..end].replace("<\\/", "</");
    let p: Provenance =
        serde_json::from_str(&json).map_err(|e| NotItsPage::Unreadable(e.to_string()))?;
    if p.page_sha256.len() != 64 || !p.page_sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(NotItsPage::Unreadable(
            "its seal is not 64 hex digits".into(),
        ));
    }
    let found = hex(&sha2::Sha256::digest(
        html.replace(&p.page_sha256, UNSEALED).as_bytes(),
    ));
    if found != p.page_sha256 {
        return Err(NotItsPage::Changed {
            stated: p.page_sha256,
            found,
        });
    }
    Ok(p)
}

/// Adds the unit history's record (`db:12 in PATH`) to the provenance of the page at `path`
/// (written before the history gave the record its id), sealed again; the page is replaced
/// only once the new one is written whole.
///
/// # Errors
/// The page cannot be read, holds no provenance of its own, or cannot be written.
pub fn add_record(path: &std::path::Path, record: &str) -> Result<(), String> {
    const START: &str = "<section id=\"provenance\">";
    const END: &str = "id=\"calflash-provenance\">";
    let at = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let html = std::fs::read_to_string(path).map_err(|e| at(&e))?;
    let mut p = read(&html).map_err(|e| at(&e))?;
    let (Some(from), Some(script)) = (html.rfind(START), html.rfind(END)) else {
        return Err(at(&"no provenance block"));
    };
    let to = html[script..]
        .find("</script>\n")
        .map(|e| script + e + "</script>\n".len())
        .ok_or_else(|| at(&"an unclosed provenance block"))?;
    let page = format!("{}{}", &html[..from], &html[to..]);
    p.record = Some(record.to_string());
    let stamped = p.stamp(&page);
    crate::files::write_atomically(path, |w| std::io::Write::write_all(w, stamped.as_bytes()))
        .map_err(|e| at(&e))
}

/// The current time, UTC, `YYYY-MM-DD HH:MM:SS`.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamped_page_reads_back_and_one_byte_changed_is_named() {
        let p = Provenance::now()
            .serial("U-1")
            .blob("u.blob", b"\x01\x02\x03");
        let page = p.stamp("<html><body><h1>x</h1></body></html>");
        assert!(page.contains("id=\"provenance\""));
        let back = read(&page).unwrap();
        assert_eq!(back.serial.as_deref(), Some("U-1"));
        assert_eq!(back.blob.unwrap().bytes, 3);
        assert_ne!(back.page_sha256, UNSEALED);
        let changed = page.replacen("<h1>x</h1>", "<h1>y</h1>", 1);
        assert!(matches!(read(&changed), Err(NotItsPage::Changed { .. })));
        assert_eq!(read("<html></html>"), Err(NotItsPage::NoBlock));
        assert_eq!(utc_now().len(), 19);
    }
}
