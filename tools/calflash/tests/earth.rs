//! The Earth's rate as the gyros' reference signal: a tactical-grade gyro (bias of a few
//! deg/h) calibrated on a tumble and a rate table absorbs the Earth's 15 deg/h unless the
//! station's latitude and the fixture's heading make it a known input; then its bias comes out
//! against it. Without them the tool says how large the neglected term is.

use calflash::earth::Station;
use calflash::sensor::{Options, Verdict, triad};
use calflash::sim::{self, Sensor, plan, truth::TriadTruth};
use spincal::model::Rails;

/// A tactical gyro on a 24-bit converter: 10^6 counts per rad/s, a bias of 2e-5 rad/s
/// (4 deg/h), 0.3 counts of noise per averaged observation.
fn tactical() -> TriadTruth {
    let k = 1.0e6;
    let c = 8_388_608.0;
    TriadTruth {
        bias: [c + 20.0, c - 14.0, c + 9.0],
        s: [
            [k * 1.0002, k * 4.0e-4, -k * 2.0e-4],
            [-k * 3.0e-4, k * 0.9997, k * 5.0e-4],
            [k * 1.0e-4, -k * 6.0e-4, k * 1.0001],
        ],
        g: [[0.0; 3]; 3],
        bias_temp: [0.0; 3],
        scale_temp: [0.0; 3],
        bias_temp2: [0.0; 3],
        noise: [0.3; 3],
        ..TriadTruth::gyro()
    }
}

fn calibrate(station: Option<Station>, dir: &std::path::Path) -> calflash::sensor::Calibrated {
    let truth = tactical();
    let items: Vec<String> = ["tumble:24", "rate:-5:5:5"].map(String::from).to_vec();
    let conds = plan::plan(&items, &[25.0], &[3.3], 2, false).unwrap();
    let here = Station::new(48.1, 30.0).unwrap();
    let obs = sim::simulate_at(&Sensor::Gyro(truth), &conds, 7, false, Some(&here)).unwrap();
    let path = dir.join("tumble.csv");
    obs.write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let mut opts = Options::new(&path, "TAC-1");
    opts.rails = Rails::unsigned(24);
    opts.earth = station;
    triad::calibrate(&opts, triad::Kind::Gyro, false).unwrap()
}

/// (bias error / its standard error) per axis.
fn bias_z(c: &calflash::sensor::Calibrated) -> [f64; 3] {
    let truth = tactical();
    std::array::from_fn(|i| {
        let f = &c.points[0].axes[i];
        let k = f.index("1").unwrap();
        (f.fit.coefficients[k] - truth.bias[i]) / f.fit.std_errors[k]
    })
}

#[test]
fn with_the_station_the_bias_comes_out_against_the_earth_rate() {
    let dir = tempfile::tempdir().unwrap();
    let c = calibrate(Some(Station::new(48.1, 30.0).unwrap()), dir.path());
    assert!(c.verdict() < Verdict::Reject, "{:?}", c.findings);
    for (i, z) in bias_z(&c).iter().enumerate() {
        assert!(z.abs() < 4.0, "axis {i}: bias {z:.2} standard errors off");
    }
    // The residual noise is the sensor's again: 0.3 counts.
    for n in &c.points[0].noise {
        assert!(*n < 4e-7, "noise {n} rad/s");
    }
    assert!(
        c.notes.iter().any(|n| n.contains("latitude 48.1")),
        "{:?}",
        c.notes
    );
    assert!(
        c.findings
            .iter()
            .all(|f| !f.text.contains("not in the model"))
    );
    let rec = calflash::sensor::record::Record::new(&c, "tumble.csv");
    assert_eq!(rec.earth, Some(Station::new(48.1, 30.0).unwrap()));
}

#[test]
fn without_it_the_tool_says_the_gyro_absorbs_it() {
    let dir = tempfile::tempdir().unwrap();
    let c = calibrate(None, dir.path());
    assert_eq!(c.verdict(), Verdict::Review, "{:?}", c.findings);
    let f = c
        .findings
        .iter()
        .find(|f| f.text.contains("not in the model"))
        .expect("the Earth-rate finding");
    assert_eq!(f.verdict, Verdict::Review);
    assert!(f.text.contains("--latitude and --heading"), "{}", f.text);
    // The Earth rate's vertical part, the same sign as gravity's reaction on every position,
    // passes for a g-sensitivity of sin(latitude) 7.29e-5 / 9.81 rad/s per m/s^2 that the
    // unit does not have; its horizontal part is left in the residuals.
    let spurious = calflash::earth::RATE * 48.1f64.to_radians().sin() / 9.806_65 * 1.0e6;
    for (i, f) in c.points[0].axes.iter().enumerate() {
        let g = f.coef(["f_x", "f_y", "f_z"][i]);
        assert!(
            (g / spurious - 1.0).abs() < 0.05,
            "axis {i}: g-sensitivity {g} counts per m/s^2"
        );
    }
    assert!(
        c.points[0].noise.iter().any(|n| *n > 1e-6),
        "{:?}",
        c.points[0].noise
    );
    // With the station the unit has none.
    let c = calibrate(Some(Station::new(48.1, 30.0).unwrap()), dir.path());
    for (i, f) in c.points[0].axes.iter().enumerate() {
        assert_eq!(
            f.coef(["f_x", "f_y", "f_z"][i]),
            0.0,
            "axis {i}: {:?}",
            f.fit.names
        );
    }
}

#[test]
fn a_mems_gyro_is_told_the_earth_rate_is_below_what_it_resolves() {
    let dir = tempfile::tempdir().unwrap();
    let conds = plan::plan(
        &["tumble:24".into(), "rate:-5:5:5".into()],
        &[25.0],
        &[3.3],
        1,
        false,
    )
    .unwrap();
    let obs = sim::simulate(&Sensor::Gyro(TriadTruth::gyro()), &conds, 3, false);
    let path = dir.path().join("mems.csv");
    obs.write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let c = triad::calibrate(&Options::new(&path, "MEMS-1"), triad::Kind::Gyro, false).unwrap();
    let f = c
        .findings
        .iter()
        .find(|f| f.text.contains("not in the model"))
        .expect("the Earth-rate finding");
    assert_eq!(f.verdict, Verdict::Accept);
    assert!(
        f.text.contains("below what this gyro resolves"),
        "{}",
        f.text
    );
}

#[test]
fn a_still_position_without_the_fixture_mark_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let conds = plan::plan(
        &["tumble:24".into(), "rate:-5:5:5".into()],
        &[25.0],
        &[3.3],
        1,
        false,
    )
    .unwrap();
    // Without a station the file has no h_* columns.
    let obs = sim::simulate(&Sensor::Gyro(tactical()), &conds, 3, false);
    let path = dir.path().join("no_mark.csv");
    obs.write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let mut opts = Options::new(&path, "TAC-2");
    opts.rails = Rails::unsigned(24);
    opts.earth = Some(Station::new(10.0, 0.0).unwrap());
    let e = triad::calibrate(&opts, triad::Kind::Gyro, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no_mark.csv: line 2:") && e.contains("h_x h_y h_z"),
        "{e}"
    );
}
