//! The shared history's test server (`common/postgres.rs`, issue 18): a real PostgreSQL
//! server, made and started by the test as an unprivileged user, takes two writers at once and
//! loses nothing. Skips with a notice where PostgreSQL is not installed (`cargo xtask test`
//! installs it as root, and then requires it).

#[path = "common/postgres.rs"]
mod pg_server;

use pg_server::Server;

#[test]
fn a_real_server_takes_two_writers_at_once() {
    let Some(server) =
        Server::start("a_real_server_takes_two_writers_at_once").unwrap_or_else(|e| panic!("{e}"))
    else {
        return;
    };
    let mut admin = postgres::Client::connect(&server.url("postgres"), postgres::NoTls)
        .unwrap_or_else(|e| panic!("{}: {e}", server.url("postgres")));
    admin.batch_execute("CREATE DATABASE history").unwrap();
    let url = server.url("history");
    let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    c.batch_execute("CREATE TABLE records (id BIGSERIAL PRIMARY KEY, serial TEXT NOT NULL, blob BYTEA NOT NULL)")
        .unwrap();
    let writers: Vec<_> = ["S1", "S2"]
        .into_iter()
        .map(|station| {
            let url = url.clone();
            std::thread::spawn(move || {
                let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
                for i in 0..500 {
                    let mut tx = c.transaction().unwrap();
                    tx.execute(
                        "INSERT INTO records (serial, blob) VALUES ($1, $2)",
                        &[&format!("{station}-{i:04}"), &vec![7u8; 64]],
                    )
                    .unwrap();
                    tx.commit().unwrap();
                }
            })
        })
        .collect();
    for w in writers {
        w.join().unwrap();
    }
    let n: i64 = c
        .query_one(
            "SELECT count(DISTINCT serial) FROM records WHERE length(blob) = 64",
            &[],
        )
        .unwrap()
        .get(0);
    assert_eq!(n, 1_000);
}
