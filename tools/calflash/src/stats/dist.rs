//! Tail probabilities and quantiles of the t, F, chi-square and normal distributions, computed
//! from the regularised incomplete beta and gamma functions so that tiny p-values keep their
//! relative precision. Every upper quantile is finite for every tail in `(0, 0.5]`, down to the
//! smallest `f64` (a level of 1e-300 is a threshold, not a NaN): where `1 - upper` rounds to 1,
//! the quantile is found by bisection on the tail itself.

use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF, StudentsT};
use statrs::function::beta::beta_reg;

/// Two-sided p-value of a t statistic with `dof` degrees of freedom: `P(|T| >= |t|)`.
#[must_use]
pub fn t_two_sided(t: f64, dof: f64) -> f64 {
    if t.is_nan() {
        return f64::NAN;
    }
    if t.is_infinite() {
        return 0.0;
    }
    beta_reg(dof / 2.0, 0.5, dof / (dof + t * t))
}

/// Upper tail `P(F >= f)` of the F distribution with `(d1, d2)` degrees of freedom.
#[must_use]
pub fn f_upper(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    // P(F >= f) = I_{d2 / (d2 + d1 f)}(d2/2, d1/2), written without 1 - x cancellation.
    beta_reg(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f))
}

/// Two-sided p-value of a standard normal statistic (libm's `erfc`, accurate to an ulp or so;
/// statrs' is good to only about 1e-10).
#[must_use]
pub fn normal_two_sided(z: f64) -> f64 {
    libm::erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The `t` with `P(T >= t) = upper` for `dof` degrees of freedom (`0 < upper <= 0.5`), polished
/// by Newton steps on the tail so that it is accurate to a few ulp.
#[must_use]
pub fn t_upper_quantile(upper: f64, dof: f64) -> f64 {
    // Without a degree of freedom there is no distribution: nothing lies beyond its quantile.
    let Ok(dist) = StudentsT::new(0.0, 1.0, dof) else {
        return f64::INFINITY;
    };
    if upper < 1e-12 {
        return by_bisection(upper, |t| 0.5 * t_two_sided(t, dof));
    }
    let mut t = dist.inverse_cdf(1.0 - upper);
    for _ in 0..4 {
        let tail = 0.5 * t_two_sided(t, dof);
        let step = (tail - upper) / dist.pdf(t);
        t += step;
        if step.abs() <= 1e-15 * t.abs() {
            break;
        }
    }
    t
}

/// The F quantile with upper tail `upper`, by bisection on [`f_upper`] (used for thresholds only).
#[must_use]
pub fn f_upper_quantile(upper: f64, d1: f64, d2: f64) -> f64 {
    by_bisection(upper, |f| f_upper(f, d1, d2))
}

/// The chi-square quantile with upper tail `upper` for `dof` degrees of freedom: the inverse
/// of the cdf where that is exact, else by bisection on the upper tail (the regularised upper
/// incomplete gamma, accurate for tiny tails).
#[must_use]
pub fn chi2_upper_quantile(upper: f64, dof: f64) -> f64 {
    let Ok(dist) = ChiSquared::new(dof) else {
        return f64::NAN;
    };
    if upper >= 1e-10 {
        return dist.inverse_cdf(1.0 - upper);
    }
    by_bisection(upper, |x| dist.sf(x))
}

/// The `x >= 0` at which the decreasing upper tail `tail(x)` equals `upper`: the bracket
/// doubles from 1 (finite to the largest `f64`), then is bisected to a relative 1e-14.
fn by_bisection(upper: f64, tail: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while tail(hi) > upper && hi < f64::MAX / 2.0 {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..2200 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > upper {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_stay_finite_and_ordered_for_tiny_tails() {
        let mut last = [0.0f64; 3];
        for e in [3, 10, 13, 15, 17, 30, 100, 300] {
            let upper = 10f64.powi(-e);
            let q = [
                t_upper_quantile(upper, 12.0),
                chi2_upper_quantile(upper, 6.0),
                f_upper_quantile(upper, 3.0, 20.0),
            ];
            for (k, (v, before)) in q.iter().zip(&last).enumerate() {
                assert!(
                    v.is_finite() && v > before,
                    "1e-{e}, quantile {k}: {v} after {before}"
                );
            }
            last = q;
        }
        // Where both ways apply they agree.
        for upper in [1e-9, 1e-11] {
            let dist = ChiSquared::new(6.0).unwrap();
            let a = dist.inverse_cdf(1.0 - upper);
            let b = by_bisection(upper, |x| dist.sf(x));
            assert!((a - b).abs() < 1e-5 * a, "{upper}: {a} {b}");
        }
        let t = StudentsT::new(0.0, 1.0, 12.0).unwrap();
        let a = t_upper_quantile(1e-12, 12.0);
        assert!((t.sf(a) - 1e-12).abs() < 1e-16, "{}", t.sf(a));
    }

    #[test]
    fn known_values() {
        // t(10): P(|T| >= 2.228138851986) = 0.05.
        assert!((t_two_sided(2.228_138_851_986, 10.0) - 0.05).abs() < 1e-12);
        assert!((t_upper_quantile(0.025, 10.0) - 2.228_138_851_986_274).abs() < 1e-12);
        assert!((t_upper_quantile(0.025, 1e6) - 1.959_966_4).abs() < 1e-6);
        // F(3, 20): P(F >= 3.098391) = 0.05.
        assert!((f_upper(3.098_391_212_4, 3.0, 20.0) - 0.05).abs() < 1e-9);
        assert!((f_upper_quantile(0.05, 3.0, 20.0) - 3.098_391_212_4).abs() < 1e-8);
        let p = normal_two_sided(1.959_963_984_540_054);
        assert!((p - 0.05).abs() < 1e-12, "{p}");
        // Far tails keep relative precision instead of rounding to 0.
        let p = t_two_sided(50.0, 100.0);
        assert!(p > 0.0 && p < 1e-70, "{p}");
        assert!(f_upper(1e6, 2.0, 100.0) > 0.0);
    }
}
