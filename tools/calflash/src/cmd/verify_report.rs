//! `calflash verify-report`: whether an HTML report belongs to the bytes it is said to
//! describe. The page's provenance block names the SHA-256 of every input and of the blob, and
//! seals the page; this checks the seal and each file given against it.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::report::provenance::{self, FileHash, NotItsPage};

/// Whether a report belongs to a blob and data files.
#[derive(Debug, Args)]
pub struct VerifyReportArgs {
    /// The HTML report (any calflash report with a provenance block).
    pub page: PathBuf,
    /// The blob the page should describe.
    #[arg(long)]
    pub blob: Option<PathBuf>,
    /// An input file the page should have been made from; repeat for several.
    #[arg(long)]
    pub data: Vec<PathBuf>,
}

/// The longest page read (a thermal IMU's report is a few MB).
const MAX_PAGE: u64 = 256 << 20;

/// Runs `calflash verify-report`; `Ok(false)` when the page does not belong to the files (the
/// caller exits 3).
///
/// # Errors
/// A file that cannot be read.
pub fn run(args: &VerifyReportArgs) -> Result<bool, Failure> {
    let bytes = crate::files::read_bounded(&args.page, MAX_PAGE, "an HTML report")?;
    let page = args.page.display().to_string();
    let html = String::from_utf8_lossy(&bytes);
    let refused = |why: NotItsPage| {
        println!("calflash verify-report  {page}: DOES NOT BELONG: {why}");
        Ok(false)
    };
    let p = match provenance::read(&html) {
        Ok(p) => p,
        Err(e) => return refused(e),
    };
    let hash = |role: &str, path: &PathBuf| {
        FileHash::of_file(role, path).map_err(|e| format!("{}: {e}", path.display()))
    };
    if let Some(b) = &args.blob {
        let Some(stated) = &p.blob else {
            return refused(NotItsPage::NoBlob);
        };
        let found = hash("blob", b)?;
        if found.sha256 != stated.sha256 {
            return refused(NotItsPage::OtherFile {
                path: b.display().to_string(),
                role: "the blob".into(),
                stated: stated.sha256.clone(),
                found: found.sha256,
                named: format!(" (written as {})", stated.path),
            });
        }
    }
    for d in &args.data {
        let found = hash("data", d)?;
        if !p.inputs.iter().any(|i| i.sha256 == found.sha256) {
            let (role, stated, named) = match p.inputs.as_slice() {
                [one] => (
                    one.role.clone(),
                    one.sha256.clone(),
                    format!(" (read as {})", one.path),
                ),
                many => (
                    "its inputs".into(),
                    many.iter()
                        .map(|i| i.sha256.clone())
                        .collect::<Vec<_>>()
                        .join(", "),
                    String::new(),
                ),
            };
            return refused(NotItsPage::OtherFile {
                path: d.display().to_string(),
                role,
                stated,
                found: found.sha256,
                named,
            });
        }
    }
    println!(
        "calflash verify-report  {page}: BELONGS: made {} UTC by calflash {} (commit {}) on station {}, operator {}{}{}; its seal holds",
        p.generated_utc,
        p.tool_version,
        p.git_commit,
        p.station,
        p.operator,
        p.serial
            .as_ref()
            .map(|s| format!(", for unit {s}"))
            .unwrap_or_default(),
        p.record
            .as_ref()
            .map(|r| format!(", the history's record {r}"))
            .unwrap_or_default()
    );
    if let (Some(b), Some(stated)) = (&args.blob, &p.blob) {
        println!(
            "  {}: the page's blob, SHA-256 {}",
            b.display(),
            stated.sha256
        );
    }
    for d in &args.data {
        println!("  {}: one of the page's inputs", d.display());
    }
    Ok(true)
}
