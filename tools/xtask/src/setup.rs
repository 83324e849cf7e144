//! What a fresh machine needs: the thumb target (rustup), qemu-system-arm, and for the tests
//! of the shared history a PostgreSQL server (Debian's packages).

use std::process::{Command, Stdio};

use host_tests::qemu::TARGET;

/// What the setup could provide.
pub struct Setup {
    /// `None` when QEMU is there; else why not.
    pub qemu_missing: Option<String>,
    /// `None` when a PostgreSQL server is installed (only looked for by `components` runs, the
    /// tests'); else why not.
    pub postgres_missing: Option<String>,
}

/// Whether Debian's PostgreSQL server is installed (`/usr/lib/postgresql/N/bin/initdb`).
fn have_postgres() -> bool {
    std::fs::read_dir("/usr/lib/postgresql").is_ok_and(|d| {
        d.filter_map(Result::ok)
            .any(|e| e.path().join("bin/initdb").is_file())
    })
}

/// Installs Debian's `postgresql` when missing and possible; `None` when it is there.
fn postgres() -> Option<String> {
    if have_postgres() {
        return None;
    }
    if !is_root() {
        return Some(
            "PostgreSQL is not installed and this user cannot install it; run `sudo apt-get install -y postgresql`"
                .into(),
        );
    }
    if !quiet(Command::new("apt-get").arg("--version")) {
        return Some("PostgreSQL is not installed and there is no apt-get to install it".into());
    }
    println!("xtask: apt-get install -y postgresql");
    let install = || {
        Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends", "postgresql"])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    let installed = install() || (quiet(Command::new("apt-get").arg("update")) && install());
    if installed && have_postgres() {
        None
    } else {
        Some("`apt-get install -y postgresql` failed (no network to the Debian mirror?)".into())
    }
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
    let postgres_missing = if components { postgres() } else { None };
    if have_qemu() {
        return Ok(Setup {
            qemu_missing: None,
            postgres_missing,
        });
    }
    let why = if !is_root() {
        "qemu-system-arm is not installed and this user cannot install it; run \
         `sudo apt-get install -y qemu-system-arm`"
            .to_string()
    } else if !quiet(Command::new("apt-get").arg("--version")) {
        "qemu-system-arm is not installed and there is no apt-get to install it; install \
         QEMU's ARM system emulator with your package manager"
            .to_string()
    } else {
        println!("xtask: apt-get install -y qemu-system-arm");
        let install = || {
            Command::new("apt-get")
                .args([
                    "install",
                    "-y",
                    "--no-install-recommends",
                    "qemu-system-arm",
                ])
                .env("DEBIAN_FRONTEND", "noninteractive")
                .stdout(Stdio::null())
                .status()
                .is_ok_and(|s| s.success())
        };
        let installed = install() || (quiet(Command::new("apt-get").arg("update")) && install());
        if installed && have_qemu() {
            return Ok(Setup {
                qemu_missing: None,
                postgres_missing,
            });
        }
        "`apt-get install -y qemu-system-arm` failed (no network to the Debian mirror?)".to_string()
    };
    Ok(Setup {
        qemu_missing: Some(why),
        postgres_missing,
    })
}
