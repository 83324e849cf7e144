//! `calflash fit`: fit a formula model to a file of observations.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::formula;
use crate::obs::Format;
use crate::regression::{self, CurveSpec, Point, Request};
use crate::report;
use crate::stats::Options;

/// Fit a linear-in-parameters model to observations and report it with regression statistics.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// The observations: CSV or whitespace-separated text with a header row.
    pub file: PathBuf,
    /// The model, e.g. "volts ~ 1 + rate + rate^2 + temp + rate:temp" (`0 +` or `- 1` for no
    /// intercept, `abs(x)` for odd forms such as rate:abs(rate)).
    #[arg(long, short)]
    pub model: String,
    /// Field separator of the file.
    #[arg(long, value_enum, default_value = "auto")]
    pub format: Format,
    /// Write the full report as JSON to this file (`-` for standard output).
    #[arg(long, value_name = "PATH")]
    pub json: Option<PathBuf>,
    /// Predict at a point: every model variable as name=value, comma-separated. Repeatable.
    #[arg(long = "predict-at", value_name = "NAME=VALUE,...")]
    pub predict_at: Vec<String>,
    /// Prediction curve: VAR=FROM:TO:POINTS, then other variables as NAME=VALUE (the rest are
    /// held at their observed means).
    #[arg(long, value_name = "VAR=FROM:TO:N[,NAME=VALUE...]")]
    pub curve: Option<String>,
    /// Significance level for intervals, tests and flags.
    #[arg(long, default_value_t = 0.05, value_parser = super::values::level)]
    pub alpha: f64,
    /// Drop terms that are not significant, one at a time (never the intercept, nor a term
    /// that a kept term contains), and report why.
    #[arg(long)]
    pub backward: bool,
    /// Partial F test against this reduced model (nested in --model).
    #[arg(long, value_name = "FORMULA")]
    pub compare: Option<String>,
    /// Hold every K-th observation out of the fit and report the error predicting it.
    #[arg(long, value_name = "K", value_parser = |s: &str| super::values::count_in(s, 2, 1_000_000_000))]
    pub holdout_every: Option<usize>,
}

fn parse_point(text: &str, what: &str) -> Result<Point, String> {
    text.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|kv| {
            let (k, v) = kv
                .split_once('=')
                .ok_or_else(|| format!("{what}: `{kv}` is not NAME=VALUE"))?;
            let v: f64 = v
                .trim()
                .parse()
                .map_err(|_| format!("{what}: `{}` is not a number (in `{kv}`)", v.trim()))?;
            Ok((k.trim().to_string(), v))
        })
        .collect()
}

fn parse_curve(text: &str) -> Result<CurveSpec, String> {
    let mut parts = text.splitn(2, ',');
    let range = parts.next().unwrap_or_default();
    let (var, spec) = range
        .split_once('=')
        .ok_or_else(|| format!("--curve: `{range}` is not VAR=FROM:TO:POINTS"))?;
    let nums: Vec<&str> = spec.split(':').collect();
    let [from, to, n] = nums[..] else {
        return Err(format!("--curve: `{spec}` is not FROM:TO:POINTS"));
    };
    let num = |s: &str| {
        s.trim()
            .parse::<f64>()
            .map_err(|_| format!("--curve: `{s}` is not a number"))
    };
    Ok(CurveSpec {
        variable: var.trim().to_string(),
        from: num(from)?,
        to: num(to)?,
        points: n
            .trim()
            .parse()
            .map_err(|_| format!("--curve: `{n}` is not a number of points"))?,
        hold: parse_point(parts.next().unwrap_or_default(), "--curve")?,
    })
}

/// Runs `calflash fit`.
///
/// # Errors
/// A one-line message naming the file, line and column or the term.
pub fn run(args: &FitArgs) -> Result<(), Failure> {
    crate::files::Paths::new()
        .input("the data", Some(&args.file))
        .output("--json", args.json.as_deref())
        .check()?;
    let formula = formula::parse(&args.model)?;
    let compare = args
        .compare
        .as_deref()
        .map(formula::parse)
        .transpose()
        .map_err(|e| format!("--compare: {e}"))?;
    let req = Request {
        file: args.file.clone(),
        format: args.format,
        formula,
        predict_at: args
            .predict_at
            .iter()
            .map(|p| parse_point(p, "--predict-at"))
            .collect::<Result<_, _>>()?,
        curve: args.curve.as_deref().map(parse_curve).transpose()?,
        compare,
        backward: args.backward.then_some(args.alpha),
        holdout_every: args.holdout_every,
        options: Options {
            alpha: args.alpha,
            ..Options::default()
        },
    };
    let reg = regression::run(&req)?;
    match args.json.as_deref() {
        Some(p) if p == std::path::Path::new("-") => {
            report::json::write(&reg, std::io::stdout().lock())?;
            println!();
        }
        Some(p) => {
            crate::files::write_atomically(p, |w| {
                report::json::write(&reg, w).map_err(std::io::Error::other)
            })?;
            print!("{}", report::terminal::render(&reg));
            println!("report: {}", p.display());
        }
        None => print!("{}", report::terminal::render(&reg)),
    }
    Ok(())
}
