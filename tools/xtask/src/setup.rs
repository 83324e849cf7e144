//! What a fresh machine needs: the thumb target (rustup), qemu-system-arm, and for the tests
//! a PostgreSQL server (the shared history) and Chromium with the reports' typeface (the reports
//! in a real browser: `chromium`, `fonts-dejavu-core`), all Debian's packages.

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
    // apt-get waits up to five minutes for another apt or dpkg to let go of its lock; what it
    // said last is kept, so that a failure is reported as apt-get's, not guessed at.
    let run = |args: &[&str]| -> Result<(), String> {
        let out = Command::new("apt-get")
            .args(["-o", "DPkg::Lock::Timeout=300"])
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| format!("apt-get did not run: {e}"))?;
        if out.status.success() {
            return Ok(());
        }
        let said = String::from_utf8_lossy(&out.stderr);
        Err(said
            .lines()
            .map(str::trim)
            .rfind(|l| !l.is_empty())
            .unwrap_or("no message")
            .to_string())
    };
    let install = || run(&["install", "-y", "--no-install-recommends", package]);
    let result = install().or_else(|first| {
        // A stale package list: update it once and try again.
        run(&["update"]).map_err(|e| format!("{first}; `apt-get update`: {e}"))?;
        install()
    });
    match result {
        Ok(()) if present() => None,
        Ok(()) => Some(format!(
            "`apt-get install -y {package}` succeeded but {package} is still not found"
        )),
        Err(said) => Some(apt_failure(package, &said)),
    }
}

/// Why `apt-get install` of `package` failed, from what apt-get `said` last: its own words,
/// and what they mean when they say it (a lock another process holds, no network).
fn apt_failure(package: &str, said: &str) -> String {
    let meaning = if said.contains("lock") {
        " (another apt-get or dpkg holds the package lock: wait for it, then run again)"
    } else if said.contains("Temporary failure resolving") || said.contains("Could not resolve") {
        " (no network to the Debian mirror)"
    } else {
        ""
    };
    format!("`apt-get install -y {package}` failed: apt-get said: {said}{meaning}")
}

/// Whether Debian's Chromium is installed, for the reports' test in a real browser.
fn have_chromium() -> bool {
    std::path::Path::new("/usr/bin/chromium").is_file()
}

/// The typeface the reports name (`report::page::FONT`), so that the browser lays them out
/// the same on every machine: Debian's `fonts-dejavu-core`.
const REPORT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

fn have_report_font() -> bool {
    std::path::Path::new(REPORT_FONT).is_file()
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

/// Installs Debian's PostgreSQL server when missing (as root), for `cargo xtask history`.
///
/// # Errors
/// Why it is not there and cannot be installed.
pub fn postgres() -> Result<(), String> {
    debian_package("postgresql", have_postgres).map_or(Ok(()), Err)
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
        .then(|| {
            debian_package("chromium", have_chromium)
                .or_else(|| debian_package("fonts-dejavu-core", have_report_font))
        })
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

#[cfg(test)]
mod tests {
    use super::apt_failure;

    #[test]
    fn an_apt_failure_is_told_in_apt_gets_words() {
        let lock = "E: Could not get lock /var/lib/dpkg/lock-frontend. It is held by process 4242 (apt-get)";
        let e = apt_failure("qemu-system-arm", lock);
        assert!(
            e.contains("held by process 4242") && e.contains("holds the package lock"),
            "{e}"
        );
        assert!(!e.contains("network"), "{e}");
        let net = "W: Failed to fetch http://deb.debian.org/...  Temporary failure resolving 'deb.debian.org'";
        assert!(apt_failure("qemu-system-arm", net).contains("no network"));
        let other = "E: Unable to locate package qemu-system-arm";
        let e = apt_failure("qemu-system-arm", other);
        assert!(
            e.ends_with("Unable to locate package qemu-system-arm"),
            "{e}"
        );
    }
}
