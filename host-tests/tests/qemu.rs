//! The golden vectors and the golden flight on the Cortex-M4F: builds the test firmware for thumbv7em-none-eabihf,
//! runs it under qemu-system-arm (mps2-an386) and fails on any mismatch with the host's
//! expected outputs. Skips with a notice when QEMU or the target is missing, unless
//! `SPINCAL_REQUIRE_QEMU=1` (as in CI).

use std::time::Duration;

use host_tests::qemu;

#[test]
fn golden_vectors_match_on_cortex_m4f() {
    if !qemu::available_or_skip("golden_vectors_match_on_cortex_m4f") {
        return;
    }
    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let run = qemu::run(&bin.join("golden"), &[], Duration::from_secs(120)).expect("qemu starts");
    println!("{}", run.stdout);
    assert_eq!(
        run.code,
        Some(0),
        "firmware reported failures:\n{}\n{}",
        run.stdout,
        run.stderr
    );
    let summary = run
        .stdout
        .lines()
        .find(|l| l.starts_with("golden:"))
        .expect("summary line");
    assert!(summary.ends_with(" 0 mismatches"), "{summary}");
    // Every sample of every vector file was checked on the device, those of the IMU cases
    // twice: one call per sample, then through `correct_batch` (the Cortex-M4F kernels).
    let expected: usize = host_tests::golden::examples()
        .iter()
        .map(|(n, _, kind)| {
            let samples =
                std::fs::read_to_string(host_tests::golden::dir().join(format!("{n}.vectors")))
                    .unwrap()
                    .lines()
                    .filter(|l| l.starts_with("raw "))
                    .count();
            match kind {
                host_tests::golden::Kind::Imu(..) => 2 * samples,
                _ => samples,
            }
        })
        .sum::<usize>()
        + host_tests::health_golden::cases()
            .iter()
            .map(|(n, _)| {
                std::fs::read_to_string(host_tests::golden::dir().join(format!("{n}.vectors")))
                    .unwrap()
                    .lines()
                    .filter(|l| l.starts_with("raw "))
                    .count()
            })
            .sum::<usize>();
    assert!(
        summary.contains(&format!(" {expected} samples checked")),
        "{summary}"
    );
}

#[test]
fn the_golden_flight_is_bit_exact_on_cortex_m4f() {
    if !qemu::available_or_skip("the_golden_flight_is_bit_exact_on_cortex_m4f") {
        return;
    }
    let bin = qemu::build_firmware().unwrap_or_else(|e| panic!("{e}"));
    let run = qemu::run(&bin.join("flight"), &[], Duration::from_secs(120)).expect("qemu starts");
    println!("{}", run.stdout);
    assert_eq!(run.code, Some(0), "{}\n{}", run.stdout, run.stderr);
    let samples = host_tests::flight_golden::flight()
        .events
        .iter()
        .filter(|e| matches!(e, host_tests::flight_golden::Event::Sample(..)))
        .count();
    let summary = run
        .stdout
        .lines()
        .find(|l| l.starts_with("flight:"))
        .expect("summary line");
    let want = format!(
        "flight: {samples} samples, 480 epochs, {} checkpoints, 0 values differ",
        samples / host_tests::flight_golden::CHECKPOINT_EVERY + 1
    );
    assert!(summary.starts_with(&want), "{summary}\nexpected {want}");
}
