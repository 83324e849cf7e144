//! Upper quantiles of the normal and chi-square distributions, for the health check's
//! thresholds. Computed in double precision when a threshold is needed (when the monitor is
//! built, and at a checkpoint), never per sample.

/// The upper-tail standard normal quantile: `z` with `P(Z > z) = q`, for `q` in `(0, 1)`.
/// Acklam's rational approximation refined by one Halley step on `erfc` (error below
/// `1e-12` over `q` in `[1e-300, 1 - 1e-16]`).
pub(super) fn normal_upper(q: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    // The lower-tail quantile x = Phi^-1(q), then z = -x.
    let q = q.clamp(1e-300, 1.0 - 1e-16);
    let tail = |t: f64| {
        let r = libm::sqrt(-2.0 * libm::log(t));
        let [c0, c1, c2, c3, c4, c5] = C;
        let [d0, d1, d2, d3] = D;
        (((((c0 * r + c1) * r + c2) * r + c3) * r + c4) * r + c5)
            / ((((d0 * r + d1) * r + d2) * r + d3) * r + 1.0)
    };
    let mut x = if q < 0.024_25 {
        tail(q)
    } else if q > 1.0 - 0.024_25 {
        -tail(1.0 - q)
    } else {
        let s = q - 0.5;
        let r = s * s;
        let [a0, a1, a2, a3, a4, a5] = A;
        let [b0, b1, b2, b3, b4] = B;
        (((((a0 * r + a1) * r + a2) * r + a3) * r + a4) * r + a5) * s
            / (((((b0 * r + b1) * r + b2) * r + b3) * r + b4) * r + 1.0)
    };
    // One Halley step: Phi(x) = erfc(-x / sqrt 2) / 2 keeps its precision in the lower tail.
    let e = 0.5 * libm::erfc(-x / core::f64::consts::SQRT_2) - q;
    let u = e * libm::sqrt(2.0 * core::f64::consts::PI) * libm::exp(0.5 * x * x);
    x -= u / (1.0 + 0.5 * x * u);
    -x
}

/// The upper quantile of chi-square with one degree of freedom: `P(X > x) = q`.
pub(super) fn chi2_1_upper(q: f64) -> f64 {
    let z = normal_upper(0.5 * q);
    z * z
}

/// The upper quantile of chi-square with `k` degrees of freedom, by Wilson and Hilferty's
/// cube-root normal approximation (relative error below 1 % for `k >= 6` and `q >= 1e-6`).
pub(super) fn chi2_upper(k: f64, q: f64) -> f64 {
    let v = 2.0 / (9.0 * k);
    let c = 1.0 - v + normal_upper(q) * libm::sqrt(v);
    k * c * c * c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantiles_match_tables() {
        // Abramowitz and Stegun, table 26.5, and scipy.stats.norm.isf.
        for (q, z) in [
            (0.5, 0.0),
            (0.025, 1.959_963_984_540_054),
            (1e-3, 3.090_232_306_167_813),
            (1e-6, 4.753_424_308_822_899),
            (0.975, -1.959_963_984_540_054),
        ] {
            assert!(
                (normal_upper(q) - z).abs() < 1e-9,
                "{q}: {}",
                normal_upper(q)
            );
        }
    }

    #[test]
    fn chi_square_quantiles_match_tables() {
        // scipy.stats.chi2.isf.
        assert!((chi2_1_upper(1e-3) - 10.827_566_170_662_733).abs() < 1e-8);
        assert!((chi2_1_upper(0.05) - 3.841_458_820_694_124).abs() < 1e-8);
        let x = chi2_upper(63.0, 1e-3);
        assert!((x / 103.442_315_695_7 - 1.0).abs() < 0.01, "{x}");
        let x = chi2_upper(6.0, 1e-3);
        assert!((x / 22.457_744_484_825_33 - 1.0).abs() < 0.01, "{x}");
    }
}
