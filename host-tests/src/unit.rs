//! The example device as a unit on the bench: the `device` firmware booted on QEMU mps2-an386
//! with its UART on a TCP port, and its calibration flash kept in a file between power cycles.
//!
//! The emulated flash is the calibration store at `_calib_start` (memory.x). At power-on the file,
//! when given and present, is loaded there (`-device loader`); at [`QemuUnit::power_off`] the
//! region is saved back through the QEMU monitor (`pmemsave`) to a temporary file that replaces
//! the old one only once QEMU has written it completely. The monitor listens on a Unix socket
//! in a folder only this user can enter (0700), not on a TCP port: on a port any local user
//! could `quit` the unit, `pmemsave` to any path this user may write, or start a gdbserver.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use calflash::device::Client;

use crate::qemu;

/// Address and size of the calibration store (memory.x: two slots, the lock sector and the
/// keys sector).
#[must_use]
pub fn region() -> (u32, u32) {
    let r = calflash::device::image::Region::from_memory_x();
    (r.start, r.bytes())
}

/// A running QEMU unit. Dropping it kills QEMU (a power cut: nothing is saved).
#[derive(Debug)]
pub struct QemuUnit {
    child: Child,
    /// The TCP port of the unit's UART.
    pub port: u16,
    /// The monitor's socket, in `private`.
    monitor: PathBuf,
    /// A folder only this user can enter (removed with the unit).
    _private: tempfile::TempDir,
    flash: Option<PathBuf>,
}

impl Drop for QemuUnit {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn free_port() -> Result<u16, String> {
    let l = TcpListener::bind("127.0.0.1:0").map_err(|e| format!("no free TCP port: {e}"))?;
    l.local_addr().map(|a| a.port()).map_err(|e| e.to_string())
}

impl QemuUnit {
    /// Powers on `elf` (the `device` firmware) with its flash from `flash` when that file exists
    /// (an erased flash otherwise); QEMU's output goes to `log`. The firmware starts when a
    /// client connects to the UART ([`QemuUnit::connect`]).
    ///
    /// # Errors
    /// When QEMU cannot be started or the log cannot be created.
    pub fn power_on(elf: &Path, flash: Option<&Path>, log: &Path) -> Result<Self, String> {
        Self::power_on_at(elf, flash, log, None)
    }

    /// [`QemuUnit::power_on`] with the UART on `port` (a free one when `None`). A unit on a
    /// port of its own starts at once, as a unit on a bench does, and takes one client after
    /// another on its UART; on a free port it waits for its first client.
    ///
    /// # Errors
    /// When QEMU cannot be started, the log cannot be created or `port` is taken.
    pub fn power_on_at(
        elf: &Path,
        flash: Option<&Path>,
        log: &Path,
        port: Option<u16>,
    ) -> Result<Self, String> {
        let wait = if port.is_some() { "off" } else { "on" };
        let port = match port {
            Some(p) => {
                TcpListener::bind(("127.0.0.1", p))
                    .map_err(|e| format!("port {p} on 127.0.0.1 cannot be listened on: {e}"))?;
                p
            }
            None => free_port()?,
        };
        let private = {
            use std::os::unix::fs::PermissionsExt as _;
            tempfile::Builder::new()
                .prefix("spincal-unit-")
                .permissions(std::fs::Permissions::from_mode(0o700))
                .tempdir()
        }
        .map_err(|e| format!("no private folder for the unit's monitor: {e}"))?;
        let monitor = private.path().join("monitor.sock");
        let mut cmd = qemu::command(elf, &[]);
        cmd.arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},server=on,wait={wait}"));
        cmd.arg("-monitor")
            .arg(format!("unix:{},server=on,wait=off", monitor.display()));
        if let Some(f) = flash.filter(|f| f.exists()) {
            let len = std::fs::metadata(f)
                .map_err(|e| format!("{}: {e}", f.display()))?
                .len();
            let (start, size) = region();
            if len != u64::from(size) {
                return Err(format!(
                    "{}: a flash image of {len} bytes; the calibration store is {size} bytes",
                    f.display()
                ));
            }
            cmd.arg("-device").arg(format!(
                "loader,file={},addr={start:#x},force-raw=on",
                f.display()
            ));
        }
        let out = std::fs::File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
        let child = cmd
            .stdin(Stdio::null())
            .stdout(out.try_clone().map_err(|e| e.to_string())?)
            .stderr(out)
            .spawn()
            .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
        Ok(Self {
            child,
            port,
            monitor,
            _private: private,
            flash: flash.map(Path::to_path_buf),
        })
    }

    /// Connects to the unit's UART, waiting for QEMU to listen; `timeout` is the client's
    /// per-reply timeout.
    ///
    /// # Errors
    /// When the UART does not listen within 20 s.
    pub fn connect(&self, timeout: Duration) -> Result<Client<TcpStream>, String> {
        let s = connect_tcp(self.port)?;
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .map_err(|e| e.to_string())?;
        Ok(Client::new(s, timeout))
    }

    /// Saves the flash to its file (when one was given) and stops QEMU.
    ///
    /// # Errors
    /// When the monitor does not answer or the image is not written completely; the old file
    /// is then left as it was.
    pub fn power_off(mut self) -> Result<(), String> {
        self.save_flash()?;
        let mut monitor = Monitor::open(&self.monitor)?;
        monitor.quit();
        let start = Instant::now();
        while self.child.try_wait().map_err(|e| e.to_string())?.is_none()
            && start.elapsed() < Duration::from_secs(10)
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        Ok(())
    }

    /// Copies the unit's flash, as it is now, to its file (when one was given): into a
    /// temporary file first, renamed over the old one only when complete. Taken while the
    /// unit runs, it is what a power cut at this instant would leave.
    ///
    /// # Errors
    /// When the monitor does not answer or the image is not written completely; the old file
    /// is then left as it was.
    pub fn save_flash(&self) -> Result<(), String> {
        let Some(flash) = self.flash.clone() else {
            return Ok(());
        };
        let tmp = flash.with_extension("bin.partial");
        let _ = std::fs::remove_file(&tmp);
        let (start, size) = region();
        Monitor::open(&self.monitor)?.command(&format!(
            "pmemsave {start:#x} {size:#x} \"{}\"",
            tmp.display()
        ))?;
        let len = std::fs::metadata(&tmp).map(|m| m.len()).unwrap_or(0);
        if len != u64::from(size) {
            let _ = std::fs::remove_file(&tmp);
            return Err(format!(
                "QEMU saved {len} of {size} bytes of the unit's flash; {} kept as it was",
                flash.display()
            ));
        }
        std::fs::rename(&tmp, &flash).map_err(|e| format!("{}: {e}", flash.display()))
    }

    /// The monitor's Unix socket (in a folder only this user can enter).
    #[must_use]
    pub fn monitor_socket(&self) -> &Path {
        &self.monitor
    }

    /// The host CPU time QEMU has used so far (user and system, from `/proc/PID/stat`; Linux).
    ///
    /// # Errors
    /// When `/proc` cannot be read for the process.
    pub fn cpu_time(&self) -> Result<Duration, String> {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id()))
            .map_err(|e| format!("/proc/{}/stat: {e}", self.child.id()))?;
        // The fields after the command name (in parentheses, which may hold spaces): utime
        // and stime are the 14th and 15th of the line, the 12th and 13th after the name.
        let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
        let field = |k: usize| -> Result<u64, String> {
            rest.split_whitespace()
                .nth(k)
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| format!("/proc/{}/stat: no field {k}: {stat}", self.child.id()))
        };
        let ticks = field(11)? + field(12)?;
        let hz = std::process::Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .ok()
            .and_then(|o| {
                String::from_utf8_lossy(&o.stdout)
                    .trim()
                    .parse::<u64>()
                    .ok()
            })
            .filter(|&h| h > 0)
            .ok_or("getconf CLK_TCK gives no clock rate")?;
        Ok(Duration::from_micros(ticks * 1_000_000 / hz))
    }

    /// Whether QEMU still runs.
    #[must_use]
    pub fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

/// A connection to QEMU's human monitor, at its prompt.
struct Monitor {
    w: UnixStream,
    r: BufReader<UnixStream>,
}

impl Monitor {
    fn open(socket: &Path) -> Result<Self, String> {
        let start = Instant::now();
        let mon = loop {
            match UnixStream::connect(socket) {
                Ok(s) => break s,
                Err(_) if start.elapsed() < Duration::from_secs(20) => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                Err(e) => {
                    return Err(format!(
                        "the QEMU unit's monitor {} does not answer: {e}",
                        socket.display()
                    ));
                }
            }
        };
        mon.set_read_timeout(Some(Duration::from_secs(10)))
            .map_err(|e| e.to_string())?;
        let w = mon.try_clone().map_err(|e| e.to_string())?;
        let mut m = Self {
            w,
            r: BufReader::new(mon),
        };
        m.prompt()?;
        Ok(m)
    }

    fn prompt(&mut self) -> Result<(), String> {
        let mut seen = Vec::new();
        let mut byte = [0u8; 1];
        while !seen.ends_with(b"(qemu) ") {
            self.r
                .read_exact(&mut byte)
                .map_err(|e| format!("the QEMU monitor stopped answering: {e}"))?;
            seen.push(byte[0]);
        }
        Ok(())
    }

    /// Runs one command and waits for the prompt after it.
    fn command(&mut self, line: &str) -> Result<(), String> {
        writeln!(self.w, "{line}").map_err(|e| e.to_string())?;
        self.prompt()
    }

    fn quit(&mut self) {
        let _ = writeln!(self.w, "quit");
        let mut rest = String::new();
        let _ = self.r.read_line(&mut rest);
    }
}

/// Connects to QEMU's listening `port`, retrying while it starts. A connection whose local
/// address is its peer's is refused and retried: connecting again and again to a local port
/// nobody listens on yet can pick that same port as its own ephemeral one, and TCP then
/// connects the socket to itself (the link "closes" on the first request).
fn connect_tcp(port: u16) -> Result<TcpStream, String> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) if s.local_addr().ok() == s.peer_addr().ok() => {
                drop(s);
                std::thread::sleep(Duration::from_millis(50));
            }
            Ok(s) => return Ok(s),
            Err(_) if start.elapsed() < Duration::from_secs(20) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => return Err(format!("the QEMU unit on port {port} does not answer: {e}")),
        }
    }
}
