//! `calflash db`: the unit history itself: copy a station's SQLite history into the shared
//! PostgreSQL database (or any history into another).

use crate::cmd::Failure;
use clap::{Args, Subcommand};

use crate::db::{self, Db, Location};

/// Work on the unit history itself.
#[derive(Debug, Args)]
pub struct DbArgs {
    #[command(subcommand)]
    pub command: DbCommand,
}

/// What to do with the history.
#[derive(Debug, Subcommand)]
pub enum DbCommand {
    /// Copy a station's history (a SQLite file) into another, e.g. the shared PostgreSQL one:
    /// all records or none, none twice; the copies get new record numbers.
    Migrate(MigrateArgs),
}

/// `calflash db migrate`.
#[derive(Debug, Args)]
pub struct MigrateArgs {
    /// The history to copy from (read, never changed): a SQLite file or a PostgreSQL URL.
    #[arg(value_name = "FROM")]
    pub from: db::Given,
    /// The history to copy into (default: $CALFLASH_DB): a PostgreSQL URL or a SQLite file.
    #[arg(long, value_name = "FILE|URL")]
    pub to: Option<db::Given>,
    /// The station of the records that name none (recorded before histories kept stations;
    /// default: $CALFLASH_STATION, else this machine's host name).
    #[arg(long)]
    pub station: Option<String>,
}

/// Runs `calflash db`.
///
/// # Errors
/// Either history's failure, named; nothing is written then.
pub fn run(args: &DbArgs) -> Result<(), Failure> {
    match &args.command {
        DbCommand::Migrate(m) => migrate(m),
    }
}

fn migrate(args: &MigrateArgs) -> Result<(), Failure> {
    let to = Location::or_default(args.to.as_ref())?;
    let from = &args.from.location()?;
    if to == *from {
        return Err(format!(
            "calflash db migrate: {from} is both the history to copy and the one to copy into"
        )
        .into());
    }
    let station = args.station.clone().unwrap_or_else(db::station);
    let (records, copied) = Db::open_existing(from)
        .and_then(|mut source| Db::open(&to)?.copy_from(&mut source, &station))?;
    println!(
        "calflash db migrate  {from} -> {to}: {copied} of {records} records copied{}",
        if copied < records {
            format!(" ({} were there already)", records - copied)
        } else {
            String::new()
        }
    );
    Ok(())
}
