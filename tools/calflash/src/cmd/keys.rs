//! `calflash keygen` and `calflash sign`: the station's key pair, and a blob signed with it for
//! a unit that holds the station's public key (issue 17).

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::files::Paths;
use crate::signing;

/// Write a new station key pair: PREFIX.key (private, readable by its owner only) and
/// PREFIX.pub.
#[derive(Debug, Args)]
pub struct KeygenArgs {
    /// The files' path without extension.
    pub prefix: PathBuf,
}

/// Runs `calflash keygen`.
///
/// # Errors
/// Files that exist or cannot be written.
pub fn keygen(args: &KeygenArgs) -> Result<(), Failure> {
    let (private, public) = signing::pair_paths(&args.prefix)?;
    Paths::new()
        .output("the private key", Some(&private))
        .output("the public key", Some(&public))
        .check()?;
    let id = signing::keygen(&private, &public)?;
    println!(
        "calflash keygen  key {}: private {} (mode 600: keep it on the station), public {}",
        id.iter().map(|b| format!("{b:02x}")).collect::<String>(),
        private.display(),
        public.display()
    );
    Ok(())
}

/// Sign a calibration blob with the station's key, for a unit that holds its public key.
#[derive(Debug, Args)]
pub struct SignArgs {
    /// The blob.
    #[arg(long)]
    pub blob: PathBuf,
    /// The station's private key (default: $CALFLASH_SIGN_KEY).
    #[arg(long)]
    pub sign_key: Option<PathBuf>,
    /// The counter: above the one the unit holds (its present one for a --downgrade), from 1.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub counter: u32,
    /// A downgrade: an earlier calibration put back on purpose, made for the unit at its
    /// present counter.
    #[arg(long)]
    pub downgrade: bool,
    /// The signed blob to write.
    #[arg(long, short)]
    pub output: PathBuf,
    /// Sign a blob whose fit was judged REJECT (made with `calibrate --force-blob`): a person
    /// insists; the blob keeps its mark.
    #[arg(long)]
    pub force_rejected: bool,
}

/// Runs `calflash sign`.
///
/// # Errors
/// Unreadable key or blob, a key readable by others, a blob already signed.
pub fn sign(args: &SignArgs) -> Result<(), Failure> {
    let key_path = signing::key_path(args.sign_key.as_deref()).ok_or(
        "no key: give --sign-key or set $CALFLASH_SIGN_KEY (make one with `calflash keygen`)",
    )?;
    Paths::new()
        .input("--blob", Some(&args.blob))
        .input("--sign-key", Some(&key_path))
        .output("-o", Some(&args.output))
        .check()?;
    let key = signing::load_private(&key_path)?;
    let blob = crate::files::read_blob(&args.blob)?;
    let cal = signing::calibration(&blob).map_err(|e| format!("{}: {e}", args.blob.display()))?;
    let warning = crate::approval::admit(
        &cal.data().identity,
        &args.blob,
        crate::approval::Act::Sign,
        args.force_rejected,
    )?;
    if args.counter == u32::MAX && !args.downgrade {
        eprintln!(
            "calflash: WARNING: counter {} is the highest there is: a unit that takes it accepts only downgrades signed at it from then on",
            u32::MAX
        );
    }
    let signed = signing::sign(&blob, &key, args.counter, args.downgrade)
        .map_err(|e| format!("{}: {e}", args.blob.display()))?;
    crate::files::write_atomically(&args.output, |w| w.write_all(&signed))?;
    if let Some(w) = warning {
        eprintln!("calflash: {w}");
    }
    println!(
        "calflash sign  {} -> {}: counter {}{}, {} bytes ({} over the blob)",
        args.blob.display(),
        args.output.display(),
        args.counter,
        if args.downgrade { " (downgrade)" } else { "" },
        signed.len(),
        signed.len() - blob.len()
    );
    Ok(())
}
