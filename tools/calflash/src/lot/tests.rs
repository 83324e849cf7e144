use super::*;

fn unit(k: usize, bias: f64) -> Unit {
    Unit {
        serial: format!("U-{k}"),
        time: k as i64,
        station: "A".into(),
        coefficients: BTreeMap::from([("bias".to_string(), bias), ("one".to_string(), 1.0)]),
    }
}

/// Each refusal is its own variant, and says what the lot needs.
#[test]
fn what_a_lot_cannot_do_is_named() {
    assert!(matches!(
        judge(vec![unit(0, 1.0)], 0.01),
        Err(Error::TooFewUnits(1))
    ));
    let flat = vec![unit(0, 1.0), unit(1, 1.0)];
    assert!(matches!(judge(flat, 0.01), Err(Error::NothingShared(k)) if k.is_empty()));
    // Units of another kind are named.
    let mut mixed: Vec<Unit> = (0..3).map(|k| unit(k, 1.0)).collect();
    mixed.push(Unit {
        serial: "SINGLE-9".into(),
        time: 9,
        station: String::new(),
        coefficients: BTreeMap::from([("output:1".to_string(), 3.0)]),
    });
    let e = judge(mixed, 0.01).unwrap_err().to_string();
    assert!(
        e.contains("more than one kind") && e.contains("1 unit(s) SINGLE-9 with output:1"),
        "{e}"
    );
    let lot = judge((0..6).map(|k| unit(k, k as f64)).collect(), 0.01).unwrap();
    assert_eq!(lot.names, ["bias"]);
    let e = lot.place(&BTreeMap::new()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "the unit lacks coefficients its lot is judged on: bias"
    );
    let e = lot
        .chart("scale", chart::Kind::Individuals, None)
        .unwrap_err();
    assert!(matches!(&e, Error::NoCoefficient { name, .. } if name == "scale"));
    let e = lot
        .chart("bias", chart::Kind::Individuals, Some("B"))
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "a chart of bias needs two units at station B"
    );
    assert!(matches!(coefficients("3"), Err(Error::NotCoefficients)));
    assert!(matches!(coefficients("{"), Err(Error::NotJson(_))));
}
