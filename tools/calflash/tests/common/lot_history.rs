//! A synthetic unit history for the lot tests and benchmark: fit records of many units written
//! straight into the database (as `calflash calibrate` records them: one point, three axes,
//! terms `1` and `input`), their coefficients drawn from a correlated normal lot.

use std::path::Path;

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// The coefficients JSON of a unit with biases `b` and scale factors `k`.
#[must_use]
pub fn coefficients(b: [f64; 3], k: [f64; 3]) -> String {
    let axes: Vec<serde_json::Value> = ["ax", "ay", "az"]
        .iter()
        .enumerate()
        .map(|(i, o)| {
            serde_json::json!({"output": o, "terms": ["1", "input"], "coefficients": [b[i], k[i]], "std_errors": [1.0, 0.001]})
        })
        .collect();
    serde_json::json!([{"temp": 25.0, "volt": 3.3, "axes": axes}]).to_string()
}

/// A lot's unit: biases about 32768 counts with spread 40, scale factors about 1670 counts per
/// g with spread 2, each axis' scale 0.9-correlated with its bias (a process that moves both).
#[must_use]
pub fn draw(rng: &mut rand::rngs::StdRng) -> ([f64; 3], [f64; 3]) {
    let mut g = || -> f64 { StandardNormal.sample(&mut *rng) };
    let mut b = [0.0; 3];
    let mut k = [0.0; 3];
    for i in 0..3 {
        let (u, v) = (g(), g());
        b[i] = 32_768.0 + 40.0 * u;
        k[i] = 1_670.0 + 2.0 * (0.9 * u + 0.436 * v);
    }
    (b, k)
}

/// Writes `n` units `{prefix}{i:06}` into the history at `path`, one fit each, a second apart
/// from `t0`; `odd(i)` may replace a unit's coefficients. Returns the serials.
///
/// # Panics
/// A database that cannot be written.
pub fn write(
    path: &Path,
    prefix: &str,
    n: usize,
    t0: i64,
    seed: u64,
    mut odd: impl FnMut(usize, &mut [f64; 3], &mut [f64; 3]),
) -> Vec<String> {
    drop(calflash::db::Db::open(path).expect("a new history"));
    let mut conn = rusqlite::Connection::open(path).expect("the history opens");
    let tx = conn.transaction().expect("a transaction");
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut serials = Vec::with_capacity(n);
    {
        let mut st = tx
            .prepare(
                "INSERT INTO records (serial, kind, time, data_hash, model, coefficients, blob, outcome)
                 VALUES (?1, 'fit', ?2, 'synthetic', 'ax ~ 1 + input', ?3, x'', 'accept')",
            )
            .expect("insert");
        for i in 0..n {
            let (mut b, mut k) = draw(&mut rng);
            odd(i, &mut b, &mut k);
            let serial = format!("{prefix}{i:06}");
            st.execute(rusqlite::params![serial, t0 + i as i64, coefficients(b, k)])
                .expect("a row");
            serials.push(serial);
        }
    }
    tx.commit().expect("commit");
    serials
}
