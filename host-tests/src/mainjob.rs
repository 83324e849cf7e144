//! The main job, end to end: simulate a unit's test data (or take the user's), calibrate it
//! (fit, report, blob, record), boot the example firmware in QEMU, flash the calibration over
//! the emulated UART, verify it on the device, record it in the unit history, and summarise.
//! `cargo xtask calibrate` runs it; `tests/mainjob.rs` runs it in CI.

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use calflash::db::Db;
use calflash::device::{self, Client, FlashOptions};
use calflash::sensor::{self, Options, record::Record, triad};
use calflash::sim::{self, Sensor, plan, truth::ImuTruth};

use crate::qemu;

/// The serial number the QEMU unit is built with (`firmware/src/bin/device.rs`).
pub const UNIT: &str = "QEMU-0001";

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

struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> Result<u16, String> {
    let l = TcpListener::bind("127.0.0.1:0").map_err(|e| format!("no free TCP port: {e}"))?;
    l.local_addr().map(|a| a.port()).map_err(|e| e.to_string())
}

/// Boots the device firmware with its UART on a TCP port; returns QEMU and the port.
fn boot(elf: &Path, log: &Path, extra: &[String]) -> Result<(Qemu, u16), String> {
    let port = free_port()?;
    let mut cmd = qemu::command(elf, &[]);
    cmd.arg("-serial").arg(format!("tcp:127.0.0.1:{port},server=on,wait=on"));
    cmd.args(extra);
    let out = std::fs::File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
    let child = cmd
        .stdin(Stdio::null())
        .stdout(out.try_clone().map_err(|e| e.to_string())?)
        .stderr(out)
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    Ok((Qemu(child), port))
}

/// Connects to the QEMU unit, waiting for it to listen.
pub fn connect(port: u16, timeout: Duration) -> Result<Client<TcpStream>, String> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => {
                s.set_read_timeout(Some(Duration::from_millis(200))).map_err(|e| e.to_string())?;
                return Ok(Client::new(s, timeout));
            }
            Err(_) if start.elapsed() < Duration::from_secs(20) => std::thread::sleep(Duration::from_millis(50)),
            Err(e) => return Err(format!("the QEMU unit's UART on port {port} does not answer: {e}")),
        }
    }
}

/// Runs the main job.
///
/// # Errors
/// A message saying which step failed and why.
pub fn run(job: &Job, mut say: impl FnMut(&str)) -> Result<Summary, String> {
    std::fs::create_dir_all(&job.workdir).map_err(|e| format!("{}: {e}", job.workdir.display()))?;
    let w = |name: &str| job.workdir.join(name);
    let data = match &job.data {
        Some(d) => d.clone(),
        None => {
            let conds = plan::plan(
                &["tumble:26".into(), "rate:-6:6:7".into(), "centrifuge:1:5:5".into()],
                &[-40.0, 25.0, 85.0],
                &[3.3],
                1,
                false,
            )
            .map_err(|e| e.to_string())?;
            let mut truth = ImuTruth::default();
            truth.accel.lever = [[0.012, 0.0, 0.0], [0.0, 0.009, 0.0], [0.0, 0.0, 0.015]];
            let obs = sim::simulate(&Sensor::Imu(Box::new(truth)), &conds, job.seed, false);
            let path = w("observations.csv");
            obs.write_csv(std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?)
                .map_err(|e| e.to_string())?;
            say(&format!(
                "1. simulated an IMU through a 26-position tumble, rate-table steps and centrifuge levels at -40, 25 and 85 C: {} observations in {}",
                obs.rows.len(),
                path.display()
            ));
            path
        }
    };
    let mut opts = Options::new(&data, UNIT);
    opts.temp_span = spincal::model::Span::new(-40.0, 85.0);
    let c = triad::calibrate(&opts, triad::Kind::Imu, false).map_err(|e| e.to_string())?;
    let record = Record::new(&c, &data.display().to_string());
    let html = calflash::report::html::render(&c, &data.display().to_string())?;
    let (blob, report, json) = (w("unit.blob"), w("report.html"), w("calibration.json"));
    std::fs::write(&blob, &c.blob).map_err(|e| e.to_string())?;
    std::fs::write(&report, html).map_err(|e| e.to_string())?;
    std::fs::write(&json, serde_json::to_vec_pretty(&record).map_err(|e| e.to_string())?).map_err(|e| e.to_string())?;
    let mut db = Db::open(&job.db)?;
    let fit_id = db.record_fit(&record, Some(&report), &c.blob)?;
    say(&format!(
        "2. calibrated unit {UNIT}: {:?}, {} table points, blob {} bytes; report {}",
        c.verdict(),
        c.points.len(),
        c.blob.len(),
        report.display()
    ));

    say("3. building the device firmware and booting it on QEMU mps2-an386 (Cortex-M4F)");
    let bin = qemu::build_firmware()?;
    let log = w("qemu.log");
    let (qemu, port) = boot(&bin.join("device"), &log, &[])?;
    let mut client = connect(port, Duration::from_secs(5))?;
    let before = client.identify().map_err(|e| e.to_string())?;
    say(&format!(
        "4. the unit answers on its UART (tcp port {port}): {}, holding {}",
        before.unit.as_str(),
        before.calibration.as_ref().map_or("no calibration", |s| s.as_str())
    ));
    let flash = device::flash(&mut client, &c.blob, &FlashOptions::default(), |_, _| {}).map_err(|e| e.to_string())?;
    let after = client.identify().map_err(|e| e.to_string())?;
    drop(qemu);
    let flash_id = db.record_flash(
        &flash.unit,
        &c.blob,
        &serde_json::to_value(&flash).map_err(|e| e.to_string())?,
        "verified",
    )?;
    say(&format!(
        "5. flashed over the emulated UART: committed as slot sequence {}, {} bytes read back identical, {} test vectors through the device's correction within {} ulp of the host's",
        flash.seq, flash.bytes, flash.vectors, flash.max_ulp
    ));
    say(&format!(
        "6. the unit now holds {} (slots {:?}); recorded as db:{fit_id} (fit) and db:{flash_id} (flash) in {}",
        after.calibration.as_ref().map_or("nothing", |s| s.as_str()),
        after.slots,
        job.db.display()
    ));
    let qemu_said = std::fs::read_to_string(&log).unwrap_or_default();
    let lines = vec![
        format!("unit {UNIT}: {:?}", c.verdict()),
        format!("report      {}", report.display()),
        format!("blob        {}", blob.display()),
        format!("record      {}", json.display()),
        format!("history     calflash history {UNIT} --db {}", job.db.display()),
        format!("device log  {} ({} lines)", log.display(), qemu_said.lines().count()),
    ];
    Ok(Summary {
        lines,
        verdict: c.verdict(),
        flash,
        records: (fit_id, flash_id),
    })
}
