//! The round's filter (`spincal::flight`, `f32` as on the Cortex-M4F) on a shell from our
//! round-Earth simulator with a GNSS fuze's fixes: none before muzzle exit plus 0.8 s, each
//! 80 ms late, velocity in east, north, up at the receiver, position wandering by 1.5 m over
//! 45 s beside its white noise; the axial accelerometer shifting 5 ms after muzzle exit, the
//! setback not saturating (`host_tests::flight_round`).

use host_tests::flight_round::{
    HORIZON_SAMPLES, Scenario, axial_z, config, departure, fly, roll_scale_z, run,
};
use spincal::flight::{Aiding, DelayedFlight, FlightFilter, Word};
use spincal::nav::filter::index;

#[test]
fn a_gnss_fuzes_late_wandering_fixes_keep_the_track_within_its_sigma_and_the_shift_is_found() {
    let flight = fly(&Scenario::shell(1));
    let mut late = FlightFilter::<f32>::new(config(&flight));
    let taken_late = run(&mut late, &flight, |_| {});
    let mut delayed = DelayedFlight::<f32, HORIZON_SAMPLES>::new(config(&flight));
    let held = run(&mut delayed, &flight, |_| {});
    println!("each fix taken as it arrives: {taken_late}");
    let filter = delayed.filter();
    let (pin, vin) = held.inside();
    let (zb, zs) = axial_z(filter, &flight);
    let s = filter.stats();
    println!("{held:?}\n{s:?}");
    println!(
        "launch {:?} setback end {:?} shift {} us; axial bias {:.4} scale {:.6}",
        filter.launch_us(),
        filter.setback_end_us(),
        flight.shift_us,
        filter.estimate().sensors.accel_bias.x,
        filter.estimate().sensors.accel_scale.x
    );
    println!("{held}; axial bias z {zb:+.2}, scale z {zs:+.2}");
    assert!(held.epochs > 1500, "{held:?}");
    // Both within 3 sigma on 95 % of epochs (this flight: 100 % and 100 %; over 50, 99.4 % and
    // 98.8 %: BENCHMARKS.md, the round's filter on a delayed horizon). Before the attitude
    // carried the angle a kink in the rate hides between two samples (`Navigation::hidden`:
    // the muzzle's tip-off), the velocity held 80.5 % here.
    assert!(pin >= 0.95 && vin >= 0.95, "{held:?}");
    assert!(zb.abs() <= 3.0 && zs.abs() <= 3.0, "{zb} {zs}");
    // The shift was learnt, not left at its prior.
    let p = filter.covariance();
    let scale_sigma = f64::from(p[(index::ACCEL_SCALE, index::ACCEL_SCALE)]).sqrt();
    assert!(scale_sigma < 1e-3, "axial scale 1-sigma {scale_sigma}");
    // The setback ended at the muzzle (a few ms after the launch), not seconds later.
    let (launch, end) = (
        filter.launch_us().unwrap(),
        filter.setback_end_us().unwrap(),
    );
    assert!((1_000..40_000).contains(&(end - launch)), "{launch} {end}");
    assert!(end < flight.shift_us, "{end} {}", flight.shift_us);
    for kind in [Aiding::Position, Aiding::Velocity] {
        let k = kind as usize;
        assert!(s.refused[k] * 20 <= s.taken[k], "{kind:?}: {s:?}");
    }
    // The round's own verdict names the axial accelerometer's bias (over 50 such flights, 50
    // SHIFTED naming it; without a shift 50 HELD: BENCHMARKS.md).
    let verdict = filter.verdict();
    println!("the round's verdict: {verdict:?}");
    assert_eq!(verdict.word, Word::Shifted, "{verdict:?}");
    assert!(verdict.is_shifted(0), "{verdict:?}");
    assert_eq!(verdict.shifted & !(1 << 0 | 1 << 6), 0, "{verdict:?}");
}

/// The same shell without a shift: the round's verdict holds the calibration, and it did
/// observe the axial terms it would have named.
#[test]
fn a_shell_whose_sensors_did_not_shift_is_held_by_the_rounds_verdict() {
    let flight = fly(&Scenario {
        shift: (0.0, 0.0),
        ..Scenario::shell(1)
    });
    let mut delayed = DelayedFlight::<f32, HORIZON_SAMPLES>::new(config(&flight));
    run(&mut delayed, &flight, |_| {});
    let verdict = delayed.filter().verdict();
    println!("the round's verdict: {verdict:?}");
    assert_eq!(verdict.word, Word::Held, "{verdict:?}");
    assert!(
        verdict.is_observed(0) && verdict.is_observed(6),
        "{verdict:?}"
    );
    assert!(
        verdict.z[0].abs() < 3.0 && verdict.z[6].abs() < 3.0,
        "{verdict:?}"
    );
}

/// Accelerometer biases that walk (1e-3 m/s^2/sqrt(s)) leave the track to the fixes more
/// than to the navigation: with the receiver's wander carried, the position stays within its
/// 3 sigma; taken as white (no receiver states), the fixes average the wander away and the
/// filter believes its track to a fraction of it. What the receiver states are for.
#[test]
fn the_receivers_wander_taken_as_white_leaves_the_track_outside_its_sigma() {
    let flight = fly(&Scenario {
        walk: 1e-3,
        ..Scenario::shell(1)
    });
    let mut carried = DelayedFlight::<f32, HORIZON_SAMPLES>::new(config(&flight));
    let with = run(&mut carried, &flight, |_| {});
    let mut white = config::<f32>(&flight);
    white.noise.receiver_sigma = nalgebra::Vector3::zeros();
    let mut filter = DelayedFlight::<f32, HORIZON_SAMPLES>::new(white);
    let without = run(&mut filter, &flight, |_| {});
    println!(
        "biases walking: position within 3 sigma {:.1} % with the receiver's states, {:.1} % \
         taken as white (velocity {:.1} %, {:.1} %)",
        100.0 * with.inside().0,
        100.0 * without.inside().0,
        100.0 * with.inside().1,
        100.0 * without.inside().1
    );
    assert!(with.inside().0 >= 0.95, "{with:?}");
    assert!(without.inside().0 < 0.8, "{without:?}");
}

/// 50 flights on the delayed horizon (`FLIGHTS=n` for another count, `WALK=x` for walking
/// biases, `LATE=1` for the filter alone taking the fixes late, `NOISE=A,G` for the samples'
/// noise at A and G times what the filter is told): the position's and the
/// velocity's NEES, the innovations' NIS, the axial shift's z, and the `f32` filter against
/// the `f64` one.
#[test]
#[ignore = "a population: cargo test --release -p host-tests --test flight_round -- --ignored --nocapture"]
fn population() {
    let n: u64 = std::env::var("FLIGHTS")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(50);
    let (mut pin, mut vin, mut pn, mut vn, mut zb2, mut zs2, mut worst) =
        (Vec::new(), Vec::new(), 0.0, 0.0, 0.0, 0.0, 0.0f64);
    let (mut epochs, mut nis_p, mut nis_v, mut taken_p, mut taken_v) = (0usize, 0.0, 0.0, 0, 0);
    let (mut shift_in, mut end_p) = (0usize, Vec::new());
    let walk: f64 = std::env::var("WALK")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(0.0);
    // LATE=1: the filter alone, taking each fix as it arrives (the delayed horizon's
    // comparison).
    let late = std::env::var("LATE").is_ok();
    let noise_scale = std::env::var("NOISE")
        .ok()
        .and_then(|x| {
            let (a, g) = x.split_once(',')?;
            Some((a.trim().parse().ok()?, g.trim().parse().ok()?))
        })
        .unwrap_or((1.0, 1.0));
    // HELD=1: no shift at all, the round's verdict's false alarms.
    let unshifted = std::env::var("HELD").is_ok();
    // RESIDUAL=1: the unit carries residual errors drawn from the filter's prior.
    let residual = std::env::var("RESIDUAL").is_ok();
    // NAV_US=n: the navigation's lower rate every n us (0: every sample) in place of the
    // default's.
    let nav_us: Option<u32> = std::env::var("NAV_US").ok().and_then(|x| x.parse().ok());
    fn set_up<T: spincal::nav::Real>(
        mut config: spincal::flight::FlightConfig<T>,
        nav_us: Option<u32>,
    ) -> spincal::flight::FlightConfig<T> {
        if let Some(us) = nav_us {
            config.navigation_interval_us = us;
        }
        config
    }
    let mut words = std::collections::BTreeMap::<&str, usize>::new();
    let mut named = std::collections::BTreeMap::<&str, usize>::new();
    let (mut z2, mut zn) = (0.0, 0usize);
    for seed in 0..n {
        let base = Scenario::shell(100 + seed);
        let flight = fly(&Scenario {
            walk,
            noise_scale,
            shift: if unshifted { (0.0, 0.0) } else { base.shift },
            residual,
            ..base
        });
        let (held, single, double) = if late {
            let mut single = FlightFilter::<f32>::new(set_up(config(&flight), nav_us));
            let mut double = FlightFilter::<f64>::new(set_up(config(&flight), nav_us));
            let held = run(&mut single, &flight, |_| {});
            run(&mut double, &flight, |_| {});
            (held, single, double)
        } else {
            let mut single =
                DelayedFlight::<f32, HORIZON_SAMPLES>::new(set_up(config(&flight), nav_us));
            let mut double =
                DelayedFlight::<f64, HORIZON_SAMPLES>::new(set_up(config(&flight), nav_us));
            let held = run(&mut single, &flight, |_| {});
            run(&mut double, &flight, |_| {});
            (held, single.filter().clone(), double.filter().clone())
        };
        let (a, b) = held.inside();
        pin.push(a);
        vin.push(b);
        epochs += held.epochs;
        pn += held.nees.0;
        vn += held.nees.1;
        end_p.push(held.end.0 / held.end_sigma.0);
        let (zb, zs) = axial_z(&single, &flight);
        zb2 += zb * zb;
        zs2 += zs * zs;
        shift_in += usize::from(zb.abs() <= 3.0 && zs.abs() <= 3.0);
        let s = single.stats();
        nis_p += f64::from(s.nis[Aiding::Position as usize]);
        nis_v += f64::from(s.nis[Aiding::Velocity as usize]);
        taken_p += s.taken[Aiding::Position as usize];
        taken_v += s.taken[Aiding::Velocity as usize];
        worst = worst.max(departure(&single, &double).0);
        let verdict = single.verdict();
        *words.entry(verdict.word.as_str()).or_default() += 1;
        for (i, z) in verdict.z.iter().enumerate() {
            // The spread had nothing shifted: the terms that did not shift.
            let moved = !unshifted && (i == 0 || i == 6);
            if verdict.is_observed(i) && !moved {
                z2 += f64::from(*z).powi(2);
                zn += 1;
            }
        }
        for (i, name) in spincal::flight::verdict::TERM_NAMES.iter().enumerate() {
            if verdict.is_shifted(i) {
                *named.entry(name).or_default() += 1;
            }
        }
    }
    println!(
        "the round's verdicts: {words:?}; terms named: {named:?}; mean z^2 of the observed \
         terms that did not shift {:.2} over {zn} (1 when the spread had nothing shifted is right)",
        z2 / zn as f64
    );
    let nf = n as f64;
    pin.sort_by(f64::total_cmp);
    vin.sort_by(f64::total_cmp);
    println!(
        "{n} flights: position within 3 sigma on {:.1} % of epochs (worst flight {:.1} %), \
         velocity {:.1} % (worst {:.1} %); mean NEES position {:.2}, velocity {:.2} (3 each); \
         mean NIS position {:.2}, velocity {:.2} (1 each); axial bias NEES {:.2}, scale {:.2} \
         (1 each), both within 3 sigma in {shift_in}/{n}; f32 against f64 at the end: {:.4} sigma",
        100.0 * pin.iter().sum::<f64>() / nf,
        100.0 * pin[0],
        100.0 * vin.iter().sum::<f64>() / nf,
        100.0 * vin[0],
        pn / epochs as f64,
        vn / epochs as f64,
        nis_p / f64::from(taken_p),
        nis_v / f64::from(taken_v),
        zb2 / nf,
        zs2 / nf,
        worst
    );
}

/// The independent simulator's shells (`../shared/data/reference-flights`: McCoy 6-DOF,
/// WGS-84 with the Earth turning, 4 kHz, fixes 80 ms late with a Gauss-Markov wander), the
/// unit's pre-launch errors taken out exactly, run on the delayed horizon: the track within
/// its 3 sigma, the 155 mm's launch shift (axial bias +0.06 m/s^2, roll scale +2e-4) found,
/// the 105 mm held, `f32` against `f64`. The filter alone, taking each fix as it arrives, is
/// printed beside it (it does not hold: BENCHMARKS.md).
#[test]
fn the_reference_shells_hold_their_track_on_a_delayed_horizon_and_the_shift_is_found() {
    for name in ["shell155", "shell105"] {
        let Some(flight) = host_tests::flight_reference::shell(name) else {
            return;
        };
        let config = host_tests::flight_reference::config(&flight);
        let mut late = FlightFilter::<f32>::new(config);
        let taken_late = run(&mut late, &flight, |_| {});
        let mut single = DelayedFlight::<f32, HORIZON_SAMPLES>::new(config);
        let held = run(&mut single, &flight, |_| {});
        let mut double = DelayedFlight::<f64, HORIZON_SAMPLES>::new(
            host_tests::flight_reference::config(&flight),
        );
        run(&mut double, &flight, |_| {});
        let (worst, state) = departure(single.filter(), double.filter());
        let filter = single.filter();
        let (zb, zs) = axial_z(filter, &flight);
        let zr = roll_scale_z(filter, &flight);
        let e = filter.estimate();
        println!(
            "{name}: each fix as it arrives: {taken_late}\n{name}: on the delayed horizon: {held}; \
             axial bias {:+.4} (z {zb:+.2}), axial scale z {zs:+.2}, roll scale {:+.3e} \
             (z {zr:+.2}); f32 against f64 at the end {worst:.3} sigma (state {state}); {:?}",
            e.sensors.accel_bias.x,
            e.sensors.gyro_scale.x,
            filter.stats()
        );
        let verdict = filter.verdict();
        println!("{name}: the round's verdict {verdict:?}");
        // The round's own verdict: the 155's axial bias and roll scale shifted at launch, named
        // (and nothing else); the 105 held.
        let (word, named) = if name == "shell155" {
            (Word::Shifted, 1 << 0 | 1 << 9)
        } else {
            (Word::Held, 0)
        };
        assert_eq!(
            (verdict.word, verdict.shifted),
            (word, named),
            "{name}: {verdict:?}"
        );
        let (pin, vin) = held.inside();
        assert!(held.epochs > 1500, "{name}: {held:?}");
        assert!(pin >= 0.95 && vin >= 0.95, "{name}: {held}");
        assert!(
            zb.abs() <= 3.0 && zs.abs() <= 3.0 && zr.abs() <= 3.0,
            "{name}: {zb} {zs} {zr}"
        );
        assert!(
            worst < 0.1,
            "{name}: f32 {worst} sigma from f64 in state {state}"
        );
    }
}

/// The navigation in two speeds (the attitude, velocity and position with the covariance
/// step, every 10 ms) against the same filter stepping them at every sample, in `f64` on the
/// independent 155 mm shell (4 kHz, shifted at launch): the same track within its sigma at the
/// same epochs, the same NEES to a hundredth, the axial terms within a tenth of their sigma of
/// each other, and the same verdict.
#[test]
fn the_two_speeds_keep_every_samples_track_and_verdict_on_a_reference_shell() {
    let Some(flight) = host_tests::flight_reference::shell("shell155") else {
        return;
    };
    let config = host_tests::flight_reference::config::<f64>(&flight);
    assert_eq!(config.navigation_interval_us, 10_000, "the default");
    let mut every_sample = config;
    every_sample.navigation_interval_us = 0;
    let mut two = DelayedFlight::<f64, HORIZON_SAMPLES>::new(config);
    let mut one = DelayedFlight::<f64, HORIZON_SAMPLES>::new(every_sample);
    let (held_two, held_one) = (
        run(&mut two, &flight, |_| {}),
        run(&mut one, &flight, |_| {}),
    );
    println!("two speeds: {held_two}\nevery sample: {held_one}");
    assert_eq!(held_two.epochs, held_one.epochs);
    let (a, b) = (held_two.inside(), held_one.inside());
    assert!(
        (a.0 - b.0).abs() < 0.005 && (a.1 - b.1).abs() < 0.005,
        "{a:?} {b:?}"
    );
    let n = held_two.epochs as f64;
    let nees = |h: &host_tests::flight_round::Held| (h.nees.0 / n, h.nees.1 / n);
    let (x, y) = (nees(&held_two), nees(&held_one));
    assert!(
        (x.0 - y.0).abs() < 0.01 && (x.1 - y.1).abs() < 0.01,
        "{x:?} {y:?}"
    );
    let (ft, fo) = (two.filter(), one.filter());
    let sigma = |i: usize| fo.covariance()[(i, i)].sqrt();
    for (i, (t, o)) in [
        (
            ft.estimate().sensors.accel_bias.x,
            fo.estimate().sensors.accel_bias.x,
        ),
        (
            ft.estimate().sensors.accel_scale.x,
            fo.estimate().sensors.accel_scale.x,
        ),
        (
            ft.estimate().sensors.gyro_scale.x,
            fo.estimate().sensors.gyro_scale.x,
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let at = [index::ACCEL_BIAS, index::ACCEL_SCALE, index::GYRO_SCALE][i];
        assert!(
            (t - o).abs() < 0.1 * sigma(at),
            "state {at}: {t} against {o}"
        );
    }
    let (vt, vo) = (ft.verdict(), fo.verdict());
    assert_eq!(
        (vt.word, vt.shifted),
        (vo.word, vo.shifted),
        "{vt:?} {vo:?}"
    );
    assert_eq!((vt.word, vt.shifted), (Word::Shifted, 1 << 0 | 1 << 9));
}

/// The harness's inverse of the reference unit's sensor model, held against the truth's own
/// specific force and rate (200 Hz rows): what is left is the noise, the differenced angular
/// acceleration's noise on the arms, and the launch shift (the 155's roll scale, 0.32 rad/s).
#[test]
fn the_reference_shells_corrected_samples_match_their_truth() {
    use std::collections::HashMap;
    for name in ["shell155", "shell105"] {
        let Some(flight) = host_tests::flight_reference::shell(name) else {
            return;
        };
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/reference-flights")
            .join(name);
        let text = std::fs::read_to_string(dir.join("truth_trajectory.csv")).unwrap();
        let mut truth = HashMap::new();
        let imu = std::fs::read_to_string(dir.join("imu.csv")).unwrap();
        let t0: f64 = imu
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        for l in text.lines().skip(1) {
            let r: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            truth.insert(((r[0] - t0) * 1e6).round() as u64, r);
        }
        let (mut sf, mut sw, mut n) = (
            nalgebra::Vector3::<f64>::zeros(),
            nalgebra::Vector3::<f64>::zeros(),
            0.0,
        );
        for i in &flight.inputs {
            if let host_tests::flight_golden::Input::Sample(t, f, w, d) = i {
                if d[0] || d[1] {
                    continue;
                }
                if let Some(r) = truth.get(t) {
                    let df = nalgebra::Vector3::from_fn(|k, _| f64::from(f[k]) - r[11 + k]);
                    let dw = nalgebra::Vector3::from_fn(|k, _| f64::from(w[k]) - r[14 + k]);
                    sf += df.component_mul(&df);
                    sw += dw.component_mul(&dw);
                    n += 1.0;
                }
            }
        }
        let (rf, rw) = ((sf / n).map(f64::sqrt), (sw / n).map(f64::sqrt));
        println!(
            "{name}: RMS against the truth: force {:?} m/s^2, rate {:?} rad/s over {n} rows",
            rf.as_slice(),
            rw.as_slice()
        );
        assert!(
            n > 4000.0 && rf.max() < 1.0 && rw.max() < 0.5,
            "{name}: {rf:?} {rw:?}"
        );
    }
}

/// What the velocity's 3-sigma lacked on our 2 kHz shells: the strapdown alone, on noise-free
/// samples from the truth, holds the spin axis to micro-radians through the bore and loses a
/// milliradian in the one sample where the round takes its tip-off at the muzzle (a step in
/// the transverse rate the trapezoid cannot place); `Navigation::hidden` states that loss, so
/// the filter's attitude variance holds it.
#[test]
fn the_tip_off_at_the_muzzle_is_lost_between_two_samples_and_the_step_says_so() {
    use nalgebra::Vector3;
    use spincal::nav::{Earth, Interval, Navigation, Step};
    let flight = fly(&Scenario {
        shift: (0.0, 0.0),
        noise_scale: (0.0, 0.0),
        ..Scenario::shell(1)
    });
    let earth = Earth::new(flight.origin.latitude.to_radians(), flight.origin.height);
    let mut nav = Navigation::at_rest(flight.attitude[0], Vector3::x());
    let mut last: Option<(u64, Vector3<f64>, Vector3<f64>)> = None;
    let (mut k, mut bore, mut lost, mut hidden) = (0usize, 0.0f64, 0.0f64, 0.0f64);
    let mut muzzle = None;
    for e in &flight.inputs {
        let host_tests::flight_golden::Input::Sample(t, f, w, _) = e else {
            continue;
        };
        let (f, w) = (
            Vector3::from(f.map(f64::from)),
            Vector3::from(w.map(f64::from)),
        );
        if let Some((t0, f0, w0)) = last {
            nav.propagate(
                &earth,
                &Step {
                    w: [w0, w],
                    f: [f0, f],
                    dt: Interval::micros((t - t0) as f64),
                },
            );
            hidden += nav.hidden();
        }
        last = Some((*t, f, w));
        let axis = (nav.attitude() * Vector3::x()).angle(&(flight.attitude[k] * Vector3::x()));
        // The bore: spinning up under thousands of g; the muzzle: the force falls to drag.
        if f.norm() > 1_000.0 {
            bore = bore.max(axis);
            muzzle = None;
        } else if bore > 0.0 && muzzle.is_none() && w.norm() > 1_000.0 {
            muzzle = Some(k);
        }
        if muzzle.is_some_and(|m| k == m + 20) {
            lost = axis;
            break;
        }
        k += 1;
    }
    println!(
        "spin axis off by {bore:.2e} rad through the bore, {lost:.2e} rad 20 samples after the \
         muzzle; stated as hidden by then: {hidden:.2e} rad (1-sigma)"
    );
    assert!(muzzle.is_some(), "no muzzle exit found");
    assert!(bore < 1e-5, "{bore}");
    assert!(lost > 5e-4, "the tip-off's step no longer lost: {lost}");
    assert!(lost < 3.0 * hidden, "{lost} against {hidden} stated");
}
