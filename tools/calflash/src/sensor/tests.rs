use super::*;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

#[test]
fn a_weighted_fits_outlier_test_treats_heavy_and_light_rows_alike() {
    // Equal errors; a fifth of the rows weighted 3.4, the rest 0.4 (mean 1), as a ramp
    // that crowds at one end is weighted. The studentized residuals of both kinds of row
    // have unit variance; the weighted fit's own would give the heavy ones 3.4.
    let n = 2000;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let x: Vec<f64> = (0..n).map(|i| i as f64 / n as f64).collect();
    let y: Vec<f64> = x
        .iter()
        .map(|x| 1.0 + 2.0 * x + noise.sample(&mut rng))
        .collect();
    let w: Vec<f64> = (0..n).map(|i| if i % 5 == 0 { 3.4 } else { 0.4 }).collect();
    let table = crate::obs::Table {
        path: "w.csv".into(),
        names: vec!["input".into(), "output".into()],
        columns: vec![x, y],
        lines: (2..n as u64 + 2).collect(),
    };
    let f = crate::formula::parse("output ~ 1 + input").unwrap();
    let fit = AxisFit::fit_weighted(
        &f,
        &table,
        "input",
        0.05,
        (Path::new("w.csv"), "all"),
        false,
        Some(&w),
    )
    .unwrap();
    let r = &fit.fit.influence.student_internal;
    let var = |heavy: bool| {
        let v: Vec<f64> = (0..n)
            .filter(|i| (i % 5 == 0) == heavy)
            .map(|i| r[i] * r[i])
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (heavy, light) = (var(true), var(false));
    assert!((heavy - 1.0).abs() < 0.15, "heavy rows: {heavy}");
    assert!((light - 1.0).abs() < 0.1, "light rows: {light}");
    assert!(fit.fit.influence.outliers.len() <= 1);
}
