//! The `calflash` command line: parsing and dispatch only.
#![forbid(unsafe_code)]

use std::process::ExitCode;

use calflash::cmd;
use clap::{Parser, Subcommand};

/// Calibration of inertial sensors: fit, report, write, flash and verify.
#[derive(Debug, Parser)]
#[command(name = "calflash", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fit a formula model to observations, with regression statistics.
    Fit(cmd::fit::FitArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Fit(args) => cmd::fit::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("calflash: {e}");
            ExitCode::FAILURE
        }
    }
}
