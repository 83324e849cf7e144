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
    let result = match &cli.command {
        Command::Fit(args) => cmd::fit::run(args),
        Command::Calibrate(args) => match cmd::calibrate::run(args) {
            // A rejected unit is a result, not an error: its own exit code for test stations.
            Ok(calflash::sensor::Verdict::Reject) => return ExitCode::from(3),
            other => other.map(|_| ()),
        },
        Command::Selfcal(args) => match cmd::selfcal::run(args) {
            // As for `calibrate`: a rejected unit has its own exit code.
            Ok(true) => return ExitCode::from(3),
            other => other.map(|_| ()),
        },
        Command::Allan(args) => cmd::allan::run(args),
        Command::Design(args) => cmd::design::run(args),
        Command::Simulate(args) => cmd::simulate::run(args),
        Command::Mission(args) => cmd::mission::run(args),
        Command::Flight(args) => match cmd::flight::run(args) {
            // As `health` and `compare`: a calibration that did not survive exits 3; a flight
            // the filter's model does not fit, 4 (nothing could be told).
            Ok("SHIFTED") => return ExitCode::from(3),
            Ok("FILTER DOES NOT FIT") => return ExitCode::from(4),
            other => other.map(|_| ()),
        },
        Command::Apply(args) => cmd::apply::run(args),
        Command::Compare(args) => match cmd::compare::run(args) {
            // A unit that changed beyond its uncertainty: the rejected unit's exit code.
            Ok(true) => return ExitCode::from(3),
            other => other.map(|_| ()),
        },
        Command::VerifyReport(args) => match cmd::verify_report::run(args) {
            // A page that is not the files': the rejected unit's exit code.
            Ok(false) => return ExitCode::from(3),
            other => other.map(|_| ()),
        },
        Command::Pdf(args) => cmd::pdf::run(args),
        Command::Threshold(args) => cmd::threshold::run(args),
        Command::Flash(args) => cmd::flash::run(args),
        Command::Read(args) => cmd::read::run(args),
        Command::Image(args) => cmd::image::run(args),
        Command::History(args) => cmd::history::run(args),
        Command::Db(args) => cmd::history_db::run(args),
        Command::Keygen(args) => cmd::keys::keygen(args),
        Command::Sign(args) => cmd::keys::sign(args),
        Command::Lot(args) => cmd::lot::run(args),
        Command::Health(args) => match cmd::health::run(args) {
            // A SUSPECT unit has the rejected unit's exit code.
            Ok("SUSPECT") => return ExitCode::from(3),
            other => other.map(|_| ()),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("calflash: {e}");
            ExitCode::FAILURE
        }
    }
}
