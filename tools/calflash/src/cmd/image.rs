//! `calflash image`: the calibration region as a file for any flasher, or written over SWD.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::device::image::{self, Region};

/// Write the calibration region (slot 0 committed with the blob; the keys sector provisioned
/// with the station public keys) as Intel HEX and raw binary at the address of memory.x, or
/// program it over SWD with probe-rs (feature `probe`).
#[derive(Debug, Args)]
pub struct ImageArgs {
    /// The blob (signed, for a provisioned unit).
    #[arg(long)]
    pub blob: Option<PathBuf>,
    /// Provision the unit with this station public key (`calflash keygen`'s PREFIX.pub;
    /// repeat for up to 4): it then takes only calibrations signed for it by one of them.
    /// Written once, at manufacture: a unit never changes its keys.
    #[arg(long, value_name = "PUB")]
    pub station_key: Vec<PathBuf>,
    /// Write Intel HEX here.
    #[arg(long)]
    pub hex: Option<PathBuf>,
    /// Write raw binary here (load it at the region's address).
    #[arg(long)]
    pub bin: Option<PathBuf>,
    /// Program the region into a unit over SWD with probe-rs; the chip name as probe-rs knows
    /// it (for example STM32F407VGTx).
    #[arg(long, value_name = "CHIP")]
    pub probe: Option<String>,
    /// Put a blob whose fit was judged REJECT (made with `calibrate --force-blob`) into the
    /// image: a person insists; the blob keeps its mark.
    #[arg(long)]
    pub force_rejected: bool,
}

/// Runs `calflash image`.
///
/// # Errors
/// A bad blob, an unwritable file, or a probe failure.
pub fn run(args: &ImageArgs) -> Result<(), Failure> {
    let mut paths = crate::files::Paths::new().input("--blob", args.blob.as_deref());
    for k in &args.station_key {
        paths = paths.input("--station-key", Some(k));
    }
    paths
        .output("--hex", args.hex.as_deref())
        .output("--bin", args.bin.as_deref())
        .check()?;
    if args.blob.is_none() && args.station_key.is_empty() {
        return Err("give --blob, --station-key or both".into());
    }
    if args.hex.is_none() && args.bin.is_none() && args.probe.is_none() {
        return Err("give --hex, --bin or --probe".into());
    }
    let keys = crate::signing::load_publics(&args.station_key)?;
    let bytes = args
        .blob
        .as_deref()
        .map(crate::files::read_blob)
        .transpose()?;
    let mut warning = None;
    if let (Some(bytes), Some(path)) = (&bytes, &args.blob) {
        let cal =
            crate::signing::calibration(bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        warning = crate::approval::admit(
            &cal.data().identity,
            path,
            crate::approval::Act::Image,
            args.force_rejected,
        )?;
    }
    if let (Some(bytes), Some(path), false) = (&bytes, &args.blob, keys.is_empty()) {
        // A provisioned unit boots only a blob signed for it by one of its keys.
        let cal =
            crate::signing::calibration(bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        spincal::signed::check(bytes, &keys, &cal.data().identity.serial).map_err(|e| {
            format!(
                "{}: a unit provisioned with these keys would not boot it: {e}",
                path.display()
            )
        })?;
    }
    let region = Region::from_memory_x();
    let image =
        image::unit_image(bytes.as_deref(), &keys, region).map_err(|e| match &args.blob {
            Some(p) => format!("{}: {e}", p.display()),
            None => e.to_string(),
        })?;
    if let Some(w) = warning {
        eprintln!("calflash: {w}");
    }
    for k in &keys {
        println!(
            "calflash image: keys sector provisioned with station key {}",
            crate::device::key_hex(k.id())
        );
    }
    if let Some(p) = &args.bin {
        crate::files::write_atomically(p, |w| w.write_all(&image))?;
        println!(
            "calflash image: {} bytes for address {:#010x} in {}",
            image.len(),
            region.start,
            p.display()
        );
    }
    if let Some(p) = &args.hex {
        let hex = image::intel_hex(&image, region.start)?;
        crate::files::write_atomically(p, |w| w.write_all(hex.as_bytes()))?;
        println!(
            "calflash image: Intel HEX at {:#010x} in {}",
            region.start,
            p.display()
        );
    }
    if let Some(chip) = &args.probe {
        probe(chip, region.start, &image)?;
    }
    Ok(())
}

#[cfg(feature = "probe")]
fn probe(chip: &str, address: u32, image: &[u8]) -> Result<(), Failure> {
    use probe_rs::flashing::{DownloadOptions, FlashLoader};
    use probe_rs::{Session, SessionConfig};
    let mut session = Session::auto_attach(chip, SessionConfig::default())
        .map_err(|e| format!("probe-rs: cannot attach to {chip}: {e}"))?;
    let mut loader: FlashLoader = session.target().flash_loader();
    loader
        .add_data(u64::from(address), image)
        .map_err(|e| format!("probe-rs: {e}"))?;
    // Only the region's sectors are erased and written; the flash loader reads them back.
    let mut options = DownloadOptions::default();
    options.verify = true;
    loader
        .commit(&mut session, options)
        .map_err(|e| format!("probe-rs: programming failed: {e}"))?;
    println!(
        "calflash image: {} bytes programmed at {address:#010x} over SWD and verified",
        image.len()
    );
    Ok(())
}

#[cfg(not(feature = "probe"))]
fn probe(_chip: &str, _address: u32, _image: &[u8]) -> Result<(), Failure> {
    Err("this calflash was built without the `probe` feature (cargo build -p calflash --features probe)".into())
}
