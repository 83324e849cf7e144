//! What a fresh machine needs: the thumb target (rustup), qemu-system-arm, and for the tests
//! a PostgreSQL server (the shared history) and Chromium (the reports in a real browser), all
//! Debian's packages.

use std::process::{Command, Stdio};

use host_tests::qemu::TARGET;

/// What the setup could provide.
pub struct Setup {
    /// `None` when QEMU is there; else why not.
    pub qemu_missing: Option<String>,
    /// `None` when a PostgreSQL server is installed (only looked for by `components` runs, the
    /// tests'); else why not.
    pub postgres_missing: Option<String>,
    /// `None` when Chromium is installed (as PostgreSQL); else why not.
    pub chromium_missing: Option<String>,
}

/// Whether Debian's PostgreSQL server is installed (`/usr/lib/postgresql/N/bin/initdb`).
fn have_postgres() -> bool {
    std::fs::read_dir("/usr/lib/postgresql").is_ok_and(|d| {
        d.filter_map(Result::ok)
            .any(|e| e.path().join("bin/initdb").is_file())
    })
}

/// Installs Debian's `package` when `present` says it is missing and it can be installed
/// (as root, with apt-get); `None` when it is there, else why not.
fn debian_package(package: &str, present: fn() -> bool) -> Option<String> {
    if present() {
        return None;
    }
    if !is_root() {
        return Some(format!(
            "{package} is not installed and this user cannot install it; run `sudo apt-get install -y {package}`"
        ));
    }
    if !quiet(Command::new("apt-get").arg("--version")) {
        return Some(format!(
            "{package} is not installed and there is no apt-get to install it"
        ));
    }
    println!("xtask: apt-get install -y {package}");
    let install = || {
        Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends", package])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    let installed = install() || (quiet(Command::new("apt-get").arg("update")) && install());
    if installed && present() {
        None
    } else {
        Some(format!(
            "`apt-get install -y {package}` failed (no network to the Debian mirror?)"
        ))
    }
}

/// Whether Debian's Chromium is installed, for the reports' test in a real browser.
fn have_chromium() -> bool {
    std::path::Path::new("/usr/bin/chromium").is_file()
}

fn quiet(cmd: &mut Command) -> bool {
    cmd.stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn have_qemu() -> bool {
    quiet(Command::new("qemu-system-arm").arg("--version"))
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// Adds the target and installs QEMU when missing. `components` also adds rustfmt and clippy.
pub fn run(components: bool) -> Result<Setup, String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("rustup is needed to add the {TARGET} target: {e}"))?;
    if !String::from_utf8_lossy(&installed.stdout)
        .lines()
        .any(|l| l.trim() == TARGET)
    {
        println!("xtask: rustup target add {TARGET}");
        let ok = Command::new("rustup")
            .args(["target", "add", TARGET])
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return Err(format!("`rustup target add {TARGET}` failed"));
        }
    }
    if components {
        for (component, subcommand) in [("rustfmt", "fmt"), ("clippy", "clippy")] {
            if !quiet(Command::new("cargo").args([subcommand, "--version"]))
                && !quiet(Command::new("rustup").args(["component", "add", component]))
            {
                return Err(format!("`rustup component add {component}` failed"));
            }
        }
    }
    let postgres_missing = components
        .then(|| debian_package("postgresql", have_postgres))
        .flatten();
    let chromium_missing = components
        .then(|| debian_package("chromium", have_chromium))
        .flatten();
    if have_qemu() {
        return Ok(Setup {
            qemu_missing: None,
            postgres_missing,
            chromium_missing,
        });
    }
    let why = debian_package("qemu-system-arm", have_qemu);
    Ok(Setup {
        qemu_missing: why,
        postgres_missing,
        chromium_missing,
    })
}
