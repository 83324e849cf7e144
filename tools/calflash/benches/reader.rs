//! Reading a recording: one 7-column text file (timestamp and six counts) of 10^6 lines,
//! whitespace-separated and as CSV, streamed by `obs::layout::read` (what `calflash selfcal`,
//! `allan` and `apply` read through); and an observation file, a CSV of 10^6 rows of a
//! response and five inputs with nine digits each (the design of `calflash fit`'s benchmark),
//! read by `obs::read_columns` (what `fit` and `calibrate` read through). Each against the
//! reference `polars.read_csv` on one thread (`POLARS_MAX_THREADS=1`) on the same file in the
//! same run, when Python has polars (a notice otherwise). calflash reads with every core (two
//! on the machine of `BENCHMARKS.md`). Run with `cargo bench -p calflash --bench reader`.

use std::hint::black_box;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use calflash::obs::layout::{self, Holds, Keep};
use calflash::obs::{Format, read_columns};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const LINES: usize = 1_000_000;

/// Writes the test file once: a 1 kHz still recording with noise of a few counts.
fn file(sep: &str) -> PathBuf {
    let name = if sep == "," {
        "reader-1e6.csv"
    } else {
        "reader-1e6.txt"
    };
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    if path.is_file() {
        return path;
    }
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut noise = |spread: i64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        i64::try_from(state % (2 * spread as u64 + 1)).unwrap() - spread
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    for i in 0..LINES {
        #[allow(clippy::cast_precision_loss)]
        let t = i as f64 * 1e-3;
        write!(out, "{t:.4}").unwrap();
        for centre in [32768, 32768, 36000, 32768, 32768, 32768] {
            write!(out, "{sep}{}", centre + noise(5)).unwrap();
        }
        writeln!(out).unwrap();
    }
    out.flush().unwrap();
    path
}

/// The observation file: a header `y,a,b,c,d,e`, then 10^6 rows of nine-digit decimals.
fn observations() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("observations-1e6.csv");
    if path.is_file() {
        return path;
    }
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        #[allow(clippy::cast_precision_loss)]
        let u = (state >> 11) as f64 / (1u64 << 53) as f64;
        u * 2.0 - 1.0
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    writeln!(out, "y,a,b,c,d,e").unwrap();
    for _ in 0..LINES {
        let v: [f64; 5] = std::array::from_fn(|_| uniform());
        let y = 2.5 + 0.4 * v[0] - 0.3 * v[1] + 0.05 * v[2] + 1e-3 * uniform();
        write!(out, "{y:.9}").unwrap();
        for x in v {
            write!(out, ",{x:.9}").unwrap();
        }
        writeln!(out).unwrap();
    }
    out.flush().unwrap();
    path
}

/// polars' single-thread rate on `path`, MB/s, or why it could not be measured.
fn polars(path: &Path, sep: &str, header: bool) -> Result<f64, String> {
    let script = format!(
        "import time, polars as pl\n\
         best = 1e9\n\
         for _ in range(5):\n    \
             t = time.perf_counter()\n    \
             pl.read_csv({path:?}, separator={sep:?}, has_header={header})\n    \
             best = min(best, time.perf_counter() - t)\n\
         print(best)",
        path = path.display().to_string(),
        header = if header { "True" } else { "False" },
    );
    let out = Command::new("python3")
        .args(["-c", &script])
        .env("POLARS_MAX_THREADS", "1")
        .output()
        .map_err(|e| format!("python3 cannot run ({e})"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr)
            .lines()
            .last()
            .unwrap_or("python3 failed")
            .to_string());
    }
    let secs: f64 = String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .map_err(|e| format!("unexpected output ({e})"))?;
    #[allow(clippy::cast_precision_loss)]
    Ok(std::fs::metadata(path).unwrap().len() as f64 / secs / 1e6)
}

/// calflash's best rate over five reads by `read`, MB/s, measured as polars' is.
fn ours(path: &Path, read: impl Fn(&Path)) -> f64 {
    let best = (0..5)
        .map(|_| {
            let t = Instant::now();
            read(path);
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    #[allow(clippy::cast_precision_loss)]
    let bytes = std::fs::metadata(path).unwrap().len() as f64;
    bytes / best / 1e6
}

fn compare(what: &str, path: &Path, sep: &str, header: bool, read: impl Fn(&Path)) {
    let bytes = std::fs::metadata(path).unwrap().len();
    let mine = ours(path, read);
    match polars(path, sep, header) {
        Ok(theirs) => println!(
            "reader, {what}: calflash {mine:.0} MB/s, polars.read_csv on one thread \
             {theirs:.0} MB/s (best of 5 each, {bytes} bytes): {:.2}x",
            mine / theirs
        ),
        Err(why) => println!(
            "reader, {what}: calflash {mine:.0} MB/s; the reference polars.read_csv could \
             not be measured here: {why}"
        ),
    }
}

fn reader(c: &mut Criterion) {
    let mut g = c.benchmark_group("reader");
    g.sample_size(10);
    for (sep, what) in [(" ", "whitespace"), (",", "csv")] {
        let path = file(sep);
        let bytes = std::fs::metadata(&path).unwrap().len();
        g.throughput(Throughput::Bytes(bytes));
        g.bench_function(
            format!("10^6 lines x 7 fields, {what}, both sensors"),
            |b| {
                b.iter(|| black_box(layout::read(&path, Holds::Both, Keep::Both).unwrap()));
            },
        );
        g.bench_function(format!("10^6 lines x 7 fields, {what}, gyro only"), |b| {
            b.iter(|| black_box(layout::read(&path, Holds::Both, Keep::Gyro).unwrap()));
        });
        compare(what, &path, sep, false, |p| {
            black_box(layout::read(p, Holds::Both, Keep::Both).unwrap());
        });
    }
    let path = observations();
    let names: Vec<String> = ["y", "a", "b", "c", "d", "e"].map(String::from).to_vec();
    let read = |p: &Path| {
        black_box(read_columns(p, &names, Format::Auto).unwrap());
    };
    g.throughput(Throughput::Bytes(std::fs::metadata(&path).unwrap().len()));
    g.bench_function("observations, 10^6 rows x 6 columns, csv", |b| {
        b.iter(|| read(&path));
    });
    compare("observations, csv", &path, ",", true, read);
    g.finish();
}

criterion_group!(benches, reader);
criterion_main!(benches);
