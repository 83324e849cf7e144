//! `calflash lot` on a lot of 10^5 units (issue 18: under 2 s from SQLite, under 5 s from
//! PostgreSQL): reading every unit's newest fit, the robust scatter and every unit's distance,
//! an individuals and an EWMA chart, and the HTML report with their plots. The SQLite history
//! is written once into the target directory; the PostgreSQL one is a copy of it (`calflash db
//! migrate`'s copy, timed once and printed) on a server the bench starts as the tests do
//! (`host-tests/src/postgres.rs`), skipped with a notice where PostgreSQL is not installed. Run
//! with `cargo bench -p calflash --bench lot`.

#[path = "../tests/common/lot_history.rs"]
mod lot_history;
#[path = "../../../host-tests/src/postgres.rs"]
mod pg_server;

use std::hint::black_box;
use std::path::PathBuf;

use calflash::db::{Db, Location, Selection};
use calflash::stats::chart::Kind;
use criterion::{Criterion, criterion_group, criterion_main};

const UNITS: usize = 100_000;

fn history() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("lot-1e5.sqlite");
    if !path.is_file() {
        let partial = path.with_extension("partial");
        let _ = std::fs::remove_file(&partial);
        lot_history::write(&partial, "LOT-", UNITS, 1_795_478_400, 1, |i, b, _| {
            if i % 1000 == 7 {
                b[0] += 400.0;
            }
        });
        std::fs::rename(&partial, &path).unwrap();
    }
    path
}

/// `calflash lot LOT- --chart ax:1 --chart ax:input --report`, without the terminal's lines.
fn lot(location: &Location) -> usize {
    let sel = Selection {
        prefix: "LOT-",
        ..Selection::all()
    };
    let lot = calflash::lot::history::load(location, &sel, 0.001).unwrap();
    assert_eq!(lot.units.len(), UNITS);
    let charts = vec![
        (
            "ax:1".to_string(),
            lot.chart("ax:1", Kind::Individuals, None).unwrap(),
        ),
        (
            "ax:input".to_string(),
            lot.chart("ax:input", Kind::Ewma, None).unwrap(),
        ),
    ];
    let html = calflash::report::lot::render(&lot, &sel.to_string(), &charts).unwrap();
    black_box(lot.outliers.len() + html.len())
}

fn bench(c: &mut Criterion) {
    let file = Location::File(history());
    let mut g = c.benchmark_group("lot");
    g.sample_size(10);
    g.bench_function("lot_1e5_units_sqlite", |b| b.iter(|| lot(&file)));
    match pg_server::Server::start("lot_1e5_units_postgres") {
        Ok(Some(server)) => {
            server.execute("postgres", "CREATE DATABASE lot");
            let url = Location::Server(server.url("lot"));
            let start = std::time::Instant::now();
            let (records, copied) = Db::open(&url)
                .unwrap()
                .copy_from(&mut Db::open_existing(&file).unwrap(), "BENCH")
                .unwrap();
            assert_eq!((records, copied), (UNITS, UNITS));
            println!(
                "copied {copied} records from SQLite into PostgreSQL (calflash db migrate) in {:.2?}",
                start.elapsed()
            );
            g.bench_function("lot_1e5_units_postgres", |b| b.iter(|| lot(&url)));
        }
        Ok(None) => {}
        Err(e) => panic!("{e}"),
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
