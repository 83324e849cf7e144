//! What a fresh machine needs: the thumb target (rustup) and qemu-system-arm (Debian).

use std::process::{Command, Stdio};

use host_tests::qemu::TARGET;

/// What the setup could provide.
pub struct Setup {
    /// `None` when QEMU is there; else why not.
    pub qemu_missing: Option<String>,
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
    if have_qemu() {
        return Ok(Setup { qemu_missing: None });
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
            return Ok(Setup { qemu_missing: None });
        }
        "`apt-get install -y qemu-system-arm` failed (no network to the Debian mirror?)".to_string()
    };
    Ok(Setup {
        qemu_missing: Some(why),
    })
}
