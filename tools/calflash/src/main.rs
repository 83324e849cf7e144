//! The `calflash` command line: parsing and dispatch only.
#![forbid(unsafe_code)]

use std::process::ExitCode;

use calflash::cmd;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Calibration of inertial sensors: fit, report, write, flash and verify.
#[derive(Debug, Parser)]
#[command(name = "calflash", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print every report the command writes as an A4 PDF beside it (PAGE.html gives
    /// PAGE.pdf; headless Chromium, as `calflash pdf`).
    #[arg(long, global = true)]
    pdf: bool,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fit a formula model to observations, with regression statistics.
    Fit(cmd::fit::FitArgs),
    /// Calibrate a sensor: fit, decide, invert, write blob, report and record.
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// Calibrate an IMU without equipment, from still poses turned by hand.
    Selfcal(cmd::selfcal::SelfcalArgs),
    /// Allan deviation and IEEE 952 noise terms of a still recording.
    Allan(cmd::allan::AllanArgs),
    /// Evaluate and optimise test plans before running them; predict their precision.
    Design(cmd::design::DesignArgs),
    /// A mission profile read, checked and summarised: ranges, time at each level, setback,
    /// spin, vibration.
    Mission(cmd::mission::MissionArgs),
    /// Check a calibration in flight: the IMU navigated with its correction against GNSS and
    /// a barometer, each sensor error's shift since the calibration (HELD, SHIFTED, CANNOT TELL).
    Flight(cmd::flight::FlightArgs),
    /// Simulate a sensor through a test plan, writing an observation file.
    Simulate(Box<cmd::simulate::SimulateArgs>),
    /// Run raw counts through the device's correction.
    Apply(cmd::apply::ApplyArgs),
    /// Compare two calibrations of one unit.
    Compare(cmd::compare::CompareArgs),
    /// Whether an HTML report belongs to a blob and data files (its provenance and seal).
    VerifyReport(cmd::verify_report::VerifyReportArgs),
    /// HTML reports as A4 PDFs to sign and file (headless Chromium).
    Pdf(cmd::pdf::PdfArgs),
    /// Threshold, dead band and resolution from a fine-step run.
    Threshold(cmd::threshold::ThresholdArgs),
    /// Write a calibration into a unit and verify it there.
    Flash(cmd::flash::FlashArgs),
    /// What a unit holds (serial, blob hash, counter, slots), read without writing to it.
    Read(cmd::read::ReadArgs),
    /// The calibration region as Intel HEX or binary for any flasher, or over SWD.
    Image(cmd::image::ImageArgs),
    /// A unit's fits and flashes.
    History(cmd::history::HistoryArgs),
    /// The unit history itself: copy a station's history into the shared database.
    Db(cmd::history_db::DbArgs),
    /// Is the unit's calibration still good? Its health check at rest, read or run.
    Health(cmd::health::HealthArgs),
    /// Write a new station key pair for signing calibrations.
    Keygen(cmd::keys::KeygenArgs),
    /// Sign a calibration blob with the station's key.
    Sign(cmd::keys::SignArgs),
    /// A production lot from the history, judged as a lot: spread, outliers, control charts.
    Lot(cmd::lot::LotArgs),
}

/// Every command takes negative numbers as option values (`--latitude -33.9`), lists of them
/// too (`--temps -40,25,85`), without an `=`.
fn negative_numbers(cmd: clap::Command) -> clap::Command {
    cmd.allow_negative_numbers(true)
        .mut_args(|a| {
            if a.get_value_delimiter().is_some() {
                a.allow_hyphen_values(true)
            } else {
                a
            }
        })
        .mut_subcommands(negative_numbers)
}

fn main() -> ExitCode {
    // A closed pipe (`calflash ... | head`) ends the process quietly, as it does any Unix tool.
    sigpipe::reset();
    let matches = negative_numbers(Cli::command()).get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = run(&cli.command);
    // The pages are printed whatever the verdict: a REJECT's report is filed too.
    let printed = if cli.pdf {
        cmd::pdf::print_written()
    } else {
        Ok(())
    };
    match (result, printed) {
        (Ok(code), Ok(())) => ExitCode::from(code),
        (Ok(code), Err(e)) => {
            eprintln!("calflash: --pdf: {e}");
            ExitCode::from(code.max(1))
        }
        (Err(e), _) => {
            eprintln!("calflash: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs `command`: its exit code (0, or 3 and 4 for the verdicts that have their own), or why
/// it could not run.
fn run(command: &Command) -> Result<u8, cmd::Failure> {
    match command {
        Command::Fit(args) => cmd::fit::run(args).map(|()| 0),
        Command::Calibrate(args) => match cmd::calibrate::run(args) {
            // A rejected unit is a result, not an error: its own exit code for test stations.
            Ok(calflash::sensor::Verdict::Reject) => Ok(3),
            other => other.map(|_| 0),
        },
        Command::Selfcal(args) => match cmd::selfcal::run(args) {
            // As for `calibrate`: a rejected unit has its own exit code.
            Ok(true) => Ok(3),
            other => other.map(|_| 0),
        },
        Command::Allan(args) => cmd::allan::run(args).map(|()| 0),
        Command::Design(args) => cmd::design::run(args).map(|()| 0),
        Command::Simulate(args) => cmd::simulate::run(args).map(|()| 0),
        Command::Mission(args) => cmd::mission::run(args).map(|()| 0),
        Command::Flight(args) => match cmd::flight::run(args) {
            // As `health` and `compare`: a calibration that did not survive exits 3; a flight
            // the filter's model does not fit, 4 (nothing could be told).
            Ok("SHIFTED") => Ok(3),
            Ok("FILTER DOES NOT FIT") => Ok(4),
            other => other.map(|_| 0),
        },
        Command::Apply(args) => cmd::apply::run(args).map(|()| 0),
        Command::Compare(args) => match cmd::compare::run(args) {
            // A unit that changed beyond its uncertainty: the rejected unit's exit code.
            Ok(true) => Ok(3),
            other => other.map(|_| 0),
        },
        Command::VerifyReport(args) => match cmd::verify_report::run(args) {
            // A page that is not the files': the rejected unit's exit code.
            Ok(false) => Ok(3),
            other => other.map(|_| 0),
        },
        Command::Pdf(args) => cmd::pdf::run(args).map(|()| 0),
        Command::Threshold(args) => cmd::threshold::run(args).map(|()| 0),
        Command::Flash(args) => cmd::flash::run(args).map(|()| 0),
        Command::Read(args) => cmd::read::run(args).map(|()| 0),
        Command::Image(args) => cmd::image::run(args).map(|()| 0),
        Command::History(args) => cmd::history::run(args).map(|()| 0),
        Command::Db(args) => cmd::history_db::run(args).map(|()| 0),
        Command::Keygen(args) => cmd::keys::keygen(args).map(|()| 0),
        Command::Sign(args) => cmd::keys::sign(args).map(|()| 0),
        Command::Lot(args) => cmd::lot::run(args).map(|()| 0),
        Command::Health(args) => match cmd::health::run(args) {
            // A SUSPECT unit has the rejected unit's exit code.
            Ok("SUSPECT") => Ok(3),
            other => other.map(|_| 0),
        },
    }
}
