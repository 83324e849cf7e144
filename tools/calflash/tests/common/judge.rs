//! An independent judge of a 6-axis calibration on a real tumble recording, written apart from
//! calflash's own pose finder and gyro integration, after `../shared/tools/realbench`'s
//! `eval_imu.py` and `heldout.py` (it reproduces their figures: see `held_out.rs`).
//!
//! Model per triad, in the recording's own values: `x_si = M (x_file - b)`. Still intervals by
//! imu_tk's detector (the norm of each accelerometer axis' variance over a centred 101-sample
//! window, below `mult` times the same norm over the first `init` seconds, at least 100 samples).
//! The accelerometer: `|a| - g` of each interval's calibrated mean. The gyro: the calibrated rate
//! (constant bias) integrated between consecutive intervals (quaternion RK4, the rate linear
//! between samples) carries the first interval's gravity direction into the second's frame; the
//! error is the angle to the direction measured there.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// A recording: time (s), the accelerometer's and the gyro's values as the file has them.
pub struct Rec {
    pub t: Vec<f64>,
    pub acc: Vec<[f64; 3]>,
    pub gyro: Vec<[f64; 3]>,
}

/// One triad's calibration.
#[derive(Clone, Copy, Debug)]
pub struct Triad {
    pub m: Matrix3<f64>,
    pub b: Vector3<f64>,
}

impl Triad {
    fn apply(&self, x: [f64; 3]) -> Vector3<f64> {
        self.m * (Vector3::from(x) - self.b)
    }

    /// From the judge's JSON form `{"M": [[..]..], "b": [..]}`.
    pub fn from_json(v: &serde_json::Value) -> Self {
        let f = |x: &serde_json::Value| x.as_f64().unwrap();
        Self {
            m: Matrix3::from_fn(|i, j| f(&v["M"][i][j])),
            b: Vector3::from_fn(|i, _| f(&v["b"][i])),
        }
    }
}

/// A calibration of both triads.
#[derive(Clone, Copy, Debug)]
pub struct Cal {
    pub acc: Triad,
    pub gyro: Triad,
}

impl Cal {
    /// A `calflash selfcal --json` record as the judge's model (`cf_to_eval.py`): `k` is
    /// calflash's working unit per unit of the file's values for each triad (1 for counts or
    /// SI, pi/180 for deg/s). Quadratic terms are dropped.
    pub fn from_selfcal(r: &serde_json::Value, k: [f64; 2]) -> Self {
        let f = |x: &serde_json::Value| x.as_f64().unwrap();
        let a = &r["accel"];
        let m = Matrix3::from_fn(|i, j| f(&a["matrix_m_s2_per_count"][i][j])) * k[0];
        let o = Vector3::from_fn(|i, _| f(&a["offset_m_s2"][i]));
        let c = Vector3::from_fn(|i, _| f(&a["center_counts"][i])) / k[0];
        let b = c - m.try_inverse().unwrap() * o;
        let g = &r["gyro"];
        Self {
            acc: Triad { m, b },
            gyro: Triad {
                m: Matrix3::from_fn(|i, j| f(&g["matrix_rad_s_per_count"][i][j])) * k[1],
                b: Vector3::from_fn(|i, _| f(&g["bias_counts"][i])) / k[1],
            },
        }
    }

    /// From the judge's JSON `{"acc": .., "gyro": ..}`.
    pub fn from_json(v: &serde_json::Value) -> Self {
        Self {
            acc: Triad::from_json(&v["acc"]),
            gyro: Triad::from_json(&v["gyro"]),
        }
    }
}

/// imu_tk's still intervals (inclusive sample ranges).
pub fn still_intervals(rec: &Rec, init: f64, mult: f64) -> Vec<(usize, usize)> {
    const WIN: usize = 101;
    const MIN_LEN: usize = 100;
    let var = |s: &[[f64; 3]]| -> f64 {
        let n = s.len() as f64;
        (0..3)
            .map(|j| {
                let m = s.iter().map(|a| a[j]).sum::<f64>() / n;
                let v = s.iter().map(|a| (a[j] - m).powi(2)).sum::<f64>() / (n - 1.0);
                v * v
            })
            .sum::<f64>()
            .sqrt()
    };
    let end = rec.t.partition_point(|&t| t < rec.t[0] + init);
    let thr = var(&rec.acc[..=end]) * mult;
    let h = WIN / 2;
    let n = rec.acc.len();
    let mut out = Vec::new();
    let mut start = None;
    for k in 0..=n - WIN {
        let i = k + h;
        let vn = var(&rec.acc[k..k + WIN]);
        match start {
            None if vn < thr => start = Some(i),
            Some(s) if vn >= thr => {
                out.push((s, i - 1));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, n - h - 1));
    }
    out.retain(|(s, e)| e - s + 1 >= MIN_LEN);
    out
}

fn mean(x: &[[f64; 3]], (s, e): (usize, usize)) -> [f64; 3] {
    let n = (e - s + 1) as f64;
    std::array::from_fn(|j| x[s..=e].iter().map(|a| a[j]).sum::<f64>() / n)
}

/// The rotation from the start of `s..=e` to its end (RK4 on the quaternion).
fn integrate(rec: &Rec, gyro: &Triad, s: usize, e: usize) -> UnitQuaternion<f64> {
    let qdot = |q: Quaternion<f64>, w: Vector3<f64>| q * Quaternion::from_parts(0.0, w) * 0.5;
    let mut q = Quaternion::identity();
    for i in s..e {
        let dt = rec.t[i + 1] - rec.t[i];
        let (w0, w1) = (gyro.apply(rec.gyro[i]), gyro.apply(rec.gyro[i + 1]));
        let wm = (w0 + w1) * 0.5;
        let k1 = qdot(q, w0);
        let k2 = qdot(q + k1 * (0.5 * dt), wm);
        let k3 = qdot(q + k2 * (0.5 * dt), wm);
        let k4 = qdot(q + k3 * dt, w1);
        q += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
        q = q.normalize();
    }
    UnitQuaternion::new_normalize(q)
}

/// RMS figures over the intervals `ivs`: `|a| - g` (mm/s^2) and the gravity-direction error of
/// the rotations between consecutive intervals (deg).
pub fn judge(rec: &Rec, cal: &Cal, ivs: &[(usize, usize)], g: f64) -> (f64, f64) {
    let dirs: Vec<Vector3<f64>> = ivs
        .iter()
        .map(|&r| cal.acc.apply(mean(&rec.acc, r)))
        .collect();
    let acc = dirs.iter().map(|a| (a.norm() - g).powi(2)).sum::<f64>() / dirs.len() as f64;
    let angles: Vec<f64> = ivs
        .windows(2)
        .zip(dirs.windows(2))
        .map(|(iv, d)| {
            let r = integrate(rec, &cal.gyro, iv[0].1, iv[1].0).to_rotation_matrix();
            let pred = r.transpose() * d[0].normalize();
            pred.dot(&d[1].normalize())
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .collect();
    let gyro = angles.iter().map(|a| a * a).sum::<f64>() / angles.len() as f64;
    (acc.sqrt() * 1e3, gyro.sqrt())
}

/// The held-out split: the first `round(2 N / 3)` of the `N` intervals are the fit part, cut at
/// the middle of the motion after the last of them. Returns that count and the cut time.
pub fn split(rec: &Rec, ivs: &[(usize, usize)]) -> (usize, f64) {
    let k = (ivs.len() as f64 * 2.0 / 3.0).round() as usize;
    assert!(k >= 1 && k < ivs.len() - 1, "{} intervals", ivs.len());
    (k, 0.5 * (rec.t[ivs[k - 1].1] + rec.t[ivs[k].0]))
}

/// Writes the rows of `rec` up to `t_cut` as the judge's `acc.txt` and `gyro.txt` (`t x y z`).
pub fn write_part(rec: &Rec, t_cut: f64, dir: &std::path::Path) {
    let mut acc = String::new();
    let mut gyro = String::new();
    for i in (0..rec.t.len()).take_while(|&i| rec.t[i] <= t_cut) {
        let row = |x: [f64; 3]| format!("{:.6} {} {} {}\n", rec.t[i], x[0], x[1], x[2]);
        acc.push_str(&row(rec.acc[i]));
        gyro.push_str(&row(rec.gyro[i]));
    }
    std::fs::write(dir.join("acc.txt"), acc).unwrap();
    std::fs::write(dir.join("gyro.txt"), gyro).unwrap();
}
