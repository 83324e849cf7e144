use super::*;

fn grid(k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| -1.0 + 2.0 * i as f64 / (k - 1) as f64)
        .collect()
}

fn poly(xs: &[f64], degree: usize) -> DMatrix<f64> {
    DMatrix::from_fn(xs.len(), degree + 1, |i, j| xs[i].powi(j as i32))
}

fn counts(xs: &[f64], found: &Found) -> Vec<(f64, usize)> {
    let mut out: Vec<(f64, usize)> = Vec::new();
    for &k in &found.points {
        match out.last_mut() {
            Some((x, c)) if *x == xs[k] => *c += 1,
            _ => out.push((xs[k], 1)),
        }
    }
    out
}

fn opts(n: usize) -> Options {
    Options {
        n,
        restarts: 8,
        seed: 3,
    }
}

#[test]
fn a_line_puts_half_the_points_at_each_end() {
    let xs = grid(201);
    let f = poly(&xs, 1);
    for c in [Criterion::D, Criterion::A] {
        let found = optimize(&f, c, None, &opts(10), |_, _| {}).unwrap();
        assert_eq!(counts(&xs, &found), [(-1.0, 5), (1.0, 5)], "{c:?}");
    }
}

#[test]
fn a_quadratic_puts_a_third_at_each_end_and_the_middle() {
    let xs = grid(201);
    let f = poly(&xs, 2);
    let found = optimize(&f, Criterion::D, None, &opts(12), |_, _| {}).unwrap();
    assert_eq!(counts(&xs, &found), [(-1.0, 4), (0.0, 4), (1.0, 4)]);
}

#[test]
fn the_i_optimal_quadratic_puts_half_the_points_in_the_middle() {
    // Over a uniform region on [-1, 1] the I-optimal quadratic has weights 1/4, 1/2, 1/4.
    let xs = grid(201);
    let f = poly(&xs, 2);
    let w = f.transpose() * &f / xs.len() as f64;
    let found = optimize(&f, Criterion::I, Some(&w), &opts(12), |_, _| {}).unwrap();
    assert_eq!(counts(&xs, &found), [(-1.0, 3), (0.0, 6), (1.0, 3)]);
}

#[test]
fn a_cubic_reaches_the_known_d_optimum() {
    // The D-optimal cubic on [-1, 1]: a quarter at each of -1, -1/sqrt 5, 1/sqrt 5, 1.
    let xs = grid(2001);
    let f = poly(&xs, 3);
    let found = optimize(&f, Criterion::D, None, &opts(12), |_, _| {}).unwrap();
    let r = 1.0 / 5f64.sqrt();
    let optimum = poly(&[-1.0, -r, r, 1.0, -1.0, -r, r, 1.0, -1.0, -r, r, 1.0], 3);
    let det = |x: &DMatrix<f64>| (x.transpose() * x).determinant();
    let x = DMatrix::from_fn(12, 4, |i, j| f[(found.points[i], j)]);
    let efficiency = (det(&x) / det(&optimum)).powf(0.25);
    assert!(
        efficiency >= 0.999,
        "{efficiency}: {:?}",
        counts(&xs, &found)
    );
    for (x, c) in counts(&xs, &found) {
        assert_eq!(c, 3);
        assert!(
            [(-1.0f64), -r, r, 1.0]
                .iter()
                .any(|o| (o - x).abs() < 1.5e-3),
            "{x}"
        );
    }
}

#[test]
fn too_few_points_or_a_blind_candidate_set_are_refused() {
    let f = poly(&grid(11), 2);
    assert_eq!(
        optimize(&f, Criterion::D, None, &opts(2), |_, _| {}).unwrap_err(),
        ExchangeError::TooFew { n: 2, p: 3 }
    );
    let f = poly(&[-1.0, 1.0], 2);
    assert_eq!(
        optimize(&f, Criterion::D, None, &opts(6), |_, _| {}).unwrap_err(),
        ExchangeError::Singular { rank: 2, p: 3 }
    );
}
