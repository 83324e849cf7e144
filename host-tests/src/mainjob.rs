//! The main job, end to end: simulate a unit's test data (or take the user's), calibrate it
//! (fit, report, blob, record), boot the example firmware in QEMU, flash the calibration over
//! the emulated UART, verify it on the device, record it in the unit history, and summarise.
//! `cargo xtask calibrate` runs it; `tests/mainjob.rs` runs it in CI.

use std::path::PathBuf;
use std::time::Duration;

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
    let record = Record::new(&c, &data.display().to_string());
    let html = calflash::report::html::render(&c, &data.display().to_string())?;
    let (blob, report, json) = (w("unit.blob"), w("report.html"), w("calibration.json"));
    std::fs::write(&blob, &c.blob).map_err(|e| e.to_string())?;
    std::fs::write(&report, html).map_err(|e| e.to_string())?;
    std::fs::write(
        &json,
        serde_json::to_vec_pretty(&record).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let mut db = Db::open(&job.db)?;
    let fit_id = db.record_fit(&record, Some(&report), &c.blob)?;
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
    let log = w("qemu.log");
    let unit = QemuUnit::power_on(&elf, Some(&flash_file), &log)?;
    let mut client = unit.connect(Duration::from_secs(5))?;
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
    let flash = device::flash(
        &mut client,
        &before,
        &c.blob,
        &FlashOptions::default(),
        |_, _| {},
    )
    .map_err(|e| e.to_string())?;
    drop(client);
    unit.power_off()?;
    let flash_id = db.record_flash(
        &flash.unit,
        &c.blob,
        &serde_json::to_value(&flash).map_err(|e| e.to_string())?,
        "verified",
    )?;
    say(&format!(
        "5. flashed over the emulated UART: committed as slot sequence {}, {} bytes read back identical, {} test vectors through the device's correction within {} ulp of the host's; recorded as db:{fit_id} (fit) and db:{flash_id} (flash) in {}",
        flash.seq,
        flash.bytes,
        flash.vectors,
        flash.max_ulp,
        job.db.display()
    ));

    let reboot_log = w("qemu-reboot.log");
    let unit = QemuUnit::power_on(&elf, Some(&flash_file), &reboot_log)?;
    let mut client = unit.connect(Duration::from_secs(5))?;
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
        "6. power-cycled: the unit boots holding {} (slots {:?}); its boot self-test says \"{}\"",
        after.calibration.as_ref().map_or("nothing", |s| s.as_str()),
        after.slots,
        self_test.trim_start_matches("device: ")
    ));
    let qemu_said = std::fs::read_to_string(&log).unwrap_or_default();
    let lines = vec![
        format!("unit {UNIT}: {:?}", c.verdict()),
        format!("report      {}", report.display()),
        format!("blob        {}", blob.display()),
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
