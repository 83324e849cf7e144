//! `calflash compare`: which terms of a unit's calibration moved beyond their uncertainty
//! between two calibrations.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::report::{terminal::num, terminal::pval};
use crate::sensor::compare::{self, Estimates};

/// Compare two calibration records of one unit (Wald tests per term, chi-square per output,
/// each family held at --alpha by Holm's procedure). Exits 3 when the unit CHANGED.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The earlier record: a file from `calflash calibrate --json` or `calflash selfcal --json`,
    /// `db:ID` from `calflash history`, or `db:SERIAL` for the unit's newest calibration in
    /// the history.
    pub before: String,
    /// The later record.
    pub after: String,
    /// The unit history for `db:ID` records: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Significance level.
    #[arg(long, default_value_t = 0.05, value_parser = super::values::level)]
    pub alpha: f64,
    /// Write the comparison as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `calflash compare`; true when the unit changed beyond its uncertainty (the process
/// exits 3).
///
/// # Errors
/// Unreadable or incomparable records.
pub fn run(args: &CompareArgs) -> Result<bool, Failure> {
    let file = |r: &str| (!r.starts_with("db:")).then(|| std::path::PathBuf::from(r));
    let (before, after) = (file(&args.before), file(&args.after));
    let db = args
        .db
        .as_ref()
        .map(crate::db::Given::location)
        .transpose()?;
    crate::files::Paths::new()
        .distinct_input("the earlier record", before.as_deref())
        .distinct_input("the later record", after.as_deref())
        .input("--db", db.as_ref().and_then(crate::db::Location::file))
        .output("--json", args.json.as_deref())
        .check()?;
    let text = |r: &str| -> Result<(String, String), String> {
        match r.strip_prefix("db:") {
            Some(key) => {
                let path =
                    crate::db::Location::or_default(args.db.as_ref()).map_err(|e| e.to_string())?;
                let mut db = crate::db::Db::open_existing(&path).map_err(|e| e.to_string())?;
                // db:ID, or db:SERIAL for the unit's newest calibration (a flash, refused or
                // not, is never taken for one).
                let id = match key.parse::<i64>() {
                    Ok(id) => id,
                    Err(_) if !key.is_empty() => db
                        .history(key)
                        .map_err(|e| e.to_string())?
                        .into_iter()
                        .rfind(|e| e.kind == "fit")
                        .map(|e| e.id)
                        .ok_or_else(|| {
                            format!(
                                "`{r}`: the unit history {path} has no calibration of unit {key}"
                            )
                        })?,
                    Err(_) => {
                        return Err(format!(
                            "`{r}`: db:ID takes a record number, db:SERIAL a unit's serial"
                        ));
                    }
                };
                let text = db.record(id).map_err(|e| e.to_string())?;
                Ok((text, format!("{path} record {id}")))
            }
            None => Ok((
                crate::files::read_json_text(std::path::Path::new(r), "a calibration record")
                    .map_err(|e| e.to_string())?,
                r.to_string(),
            )),
        }
    };
    let (ta, sa) = text(&args.before)?;
    let (tb, sb) = text(&args.after)?;
    if let Some(h) = schema_of(&tb, &sb, "calflash.health/1")? {
        return against_health(args, &ta, &sa, &h);
    }
    if let Some(f) = schema_of(&tb, &sb, "calflash.flight/1")? {
        return against_flight(args, &ta, &sa, &f);
    }
    for (kind, schema) in [
        ("health", "calflash.health/1"),
        ("flight", "calflash.flight/1"),
    ] {
        if schema_of(&ta, &sa, schema)?.is_some() {
            return Err(format!(
                "{sa}: a {kind} report comes second, after the calibration it judged"
            )
            .into());
        }
    }
    let a = Estimates::parse(&ta, &sa)?;
    let b = Estimates::parse(&tb, &sb)?;
    let changes = compare::compare(&a, &b, args.alpha)?;
    println!(
        "calflash compare  unit {}  {} -> {}",
        a.serial, args.before, args.after
    );
    let terms: usize = changes.iter().map(|c| c.terms.len()).sum();
    for c in &changes {
        let at = match (c.temp, c.volt) {
            (Some(t), Some(v)) => format!(" at {t:.1} C, {v:.2} V"),
            (Some(t), None) => format!(" at {t:.1} C"),
            (None, Some(v)) => format!(" at {v:.2} V"),
            (None, None) => String::new(),
        };
        println!(
            "  {}{at}: chi-square {} on {} dof, p = {}: {}",
            c.output,
            num(c.chi2),
            c.df,
            pval(c.p),
            if c.changed {
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
    let changed: Vec<String> = changes
        .iter()
        .filter(|c| c.changed)
        .map(|c| match c.temp {
            Some(t) => format!("{} at {t:.1} C", c.output),
            None => c.output.clone(),
        })
        .collect();
    let moved = changes
        .iter()
        .flat_map(|c| &c.terms)
        .filter(|t| t.moved)
        .count();
    let family = format!(
        "at {} over {} output test(s) and {terms} term test(s), Holm",
        args.alpha,
        changes.len()
    );
    if changed.is_empty() && moved == 0 {
        println!("verdict: UNCHANGED: no output and no term moved beyond its uncertainty {family}");
    } else {
        println!(
            "verdict: CHANGED: {} output(s) changed{}, {moved} term(s) moved, {family}",
            changed.len(),
            if changed.is_empty() {
                String::new()
            } else {
                format!(" ({})", changed.join(", "))
            }
        );
    }
    if let Some(p) = &args.json {
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &changes).map_err(std::io::Error::other)
        })?;
    }
    Ok(!changed.is_empty() || moved > 0)
}

/// The record in `text` if its schema is `schema` (a health or a flight report).
fn schema_of(text: &str, source: &str, schema: &str) -> Result<Option<serde_json::Value>, String> {
    let v: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("{source}:{}:{}: not a record: {e}", e.line(), e.column()))?;
    Ok((v["schema"] == schema).then_some(v))
}

/// The calibration record `before` (from `source`) and a report that judged a calibration
/// (`after`): the same unit, and the same calibration when the report names it.
fn same_calibration(
    before: &str,
    source: &str,
    after: &serde_json::Value,
    kind: &str,
) -> Result<String, Failure> {
    let factory: serde_json::Value =
        serde_json::from_str(before).map_err(|e| format!("{source}: not a record: {e}"))?;
    let serial = factory["serial"].as_str().unwrap_or_default().to_string();
    if serial != after["serial"].as_str().unwrap_or_default() {
        return Err(format!(
            "{source} is of unit {serial}, the {kind} report of unit {}: compare a unit with itself",
            after["serial"]
        )
        .into());
    }
    if let (Some(a), Some(b)) = (factory["data_hash"].as_str(), after["data_hash"].as_str())
        && a != b
    {
        return Err(format!(
            "{source}: the {kind} report judged another calibration of unit {serial} (data {b}, this one {a}); compare it with that one"
        ).into());
    }
    Ok(serial)
}

/// A flight report held against the calibration it judged: each sensor error's in-flight
/// estimate against the calibration's stated 1-sigma (the flight's own Wald tests, Holm over
/// the terms the flight observed), one verdict; true when a term shifted.
fn against_flight(
    args: &CompareArgs,
    before: &str,
    source: &str,
    flight: &serde_json::Value,
) -> Result<bool, Failure> {
    let serial = same_calibration(before, source, flight, "flight")?;
    let verdict = flight["verdict"].as_str().unwrap_or("?");
    println!(
        "calflash compare  unit {serial}  {} -> {} (in flight: {verdict})",
        args.before, args.after
    );
    let mut shifted = Vec::new();
    for t in flight["terms"].as_array().map_or(&[][..], Vec::as_slice) {
        let name = t["name"].as_str().unwrap_or("?");
        let unit = t["unit"].as_str().unwrap_or("");
        let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
        let seen = match (t["z"].as_f64(), t["p"].as_f64()) {
            (Some(z), Some(p)) => format!("z = {z:+.2}, p = {}", pval(p)),
            _ => "not observed in this flight".to_string(),
        };
        let moved = t["shifted"].as_bool().unwrap_or(false);
        if moved {
            shifted.push(name.to_string());
        }
        println!(
            "  {name}: {} +- {} {unit} in flight; calibration 1-sigma {}: {seen}{}",
            num(f("estimate")),
            num(f("sigma")),
            num(f("prior_sigma")),
            if moved { "  SHIFTED" } else { "" }
        );
    }
    let fits = flight["consistency"]["fits"].as_bool().unwrap_or(false);
    if !fits {
        println!(
            "verdict: CANNOT TELL: the flight's filter did not fit its data ({verdict}); no term is judged"
        );
        return Ok(false);
    }
    if shifted.is_empty() {
        println!(
            "verdict: UNCHANGED: no sensor error shifted in flight beyond the calibration's 1-sigma"
        );
    } else {
        println!(
            "verdict: CHANGED: {} shifted in flight ({})",
            shifted.len(),
            shifted.join(", ")
        );
    }
    Ok(!shifted.is_empty())
}

/// A health report held against the calibration it judged: per bias, how far the unit at
/// rest found it from the calibration, in the calibration's stated 1-sigma, and whether that
/// is beyond it (chi-square with one degree of freedom at `--alpha`, Bonferroni over the six);
/// true when one moved.
fn against_health(
    args: &CompareArgs,
    before: &str,
    source: &str,
    health: &serde_json::Value,
) -> Result<bool, Failure> {
    let serial = same_calibration(before, source, health, "health")?;
    let h = &health["health"];
    let get = |key: &str, i: usize| h[key][i].as_f64().unwrap_or(f64::NAN);
    // Chi-square with one degree of freedom at alpha / 6 (Bonferroni over the six outputs).
    let limit = crate::stats::dist::chi2_upper_quantile(args.alpha / 6.0, 1.0);
    println!(
        "calflash compare  unit {serial}  {} -> {} (health at rest: {}, {:.1} s)",
        args.before,
        args.after,
        h["verdict"].as_str().unwrap_or("?"),
        h["rest_s"].as_f64().unwrap_or(0.0)
    );
    let mut rows = Vec::new();
    for (i, name) in ["ax", "ay", "az", "wx", "wy", "wz"].iter().enumerate() {
        let (b, s, stated) = (get("bias", i), get("bias_sigma", i), get("stated_sigma", i));
        // The refined bias varies by stated^2 - s^2 over units whose calibration holds.
        let spread = (stated * stated - s * s).max(f64::MIN_POSITIVE);
        let chi2 = b * b / spread;
        let moved = chi2 > limit && s < stated;
        let unit = if i < 3 { "m/s^2" } else { "rad/s" };
        println!(
            "  {name}: {} +- {} {unit} from the calibration; stated 1-sigma {}: {:+.2} sigma{}",
            num(b),
            num(s),
            num(stated),
            b / stated,
            if moved { "  MOVED" } else { "" }
        );
        rows.push(
            serde_json::json!({"output": name, "moved_by": b, "sigma": s,
            "stated_sigma": stated, "chi2": chi2, "moved": moved}),
        );
    }
    let moved: Vec<&str> = rows
        .iter()
        .filter(|r| r["moved"] == true)
        .filter_map(|r| r["output"].as_str())
        .collect();
    let family = format!("at {} over 6 outputs, Bonferroni", args.alpha);
    if moved.is_empty() {
        println!(
            "verdict: UNCHANGED: no bias moved beyond the calibration's stated 1-sigma {family}"
        );
    } else {
        println!(
            "verdict: CHANGED: {} bias(es) moved beyond the calibration's stated 1-sigma ({}), {family}",
            moved.len(),
            moved.join(", ")
        );
    }
    if let Some(p) = &args.json {
        let v = serde_json::json!({"serial": serial, "health": h, "outputs": rows,
            "changed": !moved.is_empty()});
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    Ok(!moved.is_empty())
}
