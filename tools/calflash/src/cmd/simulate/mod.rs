//! `calflash simulate`: a virtual sensor through a test plan, to an observation file.

use crate::cmd::Failure;
use std::path::PathBuf;

mod args;
mod flight;
mod stages;

pub use args::SimulateArgs;

use crate::files::{Paths, Staged};

use super::values::SensorKind;
use crate::sim::{self, Sensor, plan, ramp, truth};

fn load<T: serde::de::DeserializeOwned + Default>(p: Option<&PathBuf>) -> Result<T, Failure> {
    match p {
        None => Ok(T::default()),
        Some(p) => {
            let text = crate::files::read_json_text(p, "a calflash JSON file")?;
            Ok(serde_json::from_str(&text)
                .map_err(|e| format!("{}:{}:{}: {e}", p.display(), e.line(), e.column()))?)
        }
    }
}

/// The conditions of a plan file, `repeat` times.
fn plan_file(
    path: &std::path::Path,
    kind: SensorKind,
    repeat: usize,
) -> Result<Vec<plan::Condition>, Failure> {
    use crate::columns as col;
    use crate::design::points::{self, Unit};
    let header = crate::obs::header(path, crate::obs::Format::Auto)?;
    let known: Vec<&str> = col::F
        .iter()
        .chain(col::W.iter())
        .copied()
        .chain([col::INPUT, col::INPUT_P, col::INPUT_O, col::TEMP, col::VOLT])
        .collect();
    let names: Vec<String> = header
        .iter()
        .filter(|h| known.contains(&h.as_str()))
        .cloned()
        .collect();
    if names.is_empty() {
        return Err(format!(
            "{}: no plan columns; expected some of {}",
            path.display(),
            known.join(", ")
        )
        .into());
    }
    let pts = points::read(path, &names)?;
    let unit = match kind {
        SensorKind::SingleAccel => Unit::SingleAccel,
        SensorKind::SingleGyro => Unit::SingleGyro,
        _ => Unit::Triad,
    };
    let once = crate::design::predict::conditions(&pts, unit);
    Ok((0..repeat).flat_map(|_| once.iter().copied()).collect())
}

/// Reads `DEGREES:HZ`.
fn coning(text: &str) -> Result<(f64, f64), String> {
    let err = || format!("--coning `{text}`: expected DEGREES:HZ, e.g. 1:10");
    let (a, f) = text.split_once(':').ok_or_else(err)?;
    let a: f64 = a.trim().parse().map_err(|_| err())?;
    let f: f64 = f.trim().parse().map_err(|_| err())?;
    if !(a.is_finite() && (0.0..=45.0).contains(&a) && f.is_finite() && f.abs() <= 1e4) {
        return Err(format!(
            "--coning `{text}`: the half-angle is 0 to 45 degrees and the rate at most 10 kHz"
        ));
    }
    Ok((a.to_radians(), f))
}

/// Holds `codes` at the converter's `rails`; how many were beyond them.
fn hold_at_rails<'a>(
    codes: impl Iterator<Item = &'a mut f64>,
    rails: spincal::model::Rails,
) -> usize {
    let mut saturated = 0;
    for code in codes {
        let v = code.clamp(f64::from(rails.lo), f64::from(rails.hi));
        saturated += usize::from(v != *code);
        *code = v;
    }
    saturated
}

/// The line that says how many codes a flight saturated (nothing when none), `why` after it.
fn saturation_note(saturated: usize, rails: spincal::model::Rails, why: &str) -> String {
    if saturated == 0 {
        return String::new();
    }
    format!(
        "  {saturated} code(s) saturated at the {} converter's rails {} and {}{why}\n",
        crate::obs::codes::name(rails),
        rails.lo,
        rails.hi
    )
}

/// The IMU a flight runs through: `--truth`, or the default unit centred on `--codes`.
fn imu_truth(args: &SimulateArgs) -> Result<truth::ImuTruth, Failure> {
    let mut truth = load::<truth::ImuTruth>(args.truth.as_ref())?;
    if args.truth.is_none()
        && let Sensor::Imu(t) = Sensor::Imu(Box::new(truth.clone())).with_codes(args.codes)
    {
        truth = *t;
    }
    Ok(truth)
}

/// The most samples a simulated flight holds (about 2 GB of CSV).
const MAX_FLIGHT_SAMPLES: f64 = 1e7;

/// Refuses a simulation of more than [`MAX_FLIGHT_SAMPLES`] samples (`what`: the option),
/// saying how many and what lowers them, before anything is allocated.
fn too_many_samples(what: &str, samples: f64) -> Result<(), Failure> {
    if samples.is_finite() && samples <= MAX_FLIGHT_SAMPLES {
        return Ok(());
    }
    Err(format!(
        "{what}: that is {samples:.3e} samples; a simulated recording holds at most {MAX_FLIGHT_SAMPLES:e} (about 2 GB): lower --sample-rate or the number of poses, or shorten --hold"
    )
    .into())
}

/// A spin-rig flight of an IMU, written as CSV.
fn spin_rig(args: &SimulateArgs, profile: &str) -> Result<(), Failure> {
    use crate::sim::spin;
    let sample_rate = args.sample_rate.unwrap_or(2000.0);
    if args.sensor != SensorKind::Imu {
        return Err("--spin: a spin-rig flight is of an IMU (--sensor imu)".into());
    }
    let segments = spin::profile(profile).map_err(|e| format!("--spin: {e}"))?;
    let seconds: f64 = segments.iter().map(spin::Segment::seconds).sum();
    if seconds * sample_rate > MAX_FLIGHT_SAMPLES {
        return Err(format!(
            "--spin: {seconds} s at {} Hz is {:.3e} samples; a flight holds at most {MAX_FLIGHT_SAMPLES:e} \
             (shorten the profile or lower --sample-rate)",
            sample_rate,
            seconds * sample_rate
        ).into());
    }
    let (cone_angle, cone_hz) = match &args.coning {
        Some(c) => coning(c)?,
        None => (0.0, 0.0),
    };
    let axis: Vec<f64> = args
        .spin_axis
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--spin-axis `{}`: expected X,Y,Z", args.spin_axis))?;
    let axis: [f64; 3] = match axis[..] {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite()) && x * x + y * y + z * z > 0.0 => {
            [x, y, z]
        }
        _ => {
            return Err(format!(
                "--spin-axis `{}`: three finite numbers, not all zero",
                args.spin_axis
            )
            .into());
        }
    };
    let truth = imu_truth(args)?;
    let run = spin::SpinRun {
        segments,
        axis,
        sample_rate,
        cone_angle,
        cone_hz,
        temp: args.temps.first().copied().unwrap_or(25.0),
        volt: args.volts.first().copied().unwrap_or(3.3),
        seed: args.seed,
    };
    let mut samples = spin::run(&truth, &run);
    let rails = args.codes;
    let saturated = hold_at_rails(samples.iter_mut().flat_map(|s| s.raw.iter_mut()), rails);
    let mut staged = Staged::new();
    staged.write(&args.output, |w| spin::write_csv(&samples, w))?;
    if let Some(p) = &args.write_truth {
        let json = serde_json::to_string_pretty(&truth)?;
        staged.write(p, |w| w.write_all(json.as_bytes()))?;
    }
    staged.commit()?;
    println!(
        "calflash simulate: a {seconds} s spin-rig flight, {} samples at {} Hz, written to {}",
        samples.len(),
        sample_rate,
        args.output.display()
    );
    print!("{}", saturation_note(saturated, rails, ""));
    Ok(())
}

/// The ramp the options describe.
fn ramp_of(args: &SimulateArgs, text: &str) -> Result<ramp::Ramp, ramp::Error> {
    let (from, to) = ramp::span(text)?;
    let self_heating = args
        .self_heating
        .as_deref()
        .map(ramp::self_heating)
        .transpose()?;
    Ok(ramp::Ramp {
        from,
        to,
        seconds: args.ramp_minutes * 60.0,
        uneven: args.uneven,
        lag: args.lag,
        self_heating,
        step: args.temp_step,
    })
}

/// The ramp's columns: `temp` becomes the sensor's reading, with `time` and `chamber_temp`.
fn ramp_columns(obs: &mut sim::Observations, temps: &ramp::Temperatures) {
    use crate::columns as col;
    if let Some(i) = obs.names.iter().position(|n| n == col::TEMP) {
        for (row, t) in obs.rows.iter_mut().zip(&temps.reported) {
            row[i] = *t;
        }
    }
    obs.names.insert(0, "time".into());
    obs.names.push("chamber_temp".into());
    for (k, row) in obs.rows.iter_mut().enumerate() {
        row.insert(0, temps.time[k]);
        row.push(temps.chamber[k]);
    }
}

/// `--rest`: the unit at rest and handled, raw counts of its blob's correction.
fn rest(args: &SimulateArgs, blob: &std::path::Path) -> Result<(), Failure> {
    if args.sensor != SensorKind::Imu {
        return Err("--rest: a unit at rest is simulated as an IMU (--sensor imu)".into());
    }
    let bytes = crate::files::read_blob(blob)?;
    let cal =
        crate::signing::calibration(&bytes).map_err(|e| format!("{}: {e}", blob.display()))?;
    let rate = args.sample_rate.unwrap_or(1000.0);
    let shift: [f64; 6] = match args.shift.as_slice() {
        [] => [0.0; 6],
        s => s
            .try_into()
            .map_err(|_| "--shift: six values, ax,ay,az,wx,wy,wz".to_string())?,
    };
    too_many_samples("--rest", (args.poses as f64 * args.hold + args.hold) * rate)?;
    let session = sim::rest::Session {
        rate,
        shift_sigmas: shift,
        poses: args.poses,
        hold: args.hold,
        aged_s: args.aged,
        seed: args.seed,
    };
    let raw = session
        .record(&cal)
        .map_err(|e| format!("{}: {e}", blob.display()))?;
    crate::files::write_atomically(&args.output, |w| sim::rest::write_csv(&raw, rate, w))?;
    println!(
        "calflash simulate  unit {} at rest: {} poses of {} s, {} samples at {rate} Hz, biases off by {shift:?} sigma -> {}",
        cal.data().identity.serial,
        args.poses,
        args.hold,
        raw.len(),
        args.output.display()
    );
    Ok(())
}

/// `--still`: an IMU at rest for an Allan deviation.
/// Units on one fixture: `first`'s columns with its outputs prefixed `u1_`, then each of
/// `others`' outputs prefixed `u2_`, `u3_`, ... (the conditions are the same).
fn on_one_fixture(first: sim::Observations, others: &[sim::Observations]) -> sim::Observations {
    use crate::columns;
    let is_output =
        |n: &str| n == columns::OUTPUT || columns::A.contains(&n) || columns::GYRO.contains(&n);
    let outputs: Vec<usize> = (0..first.names.len())
        .filter(|i| is_output(&first.names[*i]))
        .collect();
    let mut names: Vec<String> = first
        .names
        .iter()
        .map(|n| {
            if is_output(n) {
                format!("u1_{n}")
            } else {
                n.clone()
            }
        })
        .collect();
    for k in 0..others.len() {
        names.extend(
            outputs
                .iter()
                .map(|i| format!("u{}_{}", k + 2, first.names[*i])),
        );
    }
    let rows = first
        .rows
        .iter()
        .enumerate()
        .map(|(r, row)| {
            let mut row = row.clone();
            for o in others {
                row.extend(outputs.iter().map(|i| o.rows[r][*i]));
            }
            row
        })
        .collect();
    sim::Observations { names, rows }
}

/// `--tumble POSES`: the recording of a unit turned by hand (the library's `Tumble`: its
/// accelerometer and gyro, gravity 9.81 m/s^2, a 30 s rest, each pose held 4 s).
fn tumble(args: &SimulateArgs, poses: usize) -> Result<(), Failure> {
    use std::fmt::Write as _;
    if args.sensor != SensorKind::Imu {
        return Err("--tumble: a hand-turned recording is of an IMU (--sensor imu)".into());
    }
    let session = sim::recording::Tumble {
        poses,
        rate: args.sample_rate.unwrap_or(100.0),
        seed: args.seed,
        ..sim::recording::Tumble::default()
    };
    let samples = (session.rest + poses as f64 * (session.hold + session.turn)) * session.rate;
    too_many_samples("--tumble", samples)?;
    let rec = session.record();
    let mut text = String::with_capacity(rec.t.len() * 48);
    for ((t, a), g) in rec.t.iter().zip(&rec.acc).zip(&rec.gyro) {
        let _ = writeln!(
            text,
            "{t:.3} {} {} {} {} {} {}",
            a[0], a[1], a[2], g[0], g[1], g[2]
        );
    }
    let mut staged = Staged::new();
    staged.write(&args.output, |w| w.write_all(text.as_bytes()))?;
    staged.commit()?;
    println!(
        "calflash simulate: an IMU turned by hand through {poses} poses after a {} s rest, {} samples at {} Hz, written to {}",
        session.rest,
        rec.t.len(),
        session.rate,
        args.output.display()
    );
    Ok(())
}

fn still(args: &SimulateArgs, seconds: f64) -> Result<(), Failure> {
    if args.sensor != SensorKind::Imu {
        return Err("--still: a still recording is of an IMU (--sensor imu)".into());
    }
    let rate = args.sample_rate.unwrap_or(100.0);
    if seconds * rate > MAX_FLIGHT_SAMPLES {
        return Err(format!(
            "--still: {seconds} s at {rate} Hz is {:.3e} samples; at most {MAX_FLIGHT_SAMPLES:e}",
            seconds * rate
        )
        .into());
    }
    let walk = match args.bias_walk.as_slice() {
        [] => [0.0; 2],
        [a, g] => [*a, *g],
        _ => return Err("--bias-walk: two values, ACCEL,GYRO (counts per root second)".into()),
    };
    let s = sim::still::Still {
        seconds,
        rate,
        walk,
        temp: args.temps.first().copied().unwrap_or(25.0),
        volt: args.volts.first().copied().unwrap_or(5.0),
        seed: args.seed,
    };
    let truth = imu_truth(args)?;
    let mut codes = sim::still::record(&truth, &s);
    let saturated = hold_at_rails(codes.iter_mut().flatten(), args.codes);
    let mut staged = Staged::new();
    staged.write(&args.output, |w| {
        sim::still::write_csv(&codes, &s, std::io::BufWriter::new(w))
    })?;
    if let Some(p) = &args.write_truth {
        let json = serde_json::to_string_pretty(&truth)?;
        staged.write(p, |w| w.write_all(json.as_bytes()))?;
    }
    staged.commit()?;
    println!(
        "calflash simulate: an IMU still for {seconds} s, {} samples at {rate} Hz (bias walk {walk:?} counts/sqrt(s)), written to {}",
        codes.len(),
        args.output.display()
    );
    print!("{}", saturation_note(saturated, args.codes, ""));
    Ok(())
}

/// Runs `calflash simulate`.
///
/// # Errors
/// A bad plan item or truth file.
pub fn run(args: &SimulateArgs) -> Result<(), Failure> {
    Paths::new()
        .input("--plan-file", args.plan_file.as_deref())
        .input("--truth", args.truth.as_deref())
        .input("--rest", args.rest.as_deref())
        .output("-o", Some(&args.output))
        .output("--write-truth", args.write_truth.as_deref())
        .output("--flight-truth", args.flight_truth.as_deref())
        .output("--gnss", args.gnss.as_deref())
        .output("--baro", args.baro.as_deref())
        .check()?;
    if let Some(spec) = &args.flight {
        return flight::run(args, spec);
    }
    if let Some(dir) = &args.stages {
        if args.sensor != SensorKind::Imu {
            return Err("--stages: two stages make an assembled IMU (--sensor imu)".into());
        }
        return stages::run(args, dir);
    }
    if let Some(seconds) = args.still {
        return still(args, seconds);
    }
    if let Some(poses) = args.tumble {
        return tumble(args, poses);
    }
    if let Some(blob) = &args.rest {
        return rest(args, blob);
    }
    if let Some(profile) = &args.spin {
        return spin_rig(args, profile);
    }
    let single = matches!(
        args.sensor,
        SensorKind::SingleAccel | SensorKind::SingleGyro
    );
    let mut conditions = match &args.plan_file {
        Some(path) => plan_file(path, args.sensor, args.repeat)?,
        // Along a ramp, each repeat runs the plan at every voltage in turn, so that the
        // voltages share the temperatures.
        None if args.ramp.is_some() => {
            let once = plan::plan(&args.plan, &args.temps, &args.volts, 1, single)?;
            if once.len().saturating_mul(args.repeat) > plan::MAX_CONDITIONS {
                return Err(format!(
                    "{} conditions with every voltage and repeat; a plan holds at most {}",
                    once.len().saturating_mul(args.repeat),
                    plan::MAX_CONDITIONS
                )
                .into());
            }
            (0..args.repeat)
                .flat_map(|_| once.iter().copied())
                .collect()
        }
        None => plan::plan(&args.plan, &args.temps, &args.volts, args.repeat, single)?,
    };
    let ramp = match &args.ramp {
        Some(text) => {
            let (ramped, temps) = ramp::run(&ramp_of(args, text)?, &conditions);
            conditions = ramped;
            Some(temps)
        }
        None => None,
    };
    let t = args.truth.as_ref();
    let sensor = match args.sensor {
        SensorKind::SingleAccel => Sensor::Single {
            gyro: false,
            truth: load::<truth::SingleTruth>(t)?,
        },
        SensorKind::SingleGyro => Sensor::Single {
            gyro: true,
            truth: load::<truth::SingleTruth>(t)?,
        },
        SensorKind::Accel => Sensor::Accel(match t {
            Some(_) => load::<truth::TriadTruth>(t)?,
            None => truth::TriadTruth::accelerometer(),
        }),
        SensorKind::Gyro => Sensor::Gyro(match t {
            Some(_) => load::<truth::TriadTruth>(t)?,
            None => truth::TriadTruth::gyro(),
        }),
        SensorKind::Imu => Sensor::Imu(Box::new(load::<truth::ImuTruth>(t)?)),
    };
    // The default unit is written for an unsigned 16-bit converter: behind another, its
    // biases sit at that converter's mid-scale. A truth file is taken as it is.
    let sensor = if t.is_none() {
        sensor.with_codes(args.codes)
    } else {
        sensor
    };
    let station = match (args.latitude, args.heading) {
        (Some(lat), Some(heading)) => {
            if matches!(sensor, Sensor::Single { .. }) {
                return Err("--latitude: the Earth's rate is simulated for triads and IMUs".into());
            }
            Some(crate::earth::Station::new(lat, heading)?)
        }
        _ => None,
    };
    let mut obs = sim::simulate_at(
        &sensor,
        &conditions,
        args.seed,
        args.quantize,
        station.as_ref(),
    )
    .map_err(|e| format!("--latitude: {e}"))?;
    if let Some(units) = args.fixture {
        let mut others = Vec::with_capacity(units - 1);
        for k in 1..units {
            others.push(
                sim::simulate_at(
                    &sensor,
                    &conditions,
                    args.seed.wrapping_add(k as u64),
                    args.quantize,
                    station.as_ref(),
                )
                .map_err(|e| format!("--latitude: {e}"))?,
            );
        }
        obs = on_one_fixture(obs, &others);
    }
    if let Some(r) = &ramp {
        ramp_columns(&mut obs, r);
    }
    let saturated = obs.saturate(args.codes);
    let mut staged = Staged::new();
    staged.write(&args.output, |w| obs.write_csv(w))?;
    if let Some(p) = &args.write_truth {
        let json = match &sensor {
            Sensor::Single { truth, .. } => serde_json::to_string_pretty(truth),
            Sensor::Accel(t) | Sensor::Gyro(t) => serde_json::to_string_pretty(t),
            Sensor::Imu(t) => serde_json::to_string_pretty(t),
        }?;
        staged.write(p, |w| w.write_all(json.as_bytes()))?;
    }
    staged.commit()?;
    println!(
        "calflash simulate: {} observations written to {}",
        obs.rows.len(),
        args.output.display()
    );
    if saturated > 0 {
        println!(
            "  {saturated} output(s) saturated at the {} converter's rails {} and {}",
            crate::obs::codes::name(args.codes),
            args.codes.lo,
            args.codes.hi
        );
    }
    Ok(())
}
