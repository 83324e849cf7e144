//! The independent simulator's shells (`../shared/data/reference-flights/shell155`, `shell105`:
//! McCoy's 6-DOF on a rotating WGS-84 Earth, its own sensor and receiver models) as the round's
//! filter receives them: the IMU's codes corrected by the unit's pre-launch truth exactly
//! (its sensor model as the data's README states it, inverted here), so that only the launch
//! shift, the bias random walk and the noise are left to find; the fixes delivered their
//! latency after their instant; the truth of the navigation in the filter's level frame.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use serde_json::Value;
use spincal::flight::{FlightConfig, Geodetic, GnssFix, Origin};
use spincal::nav::{NavNoise, Real, SensorErrors};

use crate::flight_golden::Input;
use crate::flight_round::RoundFlight;

fn v3(x: &Value) -> Vector3<f64> {
    Vector3::from_fn(|i, _| x[i].as_f64().expect("a number"))
}

fn m3(x: &Value) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| x[i][j].as_f64().expect("a number"))
}

fn rows(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|x| x.trim().parse().expect("a number"))
                .collect()
        })
        .collect()
}

/// One sensor family's terms before launch.
struct Terms {
    bias: Vector3<f64>,
    scale: Vector3<f64>,
    misalignment: Matrix3<f64>,
    bias_tempco: Vector3<f64>,
    sf_tempco: Vector3<f64>,
    t_ref: f64,
}

impl Terms {
    fn of(x: &Value) -> Self {
        Self {
            bias: v3(&x["bias"]),
            scale: v3(&x["scale_factor"]),
            misalignment: m3(&x["misalignment"]),
            bias_tempco: v3(&x["bias_tempco"]),
            sf_tempco: v3(&x["sf_tempco"]),
            t_ref: x["t_ref_c"].as_f64().expect("t_ref_c"),
        }
    }

    /// `(y - b - bT dT) / (1 + s + sT dT)` per axis.
    fn unscaled(&self, y: &Vector3<f64>, temp: f64) -> Vector3<f64> {
        let dt = temp - self.t_ref;
        Vector3::from_fn(|i, _| {
            (y[i] - self.bias[i] - self.bias_tempco[i] * dt)
                / (1.0 + self.scale[i] + self.sf_tempco[i] * dt)
        })
    }
}

/// A reference shell, corrected, with its truth; `None` (with a printed notice) when the
/// shared data is not beside the checkout.
///
/// # Panics
/// If the files are there but do not read as the data's README describes.
#[must_use]
pub fn shell(name: &str) -> Option<RoundFlight> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/reference-flights")
        .join(name);
    if !dir.is_dir() {
        println!(
            "skipped: {} is not here (the shared data sits beside the checkout, not in it)",
            dir.display()
        );
        return None;
    }
    let unit: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("unit_truth.json")).expect("unit_truth.json"),
    )
    .expect("unit_truth.json is JSON");
    let scenario: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("scenario.json")).expect("scenario.json"),
    )
    .expect("scenario.json is JSON");
    let before = &unit["before_launch"];
    let (accel, gyro) = (Terms::of(&before["accel"]), Terms::of(&before["gyro"]));
    let k2 = v3(&before["accel"]["k2"]);
    let arms = m3(&before["accel"]["lever_arms_m"]);
    let g_sens = m3(&before["gyro"]["g_sensitivity"]);
    let lsb_a = v3(&unit["imu_file"]["accel_lsb_m_s2_per_code"]);
    let lsb_g = v3(&unit["imu_file"]["gyro_lsb_rad_s_per_code"]);
    let bits = before["accel"]["bits"].as_f64().expect("bits");
    let rail = 2f64.powf(bits - 1.0);
    // Sensing directions: rows e_i + MA[i, :].
    let u_a = Matrix3::identity() + accel.misalignment;
    let u_a_inv = u_a.try_inverse().expect("directions");
    let m_g_inv = (Matrix3::identity() + gyro.misalignment)
        .try_inverse()
        .expect("directions");
    let imu = rows(&dir.join("imu.csv"));
    let t0 = imu[0][0];
    let us = |t: f64| ((t - t0) * 1e6).round() as u64;
    let mut timed: Vec<(u64, u8, Input)> = Vec::with_capacity(imu.len() + 1000);
    // The angular acceleration from one sample to the next (its noise puts about 0.4 m/s^2 on
    // the transverse accelerometers through their arms; rates 4 ms apart lag the yaw and did
    // worse: 0.8 m/s^2 against the truth).
    let mut previous: Option<(f64, Vector3<f64>)> = None;
    for r in &imu {
        let t = r[0];
        let ya = Vector3::new(r[1], r[2], r[3]).component_mul(&lsb_a);
        let yg = Vector3::new(r[4], r[5], r[6]).component_mul(&lsb_g);
        let temp = r[7];
        let clipped = |c: f64| c <= -rail || c >= rail - 1.0;
        let doubted = [
            clipped(r[1]) || clipped(r[2]) || clipped(r[3]),
            clipped(r[4]) || clipped(r[5]) || clipped(r[6]),
        ];
        // Each axis' reading, its K2 taken out: the root of `k a^2 + a - x = 0` near `x`,
        // `k = K2 / scale`, in the form that does not cancel. (A few passes of
        // `a = x - k a^2` do not converge at a 10,000 g setback, where `2 k a` is 0.6: they
        // left the 105 mm shell's muzzle velocity 10.5 m/s short, 2 %, which its first fix
        // then put into the heading.)
        let x = accel.unscaled(&ya, temp);
        let a = Vector3::from_fn(|i, _| {
            let scale = 1.0 + accel.scale[i] + accel.sf_tempco[i] * (temp - accel.t_ref);
            let k = k2[i] / scale;
            2.0 * x[i] / (1.0 + (1.0 + 4.0 * k * x[i]).max(0.0).sqrt())
        });
        // The rate from the gyros (their g-sensitivity from the force, two passes), then the
        // force at the reference point: a_i = u_i . (f + dw x r_i + w x (w x r_i)).
        let gyro_unscaled = gyro.unscaled(&yg, temp);
        let mut f = u_a_inv * a;
        let mut w = m_g_inv * gyro_unscaled;
        let (t_then, w_then) = previous.unwrap_or((t, Vector3::zeros()));
        let dt = t - t_then;
        for _ in 0..2 {
            w = m_g_inv * (gyro_unscaled - gyro_scale_div(&gyro, temp, &(g_sens * f)));
            let dw = if dt > 0.0 {
                (w - w_then) / dt
            } else {
                Vector3::zeros()
            };
            let felt = Vector3::from_fn(|i, _| {
                let r_i = Vector3::from(arms.row(i).transpose());
                u_a.row(i)
                    .transpose()
                    .dot(&(dw.cross(&r_i) + w.cross(&w.cross(&r_i))))
            });
            f = u_a_inv * (a - felt);
        }
        previous = Some((t, w));
        let t_us = us(t);
        timed.push((
            t_us,
            0,
            Input::Sample(
                t_us,
                [f.x as f32, f.y as f32, f.z as f32],
                [w.x as f32, w.y as f32, w.z as f32],
                doubted,
            ),
        ));
    }
    let gnss = &scenario["gnss"];
    // AT_INSTANT=1: the fixes as a receiver without latency would give them (the measurement's
    // comparison: what the latency alone costs).
    let latency_us = if std::env::var("AT_INSTANT").is_ok() {
        0
    } else {
        (gnss["latency_s"].as_f64().expect("latency_s") * 1e6).round() as u64
    };
    for r in rows(&dir.join("gnss.csv")) {
        let t_us = us(r[0]);
        timed.push((
            t_us + latency_us,
            2,
            Input::Fix(GnssFix {
                t_us,
                position: Geodetic {
                    latitude: r[1],
                    longitude: r[2],
                    height: r[3],
                },
                velocity: Some([r[4] as f32, r[5] as f32, r[6] as f32]),
                satellites: 12,
            }),
        ));
    }
    for r in rows(&dir.join("baro.csv")) {
        let t_us = us(r[0]);
        timed.push((t_us, 1, Input::Pressure(t_us, r[1] as f32)));
    }
    timed.sort_by_key(|e| (e.0, e.1));
    let truth_rows = rows(&dir.join("truth_trajectory.csv"));
    let first = &truth_rows[0];
    let origin = Geodetic {
        latitude: first[1],
        longitude: first[2],
        height: first[3],
    };
    let o = Origin::new(origin);
    let truth = truth_rows
        .iter()
        .map(|r| {
            let at = Geodetic {
                latitude: r[1],
                longitude: r[2],
                height: r[3],
            };
            let p = o.local(&at);
            // North, east, down at the point, to east, north, up, then the origin's frame.
            let v = o.level_velocity(&at, &[r[5] as f32, r[4] as f32, -r[6] as f32]);
            (us(r[0]), Vector3::from(p), Vector3::from(v))
        })
        .collect();
    let (sigma, tau) = (
        gnss["gauss_markov_sigma_m"]
            .as_f64()
            .expect("gauss_markov_sigma_m"),
        gnss["gauss_markov_tau_s"]
            .as_f64()
            .expect("gauss_markov_tau_s"),
    );
    let shift = &unit["launch_shift"];
    let shift_us = shift["t_s"].as_f64().map_or(0, us);
    // The launch's changes the filter is to find (the pre-launch values were taken out).
    let change = |term: &str| -> f64 {
        shift["changes"]
            .as_array()
            .and_then(|c| c.iter().find(|x| x["term"] == term))
            .and_then(|x| x["change"].as_f64())
            .unwrap_or(0.0)
    };
    let azimuth = scenario["azimuth_deg"].as_f64().expect("azimuth_deg");
    Some(RoundFlight {
        inputs: timed.into_iter().map(|e| e.2).collect(),
        truth,
        attitude: Vec::new(),
        heading: azimuth.to_radians(),
        origin,
        antenna: v3(&unit["geometry"]["gnss_antenna_from_imu_body_m"]),
        shift_us,
        axial_residual: (0.0, 0.0),
        scenario: crate::flight_round::Scenario {
            spec: "reference",
            seed: 0,
            shift: (change("accel bias x"), change("accel scale_factor x")),
            roll_scale_shift: change("gyro scale_factor x"),
            shift_after_muzzle: 0.0,
            latency_us,
            correlated: (sigma, tau),
            acquisition: 0.0,
            walk: 1e-4,
            noise_scale: (1.0, 1.0),
            residual: false,
        },
    })
}

fn gyro_scale_div(gyro: &Terms, temp: f64, x: &Vector3<f64>) -> Vector3<f64> {
    let dt = temp - gyro.t_ref;
    Vector3::from_fn(|i, _| x[i] / (1.0 + gyro.scale[i] + gyro.sf_tempco[i] * dt))
}

/// The filter's set-up for a reference shell: its receiver as its scenario states, the heading
/// from the line of fire's azimuth (`flight.heading`) levelled on the first rest, the pre-launch
/// errors' prior small (they were taken out), a launch shift that covers a gun's.
#[must_use]
pub fn config<T: Real>(flight: &RoundFlight) -> FlightConfig<T> {
    let c = |x: f64| -> T { nalgebra::convert(x) };
    let rest: Vec<Vector3<f64>> = flight
        .inputs
        .iter()
        .filter_map(|i| match i {
            Input::Sample(t, f, ..) if *t < 200_000 => {
                Some(Vector3::from_fn(|k, _| f64::from(f[k])))
            }
            _ => None,
        })
        .collect();
    let mean = rest.iter().sum::<Vector3<f64>>() / rest.len().max(1) as f64;
    let heading = FlightConfig::<f64>::heading_of_azimuth(&mean, &Vector3::x(), flight.heading)
        .unwrap_or(0.0);
    let noise = NavNoise {
        accel_white: c(3e-3),
        gyro_white: c(1e-3),
        accel_walk: c(1e-4),
        gyro_walk: c(2e-5),
        scale_walk: c(1e-7),
        baro_walk: c(0.1),
        receiver_sigma: Vector3::zeros(),
        receiver_tau: c(0.0),
    };
    let prior = SensorErrors {
        accel_bias: Vector3::repeat(c(0.01)),
        gyro_bias: Vector3::repeat(c(1e-4)),
        accel_scale: Vector3::repeat(c(1e-4)),
        gyro_scale: Vector3::repeat(c(1e-5)),
        baro_bias: c(10.0),
    };
    let mut config = FlightConfig::new((c(heading), c(1f64.to_radians())), noise, prior);
    crate::flight_round::receiver(&mut config, flight);
    config.launch_shift = SensorErrors {
        accel_bias: Vector3::repeat(c(0.1)),
        gyro_bias: Vector3::repeat(c(1e-3)),
        accel_scale: Vector3::repeat(c(2e-3)),
        gyro_scale: Vector3::repeat(c(3e-4)),
        baro_bias: c(10.0),
    };
    config
}
