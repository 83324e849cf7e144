use super::*;

fn line_data() -> (DMatrix<f64>, Vec<f64>) {
    // The seed's example 1: x = 1..10, y = 2 + 3x + small noise.
    let noise = [0.1, -0.2, 0.05, 0.0, 0.15, -0.1, 0.2, -0.05, -0.1, 0.05];
    let x = DMatrix::from_fn(10, 2, |i, j| if j == 0 { 1.0 } else { (i + 1) as f64 });
    let y = (0..10)
        .map(|i| 2.0 + 3.0 * (i + 1) as f64 + noise[i])
        .collect();
    (x, y)
}

#[test]
fn seed_example_covariance_form() {
    let (x, y) = line_data();
    let f = fit(
        &x,
        &y,
        vec!["1".into(), "x".into()],
        true,
        &Options::default(),
    )
    .unwrap();
    // (X'X)^-1 of the seed: [[0.4667, -0.0667], [-0.0667, 0.0121]].
    let c = f.unscaled_covariance();
    assert!((c[(0, 0)] - 0.466_666_666_666_7).abs() < 1e-12);
    assert!((c[(0, 1)] + 0.066_666_666_666_7).abs() < 1e-12);
    assert!((c[(1, 1)] - 0.012_121_212_121_2).abs() < 1e-12);
    assert!((f.coefficients[1] - 3.0).abs() < 0.05);
    // Prediction variance grows away from the centroid (x = 5.5).
    let at = |v: f64| f.predict(&[1.0, v]).variance;
    assert!(at(5.5) < at(1.0) && at(1.0) < at(-5.0));
    assert!((at(5.5) / f.sigma2 - 0.1).abs() < 1e-12);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// The residuals are orthogonal to every column (to rounding scaled by eps n), the
    /// fitted values rebuild y, and the covariance is symmetric positive definite.
    #[test]
    fn normal_equations_hold(n in 8usize..200, p in 1usize..7, seed in 0u64..1000) {
        let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        let mut u = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let p = p.min(n - 1);
        let x = DMatrix::from_fn(n, p, |_, j| if j == 0 { 1.0 } else { u() * 10f64.powi(j as i32 - 2) });
        let y: Vec<f64> = (0..n).map(|_| u()).collect();
        let names = (0..p).map(|j| format!("x{j}")).collect();
        let f = fit(&x, &y, names, true, &Options::default()).unwrap();
        let scale = f64::EPSILON * n as f64 * 10.0;
        for j in 0..p {
            let col = x.column(j);
            let dot: f64 = col.iter().zip(&f.residuals).map(|(a, e)| a * e).sum();
            let bound = scale * col.norm() * y.iter().map(|v| v * v).sum::<f64>().sqrt();
            proptest::prop_assert!(dot.abs() <= bound, "column {j}: {dot:e} > {bound:e}");
        }
        for ((fi, ei), yi) in f.fitted.iter().zip(&f.residuals).zip(&y) {
            proptest::prop_assert!((fi + ei - yi).abs() <= 4.0 * f64::EPSILON * (1.0 + yi.abs()));
        }
        let c = f.unscaled_covariance();
        proptest::prop_assert!((&c - c.transpose()).amax() <= 1e-12 * c.amax());
        proptest::prop_assert!(c.clone().cholesky().is_some());
        let h: f64 = f.influence.leverage.iter().sum();
        proptest::prop_assert!((h - p as f64).abs() < 1e-9 * p as f64, "trace of the hat matrix {h}");
    }
}

#[test]
fn rank_deficiency_finds_the_combination() {
    let x = DMatrix::from_fn(6, 3, |i, j| match j {
        0 => 1.0,
        1 => i as f64,
        _ => 2.0 - 3.0 * i as f64,
    });
    let y: Vec<f64> = (0..6).map(|i| i as f64 * 0.5).collect();
    let e = fit(
        &x,
        &y,
        vec!["1".into(), "a".into(), "b".into()],
        true,
        &Options::default(),
    )
    .unwrap_err();
    let FitError::RankDeficient {
        column,
        combination,
    } = e
    else {
        panic!("{e}")
    };
    assert_eq!(column, 2);
    assert!((combination[0].1 - 2.0).abs() < 1e-9 && (combination[1].1 + 3.0).abs() < 1e-9);
    let e = fit(
        &x.view((0, 0), (2, 2)).clone_owned(),
        &y[..2],
        vec!["1".into(), "a".into()],
        true,
        &Options::default(),
    );
    assert!(matches!(
        e,
        Err(FitError::TooFewObservations { n: 2, p: 2 })
    ));
}
