//! Shared by the command-line tests.

use std::path::Path;
use std::process::Command;

/// Runs `calflash` with `args` in `dir`; returns its exit code, stdout and stderr.
#[allow(dead_code)] // the red-team tests run it under their watchdog instead
pub fn calflash(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_calflash"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("calflash runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Writes a recording as two loggers' files, `acc.txt` and `gyro.txt` in `dir` (`t x y z` per
/// line); their paths.
#[allow(dead_code)] // used by the selfcal and report tests only
pub fn write_recording(
    rec: &calflash::obs::recording::Recording,
    dir: &Path,
) -> (std::path::PathBuf, std::path::PathBuf) {
    let (a, g) = (dir.join("acc.txt"), dir.join("gyro.txt"));
    let text = |x: &[[f64; 3]]| {
        rec.t
            .iter()
            .zip(x)
            .map(|(t, v)| format!("{t:.6} {} {} {}\n", v[0], v[1], v[2]))
            .collect::<String>()
    };
    std::fs::write(&a, text(&rec.acc)).unwrap();
    std::fs::write(&g, text(&rec.gyro)).unwrap();
    (a, g)
}

/// A simulated truth's temperature polynomials in the terms of a continuous model's fit.
#[allow(dead_code)] // used by the thermal tests only
pub mod truth_in_legendre {
    use calflash::sensor::thermal::Scale;

    /// Monomial coefficients in `x` (up to `x^3`) as Legendre coefficients:
    /// `x^2 = (2 P2 + P0) / 3`, `x^3 = (2 P3 + 3 P1) / 5`.
    pub fn legendre_of(m: &[f64]) -> Vec<f64> {
        let c = |k: usize| m.get(k).copied().unwrap_or(0.0);
        let mut out = vec![
            c(0) + c(2) / 3.0,
            c(1) + 0.6 * c(3),
            2.0 * c(2) / 3.0,
            0.4 * c(3),
        ];
        out.truncate(m.len());
        out
    }

    /// The truth's polynomial `sum p_m dt^m` (dt = T - 25) written in `x = (T - t0) / half`.
    pub fn in_x(p: &[f64], scale: &Scale) -> Vec<f64> {
        // dt = a + h x
        let (a, h) = (scale.center() - 25.0, scale.half());
        let mut out = vec![0.0; p.len()];
        let binomial =
            |n: usize, k: usize| (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64);
        for (m, pm) in p.iter().enumerate() {
            for (k, o) in out.iter_mut().enumerate().take(m + 1) {
                *o += pm * binomial(m, k) * a.powi((m - k) as i32) * h.powi(k as i32);
            }
        }
        out
    }
}

/// Stated errors against simulated truths, pooled over seeds.
#[allow(dead_code)] // used by the thermal tests only
pub mod stated {
    /// `(fits, covered)`: of the `(name, covered)` records, those of `name`.
    pub fn covered<'a>(
        records: impl Iterator<Item = &'a (String, bool)>,
        name: &str,
    ) -> (usize, usize) {
        records
            .filter(|(t, _)| t == name)
            .fold((0, 0), |(n, h), (_, ok)| (n + 1, h + usize::from(*ok)))
    }

    /// Errors in their own stated 1-sigma (`z`) are normal: within 1 for 0.683 +- 0.06 of them
    /// and within 1.96 for 0.95 +- 0.035; printed under `what`.
    pub fn assert_normal(what: &str, z: &[f64]) {
        let within = |k: f64| z.iter().filter(|v| v.abs() <= k).count() as f64 / z.len() as f64;
        println!(
            "{what}: {:.3} within 1 sigma, {:.3} within 1.96 sigma ({} outputs)",
            within(1.0),
            within(1.96),
            z.len()
        );
        assert!(
            (within(1.96) - 0.95).abs() <= 0.035,
            "{what}: {}",
            within(1.96)
        );
        assert!(
            (within(1.0) - 0.683).abs() <= 0.06,
            "{what}: {}",
            within(1.0)
        );
    }
}

/// Writes an Allan file as `calflash allan --json` does, three axes of white noise `n` and rate
/// random walk `k` in `unit`, to `dir/name`.
#[allow(dead_code)] // used by the health and red-team tests only
pub fn allan(dir: &Path, name: &str, unit: &str, n: f64, k: f64) {
    let axis = serde_json::json!({"axis": "x", "curve": [], "terms": {
        "quantization": 0.0, "random_walk": n, "bias_instability": 0.0,
        "rate_random_walk": k, "rate_ramp": 0.0}});
    let v = serde_json::json!({"schema": "calflash.allan/1", "source": "still.csv",
        "unit": unit, "axes": [axis.clone(), axis.clone(), axis]});
    std::fs::write(dir.join(name), v.to_string()).unwrap();
}

/// The spinning round's spin rig simulated into `dir/rig.csv`: the unit `truth` (a truth file)
/// tumbled, turned about its axes and its 45-degree diagonals to 1,900 rad/s and centrifuged
/// to 1,500 g, with `extra` options (a seed).
#[allow(dead_code)] // the flight, spin, NEES and report tests use it
pub fn simulate_rig(dir: &Path, truth: &str, extra: &[&str]) {
    let mut args = vec![
        "simulate",
        "--sensor",
        "imu",
        "--truth",
        truth,
        "--plan",
        "tumble:24",
        "--plan",
        "rate:-1900:1900:9",
        "--plan",
        "diagonal:-1900:1900:9",
        "--plan",
        "centrifuge:1:1500:6",
        "-o",
        "rig.csv",
    ];
    args.extend_from_slice(extra);
    let (code, out, err) = calflash(dir, &args);
    assert_eq!(code, 0, "{args:?}: {out}{err}");
}

/// A flight of the unit `truth` simulated into `dir`: `simulate --flight SPEC` at `rate` Hz, the
/// IMU's codes to `out` and a GNSS receiver's fixes to `g.csv`, with `extra` options (a
/// barometer, a launch shift, a seed, ...).
#[allow(dead_code)] // the flight, NEES and report tests use it
pub fn simulate_flight(
    dir: &Path,
    truth: &str,
    (spec, rate): (&str, &str),
    out: &str,
    extra: &[&str],
) {
    let mut args = vec![
        "simulate",
        "--sensor",
        "imu",
        "--truth",
        truth,
        "--flight",
        spec,
        "--sample-rate",
        rate,
        "-o",
        out,
        "--gnss",
        "g.csv",
    ];
    args.extend_from_slice(extra);
    let (code, stdout, err) = calflash(dir, &args);
    assert_eq!(code, 0, "{args:?}: {stdout}{err}");
}

/// A calibration record's axes at its first table point: each axis' term names and their
/// coefficients, in the record's order.
#[allow(dead_code)] // used by the mission tests only
pub fn record_axes(record: &serde_json::Value) -> Vec<(Vec<String>, Vec<f64>)> {
    record["points"][0]["axes"]
        .as_array()
        .expect("a record's axes")
        .iter()
        .map(|axis| {
            let names = axis["terms"]
                .as_array()
                .expect("an axis' terms")
                .iter()
                .map(|n| n.as_str().expect("a term's name").to_string())
                .collect();
            let b = axis["coefficients"]
                .as_array()
                .expect("an axis' coefficients")
                .iter()
                .map(|v| v.as_f64().expect("a coefficient"))
                .collect();
            (names, b)
        })
        .collect()
}
