//! `calflash pdf`: a report as an A4 PDF a person signs and files (issue 68), printed by a
//! headless Chromium with the reports' print style sheet: A4, margins, "page N of M" at the
//! foot of each page, no browser header or footer. Any browser's "print to PDF" of a report
//! gives the same pages.

use crate::cmd::Failure;
use std::path::{Path, PathBuf};
use std::process::Command;

use clap::Args;

/// Print HTML reports as A4 PDFs.
#[derive(Debug, Args)]
pub struct PdfArgs {
    /// The reports (each PAGE.html gives PAGE.pdf beside it, unless -o).
    #[arg(required = true)]
    pub pages: Vec<PathBuf>,
    /// The PDF (with one report only).
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// The browser (default: chromium, chromium-browser or google-chrome on the PATH).
    #[arg(long)]
    pub browser: Option<PathBuf>,
}

/// The browsers tried, in order.
const BROWSERS: [&str; 3] = ["chromium", "chromium-browser", "google-chrome"];

/// The first of `BROWSERS` on the PATH.
fn find_browser() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| BROWSERS.iter().map(move |b| dir.join(b)))
        .find(|p| p.is_file())
}

/// Prints `page` to `pdf` with `browser`.
fn print(browser: &Path, page: &Path, pdf: &Path) -> Result<(), Failure> {
    let page = std::path::absolute(page).map_err(|e| format!("{}: {e}", page.display()))?;
    let pdf_abs = std::path::absolute(pdf).map_err(|e| format!("{}: {e}", pdf.display()))?;
    let folder = pdf_abs.parent().unwrap_or(Path::new("."));
    // Printed beside its destination, then renamed: no half-written PDF at its path.
    let staged = tempfile::Builder::new()
        .prefix(".calflash-pdf")
        .suffix(".pdf")
        .tempfile_in(folder)
        .map_err(|e| format!("{}: {e}", folder.display()))?;
    let profile = tempfile::tempdir().map_err(|e| e.to_string())?;
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-pdf-header-footer",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("--print-to-pdf={}", staged.path().display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .map_err(|e| format!("{}: {e}", browser.display()))?;
    let printed = std::fs::metadata(staged.path())
        .map(|m| m.len())
        .unwrap_or(0);
    let head = std::fs::read(staged.path())
        .ok()
        .map(|b| b.starts_with(b"%PDF"))
        .unwrap_or(false);
    if printed == 0 || !head {
        return Err(format!(
            "{}: {} printed no PDF: {}",
            page.display(),
            browser.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )
        .into());
    }
    // A document to file and share: readable as any file the user writes (tempfile's is 0600).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        let _ = std::fs::set_permissions(staged.path(), std::fs::Permissions::from_mode(0o644));
    }
    staged
        .persist(&pdf_abs)
        .map_err(|e| format!("{}: {e}", pdf.display()))?;
    Ok(())
}

/// Prints every report this run wrote ([`crate::report::written`]) as PAGE.pdf beside it:
/// `--pdf` on any command.
///
/// # Errors
/// No browser, or a page that cannot be printed.
pub fn print_written() -> Result<(), Failure> {
    let pages: Vec<PathBuf> = crate::report::written::pages()
        .into_iter()
        .filter(|p| p.is_file())
        .collect();
    if pages.is_empty() {
        println!("calflash --pdf: the command wrote no report to print");
        return Ok(());
    }
    run(&PdfArgs {
        pages,
        output: None,
        browser: None,
    })
}

/// Runs `calflash pdf`.
///
/// # Errors
/// No browser, a page that cannot be printed, or `-o` with several pages.
pub fn run(args: &PdfArgs) -> Result<(), Failure> {
    if args.output.is_some() && args.pages.len() > 1 {
        return Err("-o: one report only (each PAGE.html gives PAGE.pdf beside it)".into());
    }
    if let [page] = args.pages.as_slice() {
        crate::files::Paths::new()
            .input("the report", Some(page))
            .output("-o", args.output.as_deref())
            .check()?;
    }
    let browser = args.browser.clone().or_else(find_browser).ok_or_else(|| {
        format!(
            "no browser to print with: none of {} is on the PATH (Debian: apt-get install chromium); or open the report in any browser and print it to PDF: its print style sheet gives A4 pages numbered N of M",
            BROWSERS.join(", ")
        )
    })?;
    for page in &args.pages {
        if !page.is_file() {
            return Err(format!("{}: no such report", page.display()).into());
        }
        let pdf = args
            .output
            .clone()
            .unwrap_or_else(|| page.with_extension("pdf"));
        print(&browser, page, &pdf)?;
        println!("calflash pdf  {}: {}", page.display(), pdf.display());
    }
    Ok(())
}
