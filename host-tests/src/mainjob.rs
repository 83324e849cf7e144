//! The main job, end to end: simulate a unit's test data (or take the user's), calibrate it
//! (fit, report, blob, record), provision the example unit with the job's station key (made on
//! the first run), boot the example firmware in QEMU, sign the calibration for the unit and
//! flash it over the emulated UART (the unit verifies the signature at commit and at boot),
//! verify it on the device, record it in the unit history, and summarise.
//! `cargo xtask calibrate` runs it; `tests/mainjob.rs` runs it in CI.

use std::path::{Path, PathBuf};
use std::time::Duration;

use calflash::device::image::{Region, unit_image};
use spincal::signed::StationKey;
use spincal::store::{KEYS_SPAN, Provisioning, keys_record};

use calflash::db::Db;
use calflash::device::{self, FlashOptions};
use calflash::sensor::{self, Options, record::Record, triad};
use calflash::sim::{self, Sensor, plan, truth::ImuTruth};

use spincal::store::SlotState;

use crate::qemu;
use crate::unit::QemuUnit;

/// The serial number the QEMU unit is built with (`firmware/src/bin/device.rs`).
pub const UNIT: &str = "QEMU-0001";

/// The converter codes of the main job's unit unless told otherwise.
pub const DEFAULT_CODES: spincal::model::Rails = spincal::model::Rails::unsigned(16);

/// Reads `--codes` as `calflash` does (`unsigned16`, `signed16`, any width, `LO:HI`).
///
/// # Errors
/// What is understood.
pub fn codes(text: &str) -> Result<spincal::model::Rails, String> {
    calflash::cmd::values::codes(text)
}

/// What to run.
#[derive(Debug, Clone)]
pub struct Job {
    /// The user's IMU observations; simulated when `None`.
    pub data: Option<PathBuf>,
    /// Where the files go.
    pub workdir: PathBuf,
    /// The unit history database.
    pub db: PathBuf,
    /// Seed of the simulated unit.
    pub seed: u64,
    /// The unit's converter codes (the simulated unit's biases sit at their mid-scale, and
    /// the calibration takes them).
    pub codes: spincal::model::Rails,
}

/// What it did.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Lines to print.
    pub lines: Vec<String>,
    /// The verdict of the calibration.
    pub verdict: sensor::Verdict,
    /// The flash's report.
    pub flash: device::FlashReport,
    /// Database ids of the fit and the flash.
    pub records: (i64, i64),
}

/// Runs the main job.
///
/// # Errors
/// A message saying which step failed and why.
pub fn run(job: &Job, mut say: impl FnMut(&str)) -> Result<Summary, String> {
    // The example unit is built for two converter formats.
    let device_bin = if job.codes == DEFAULT_CODES {
        "device"
    } else if job.codes == spincal::model::Rails::signed(16) {
        "device_signed16"
    } else {
        return Err(format!(
            "the QEMU unit is built with unsigned16 or signed16 converters, not {}",
            calflash::obs::codes::name(job.codes)
        ));
    };
    std::fs::create_dir_all(&job.workdir).map_err(|e| format!("{}: {e}", job.workdir.display()))?;
    let w = |name: &str| job.workdir.join(name);
    let data = match &job.data {
        Some(d) => d.clone(),
        None => {
            let conds = plan::plan(
                &[
                    "tumble:26".into(),
                    "rate:-6:6:7".into(),
                    "centrifuge:1:5:5".into(),
                ],
                &[-40.0, 25.0, 85.0],
                &[3.3],
                1,
                false,
            )
            .map_err(|e| e.to_string())?;
            let mut truth = ImuTruth::default();
            truth.accel.lever = [[0.012, 0.0, 0.0], [0.0, 0.009, 0.0], [0.0, 0.0, 0.015]];
            let unit = Sensor::Imu(Box::new(truth)).with_codes(job.codes);
            let obs = sim::simulate(&unit, &conds, job.seed, false);
            let path = w("observations.csv");
            obs.write_csv(
                std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?,
            )
            .map_err(|e| e.to_string())?;
            say(&format!(
                "1. simulated an IMU ({} codes) through a 26-position tumble, rate-table steps and centrifuge levels at -40, 25 and 85 C: {} observations in {}",
                calflash::obs::codes::name(job.codes),
                obs.rows.len(),
                path.display()
            ));
            path
        }
    };
    let mut opts = Options::new(&data, UNIT);
    opts.temp_span = spincal::model::Span::new(-40.0, 85.0);
    opts.rails = job.codes;
    let c = triad::calibrate(&opts, triad::Kind::Imu, false).map_err(|e| e.to_string())?;
    let record = Record::new(&c, &data.display().to_string()).sealed();
    let html = calflash::report::html::render(&c, &data.display().to_string())
        .map_err(|e| e.to_string())?;
    let (blob, report, json) = (w("unit.blob"), w("report.html"), w("calibration.json"));
    std::fs::write(&blob, &c.blob).map_err(|e| e.to_string())?;
    std::fs::write(&report, html).map_err(|e| e.to_string())?;
    std::fs::write(
        &json,
        serde_json::to_vec_pretty(&record).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let mut db = Db::open(&job.db).map_err(|e| e.to_string())?;
    let fit_id = db
        .record_fit(&record, Some(&report), &c.blob)
        .map_err(|e| e.to_string())?;
    say(&format!(
        "2. calibrated unit {UNIT}: {:?}, {} table points, blob {} bytes; report {}",
        c.verdict(),
        c.points.len(),
        c.blob.len(),
        report.display()
    ));

    say("3. building the device firmware and powering the unit on: QEMU mps2-an386 (Cortex-M4F)");
    let bin = qemu::build_firmware()?;
    let elf = bin.join(device_bin);
    let flash_file = w("unit-flash.bin");
    let (key_file, pub_file) = (w("station.key"), w("station.pub"));
    if !key_file.exists() {
        calflash::signing::keygen(&key_file, &pub_file).map_err(|e| e.to_string())?;
    }
    let key = calflash::signing::load_private(&key_file).map_err(|e| e.to_string())?;
    let station = calflash::signing::load_public(&pub_file).map_err(|e| e.to_string())?;
    let provisioned = provision(&flash_file, station)?;
    say(&format!(
        "   the unit is provisioned with station key {} ({}{})",
        device::key_hex(station.id()),
        pub_file.display(),
        if provisioned {
            ", written into its keys sector now, as a flasher does at manufacture"
        } else {
            ""
        }
    ));
    let log = w("qemu.log");
    let unit = QemuUnit::power_on(&elf, Some(&flash_file), &log)?;
    let mut client = unit.connect(Duration::from_secs(15))?;
    let before = client.identify().map_err(|e| e.to_string())?;
    say(&format!(
        "4. the unit answers on its UART (tcp port {}): {}, holding {} (flash kept in {})",
        unit.port,
        before.unit.as_str(),
        before
            .calibration
            .as_ref()
            .map_or("no calibration", |s| s.as_str()),
        flash_file.display()
    ));
    // Signed for this unit, at the counter above the one it holds.
    let counter = before.counter + 1;
    let signed =
        calflash::signing::sign(&c.blob, &key, counter, false).map_err(|e| e.to_string())?;
    let signed_path = w("unit-signed.blob");
    std::fs::write(&signed_path, &signed).map_err(|e| format!("{}: {e}", signed_path.display()))?;
    let flash = device::flash(
        &mut client,
        &before,
        &signed,
        &FlashOptions::default(),
        |_, _| {},
    )
    .map_err(|e| e.to_string())?;
    drop(client);
    unit.power_off()?;
    let flash_id = db
        .record_flash(
            &flash.unit,
            &signed,
            &serde_json::to_value(&flash).map_err(|e| e.to_string())?,
            "verified",
        )
        .map_err(|e| e.to_string())?;
    say(&format!(
        "5. signed by station key {} at counter {counter} ({}) and flashed over the emulated UART: the unit verified the signature and committed it as slot sequence {}, {} bytes read back identical, {} test vectors through the device's correction within {} ulp of the host's; recorded as db:{fit_id} (fit) and db:{flash_id} (flash) in {}",
        device::key_hex(station.id()),
        signed_path.display(),
        flash.seq,
        flash.bytes,
        flash.vectors,
        flash.max_ulp,
        job.db.display()
    ));

    let reboot_log = w("qemu-reboot.log");
    let unit = QemuUnit::power_on(&elf, Some(&flash_file), &reboot_log)?;
    let mut client = unit.connect(Duration::from_secs(15))?;
    let after = client.identify().map_err(|e| e.to_string())?;
    drop(client);
    drop(unit);
    let booted = std::fs::read_to_string(&reboot_log).unwrap_or_default();
    let self_test = booted
        .lines()
        .find(|l| l.starts_with("device: calibration") || l.starts_with("device: no valid"))
        .unwrap_or("device: (no self-test line)")
        .to_string();
    if after.calibration.is_none()
        || after.signed_by != Some(station.id())
        || after.counter != counter
        || after
            .slots
            .iter()
            .all(|s| !matches!(s, SlotState::Valid { seq, .. } if *seq == flash.seq))
    {
        return Err(format!(
            "after a power cycle the unit does not hold the calibration just flashed (slots {:?}); see {}",
            after.slots,
            reboot_log.display()
        ));
    }
    say(&format!(
        "6. power-cycled: the unit verifies the signature at boot and runs with {} (counter {}, slots {:?}); its boot self-test says \"{}\"",
        after.calibration.as_ref().map_or("nothing", |s| s.as_str()),
        after.counter,
        after.slots,
        self_test.trim_start_matches("device: ")
    ));
    let qemu_said = std::fs::read_to_string(&log).unwrap_or_default();
    let lines = vec![
        format!("unit {UNIT}: {:?}", c.verdict()),
        format!("report      {}", report.display()),
        format!(
            "blob        {} (signed for the unit: {})",
            blob.display(),
            signed_path.display()
        ),
        format!(
            "station key {} (private; mode 600), {}",
            key_file.display(),
            pub_file.display()
        ),
        format!("record      {}", json.display()),
        format!(
            "history     calflash history {UNIT} --db {}",
            job.db.display()
        ),
        format!(
            "unit flash  {} (the next run boots the unit with it)",
            flash_file.display()
        ),
        format!(
            "device log  {} ({} lines), {}",
            log.display(),
            qemu_said.lines().count(),
            reboot_log.display()
        ),
    ];
    Ok(Summary {
        lines,
        verdict: c.verdict(),
        flash,
        records: (fit_id, flash_id),
    })
}

/// Makes sure the unit's flash file holds `station` in its keys sector, as a flasher writes it
/// at manufacture: a new unit (no file) gets a region with the key; a unit from before signed
/// calibrations (a shorter file, or an empty keys sector) gets the key added. True when the
/// key was written now.
///
/// # Errors
/// A file that cannot be read or written, or a unit provisioned with other keys (it would
/// refuse this station's calibrations) or with a damaged keys sector.
fn provision(flash_file: &Path, station: StationKey) -> Result<bool, String> {
    let region = Region::from_memory_x();
    let size = region.bytes() as usize;
    let name = flash_file.display();
    let mut image = match std::fs::read(flash_file) {
        Ok(image) => image,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            unit_image(None, &[], region).map_err(|e| e.to_string())?
        }
        Err(e) => return Err(format!("{name}: {e}")),
    };
    let before_keys = region.keys_offset() as usize;
    if image.len() == before_keys {
        // The region before the keys sector existed: an unprovisioned unit.
        image.resize(size, 0xff);
    }
    if image.len() != size {
        return Err(format!(
            "{name}: a flash image of {} bytes; the unit's region is {size} bytes (delete it to start a fresh unit)",
            image.len()
        ));
    }
    let sector = &mut image[before_keys..before_keys + region.lock_size as usize];
    let record: &[u8; KEYS_SPAN] = sector[..KEYS_SPAN].try_into().map_err(|_| "keys span")?;
    match Provisioning::read(record) {
        Provisioning::Provisioned(keys) if keys.contains(&station) => return Ok(false),
        Provisioning::Provisioned(keys) => {
            return Err(format!(
                "{name}: the unit is provisioned with other station keys ({}) and would refuse this station's calibrations; delete the file to start a fresh unit",
                keys.iter()
                    .map(|k| device::key_hex(k.id()))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        Provisioning::Damaged => {
            return Err(format!(
                "{name}: the unit's keys sector is damaged; delete the file to start a fresh unit"
            ));
        }
        Provisioning::Unprovisioned => {}
    }
    keys_record(&[station], sector).ok_or("one key fits the keys sector")?;
    std::fs::write(flash_file, &image).map_err(|e| format!("{name}: {e}"))?;
    Ok(true)
}
