//! `calflash read`: what a unit holds, asked without writing anything to it: its serial and
//! sensor, its firmware, both slots, the calibration it runs (serial, length, SHA-256, counter,
//! signing key), whether it checks signatures and is locked; with `-o` its blob, as it holds
//! it, read back into a file. A station asks it before a flash (what is there) and after (what
//! went in).

use crate::cmd::Failure;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

use clap::Args;
use serde::Serialize;
use spincal::store::SlotState;

use crate::device::{Client, link::Link};
use crate::sensor::record::hex;

/// Read what a unit holds, writing nothing to it.
#[derive(Debug, Args)]
pub struct ReadArgs {
    /// The unit's link: a serial device or pty path, or tcp://HOST:PORT.
    #[arg(long)]
    pub port: String,
    /// Write the unit's blob here, as it holds it (a signed one with its trailer).
    #[arg(short = 'o', long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Print what the unit holds as JSON.
    #[arg(long)]
    pub json: bool,
    /// Seconds to wait for each answer (a slow link, or a unit emulated on a busy host:
    /// `$CALFLASH_TIMEOUT`).
    #[arg(long, env = "CALFLASH_TIMEOUT", default_value_t = 3.0, value_parser = |s: &str| super::values::in_range(s, 0.1, 3600.0))]
    pub timeout: f64,
}

/// One slot, as the unit reports it.
#[derive(Debug, Serialize)]
struct Slot {
    /// `empty`, `invalid` or `valid`.
    state: &'static str,
    /// A valid slot's sequence number.
    #[serde(skip_serializing_if = "Option::is_none")]
    seq: Option<u32>,
    /// A valid slot's record length, bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    len: Option<u32>,
}

/// What a unit holds (`--json`).
#[derive(Debug, Serialize)]
pub struct Holding {
    /// The unit's serial.
    pub unit: String,
    /// The sensor it carries, in words.
    pub sensor: String,
    /// Firmware version.
    pub firmware: String,
    /// Protocol version.
    pub protocol: u8,
    /// The calibration's serial (`None`: it runs without one).
    pub calibration: Option<String>,
    /// The blob's length, bytes (a signed one's trailer included).
    pub blob_len: u32,
    /// The SHA-256 (hex) of the blob as read back; `None` without one.
    pub blob_sha256: Option<String>,
    /// When the calibration was made (Unix seconds), from the blob read back.
    pub created_unix_s: Option<u64>,
    /// The counter of the calibration it holds (0: none or unsigned).
    pub counter: u32,
    /// The station key that signed it, when signed.
    pub signed_by: Option<String>,
    /// Whether it checks signatures: `unprovisioned`, `provisioned` or `keys damaged`.
    pub trust: String,
    /// The station keys it holds.
    pub station_keys: Vec<String>,
    /// Whether writes are refused.
    pub locked: bool,
    /// Both slots.
    slots: Vec<Slot>,
    /// Why it runs without the calibration a slot holds, when it refused it at boot.
    pub refused_at_boot: Option<String>,
}

/// What the unit on `client` holds, and its blob's bytes.
///
/// # Errors
/// The link's failure, or a unit whose blob does not read back as it says.
pub fn holding<L: std::io::Read + std::io::Write>(
    client: &mut Client<L>,
) -> Result<(Holding, Vec<u8>), Failure> {
    use sha2::Digest as _;
    let id = client.identify()?;
    let blob = if id.blob_len > 0 {
        client.read_blob(id.blob_len as usize)?
    } else {
        Vec::new()
    };
    let cal = (!blob.is_empty())
        .then(|| crate::signing::calibration(&blob))
        .transpose()
        .map_err(|e| {
            format!(
                "the unit's blob ({} bytes) does not read back as a calibration: {e}",
                blob.len()
            )
        })?;
    if let (Some(cal), Some(serial)) = (&cal, &id.calibration)
        && cal.data().identity.serial != *serial
    {
        return Err(format!(
            "the unit says it runs calibration {serial}, and the blob it reads back is {}'s",
            cal.data().identity.serial
        )
        .into());
    }
    let slots = id
        .slots
        .iter()
        .map(|s| match *s {
            SlotState::Empty => Slot {
                state: "empty",
                seq: None,
                len: None,
            },
            SlotState::Invalid => Slot {
                state: "invalid",
                seq: None,
                len: None,
            },
            SlotState::Valid { seq, len } => Slot {
                state: "valid",
                seq: Some(seq),
                len: Some(len),
            },
        })
        .collect();
    let h = Holding {
        unit: id.unit.as_str().to_string(),
        sensor: sensor_words(&id.sensor),
        firmware: format!("{}.{}.{}", id.firmware[0], id.firmware[1], id.firmware[2]),
        protocol: id.protocol,
        calibration: id.calibration.as_ref().map(|s| s.as_str().to_string()),
        blob_len: id.blob_len,
        blob_sha256: (!blob.is_empty()).then(|| hex(&sha2::Sha256::digest(&blob))),
        created_unix_s: cal.as_ref().map(|c| c.data().identity.created_unix_s),
        counter: id.counter,
        signed_by: id.signed_by.map(|k| hex(&k)),
        trust: match id.trust {
            spincal::protocol::Trust::Unprovisioned => "unprovisioned",
            spincal::protocol::Trust::Provisioned => "provisioned",
            spincal::protocol::Trust::KeysDamaged => "keys damaged",
        }
        .into(),
        station_keys: id.station_keys.iter().map(|k| hex(k)).collect(),
        locked: id.locked,
        slots,
        refused_at_boot: id.refused.map(|r| format!("{r:?}")),
    };
    Ok((h, blob))
}

/// The sensor a unit carries, in words.
fn sensor_words(s: &spincal::protocol::UnitSensor) -> String {
    use spincal::model::Quantity;
    use spincal::protocol::UnitSensor;
    let what = |q: &Quantity| match q {
        Quantity::Acceleration => "accelerometer",
        Quantity::AngularRate => "gyro",
    };
    match s {
        UnitSensor::Single { quantity, .. } => format!("a single {}", what(quantity)),
        UnitSensor::Triad { quantity, .. } => format!("{} triad", what(quantity)),
        UnitSensor::Imu { .. } => "an IMU".into(),
    }
}

/// What a person reads of `h`.
fn text(port: &str, h: &Holding) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calflash read  {port}: unit {} ({}), firmware {}, protocol {}",
        h.unit, h.sensor, h.firmware, h.protocol
    );
    match (&h.calibration, &h.blob_sha256) {
        (Some(c), Some(sha)) => {
            let _ = writeln!(
                s,
                "  calibration {c}: {} bytes, SHA-256 {sha}, {}",
                h.blob_len,
                match &h.signed_by {
                    Some(k) => format!("signed by station key {k}, counter {}", h.counter),
                    None => "unsigned".into(),
                }
            );
        }
        _ => {
            let _ = writeln!(s, "  no calibration: the unit flags every sample");
        }
    }
    let slots: Vec<String> = h
        .slots
        .iter()
        .zip(["A", "B"])
        .map(|(sl, name)| match (sl.seq, sl.len) {
            (Some(seq), Some(len)) => format!("{name} valid (sequence {seq}, {len} bytes)"),
            _ => format!("{name} {}", sl.state),
        })
        .collect();
    let _ = writeln!(s, "  slots: {}", slots.join(", "));
    let _ = writeln!(
        s,
        "  signatures: {}{}; writes {}",
        h.trust,
        if h.station_keys.is_empty() {
            String::new()
        } else {
            format!(" (station keys {})", h.station_keys.join(", "))
        },
        if h.locked {
            "refused (locked)"
        } else {
            "taken"
        }
    );
    if let Some(why) = &h.refused_at_boot {
        let _ = writeln!(
            s,
            "  a slot's calibration was refused at boot ({why}): the unit runs without it"
        );
    }
    s
}

/// Runs `calflash read`.
///
/// # Errors
/// The link's failure, naming the port; a file that cannot be written.
pub fn run(args: &ReadArgs) -> Result<(), Failure> {
    let timeout = Duration::from_secs_f64(args.timeout);
    let link = Link::open(&args.port, timeout)?;
    let mut client = Client::new(link, timeout);
    let (h, blob) = holding(&mut client).map_err(|e| format!("{}: {e}", args.port))?;
    if let Some(path) = &args.output {
        if blob.is_empty() {
            return Err(format!(
                "{}: unit {} holds no calibration; nothing written to {}",
                args.port,
                h.unit,
                path.display()
            )
            .into());
        }
        crate::files::write_atomically(path, |w| w.write_all(&blob))?;
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&h).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", text(&args.port, &h));
        if let Some(path) = &args.output {
            println!("  blob written to {}", path.display());
        }
    }
    Ok(())
}
