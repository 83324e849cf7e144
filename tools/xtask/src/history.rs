//! `cargo xtask history`: a local PostgreSQL (Debian's `postgresql`) holding a shared unit
//! history, for the README's walk where a plant's history server would be: login `station`,
//! database `calflash`, on 127.0.0.1, its cluster kept between runs.

use std::io::BufRead as _;
use std::path::PathBuf;

use host_tests::postgres::Server;

use crate::setup;

const USAGE: &str = "usage: cargo xtask history [--port N] [--dir DIR]

  --port N   the server on 127.0.0.1:N (default 5433)
  --dir DIR  its cluster, kept between runs (default /tmp/calflash-history-N; delete it for
             an empty history)

Runs until Enter is pressed, its input closes, or Ctrl-C (SIGINT, SIGTERM, SIGHUP): each
stops the server. Installs Debian's postgresql when missing (as root).";

/// The login and its password the README's walk uses.
const LOGIN: (&str, &str) = ("station", "calflash");

pub fn run(args: &[String]) -> Result<(), String> {
    let mut port: u16 = 5433;
    let mut dir = None;
    for (name, v) in crate::options(args, USAGE)? {
        match name {
            "--port" => {
                port = v
                    .parse()
                    .map_err(|_| format!("--port: expected a TCP port number, found `{v}`"))?;
            }
            "--dir" => dir = Some(PathBuf::from(v)),
            other => return Err(format!("unknown option `{other}`\n\n{USAGE}")),
        }
    }
    let dir = dir.unwrap_or_else(|| std::env::temp_dir().join(format!("calflash-history-{port}")));
    setup::postgres()?;
    let server = Server::start_kept(&dir, port)?;
    let (login, password) = LOGIN;
    server.try_execute(
        "postgres",
        &format!(
            "DO $$ BEGIN IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = '{login}') THEN CREATE ROLE {login} LOGIN PASSWORD '{password}'; END IF; END $$"
        ),
    )?;
    // CREATE DATABASE runs outside a transaction, so not in the block above: made once.
    if server.try_execute("calflash", "SELECT 1").is_err() {
        server.try_execute(
            "postgres",
            &format!("CREATE DATABASE calflash OWNER {login}"),
        )?;
    }
    println!(
        "xtask: a shared unit history on 127.0.0.1:{port} (PostgreSQL; its cluster in {})",
        dir.display()
    );
    println!(
        "xtask: it runs until Enter is pressed, its input closes, or Ctrl-C; in another terminal:"
    );
    println!("  export CALFLASH_DB=postgres://{login}:{password}@127.0.0.1:{port}/calflash");
    // Enter, the input's end, or a signal (Ctrl-C, SIGTERM, SIGHUP) all stop the server: it
    // runs detached from this process, and a Ctrl-C that only ended this process left it
    // running on its port, so that the next start failed.
    let (tx, rx) = std::sync::mpsc::channel::<&'static str>();
    let signalled = tx.clone();
    ctrlc::set_handler(move || {
        let _ = signalled.send("a signal");
    })
    .map_err(|e| format!("cannot take Ctrl-C: {e}"))?;
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::stdin().lock().read_line(&mut line);
        let _ = tx.send("Enter or the input's end");
    });
    let why = rx.recv().unwrap_or("the input's end");
    drop(server);
    println!(
        "xtask: the history server stopped ({why}); its cluster is kept in {}",
        dir.display()
    );
    Ok(())
}
