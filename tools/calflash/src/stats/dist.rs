//! Tail probabilities and quantiles of the t, F and normal distributions, computed from the
//! regularised incomplete beta function so that tiny p-values keep their relative precision.

use statrs::distribution::{Continuous, ContinuousCDF, StudentsT};
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
    let dist = StudentsT::new(0.0, 1.0, dof).expect("dof > 0");
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
    let (mut lo, mut hi) = (0.0, 1.0);
    while f_upper(hi, d1, d2) > upper {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f_upper(mid, d1, d2) > upper {
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
