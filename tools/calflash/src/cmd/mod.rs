//! One module per subcommand, each a thin `run` over the library.

pub mod allan;
pub mod apply;
pub mod calibrate;
pub mod compare;
pub mod design;
pub mod fit;
pub mod flash;
pub mod flight;
pub mod flight_unit;
pub mod health;
pub mod history;
pub mod history_db;
pub mod image;
pub mod keys;
pub mod lot;
pub mod mission;
pub mod mission_columns;
pub mod outputs;
pub mod pdf;
pub mod read;
pub mod selfcal;
pub mod simulate;
pub mod threshold;
pub mod units;
pub mod values;
pub mod verify_report;

/// Why a command failed: an error of the library below it (its source kept), or the command's
/// own message. `calflash` prints it after `calflash: `; each converts into it with `?`.
pub type Failure = Box<dyn std::error::Error + Send + Sync>;
