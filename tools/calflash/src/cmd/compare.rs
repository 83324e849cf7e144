//! `calflash compare`: which terms of a unit's calibration moved beyond their uncertainty
//! between two calibrations.

use std::path::PathBuf;

use clap::Args;

use crate::report::{terminal::num, terminal::pval};
use crate::sensor::compare::{self, Estimates};

/// Compare two calibration records of one unit (Wald tests per term, chi-square per output).
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The earlier record: a file from `calflash calibrate --json` or `calflash selfcal --json`,
    /// or `db:ID` from `calflash history`.
    pub before: String,
    /// The later record.
    pub after: String,
    /// The unit history database for `db:ID` records.
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Significance level.
    #[arg(long, default_value_t = 0.05, value_parser = super::values::level)]
    pub alpha: f64,
    /// Write the comparison as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `calflash compare`.
///
/// # Errors
/// Unreadable or incomparable records.
pub fn run(args: &CompareArgs) -> Result<(), String> {
    let file = |r: &str| (!r.starts_with("db:")).then(|| std::path::PathBuf::from(r));
    let (before, after) = (file(&args.before), file(&args.after));
    crate::files::Paths::new()
        .input("the earlier record", before.as_deref())
        .input("the later record", after.as_deref())
        .input("--db", args.db.as_deref())
        .output("--json", args.json.as_deref())
        .check()?;
    let load = |r: &str| -> Result<Estimates, String> {
        match r.strip_prefix("db:") {
            Some(id) => {
                let id: i64 = id
                    .parse()
                    .map_err(|_| format!("`{r}`: db:ID takes a record number"))?;
                let path = args.db.clone().unwrap_or_else(crate::db::default_path);
                let text = crate::db::Db::open_existing(&path)?.record(id)?;
                Estimates::parse(&text, &format!("{} record {id}", path.display()))
            }
            None => {
                let text = std::fs::read_to_string(r).map_err(|e| format!("{r}: {e}"))?;
                Estimates::parse(&text, r)
            }
        }
    };
    let a = load(&args.before)?;
    let b = load(&args.after)?;
    let changes = compare::compare(&a, &b, args.alpha)?;
    println!(
        "calflash compare  unit {}  {} -> {}",
        a.serial, args.before, args.after
    );
    let mut moved_any = false;
    for c in &changes {
        let at = match (c.temp, c.volt) {
            (Some(t), Some(v)) => format!(" at {t:.1} C, {v:.2} V"),
            (Some(t), None) => format!(" at {t:.1} C"),
            (None, Some(v)) => format!(" at {v:.2} V"),
            (None, None) => String::new(),
        };
        let moved: Vec<&compare::TermChange> = c.terms.iter().filter(|t| t.moved).collect();
        moved_any |= !moved.is_empty() || c.p < args.alpha;
        println!(
            "  {}{at}: chi-square {} on {} dof, p = {}: {}",
            c.output,
            num(c.chi2),
            c.df,
            pval(c.p),
            if c.p < args.alpha {
                "CHANGED"
            } else {
                "no change beyond the uncertainty"
            }
        );
        for t in &c.terms {
            println!(
                "    {:<16} {} -> {}  z = {:>7.2}  p = {}{}",
                t.term,
                num(t.before),
                num(t.after),
                t.z,
                pval(t.p),
                if t.moved { "  MOVED" } else { "" }
            );
        }
    }
    if !moved_any {
        println!("  no term moved beyond its uncertainty at {}", args.alpha);
    }
    if let Some(p) = &args.json {
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &changes).map_err(std::io::Error::other)
        })?;
    }
    Ok(())
}
