//! `calflash threshold`: threshold, dead band and resolution from a fine-step run.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::columns as col;
use crate::obs::{self, Format};
use crate::report::terminal::num;
use crate::sensor::threshold;

/// Threshold, dead band and resolution of a single axis from a fine-step run near zero.
#[derive(Debug, Args)]
pub struct ThresholdArgs {
    /// The fine-step run (columns input, output).
    pub data: PathBuf,
    /// The accepted scale factor, counts per input unit.
    #[arg(long, value_parser = super::values::non_zero)]
    pub scale: f64,
    /// Output at zero input, counts (default: the mean output at input 0).
    #[arg(long, value_parser = super::values::finite)]
    pub bias: Option<f64>,
    /// Field separator.
    #[arg(long, value_enum, default_value = "auto")]
    pub format: Format,
}

/// Runs `calflash threshold`.
///
/// # Errors
/// A bad file or a run that cannot give the figures.
pub fn run(args: &ThresholdArgs) -> Result<(), Failure> {
    let t = obs::read_columns(
        &args.data,
        &[col::INPUT.into(), col::OUTPUT.into()],
        args.format,
    )?;
    let r = threshold::analyse(
        t.column(col::INPUT).unwrap_or_default(),
        t.column(col::OUTPUT).unwrap_or_default(),
        args.scale,
        args.bias,
    )
    .map_err(|e| format!("{}: {e}", args.data.display()))?;
    let opt = |v: Option<f64>| v.map_or("not reached".into(), num);
    println!("calflash threshold  {}", args.data.display());
    match (args.bias, r.measured_zero) {
        (Some(_), Some(m)) => println!(
            "  output at zero input  {} counts (--bias; the run's mean at input 0 is {})",
            num(r.zero),
            num(m)
        ),
        (Some(_), None) => println!("  output at zero input  {} counts (--bias)", num(r.zero)),
        _ => println!(
            "  output at zero input  {} counts (the run's mean at input 0)",
            num(r.zero)
        ),
    }
    println!(
        "  threshold             {} (positive), {} (negative)",
        opt(r.positive),
        opt(r.negative)
    );
    match r.dead_band {
        Some((a, b)) => println!("  dead band             [{}, {}]", num(a), num(b)),
        None => println!(
            "  dead band             not found: the response never reaches half the expected on one side"
        ),
    }
    println!("  resolution            {}", opt(r.resolution));
    println!("  steps (input, response counts, ratio to expected):");
    for (x, resp, ratio) in &r.steps {
        println!("    {:>12} {:>12} {:>8.3}", num(*x), num(*resp), ratio);
    }
    Ok(())
}
