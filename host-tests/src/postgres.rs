//! A real PostgreSQL server for the history tests (issue 18) and for a newcomer's shared
//! history (`cargo xtask history`): Debian's `postgresql` package (`cargo xtask test` installs
//! it when missing and it can), a cluster made by `initdb` in a temporary directory (or one
//! kept between runs), run as an unprivileged user (`nobody` when run as root: the server
//! refuses root), listening on 127.0.0.1 (a free port, or the one given) and on a socket in
//! that directory; stopped when dropped (a temporary cluster's files removed). Local
//! connections are trusted, except the logins of [`Server::login`], which must give their
//! password (SCRAM).

// Also included by path into calflash's test and bench crates, each using a part of it.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Stdio};

/// The logins that must give a password (see [`Server::login`]).
pub const LOGINS: [&str; 2] = ["station", "reader"];

/// Where a cluster lives.
enum Place {
    /// Removed when the server stops.
    Temporary(tempfile::TempDir),
    /// Kept for the next run.
    Kept(PathBuf),
}

impl Place {
    fn path(&self) -> &std::path::Path {
        match self {
            Self::Temporary(t) => t.path(),
            Self::Kept(p) => p,
        }
    }
}

/// A running server.
pub struct Server {
    dir: Place,
    bin: PathBuf,
    /// Its TCP port on 127.0.0.1.
    pub port: u16,
    as_nobody: bool,
}

/// The newest installed server's `bin` directory (`/usr/lib/postgresql/N/bin`).
fn server_bin() -> Option<PathBuf> {
    let mut versions: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .ok()?
        .filter_map(|e| {
            let e = e.ok()?;
            let v: u32 = e.file_name().to_str()?.parse().ok()?;
            let bin = e.path().join("bin");
            bin.join("initdb").is_file().then_some((v, bin))
        })
        .collect();
    versions.sort();
    versions.pop().map(|(_, b)| b)
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

impl Server {
    /// Starts a server; `Ok(None)` (with a notice printed) when PostgreSQL is not installed,
    /// unless `SPINCAL_REQUIRE_POSTGRES=1` (as `cargo xtask test` sets once it has installed
    /// it), which makes that an error.
    ///
    /// # Errors
    /// A server that is installed but does not start, with its log.
    pub fn start(test: &str) -> Result<Option<Self>, String> {
        let Some(bin) = server_bin() else {
            if std::env::var("SPINCAL_REQUIRE_POSTGRES").is_ok_and(|v| v == "1") {
                return Err("PostgreSQL is required (SPINCAL_REQUIRE_POSTGRES=1) but no /usr/lib/postgresql/N/bin/initdb is installed".into());
            }
            println!(
                "SKIPPED {test}: PostgreSQL is not installed (Debian: apt-get install -y postgresql; `cargo xtask test` does it as root)"
            );
            return Ok(None);
        };
        let dir = Place::Temporary(tempfile::tempdir().map_err(|e| e.to_string())?);
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| format!("no free TCP port: {e}"))?
            .port();
        Self::start_at(bin, dir, port).map(Some)
    }

    /// Starts a server on `port` whose cluster is kept in `dir` (made there on the first run).
    ///
    /// # Errors
    /// PostgreSQL not installed, the port taken, or a server that does not start, with its log.
    pub fn start_kept(dir: &std::path::Path, port: u16) -> Result<Self, String> {
        let bin = server_bin().ok_or(
            "PostgreSQL is not installed: no /usr/lib/postgresql/N/bin/initdb (Debian: apt-get install -y postgresql)",
        )?;
        std::net::TcpListener::bind(("127.0.0.1", port))
            .map_err(|e| format!("port {port} on 127.0.0.1 cannot be listened on: {e}"))?;
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        Self::start_at(bin, Place::Kept(dir.to_path_buf()), port)
    }

    fn start_at(bin: PathBuf, dir: Place, port: u16) -> Result<Self, String> {
        let as_nobody = is_root();
        let data = dir.path().join("data");
        let fresh = !data.join("PG_VERSION").is_file();
        if fresh {
            std::fs::create_dir_all(&data).map_err(|e| e.to_string())?;
        }
        if as_nobody {
            // The server's user must own the cluster and reach the directory.
            let ok = Command::new("chmod")
                .args(["755", &dir.path().display().to_string()])
                .status()
                .is_ok_and(|s| s.success())
                && Command::new("chown")
                    .args(["-R", "nobody", &dir.path().display().to_string()])
                    .status()
                    .is_ok_and(|s| s.success());
            if !ok {
                return Err(format!(
                    "cannot give {} to the user nobody",
                    dir.path().display()
                ));
            }
        }
        let s = Self {
            dir,
            bin,
            port,
            as_nobody,
        };
        let log = s.dir.path().join("server.log");
        if fresh {
            s.init(&data)?;
        }
        let options = format!(
            "-p {port} -k {} -c listen_addresses=127.0.0.1 -c fsync=off",
            s.dir.path().display()
        );
        s.run(
            "pg_ctl",
            &[
                "-D",
                &data.display().to_string(),
                "-o",
                &options,
                "-l",
                &log.display().to_string(),
                "-w",
                "-t",
                "60",
                "start",
            ],
        )
        .map_err(|e| format!("{e}\n{}", std::fs::read_to_string(&log).unwrap_or_default()))?;
        Ok(s)
    }

    /// Makes the cluster in `data`: trusted locally, [`LOGINS`] by password over TCP.
    fn init(&self, data: &std::path::Path) -> Result<(), String> {
        self.run(
            "initdb",
            &[
                "-D",
                &data.display().to_string(),
                "-U",
                "postgres",
                "-A",
                "trust",
                "-E",
                "UTF8",
                "--no-sync",
            ],
        )?;
        // Password logins first: pg_hba.conf takes the first line that matches.
        let hba = data.join("pg_hba.conf");
        let trusted = std::fs::read_to_string(&hba).map_err(|e| e.to_string())?;
        std::fs::write(
            &hba,
            format!(
                "host all {} 127.0.0.1/32 scram-sha-256\n{trusted}",
                LOGINS.join(",")
            ),
        )
        .map_err(|e| e.to_string())
    }

    /// Runs one of the server's programs as the server's user.
    fn run(&self, program: &str, args: &[&str]) -> Result<(), String> {
        let exe = self.bin.join(program);
        let mut cmd = if self.as_nobody {
            let mut c = Command::new("runuser");
            c.args(["-u", "nobody", "--"]).arg(&exe);
            c
        } else {
            Command::new(&exe)
        };
        let out = cmd
            .args(args)
            .current_dir(self.dir.path())
            .stdin(Stdio::null())
            .output()
            .map_err(|e| format!("{}: {e}", exe.display()))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(format!(
                "{program} failed: {}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ))
        }
    }

    /// A connection URL to database `db` as the superuser.
    #[must_use]
    pub fn url(&self, db: &str) -> String {
        format!("postgres://postgres@127.0.0.1:{}/{db}", self.port)
    }

    /// Runs `sql` as the superuser in database `db`.
    ///
    /// # Panics
    /// SQL the server refuses.
    #[allow(dead_code)] // not every test file makes databases
    pub fn execute(&self, db: &str, sql: &str) {
        self.try_execute(db, sql).unwrap_or_else(|e| panic!("{e}"));
    }

    /// Runs `sql` as the superuser in database `db`.
    ///
    /// # Errors
    /// The server's refusal, with the SQL.
    pub fn try_execute(&self, db: &str, sql: &str) -> Result<(), String> {
        let mut c = postgres::Client::connect(&self.url(db), postgres::NoTls)
            .map_err(|e| format!("{}: {e}", self.url(db)))?;
        c.batch_execute(sql).map_err(|e| format!("{sql}: {e}"))
    }

    /// Makes login `name` (one of [`LOGINS`]) with `password`; a URL of database `db` as it.
    ///
    /// # Panics
    /// SQL the server refuses.
    #[allow(dead_code)] // not every test file makes logins
    pub fn login(&self, name: &str, password: &str, db: &str) -> String {
        assert!(LOGINS.contains(&name), "{name} is not a password login");
        self.execute(
            "postgres",
            &format!("CREATE ROLE {name} LOGIN PASSWORD '{password}'"),
        );
        format!("postgres://{name}:{password}@127.0.0.1:{}/{db}", self.port)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let data = self.dir.path().join("data").display().to_string();
        let _ = self.run("pg_ctl", &["-D", &data, "-m", "immediate", "-w", "stop"]);
    }
}
