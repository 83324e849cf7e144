//! `calflash simulate --flight`: a shell or a rocket flown, its profile written with the raw
//! codes of an IMU riding in it, and the flight's truth.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{MAX_FLIGHT_SAMPLES, SimulateArgs, imu_truth};
use crate::cmd::Failure;
use crate::cmd::values::SensorKind;
use crate::files::Staged;
use crate::sim::flight::{self, spec::Launch};

/// Runs `--flight SPEC`.
pub(super) fn run(args: &SimulateArgs, spec: &str) -> Result<(), Failure> {
    if args.sensor != SensorKind::Imu {
        return Err("--flight: a flight carries an IMU (--sensor imu)".into());
    }
    let launch = Launch::parse(spec)?;
    let rate = args.sample_rate.unwrap_or_else(|| launch.default_rate());
    if launch.seconds() * rate > MAX_FLIGHT_SAMPLES {
        return Err(format!(
            "--flight: {} s at {rate} Hz is {:.3e} samples; a flight holds at most {MAX_FLIGHT_SAMPLES:e} (give seconds=... or a lower --sample-rate)",
            launch.seconds(),
            launch.seconds() * rate
        )
        .into());
    }
    // A flight needs a unit made for it: the spinning round's (+-2000 g, +-2000 rad/s) unless
    // --truth says otherwise.
    let truth = if args.truth.is_some() {
        imu_truth(args)?
    } else {
        crate::sim::truth::ImuTruth::spinning_round()
    };
    let volt = args.volts.first().copied().unwrap_or(5.0);
    let flown = launch.fly(1.0 / rate);
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
    let raw: Vec<[f64; 6]> = flown
        .samples
        .iter()
        .map(|s| truth.codes((s.f, s.w, s.dw), (s.temp, volt), &mut rng))
        .collect();
    let mut raw = raw;
    let rails = args.codes;
    let saturated = super::hold_at_rails(raw.iter_mut().flatten(), rails);
    let mut staged = Staged::new();
    staged.write(&args.output, |w| {
        flight::write_csv(&flown.samples, volt, Some(&raw), std::io::BufWriter::new(w))
    })?;
    if let Some(p) = &args.flight_truth {
        staged.write(p, |w| {
            flight::write_truth(&flown.samples, std::io::BufWriter::new(w))
        })?;
    }
    if let Some(p) = &args.write_truth {
        let json = serde_json::to_string_pretty(&truth)?;
        staged.write(p, |w| w.write_all(json.as_bytes()))?;
    }
    staged.commit()?;
    let events: Vec<String> = flown
        .events
        .iter()
        .map(|(what, t)| format!("{what} {t:.3} s"))
        .collect();
    let apogee = flown.samples.iter().map(|s| s.r[2]).fold(0.0, f64::max);
    let range = flown.samples.last().map_or(0.0, |s| s.r[0]);
    println!(
        "calflash simulate: a {} flight, {} samples at {rate} Hz, written to {}",
        if matches!(launch, Launch::Shell(_)) {
            "shell"
        } else {
            "rocket"
        },
        flown.samples.len(),
        args.output.display()
    );
    println!(
        "  {}; apogee {apogee:.0} m, {range:.0} m downrange at the end",
        events.join(", ")
    );
    print!(
        "{}",
        super::saturation_note(saturated, rails, " (the unit's range, not the flight's)")
    );
    Ok(())
}
