//! The strapdown navigation against closed forms: at rest, coning at a round's spin, two
//! speeds against every step, an interval's largest turn.

use super::*;

fn earth() -> Earth<f64> {
    Earth::new(0.6, 0.0)
}

#[test]
fn a_unit_at_rest_stays_at_rest_when_it_feels_gravity_and_the_earth_rate() {
    let e = earth();
    let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    let mut nav = Navigation::at_rest(q, Vector3::x());
    let f = q.inverse() * (-e.gravity(&Vector3::zeros()));
    let w = q.inverse() * e.rate();
    let step = Step {
        w: [w; 2],
        f: [f; 2],
        dt: Interval::seconds(0.01),
    };
    for _ in 0..6000 {
        nav.propagate(&e, &step);
    }
    // Sixty seconds: the vertical channel's instability and second-order terms only.
    assert!(
        nav.p.norm() < 1e-3 && nav.v.norm() < 1e-4,
        "{:?} {:?}",
        nav.p,
        nav.v
    );
    assert!(nav.settled_attitude(&e).angle_to(&q) < 1e-9);
}

#[test]
fn coning_motion_is_followed_at_high_spin() {
    // A body spinning at 1885 rad/s (300 rev/s) about its x axis while that axis cones at
    // 5 rad/s about the level x axis, half-angle 0.05 rad: attitude after one second,
    // sampled at 2 kHz, against the closed form.
    let (spin, cone, half_angle) = (1885.0_f64, 5.0_f64, 0.05_f64);
    let truth = |t: f64| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), cone * t)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), half_angle)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t)
    };
    // Body rate of that motion: the spin and the cone's rate seen in body axes.
    let rate = |t: f64| {
        let q = truth(t);
        q.inverse() * (Vector3::x() * cone)
            + UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t).inverse()
                * (Vector3::x() * (spin - cone))
    };
    let dt = 1.0 / 2000.0;
    let e = Earth::new(0.0, 0.0);
    // The closed form turns against the level frame: the gyros also feel the Earth's rate.
    let mut with = Navigation::at_rest(truth(0.0), Vector3::x());
    let mut plain = truth(0.0);
    for k in 0..2000 {
        let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
        let earth_rate = |t: f64| truth(t).inverse() * e.rate();
        let w = [rate(t0) + earth_rate(t0), rate(t1) + earth_rate(t1)];
        let f = [Vector3::zeros(); 2];
        with.propagate(
            &e,
            &Step {
                w,
                f,
                dt: Interval::seconds(dt),
            },
        );
        let theta = (w[0] + w[1]) * (dt / 2.0);
        plain = UnitQuaternion::from_scaled_axis(e.rate() * -dt)
            * plain
            * UnitQuaternion::from_scaled_axis(theta);
    }
    let err_with = with.settled_attitude(&e).angle_to(&truth(1.0));
    let err_without = plain.angle_to(&truth(1.0));
    assert!(
        err_with < 1e-6,
        "de-spun with the coning term: {err_with} rad, plain {err_without}"
    );
    assert!(err_without > 10.0 * err_with, "{err_without} vs {err_with}");
}

/// The coning shell of the test above, pushed by 100 m/s^2 along the level x axis (a
/// force that turns with the spin in the body): the two-speed navigation at 100 Hz ends
/// where stepping everything at every sample does, and the attitude where the closed
/// form does.
#[test]
fn two_speeds_follow_every_step_through_coning_and_a_turning_force() {
    let (spin, cone, half_angle) = (1885.0_f64, 5.0_f64, 0.05_f64);
    let truth = |t: f64| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), cone * t)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), half_angle)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t)
    };
    let rate = |t: f64| {
        truth(t).inverse() * (Vector3::x() * cone)
            + UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (spin - cone) * t).inverse()
                * (Vector3::x() * (spin - cone))
    };
    let e = Earth::new(0.6, 0.0);
    let push = Vector3::new(100.0, 0.0, 0.0) - e.gravity(&Vector3::zeros());
    let dt = 1.0 / 2000.0;
    let mut every = Navigation::at_rest(truth(0.0), Vector3::x());
    let mut two = Navigation::at_rest(truth(0.0), Vector3::x()).with_interval(0.01);
    let mut flushes = 0;
    for k in 0..2000 {
        let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
        let at = |t: f64| {
            (
                rate(t) + truth(t).inverse() * e.rate(),
                truth(t).inverse() * push,
            )
        };
        let ((w0, f0), (w1, f1)) = (at(t0), at(t1));
        let step = Step {
            w: [w0, w1],
            f: [f0, f1],
            dt: Interval::seconds(dt),
        };
        let _ = every.propagate(&e, &step);
        flushes += usize::from(two.propagate(&e, &step).is_some());
    }
    assert!(two.flush(&e).is_none(), "the last sample ends an interval");
    assert!((99..=101).contains(&flushes), "{flushes} intervals in 1 s");
    let turned = two.settled_attitude(&e).angle_to(&truth(1.0));
    assert!(turned < 1e-6, "{turned} rad from the closed form");
    let each = every.settled_attitude(&e).angle_to(&truth(1.0));
    let apart = two
        .settled_attitude(&e)
        .angle_to(&every.settled_attitude(&e));
    assert!(
        apart < 2.0 * each.max(turned),
        "{apart} rad apart, {turned} and {each} from the closed form"
    );
    assert!((two.v - every.v).norm() < 1e-5, "{} {}", two.v, every.v);
    assert!((two.p - every.p).norm() < 1e-5, "{} {}", two.p, every.p);
    // Pushed: 100 m/s after a second, 50 m on.
    assert!((two.v.x - 100.0).abs() < 0.1 && (two.p.x - 50.0).abs() < 0.1);
}

/// A round spinning at 1885 rad/s whose axis turns at 30 rad/s in the level frame: its
/// de-spun frame turns by 0.05 rad every 1.7 ms, so the intervals end at the sample that
/// reaches that turn (every fourth at 2 kHz), not at their stated second, and the attitude
/// holds the closed form.
#[test]
fn an_interval_ends_at_its_largest_turn() {
    let (spin, yaw) = (1885.0_f64, 30.0_f64);
    let q0 = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
    let truth = |t: f64| {
        q0 * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw * t)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), spin * t)
    };
    let e = Earth::new(0.0, 0.0);
    let at = |t: f64| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), spin * t).inverse()
            * (Vector3::y() * yaw)
            + Vector3::x() * spin
            + truth(t).inverse() * e.rate()
    };
    let mut nav = Navigation::at_rest(q0, Vector3::x()).with_interval(1.0);
    let dt = 1.0 / 2000.0;
    let mut flushes = 0;
    for k in 0..200 {
        let step = Step {
            w: [at(k as f64 * dt), at((k + 1) as f64 * dt)],
            f: [Vector3::zeros(); 2],
            dt: Interval::seconds(dt),
        };
        flushes += usize::from(nav.propagate(&e, &step).is_some());
    }
    let _ = nav.flush(&e);
    assert_eq!(flushes, 50, "intervals in 0.1 s");
    let off = nav.settled_attitude(&e).angle_to(&truth(0.1));
    assert!(off < 1e-6, "{off} rad");
}
