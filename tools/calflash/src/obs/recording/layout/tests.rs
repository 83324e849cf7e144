use super::super::header::{ACCEL, GYRO, axis};
use super::super::tests::write;
use super::*;

#[test]
fn names_units_and_preambles() {
    assert_eq!(timestamp("time_us"), Some(1e-6));
    assert_eq!(timestamp("Timestamp"), Some(1.0));
    assert_eq!(timestamp("t[ms]"), Some(1e-3));
    assert_eq!(timestamp("temp"), None);
    assert_eq!(axis("acc_x", &ACCEL, Sensor::Accel), Some((0, None)));
    assert_eq!(axis("AccelZ", &ACCEL, Sensor::Accel), Some((2, None)));
    assert_eq!(axis("gyro_y", &GYRO, Sensor::Gyro), Some((1, None)));
    assert_eq!(axis("gx", &ACCEL, Sensor::Accel), None);
    let mps2 = Unit::parse("m/s^2", Sensor::Accel);
    assert_eq!(axis("ax_mps2", &ACCEL, Sensor::Accel), Some((0, mps2)));
    let dps = Unit::parse("deg/s", Sensor::Gyro);
    assert_eq!(axis("gyro_z[dps]", &GYRO, Sensor::Gyro), Some((2, dps)));
    assert_eq!(axis("ax_filtered", &ACCEL, Sensor::Accel), None);
    let d = tempfile::tempdir().unwrap();
    // An MPU-6050 logger's layout: a preamble, a header, signed counts, no timestamp.
    let p = write(
        d.path(),
        "mpu.csv",
        "Fs,100\nLogging Type,0\nInitialization time,36.5\nax,ay,az,gx,gy,gz\n-12,-812,15032,-447,156,-86\n-208,-828,14796,-398,132,-63\n",
    );
    let r = read(&p, Holds::Both, Keep::Both).unwrap();
    assert_eq!(r.t, None);
    assert_eq!(
        (r.triads[0][0], r.triads[1][0]),
        ([-12.0, -812.0, 15032.0], [-447.0, 156.0, -86.0])
    );
    assert_eq!(r.line, [5, 6]);
    assert_eq!(
        r.preamble.rate,
        Some(Setting {
            value: 100.0,
            line: 1
        })
    );
    assert_eq!(
        r.preamble.rest,
        Some(Setting {
            value: 36.5,
            line: 3
        })
    );
    assert_eq!(r.preamble.ignored, ["Logging Type"]);
    // Columns by name, in another order, with a temperature beside them and microseconds.
    let p = write(
        d.path(),
        "named.csv",
        "gyro_x,gyro_y,gyro_z,temp,time_us,acc_x,acc_y,acc_z\n4,5,6,25,1000,1,2,3\n4,5,6,25,2000,1,2,3\n",
    );
    let r = read(&p, Holds::Both, Keep::Both).unwrap();
    assert_eq!(r.t, Some(vec![1e-3, 2e-3]));
    assert_eq!(
        (r.triads[0][1], r.triads[1][1]),
        ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    );
    // A line short of the header's names.
    let p = write(d.path(), "short.csv", "t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5\n");
    assert_eq!(
        read(&p, Holds::Both, Keep::Both).unwrap_err().to_string(),
        format!(
            "{}:2: 6 fields; expected 7, as the header on line 1 names",
            p.display()
        )
    );
}
