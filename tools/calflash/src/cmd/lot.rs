//! `calflash lot`: a production lot from the unit history, judged as a lot.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::{Args, ValueEnum};

use crate::db::Selection;
use crate::lot::{self, Judge};
use crate::stats::chart;

/// Judge a lot: every unit's newest coefficients from the history, their spread, each unit's
/// robust distance from the lot with the units outside named, and control charts.
#[derive(Debug, Args)]
pub struct LotArgs {
    /// Units whose serial starts with this (`IMU-24-` takes IMU-24-0001, IMU-24-0002, ...);
    /// none for every unit (of the lot, with --lot).
    #[arg(default_value = "")]
    pub prefix: String,
    /// Units calibrated in this production lot (`calflash calibrate --lot NAME`).
    #[arg(long, value_name = "NAME")]
    pub lot: Option<String>,
    /// Only fits recorded from this date (YYYY-MM-DD, UTC).
    #[arg(long, value_parser = super::values::date)]
    pub since: Option<i64>,
    /// Only fits recorded up to this date (inclusive).
    #[arg(long, value_parser = super::values::date)]
    pub until: Option<i64>,
    /// Only fits recorded by this station (`$CALFLASH_STATION` of the station, else its host
    /// name). Without it, each chart is drawn per station as well when the lot has several.
    #[arg(long)]
    pub station: Option<String>,
    /// The probability that a unit of the lot's own distribution is called outside.
    #[arg(long, default_value_t = 0.001, value_parser = super::values::level)]
    pub alpha: f64,
    /// A coefficient to chart over the units in calibration order (`OUTPUT:TERM`, as listed);
    /// repeat for more.
    #[arg(long)]
    pub chart: Vec<String>,
    /// The kind of chart.
    #[arg(long, value_enum, default_value = "individuals")]
    pub chart_kind: ChartKind,
    /// Write the result as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the HTML report (spread, distances with the limit, outliers, charts) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The unit history: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
}

/// A chart kind on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ChartKind {
    /// Shewhart individuals (moving-range sigma, 3-sigma limits).
    Individuals,
    /// EWMA (lambda 0.2, 3-sigma limits).
    Ewma,
}

/// Runs `calflash lot`.
///
/// # Errors
/// As [`lot::history::load`], a coefficient to chart that the lot lacks, or an unwritable JSON
/// file.
pub fn run(args: &LotArgs) -> Result<(), Failure> {
    if let (Some(since), Some(until)) = (args.since, args.until)
        && since > until
    {
        return Err(
            "--since is after --until: the range holds no day; give the earlier date to --since"
                .into(),
        );
    }
    let path = crate::db::Location::or_default(args.db.as_ref())?;
    crate::files::Paths::new()
        .input("--db", path.file())
        .output("--json", args.json.as_deref())
        .output("--report", args.report.as_deref())
        .check()?;
    let sel = Selection {
        prefix: &args.prefix,
        lot: args.lot.as_deref(),
        since: args.since.unwrap_or(i64::MIN),
        until: args.until.map_or(i64::MAX, |u| u + 86_399),
        station: args.station.as_deref(),
    };
    let lot = lot::history::load(&path, &sel, args.alpha)?;
    let kind = match args.chart_kind {
        ChartKind::Individuals => chart::Kind::Individuals,
        ChartKind::Ewma => chart::Kind::Ewma,
    };
    // Each chart over the lot, then per station when the lot has several.
    let stations = lot.stations();
    let mut charts = Vec::new();
    for name in &args.chart {
        charts.push((name.clone(), lot.chart(name, kind, None)?));
        if stations.len() > 1 {
            for s in &stations {
                charts.push((format!("{name} at {s}"), lot.chart(name, kind, Some(s))?));
            }
        }
    }
    println!(
        "calflash lot  {sel}: {} units, {} coefficients ({} in {})",
        lot.units.len(),
        lot.names.len(),
        match &lot.judge {
            Judge::Scatter { robust, .. } => format!(
                "robust centre and covariance of {} units kept after reweighting",
                robust.kept
            ),
            Judge::Columns { why } => format!("coefficient by coefficient: {why}"),
        },
        path
    );
    if !lot.left_out.is_empty() {
        println!(
            "  left out ({}): not in every unit, or the same in all: {}",
            lot.left_out.len(),
            lot.left_out.join(", ")
        );
    }
    if let Some(kinds) = crate::lot::kinds(&lot.units) {
        println!("  units of more than one kind, judged on what they share: {kinds}");
    }
    println!(
        "  {:<28} {:>14} {:>12} {:>14} {:>14}  spread in a datasheet's unit",
        "coefficient", "median", "MAD", "min", "max"
    );
    for s in &lot.spread {
        let said = s.engineering.as_ref().map_or_else(String::new, |e| {
            format!(
                "MAD {} {} ({} .. {})",
                crate::report::terminal::num(e.mad),
                e.unit,
                crate::report::terminal::signed(e.range.0),
                crate::report::terminal::signed(e.range.1)
            )
        });
        println!(
            "  {:<28} {:>14.6e} {:>12.3e} {:>14.6e} {:>14.6e}  {said}",
            s.name, s.median, s.mad, s.min, s.max
        );
    }
    println!(
        "  {} of {} units outside the lot (distance beyond {:.2}, alpha {})",
        lot.outliers.len(),
        lot.units.len(),
        lot.distance_limit(),
        lot.alpha
    );
    for o in &lot.outliers {
        let why: Vec<String> = o
            .coefficients
            .iter()
            .map(|(k, z)| format!("{k} z={z:+.1}"))
            .collect();
        let jointly = o.coefficients.iter().all(|(_, z)| z.abs() <= 3.0);
        println!(
            "    {:<20} distance {:>8.2}  {}{}",
            o.serial,
            o.distance,
            why.join(", "),
            if jointly {
                " (none alone beyond 3 MADs: their combination is unlike the lot's)"
            } else {
                ""
            }
        );
    }
    for (name, c) in &charts {
        let serials = |i: &usize| -> String { c.serials.get(*i).cloned().unwrap_or_default() };
        println!(
            "  {:?} chart of {name}: centre {:.6e}, sigma {:.3e}; {} point(s) out of control{}",
            c.kind,
            c.centre,
            c.sigma,
            c.out_of_control.len(),
            if c.out_of_control.is_empty() {
                String::new()
            } else {
                format!(
                    ": {}",
                    c.out_of_control
                        .iter()
                        .map(serials)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        );
    }
    if let Some(p) = &args.report {
        let html = crate::report::provenance::Provenance::now().stamp(&crate::report::lot::render(
            &lot,
            &sel.to_string(),
            &charts,
        )?);
        crate::files::write_atomically(p, |w| w.write_all(html.as_bytes()))?;
        crate::report::written::page(p);
        println!("  report: {}", p.display());
    }
    if let Some(p) = &args.json {
        let v = crate::lot::Record::new(&lot, (&args.prefix, args.lot.as_deref()), &charts);
        crate::files::write_atomically(p, |w| {
            serde_json::to_writer_pretty(&mut *w, &v).map_err(std::io::Error::other)
        })?;
    }
    Ok(())
}
