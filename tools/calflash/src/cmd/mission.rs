//! `calflash mission`: a mission profile read, checked and summarised.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use super::mission_columns::MissionColumns;
use crate::files::{Paths, Staged};
use crate::mission::{self, summary};
use crate::report::mission as show;

/// A mission profile: what a unit feels over a flight.
#[derive(Debug, Args)]
pub struct MissionArgs {
    /// The profile: CSV with a header naming the columns.
    pub profile: PathBuf,
    #[command(flatten)]
    pub columns: MissionColumns,
    /// Motion faster than this, Hz, is vibration rather than the airframe's rigid-body motion.
    #[arg(long, default_value_t = 10.0, value_parser = |s: &str| super::values::in_range(s, 1e-3, 1e6))]
    pub vibration_above: f64,
    /// A unit's g-squared coefficient per axis, ug/g^2 (one for all axes or three): the
    /// rectification error the flight's vibration makes of it.
    #[arg(long, value_delimiter = ',', value_parser = super::values::finite)]
    pub k2: Vec<f64>,
    /// Write the summary as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `calflash mission`.
///
/// # Errors
/// A profile that cannot be read or is not a flight, named by line and column.
pub fn run(a: &MissionArgs) -> Result<(), Failure> {
    Paths::new()
        .input("the profile", Some(&a.profile))
        .output("--json", a.json.as_deref())
        .check()?;
    let k2 = match a.k2.len() {
        0 => None,
        1 => Some([a.k2[0]; 3]),
        3 => Some([a.k2[0], a.k2[1], a.k2[2]]),
        n => return Err(format!("--k2: {n} values; give one for all axes or three").into()),
    };
    let profile = mission::read(&a.profile, &a.columns.mission_columns)?;
    let s = summary::summarise(&profile, a.vibration_above);
    print!("{}", show::text(&profile, &s, k2));
    if let Some(path) = &a.json {
        let mut staged = Staged::new();
        staged.write(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &s).map_err(std::io::Error::other)
        })?;
        staged.commit()?;
    }
    Ok(())
}
