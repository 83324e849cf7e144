//! The guide (`docs/`): built with mdBook and its links checked, as CI does.
//!
//! mdBook comes from the crate registry: `mdbook` on the PATH when there is one, else the
//! pinned version installed once into `target/tools` (`cargo install`, about two minutes on two
//! cores). The book is built into `target/book`, then every link of every page is followed:
//! a page or file the link names must be in the book, and an anchor (`#name`) must be an `id` of
//! that page.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::{cargo, root};

/// The mdBook the guide is built with when none is on the PATH.
const MDBOOK: &str = "mdbook@0.5.4";

/// Builds and link-checks the guide: `Ok(None)` when it built and every link holds,
/// `Ok(Some(why))` when mdBook is neither installed nor installable here, `Err` naming each
/// broken link.
pub fn check() -> Result<Option<String>, String> {
    let mdbook = match mdbook()? {
        Ok(m) => m,
        Err(why) => return Ok(Some(why)),
    };
    let out = root().join("target").join("book");
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(&mdbook)
        .arg("build")
        .arg(root().join("docs"))
        .arg("--dest-dir")
        .arg(&out)
        .status()
        .map_err(|e| format!("{}: {e}", mdbook.display()))?;
    if !status.success() {
        return Err(format!("mdbook build docs: {status}"));
    }
    let broken = broken_links(&out)?;
    if broken.is_empty() {
        println!("the guide: built into {}; every link holds", out.display());
        Ok(None)
    } else {
        Err(format!(
            "{} broken link(s) in the guide:\n  {}",
            broken.len(),
            broken.join("\n  ")
        ))
    }
}

/// The mdbook to run: the PATH's, or ours in `target/tools` (installed when missing);
/// `Ok(Err(why))` when neither can be had.
fn mdbook() -> Result<Result<PathBuf, String>, String> {
    let runs = |p: &Path| {
        Command::new(p)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if runs(Path::new("mdbook")) {
        return Ok(Ok(PathBuf::from("mdbook")));
    }
    let tools = root().join("target").join("tools");
    let ours = tools.join("bin").join("mdbook");
    if runs(&ours) {
        return Ok(Ok(ours));
    }
    println!(
        "the guide: mdbook is not installed; installing {MDBOOK} from the crate registry into {} \
         (once, about two minutes)",
        tools.display()
    );
    let status = cargo()
        .args([
            "install",
            MDBOOK,
            "--locked",
            "--no-default-features",
            "--root",
        ])
        .arg(&tools)
        .status()
        .map_err(|e| format!("cargo install {MDBOOK}: {e}"))?;
    if status.success() && runs(&ours) {
        Ok(Ok(ours))
    } else {
        Ok(Err(format!(
            "mdbook is not installed and `cargo install {MDBOOK}` failed here ({status}): the \
             guide was not built; its chapters' commands still run in the README's test"
        )))
    }
}

/// Every link of every page of the book at `book` that leads nowhere, as "page: link (why)".
fn broken_links(book: &Path) -> Result<Vec<String>, String> {
    let book = &book
        .canonicalize()
        .map_err(|e| format!("{}: {e}", book.display()))?;
    let mut pages = BTreeMap::new();
    collect(book, &mut pages)?;
    let ids: BTreeMap<&PathBuf, BTreeSet<String>> = pages
        .iter()
        .map(|(p, html)| (p, attribute(html, "id")))
        .collect();
    let mut broken = Vec::new();
    for (page, html) in &pages {
        let name = page
            .strip_prefix(book)
            .unwrap_or(page)
            .display()
            .to_string();
        // mdBook's own "not found" page links to the site's root, wherever it is served.
        if name == "404.html" {
            continue;
        }
        for link in attribute(html, "href")
            .into_iter()
            .chain(attribute(html, "src"))
        {
            if link.contains("://")
                || link.starts_with("mailto:")
                || link.starts_with("javascript:")
            {
                continue;
            }
            let (path, anchor) = link.split_once('#').unwrap_or((&link, ""));
            let target = if path.is_empty() {
                page.clone()
            } else {
                let dir = page.parent().unwrap_or(book);
                normalise(&dir.join(path))
            };
            if !target.starts_with(book) || !target.exists() {
                broken.push(format!("{name}: {link} (no such file in the book)"));
                continue;
            }
            if anchor.is_empty() {
                continue;
            }
            match ids.get(&target) {
                Some(set) if set.contains(anchor) => {}
                Some(_) => broken.push(format!("{name}: {link} (no id `{anchor}` on that page)")),
                None => broken.push(format!(
                    "{name}: {link} (an anchor into a file that is not a page)"
                )),
            }
        }
    }
    Ok(broken)
}

/// The HTML pages under `dir`, by path.
fn collect(dir: &Path, pages: &mut BTreeMap<PathBuf, String>) -> Result<(), String> {
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.is_dir() {
            collect(&path, pages)?;
        } else if path.extension().is_some_and(|e| e == "html") {
            let html =
                std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            pages.insert(path, html);
        }
    }
    Ok(())
}

/// The values of every `name="..."` attribute in `html`, entities `&amp;` undone.
fn attribute(html: &str, name: &str) -> BTreeSet<String> {
    let key = format!(" {name}=\"");
    let mut out = BTreeSet::new();
    let mut rest = html;
    while let Some(i) = rest.find(&key) {
        rest = &rest[i + key.len()..];
        if let Some(end) = rest.find('"') {
            out.insert(rest[..end].replace("&amp;", "&"));
            rest = &rest[end..];
        }
    }
    out
}

/// `path` with `.` and `..` resolved lexically.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_to_a_missing_page_or_anchor_is_named_and_a_good_one_is_not() {
        let dir = tempfile::tempdir().unwrap();
        let book = dir.path();
        std::fs::create_dir(book.join("css")).unwrap();
        std::fs::write(book.join("css/a.css"), "").unwrap();
        std::fs::write(
            book.join("index.html"),
            r##"<a href="b.html#there">ok</a> <a href="b.html#gone">x</a> <a href="c.html">x</a>
               <link href="css/a.css"> <a href="https://example.org/">ext</a> <a href="#top">t</a>
               <h1 id="top">"##,
        )
        .unwrap();
        std::fs::write(
            book.join("b.html"),
            r#"<h2 id="there"> <a href="../out.html">x</a>"#,
        )
        .unwrap();
        let broken = broken_links(book).unwrap();
        assert_eq!(
            broken,
            [
                "b.html: ../out.html (no such file in the book)",
                "index.html: b.html#gone (no id `gone` on that page)",
                "index.html: c.html (no such file in the book)",
            ],
            "{broken:?}"
        );
    }
}
