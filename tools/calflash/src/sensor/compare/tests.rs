use super::*;

fn one(kind: &str, value: f64) -> Estimates {
    Estimates {
        serial: "U-1".into(),
        kind: kind.into(),
        points: vec![PointEstimates {
            temp: None,
            volt: None,
            outputs: vec![Estimate {
                output: "gyro".into(),
                terms: vec!["G11".into(), "G22".into()],
                values: vec![value, 1.0],
                std_errors: vec![0.01, 0.01],
                covariance: vec![vec![1e-4, 0.0], vec![0.0, 1e-4]],
                dof: None,
            }],
        }],
        accel_center: None,
    }
}

#[test]
fn records_of_different_kinds_are_refused() {
    let e = compare(&one("imu", 1.0), &one("imu without equipment", 1.0), 0.05).unwrap_err();
    assert!(matches!(e, Error::DifferentKinds { .. }));
    assert_eq!(
        e.to_string(),
        "the records are of different kinds: imu and imu without equipment (compare two records of one kind)"
    );
}

#[test]
fn records_that_cannot_be_read_say_where_and_what() {
    let parse = |text: &str| Estimates::parse(text, "a.json").unwrap_err();
    let e = parse("{\n  \"schema\": ");
    assert!(matches!(e, Error::NotJson { line: 2, .. }), "{e:?}");
    assert!(e.to_string().starts_with("a.json:2:"), "{e}");
    let e = parse(r#"{"serial": "U-1"}"#);
    assert!(matches!(e, Error::NoSchema { .. }));
    let e = parse(r#"{"schema": "other/9"}"#);
    assert_eq!(
        e.to_string(),
        format!(
            "a.json: schema `other/9`, expected `{}` or `{SELFCAL_SCHEMA}`",
            record::SCHEMA
        )
    );
    let e = parse(&format!(r#"{{"schema": "{SELFCAL_SCHEMA}", "serial": 7}}"#));
    assert_eq!(e.to_string(), "a.json: `serial` is not a string");
    let e = parse(&format!(
        r#"{{"schema": "{SELFCAL_SCHEMA}", "serial": "U-1"}}"#
    ));
    assert!(matches!(&e, Error::Missing { field, .. } if field == "accel.terms"));
    let e = parse(&format!(
        r#"{{"schema": "{SELFCAL_SCHEMA}", "serial": "U-1",
                "accel": {{"terms": ["b"], "parameters": [1.0], "covariance": [[1.0, 0.0]]}}}}"#
    ));
    assert_eq!(
        e.to_string(),
        "a.json: `accel.covariance` is not 1 x 1 for the 1 terms of the accelerometer"
    );
}

#[test]
fn a_term_moved_by_five_combined_standard_errors_is_flagged() {
    // Combined standard error sqrt(2) * 0.01; a change of 5 of them.
    let moved = 1.0 + 5.0 * 2f64.sqrt() * 0.01;
    let c = compare(&one("imu", 1.0), &one("imu", moved), 0.05).unwrap();
    let t = &c[0].terms;
    assert!((t[0].z - 5.0).abs() < 1e-9 && t[0].moved, "{t:?}");
    assert!(!t[1].moved);
    assert_eq!(c[0].df, 2);
    assert!((c[0].chi2 - 25.0).abs() < 1e-9);
}
