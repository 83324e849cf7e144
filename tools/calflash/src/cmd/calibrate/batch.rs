//! A batch of units: `calflash calibrate` over several files or a directory of them, one unit
//! per file, on every core (rayon), with a progress bar and a final table. Each unit is
//! calibrated exactly as one file at a time would be; a unit that fails does not stop the
//! others.

use crate::cmd::Failure;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::{CalibrateArgs, calibrate_one};
use crate::cmd::outputs::Outputs;
use crate::sensor::Verdict;

/// One unit's outcome.
#[derive(Debug)]
pub struct Outcome {
    /// The unit's serial.
    pub serial: String,
    /// Its observation file.
    pub file: PathBuf,
    /// Its verdict and the findings that gave it, or why it failed.
    pub result: Result<super::Judged, String>,
}

/// The observation files of `inputs`: files as given, and each directory's `.csv` and `.txt`
/// files in name order.
fn files(inputs: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| format!("{}: {e}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.is_file()
                        && f.extension().is_some_and(|x| {
                            x.eq_ignore_ascii_case("csv") || x.eq_ignore_ascii_case("txt")
                        })
                })
                .collect();
            found.sort();
            if found.is_empty() {
                return Err(format!(
                    "{}: no .csv or .txt observation files in it",
                    p.display()
                ));
            }
            out.extend(found);
        } else if p.is_file() {
            out.push(p.clone());
        } else {
            return Err(format!("{}: no such file or directory", p.display()));
        }
    }
    Ok(out)
}

/// A unit's serial: its file's name without extension.
fn serial_of(file: &Path) -> Result<String, String> {
    let stem = file
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| format!("{}: a file name that is not text", file.display()))?;
    crate::sensor::blob::serial(stem).map_err(|e| {
        format!(
            "{}: its name is the unit's serial in a batch: {e}",
            file.display()
        )
    })?;
    Ok(stem.to_string())
}

/// The files a batch writes for one unit into `--out-dir`.
#[derive(Debug, Clone)]
pub struct UnitFiles {
    /// `SERIAL.blob`.
    pub blob: PathBuf,
    /// `SERIAL.json`.
    pub json: PathBuf,
    /// `SERIAL.html`, with `--reports`.
    pub report: Option<PathBuf>,
    /// `SERIAL.txt`: what `calibrate` prints for one unit.
    pub summary: PathBuf,
}

/// Every unit's files in `out_dir`, checked before any work: a serial that is not a plain file
/// name is refused, and no unit's file may be an input of the batch (an observation file, a
/// fixture) or another unit's file, nor `index.html`.
///
/// # Errors
/// The unit and the file.
pub fn unit_files(
    args: &CalibrateArgs,
    units: &[(String, PathBuf)],
    out_dir: &Path,
) -> Result<Vec<UnitFiles>, Failure> {
    let file = |serial: &str, ext: &str| crate::files::unit_file(out_dir, serial, ext);
    let mut paths = crate::files::Paths::new();
    for d in &args.data {
        paths = paths.input("the data", Some(d.as_path()));
    }
    for (serial, f) in units {
        paths = paths.input(&format!("unit {serial}'s observations"), Some(f.as_path()));
    }
    let mut all = Vec::with_capacity(units.len());
    for (serial, _) in units {
        let files = UnitFiles {
            blob: file(serial, "blob")?,
            json: file(serial, "json")?,
            report: args.reports.then(|| file(serial, "html")).transpose()?,
            summary: file(serial, "txt")?,
        };
        let named = |what: &str| format!("--out-dir (unit {serial}'s {what})");
        paths = paths
            .output(&named("blob"), Some(&files.blob))
            .output(&named("record"), Some(&files.json))
            .output(&named("report"), files.report.as_deref())
            .output(&named("summary"), Some(&files.summary));
        all.push(files);
    }
    let index = out_dir.join("index.html");
    paths
        .output(
            "--out-dir (the batch's index.html)",
            args.reports.then_some(index.as_path()),
        )
        .check()?;
    Ok(all)
}

/// Calibrates `units` (serial, file) with the options of `args` on rayon's threads, each
/// unit's files and summary (`SERIAL.txt`) into `out_dir`, with a progress bar; the outcomes
/// in the order of `units`.
///
/// # Errors
/// A unit's files that cannot be written ([`unit_files`]), before any unit is calibrated.
pub fn calibrate_all(
    args: &CalibrateArgs,
    units: &[(String, PathBuf)],
    out_dir: &Path,
) -> Result<Vec<Outcome>, Failure> {
    let files = unit_files(args, units, out_dir)?;
    let bar = indicatif::ProgressBar::new(units.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  calibrating {bar:40} {pos}/{len} units, {eta} left",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // The lot as it stood before the batch, without the batch's units: judged once, so that
    // every unit is compared with the same lot whatever order the threads take them in.
    let lot_before = args.out.lot.as_deref().map(|name| {
        let serials: std::collections::HashSet<&str> =
            units.iter().map(|(s, _)| s.as_str()).collect();
        let sel = crate::db::Selection {
            lot: Some(name),
            ..crate::db::Selection::all()
        };
        std::sync::Arc::new(
            crate::db::Location::or_default(args.out.db.as_ref())
                .map_err(|e| e.to_string())
                .and_then(|path| {
                    crate::lot::history::load_without(&path, &sel, |s| serials.contains(s), 0.001)
                        .map_err(|e| e.to_string())
                }),
        )
    });
    let outcomes: Vec<Outcome> = units
        .par_iter()
        .zip(&files)
        .map(|((serial, file), files)| {
            let out = Outputs {
                blob: Some(files.blob.clone()),
                report: files.report.clone(),
                json: Some(files.json.clone()),
                db: args.out.db.clone(),
                no_db: args.out.no_db,
                force_blob: args.out.force_blob,
                sign_key: args.out.sign_key.clone(),
                sign_review: args.out.sign_review,
                counter: None,
                lot: args.out.lot.clone(),
                lot_before: lot_before.clone(),
            };
            let mut said = String::new();
            let result = calibrate_one(args, file, serial, &out, &mut said);
            // Each unit's summary beside its files, as `calibrate` prints it for one; a unit
            // that failed keeps no file of an earlier run.
            let mut staged = crate::files::Staged::new();
            let text = match &result {
                Ok(_) => said,
                Err(e) => {
                    for p in [Some(&files.blob), Some(&files.json), files.report.as_ref()]
                        .into_iter()
                        .flatten()
                    {
                        staged.remove(p);
                    }
                    format!("{said}calflash: {e}\n")
                }
            };
            let _ = staged
                .write(&files.summary, |w| w.write_all(text.as_bytes()))
                .and_then(|()| staged.commit());
            bar.inc(1);
            Outcome {
                serial: serial.clone(),
                file: file.clone(),
                result: result.map_err(|e| e.to_string()),
            }
        })
        .collect();
    bar.finish_and_clear();
    Ok(outcomes)
}

/// Refuses the options that name one unit's files or serial in a batch.
///
/// # Errors
/// The option given.
pub fn check_options(args: &CalibrateArgs) -> Result<(), Failure> {
    for (given, name) in [
        (args.serial.is_some(), "--serial"),
        (args.out.blob.is_some(), "--blob"),
        (args.out.report.is_some(), "--report"),
        (args.out.json.is_some(), "--json"),
        (args.out.counter.is_some(), "--counter"),
    ] {
        if given {
            return Err(format!(
                "{name} names one unit's; in a batch each unit's serial is its file's name (or its fixture columns'), its files go to --out-dir, and a signed blob's counter comes from its history"
            ).into());
        }
    }
    Ok(())
}

/// `--out-dir`, made (with its parents) when it does not exist yet, as `mkdir -p` would.
///
/// # Errors
/// A path that exists and is not a directory, or one that cannot be made.
pub(super) fn ready_out_dir(dir: &Path) -> Result<(), Failure> {
    if dir.exists() && !dir.is_dir() {
        return Err(format!("--out-dir {}: not a directory", dir.display()).into());
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("--out-dir {}: cannot make it: {e}", dir.display()).into())
}

/// Runs a batch; the worst verdict.
///
/// # Errors
/// Options a batch cannot take, two files of one serial, or units that failed (after all
/// the others are done: the message says how many and which).
pub fn run(args: &CalibrateArgs) -> Result<Verdict, Failure> {
    let out_dir = args.out_dir.as_ref().ok_or(
        "a batch (several files or a directory) writes each unit's files into --out-dir: give it",
    )?;
    check_options(args)?;
    ready_out_dir(out_dir)?;
    // One writer at a time in the folder, for the whole batch.
    let _lock = crate::files::FolderLock::take(out_dir, "--out-dir")?;
    let files = files(&args.data)?;
    let mut units: Vec<(String, PathBuf)> = Vec::with_capacity(files.len());
    let mut seen = std::collections::HashMap::with_capacity(files.len());
    for f in &files {
        let serial = serial_of(f)?;
        if let Some(other) = seen.insert(serial.clone(), f) {
            return Err(format!(
                "{} and {}: two files for unit {serial}",
                other.display(),
                f.display()
            )
            .into());
        }
        units.push((serial, f.clone()));
    }
    run_units(args, &units, out_dir)
}

/// Calibrates `units` as a batch into `out_dir`, prints the table (and, with `--reports`,
/// writes `index.html` linking each unit's report); the worst verdict.
///
/// # Errors
/// Units that failed, named, after all the others are done.
pub fn run_units(
    args: &CalibrateArgs,
    units: &[(String, PathBuf)],
    out_dir: &Path,
) -> Result<Verdict, Failure> {
    let outcomes = calibrate_all(args, units, out_dir)?;
    println!(
        "calflash calibrate  {} units on {} threads into {}",
        outcomes.len(),
        rayon::current_num_threads(),
        out_dir.display()
    );
    println!("  {:<18} {:<8} {:<24} why", "unit", "verdict", "file");
    let mut failed = Vec::new();
    let mut counts = [0usize; 3];
    for o in &outcomes {
        let (word, why) = match &o.result {
            Ok(j) => {
                counts[j.verdict as usize] += 1;
                (j.verdict.word().to_string(), reason_line(&j.reasons))
            }
            Err(e) => {
                failed.push(o.serial.as_str());
                ("FAILED".to_string(), e.clone())
            }
        };
        let file = o.file.display().to_string();
        println!("  {:<18} {:<8} {file:<24} {why}", o.serial, word);
    }
    println!(
        "  {} ACCEPT, {} REVIEW, {} REJECT, {} failed; each unit's summary in {}",
        counts[0],
        counts[1],
        counts[2],
        failed.len(),
        out_dir.join("SERIAL.txt").display()
    );
    if args.reports {
        let index = out_dir.join("index.html");
        crate::files::write_atomically(&index, |w| {
            w.write_all(
                crate::report::provenance::Provenance::now()
                    .stamp(&index_html(
                        &outcomes,
                        args.out.lot.as_deref(),
                        data_dir_name(&outcomes),
                    ))
                    .as_bytes(),
            )
        })?;
        crate::report::written::page(&index);
        println!("  reports: {}", index.display());
    }
    if !failed.is_empty() {
        return Err(format!(
            "{} of {} units failed: {}",
            failed.len(),
            outcomes.len(),
            failed.join(", ")
        )
        .into());
    }
    Ok(outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok().map(|j| j.verdict))
        .max()
        .unwrap_or(Verdict::Accept))
}

/// The first reason of a unit's verdict on one line, and how many more its summary holds.
fn reason_line(reasons: &[String]) -> String {
    const WIDTH: usize = 100;
    let Some(first) = reasons.first() else {
        return String::new();
    };
    let mut line: String = first.chars().take(WIDTH).collect();
    if first.chars().count() > WIDTH {
        line.push_str("...");
    }
    if reasons.len() > 1 {
        line.push_str(&format!(" (+{} more)", reasons.len() - 1));
    }
    line
}

/// A unit's reasons in the index: the first on its line, the others folded under it.
fn reasons_cell(reasons: &[String]) -> String {
    use crate::report::page::esc;
    match reasons {
        [] => String::new(),
        [one] => esc(one),
        [first, rest @ ..] => format!(
            "<details><summary>{} (+{} more)</summary><ul>{}</ul></details>",
            esc(first),
            rest.len(),
            rest.iter()
                .map(|r| format!("<li>{}</li>", esc(r)))
                .collect::<String>()
        ),
    }
}

/// The folder the batch's files came from (the first unit's), for the index's heading.
fn data_dir_name(outcomes: &[Outcome]) -> String {
    outcomes
        .first()
        .and_then(|o| o.file.parent())
        .map(|p| p.display().to_string())
        .unwrap_or_default()
}

/// The batch's report: a heading that says which batch (its lot, its folder, when, the
/// totals), then one table with a row and a link per unit to its own page, each verdict in its
/// colour.
fn index_html(outcomes: &[Outcome], lot: Option<&str>, folder: String) -> String {
    use crate::report::page::{STYLE, esc};
    let mut rows = String::new();
    let mut counts = [0usize; 4];
    for o in outcomes {
        let (verdict, class, page, figures, why) = match &o.result {
            Ok(j) => {
                counts[j.verdict as usize] += 1;
                (
                    j.verdict.word(),
                    j.verdict.word().to_lowercase(),
                    format!("<a href=\"{0}.html\">{0}</a>", esc(&o.serial)),
                    esc(&j.figures),
                    reasons_cell(&j.reasons),
                )
            }
            Err(e) => {
                counts[3] += 1;
                (
                    "FAILED",
                    "reject".to_string(),
                    esc(&o.serial),
                    String::new(),
                    reasons_cell(std::slice::from_ref(e)),
                )
            }
        };
        rows.push_str(&format!(
            "<tr><td class=\"unit\">{page}</td><td class=\"{class}\">{verdict}</td><td class=\"why\">{figures}</td><td class=\"why\">{why}</td><td>{}</td></tr>\n",
            esc(&o.file.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned()))
        ));
    }
    let when = crate::cmd::history::format_time(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs() as i64),
    );
    let title = match lot {
        Some(l) => format!("Batch of lot {l}: {} units", outcomes.len()),
        None => format!("Batch of {} units", outcomes.len()),
    };
    // The batch's verdict is its worst unit's: a failed or REJECTed unit rejects the batch.
    let class = if counts[2] + counts[3] > 0 {
        "reject"
    } else if counts[1] > 0 {
        "review"
    } else {
        "accept"
    };
    format!(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{0}</title><style>{STYLE}td.why{{text-align:left}}td.unit{{white-space:nowrap}}ul{{margin:0;padding-left:1.2em}}</style></head><body>\n<h1>{0}</h1>\n<p class=\"verdict {class}\">{2} ACCEPT, {3} REVIEW, {4} REJECT, {5} failed</p>\n<p>From {1}, calibrated {when} UTC. One line per unit: its page is linked from its serial; its figures are each output's bias at the reference point (mg, deg/h) and its largest misalignment (mrad); the reason is the first finding that gave its verdict, the others a click away.</p>\n<table>\n<tr><th>unit</th><th>verdict</th><th>figures</th><th>why</th><th>observations</th></tr>\n{rows}</table>\n</body></html>\n",
        esc(&title),
        esc(&folder),
        counts[0],
        counts[1],
        counts[2],
        counts[3],
    )
}
