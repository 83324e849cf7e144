//! `calflash simulate --flight`: a shell or a rocket flown, its profile written with the raw
//! codes of an IMU riding in it, and the flight's truth.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{MAX_FLIGHT_SAMPLES, SimulateArgs, imu_truth};
use crate::cmd::Failure;
use crate::cmd::values::SensorKind;
use crate::files::Staged;
use crate::sim::flight::receivers::{LaunchShift, Receiver, write_baro, write_gnss};
use crate::sim::flight::{self, spec::Launch};

/// Runs `--flight SPEC`.
pub(super) fn run(args: &SimulateArgs, spec: &str) -> Result<(), Failure> {
    if args.sensor != SensorKind::Imu {
        return Err("--flight: a flight carries an IMU (--sensor imu)".into());
    }
    let mut launch = Launch::parse(spec)?;
    let receivers = args.gnss.is_some() || args.baro.is_some();
    let defaulted = receivers && launch.site_mut().is_none();
    if defaulted {
        *launch.site_mut() = Some(flight::spec::DEFAULT_SITE);
    }
    let shift = args
        .launch_shift
        .as_deref()
        .map(LaunchShift::parse)
        .transpose()?
        .unwrap_or_default();
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
    let site = *launch.site_mut();
    let earth_rate = site.map_or_else(nalgebra::Vector3::zeros, |s| s.rate());
    let raw: Vec<[f64; 6]> = flown
        .samples
        .iter()
        .map(|s| {
            // The gyros sense the Earth's rate too; after launch, the unit's shifted errors.
            let [qw, qx, qy, qz] = s.q;
            let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                qw, qx, qy, qz,
            ));
            let w: [f64; 3] = (nalgebra::Vector3::from(s.w) + q.inverse() * earth_rate).into();
            let (f, w) = if s.t > 0.0 {
                shift.apply(s.f, w)
            } else {
                (s.f, w)
            };
            truth.codes((f, w, s.dw), (s.temp, volt), &mut rng)
        })
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
    let mut receiver_rng = ChaCha8Rng::seed_from_u64(args.seed.wrapping_add(1));
    if let (Some(p), Some(site)) = (&args.gnss, &site) {
        let rx = Receiver {
            rate: args.gnss_rate,
            noise: (
                args.gnss_noise.first().copied().unwrap_or(2.0),
                args.gnss_noise.get(1).copied().unwrap_or(4.0),
            ),
            latency: args.gnss_latency,
            outage: args.gnss_outage,
            in_flight_only: match args.gnss_acquire.as_deref() {
                Some(when) => when == "flight",
                None => matches!(launch, Launch::Shell(_)),
            },
            correlated: match args.gnss_correlated.as_slice() {
                [sigma, tau] => (*sigma, tau.max(1e-3)),
                _ => {
                    return Err(
                        "--gnss-correlated: two values, SIGMA,TAU (m, s); 0,60 for none".into(),
                    );
                }
            },
            antenna: match args.gnss_antenna.as_slice() {
                [x, y, z] => [*x, *y, *z],
                [] => [0.0; 3],
                other => {
                    return Err(format!(
                        "--gnss-antenna: 3 comma-separated values, {} given",
                        other.len()
                    )
                    .into());
                }
            },
            ..Receiver::default()
        };
        staged.write(p, |w| {
            write_gnss(
                &flown.samples,
                site,
                &rx,
                &mut receiver_rng,
                std::io::BufWriter::new(w),
            )
        })?;
    }
    if let (Some(p), Some(site)) = (&args.baro, &site) {
        staged.write(p, |w| {
            write_baro(
                &flown.samples,
                site.height,
                100.0,
                args.baro_noise,
                &mut receiver_rng,
                std::io::BufWriter::new(w),
            )
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
    if let (true, Some(site)) = (defaulted, site) {
        println!(
            "  launched at {} N, {} E, fired at azimuth {} (the receivers need a place: lat=, lon=, azimuth= in --flight)",
            site.latitude, site.longitude, site.azimuth
        );
    }
    print!(
        "{}",
        super::saturation_note(saturated, rails, " (the unit's range, not the flight's)")
    );
    Ok(())
}
