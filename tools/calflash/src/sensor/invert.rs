//! From a fitted forward model to the correction the device applies.
//!
//! One axis's forward model, in counts, is
//! `out(x) = bias + slope x + c2 x^2 + c3 x^3 + coq x|x| + ca (|x - bp| - |bp|)`. The device
//! (see `spincal::model`) linearises the raw code first, `u = v + q v^2 + k v^3 + o v|v| +
//! s |v - b|` with `v = out - center`, then applies an affine map. The linearisation must
//! carry `v` to the linear part of the forward model, `L(x) = bias - center + slope x`; its
//! coefficients are fitted by least squares over a dense grid of the calibrated range, and the
//! worst error on a finer grid is the inversion error reported against the residual noise.

use nalgebra::{DMatrix, DVector, Matrix3};

/// One axis's own forward polynomial (counts).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Own {
    /// Output at zero input.
    pub bias: f64,
    /// Counts per SI unit.
    pub slope: f64,
    /// Coefficient of x^2 (counts / SI^2).
    pub c2: f64,
    /// Coefficient of x^3.
    pub c3: f64,
    /// Coefficient of x|x|.
    pub coq: f64,
    /// Coefficient of the kink `|x - bp| - |bp|` (asymmetric scale).
    pub ca: f64,
    /// The asymmetry breakpoint, SI.
    pub bp: f64,
}

impl Own {
    /// The output for input `x`.
    #[must_use]
    pub fn output(&self, x: f64) -> f64 {
        self.bias
            + self.slope * x
            + self.c2 * x * x
            + self.c3 * x * x * x
            + self.coq * x * x.abs()
            + self.ca * ((x - self.bp).abs() - self.bp.abs())
    }

    /// The input whose output is `out` (Newton's method from `guess`): the exact inverse the
    /// device's correction approximates.
    #[must_use]
    pub fn input_for(&self, out: f64, guess: f64) -> f64 {
        let mut x = guess;
        for _ in 0..50 {
            let h = 1e-4 * (1.0 + x.abs());
            let d = (self.output(x + h) - self.output(x - h)) / (2.0 * h);
            let step = (self.output(x) - out) / d;
            if !step.is_finite() {
                break;
            }
            x -= step;
            if step.abs() <= 1e-13 * (1.0 + x.abs()) {
                break;
            }
        }
        x
    }

    fn is_linear(&self) -> bool {
        self.c2 == 0.0 && self.c3 == 0.0 && self.coq == 0.0 && self.ca == 0.0
    }
}

/// The device's linearisation `[q, k, o, s, b]` (as `spincal::model::AxisNonlinearity`).
pub type Linearization = [f64; 5];

/// `u(v)` in f64, exactly the device's formula.
#[must_use]
pub fn linearize(n: &Linearization, v: f64) -> f64 {
    let [q, k, o, s, b] = *n;
    v + v * (v * (q + k * v) + o * v.abs()) + s * (v - b).abs()
}

fn grid(lo: f64, hi: f64, n: usize, extra: f64) -> Vec<f64> {
    let mut g: Vec<f64> = (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect();
    if extra > lo && extra < hi {
        g.push(extra);
    }
    g
}

/// A fitted linearisation: `L(x) ~ alpha + gamma u(out(x) - center)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    /// The device's coefficients.
    pub n: Linearization,
    /// Constant of the affine map.
    pub alpha: f64,
    /// Slope of the affine map.
    pub gamma: f64,
    /// Worst error over the calibrated range, SI units (counts / slope).
    pub error: f64,
}

/// Fits the linearisation of `own` over `[lo, hi]` around `center`.
#[must_use]
pub fn linearization(own: &Own, center: f64, lo: f64, hi: f64) -> Fitted {
    let lin = |x: f64| own.bias - center + own.slope * x;
    if own.is_linear() {
        let n = [0.0; 5];
        return Fitted {
            n,
            alpha: 0.0,
            gamma: 1.0,
            error: max_error(own, center, lo, hi, &n, 0.0, 1.0, lin),
        };
    }
    let vb = own.output(own.bp) - center;
    let xs = grid(lo, hi, 2001, own.bp);
    let vs: Vec<f64> = xs.iter().map(|x| own.output(*x) - center).collect();
    let scale = vs.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1.0);
    // Columns in v / scale so that v^3 and v stay comparable; rescaled after.
    type Col = (usize, fn(f64, f64) -> f64);
    let mut cols: Vec<Col> = Vec::new();
    if own.c2 != 0.0 {
        cols.push((0, |w, _| w * w));
    }
    // The inverse of a quadratic or odd-quadratic term has a cubic term of its own
    // (`z + a z^2` inverts to `v - a v^2 + 2 a^2 v^3 - ...`), so the cubic column goes in with
    // any of them.
    if own.c2 != 0.0 || own.c3 != 0.0 || own.coq != 0.0 {
        cols.push((1, |w, _| w * w * w));
    }
    if own.coq != 0.0 {
        cols.push((2, |w, _| w * w.abs()));
    }
    if own.ca != 0.0 {
        cols.push((3, |w, wb| (w - wb).abs()));
    }
    let wb = vb / scale;
    // L ~ alpha + gamma v + sum d_k term_k(v): columns 1, w, then the nonlinear terms.
    let a = DMatrix::from_fn(xs.len(), cols.len() + 2, |i, j| match j {
        0 => 1.0,
        1 => vs[i] / scale,
        _ => (cols[j - 2].1)(vs[i] / scale, wb),
    });
    let b = DVector::from_iterator(xs.len(), xs.iter().map(|x| lin(*x)));
    let sol = crate::stats::decompose::svd(a, true, true)
        .ok()
        .and_then(|svd| svd.solve(&b, 1e-14).ok())
        .unwrap_or_else(|| DVector::zeros(cols.len() + 2));
    let alpha = sol[0];
    let gamma = sol[1] / scale;
    let mut n = [0.0, 0.0, 0.0, 0.0, vb];
    for (j, (which, _)) in cols.iter().enumerate() {
        let d = sol[j + 2]
            / match which {
                0 | 2 => scale * scale,
                1 => scale * scale * scale,
                _ => scale,
            };
        n[*which] = d / gamma;
    }
    if own.ca == 0.0 {
        n[4] = 0.0;
    }
    Fitted {
        n,
        alpha,
        gamma,
        error: max_error(own, center, lo, hi, &n, alpha, gamma, lin),
    }
}

/// A triad's fitted forward model: axis `i` senses `s_i . x` (counts, `s_i` row `i` of `s`)
/// and outputs `own[i].output(z_i / S_ii)` (`spincal::model::rotation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriadForward {
    /// Scale-misalignment matrix, counts per SI unit.
    pub s: Matrix3<f64>,
    /// Each axis' own polynomial in what it senses (SI).
    pub own: [Own; 3],
}

/// A triad's correction as the device applies it, in f64: `u = linearize(out - center)`,
/// `y = m u + off`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriadDevice {
    /// Per-axis linearisation.
    pub lins: [Linearization; 3],
    /// Per-axis zero-input code.
    pub centers: [f64; 3],
    /// The device's matrix.
    pub m: Matrix3<f64>,
    /// The device's offset.
    pub off: [f64; 3],
}

/// The inversion check of a triad: the worst `|y - x|` per output over 1000 points spread
/// through the box `ranges` (SI), each sensed through the forward model and corrected by the
/// device's form. It must be far below the noise; a correction that is not the inverse of the
/// fitted model (a missing term, a wrong axis) shows here.
#[must_use]
pub fn triad_inversion_error(
    fwd: &TriadForward,
    dev: &TriadDevice,
    ranges: &[(f64, f64); 3],
) -> [f64; 3] {
    let s = &fwd.s;
    let mut err = [0.0f64; 3];
    for k in 0..1000u32 {
        let x: [f64; 3] = std::array::from_fn(|j| {
            let frac = (f64::from(k) * [0.618_034, 0.754_878, 0.569_840][j]).fract();
            ranges[j].0 + (ranges[j].1 - ranges[j].0) * frac
        });
        let u: [f64; 3] = std::array::from_fn(|i| {
            let z: f64 = (0..3).map(|j| s[(i, j)] * x[j]).sum();
            let out = fwd.own[i].output(z / s[(i, i)]);
            linearize(&dev.lins[i], out - dev.centers[i])
        });
        for i in 0..3 {
            let y = dev.off[i] + (0..3).map(|j| dev.m[(i, j)] * u[j]).sum::<f64>();
            err[i] = err[i].max((y - x[i]).abs());
        }
    }
    err
}

#[allow(clippy::too_many_arguments)]
fn max_error(
    own: &Own,
    center: f64,
    lo: f64,
    hi: f64,
    n: &Linearization,
    alpha: f64,
    gamma: f64,
    lin: impl Fn(f64) -> f64,
) -> f64 {
    grid(lo, hi, 5_001, own.bp)
        .iter()
        .map(|x| (alpha + gamma * linearize(n, own.output(*x) - center) - lin(*x)).abs())
        .fold(0.0, f64::max)
        / own.slope.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_and_cubic_are_inverted_far_below_a_count() {
        let own = Own {
            bias: 32_900.0,
            slope: 408.0,
            c2: 408.0 * 1.5e-4,
            c3: -408.0 * 2e-6,
            ..Own::default()
        };
        // At a table point whose bias is 40 counts off the center.
        let f = linearization(&own, 32_860.0, -20.0, 20.0);
        let n = f.n;
        assert!(n[0] != 0.0 && n[1] != 0.0 && n[2] == 0.0 && n[3] == 0.0);
        // The forward nonlinearity is 0.3% of full scale; the inverse leaves a few micro-g.
        assert!(f.error < 1e-4, "{f:?}");
        let lin_only = Own {
            c2: 0.0,
            c3: 0.0,
            ..own
        };
        let f = linearization(&lin_only, 32_900.0, -50.0, 50.0);
        assert_eq!((f.n, f.alpha, f.gamma), ([0.0; 5], 0.0, 1.0));
        assert!(f.error < 1e-12);
    }

    #[test]
    fn a_g_squared_term_alone_is_inverted_with_its_cubic() {
        // A high-rate gyro axis with only K2: 17 counts per rad/s over +-1900 rad/s, K2 of
        // 1e-6 /(rad/s) (0.2% at full scale). Without the inverse's cubic term the device's
        // correction is off by about 1e-2 rad/s at the ends of the range.
        let own = Own {
            bias: 32_768.0,
            slope: 17.0,
            c2: 17.0 * 1e-6,
            ..Own::default()
        };
        let f = linearization(&own, 32_768.0, -1900.0, 1900.0);
        assert!(f.n[1] != 0.0, "{f:?}");
        assert!(f.error < 1e-4, "{f:?}");
        // The quadratic-only inverse, for contrast.
        let q_only = max_error(
            &own,
            32_768.0,
            -1900.0,
            1900.0,
            &[f.n[0], 0.0, 0.0, 0.0, 0.0],
            f.alpha,
            f.gamma,
            |x| own.bias - 32_768.0 + own.slope * x,
        );
        assert!(q_only > 100.0 * f.error, "{q_only} vs {}", f.error);
    }

    #[test]
    fn the_triad_check_passes_the_inverse_and_catches_a_wrong_correction() {
        // A high-rate gyro triad with misalignment and K2 on every axis, +-1900 rad/s.
        let k = 16.4;
        let s = Matrix3::new(
            k * 0.999,
            k * 2.5e-3,
            k * 1.0e-3,
            -k * 2.0e-3,
            k * 1.002,
            k * 3.0e-3,
            k * 1.5e-3,
            -k * 2.2e-3,
            k * 1.001,
        );
        let own: [Own; 3] = std::array::from_fn(|i| Own {
            bias: 32_768.0 + [3.0, -4.0, 1.5][i],
            slope: s[(i, i)],
            c2: s[(i, i)] * [1.0e-6, -0.8e-6, 0.6e-6][i],
            ..Own::default()
        });
        let ranges = [(-1900.0, 1900.0); 3];
        let centers: [f64; 3] = std::array::from_fn(|i| own[i].bias);
        // Each axis senses up to |s_i| times the box (cross-axis included).
        let fitted: [Fitted; 3] = std::array::from_fn(|i| {
            let reach: f64 = (0..3).map(|j| s[(i, j)].abs() * 1900.0).sum::<f64>() / s[(i, i)];
            linearization(&own[i], centers[i], -reach, reach)
        });
        let inv = s.try_inverse().unwrap();
        let dev = TriadDevice {
            lins: fitted.map(|f| f.n),
            centers,
            m: Matrix3::from_fn(|i, j| inv[(i, j)] * fitted[j].gamma),
            off: std::array::from_fn(|i| (0..3).map(|k| inv[(i, k)] * fitted[k].alpha).sum()),
        };
        let fwd = TriadForward { s, own };
        let good = triad_inversion_error(&fwd, &dev, &ranges);
        assert!(good.iter().all(|e| *e < 1e-3), "{good:?}");
        // Without the inverse's cubic term: off by about 1e-2 rad/s at the ends.
        let mut no_cubic = dev;
        for l in &mut no_cubic.lins {
            l[1] = 0.0;
        }
        let bad = triad_inversion_error(&fwd, &no_cubic, &ranges);
        assert!(bad.iter().all(|e| *e > 3e-3), "{bad:?}");
        // A linearisation applied to the wrong axis.
        let mut swapped = dev;
        swapped.lins.swap(0, 1);
        let bad = triad_inversion_error(&fwd, &swapped, &ranges);
        assert!(bad[0] > 1e-2 && bad[1] > 1e-2, "{bad:?}");
    }

    #[test]
    fn asymmetric_scale_is_a_kink_in_the_linearisation() {
        let own = Own {
            bias: 32_768.0,
            slope: 900.0,
            ca: 900.0 * 2e-3,
            bp: 0.5,
            ..Own::default()
        };
        let f = linearization(&own, 32_768.0, -30.0, 30.0);
        assert!((f.n[3] + 2e-3).abs() < 1e-5, "{f:?}");
        assert!((f.n[4] - (own.output(0.5) - 32_768.0)).abs() < 1e-9);
        assert!(f.error < 1e-6, "{f:?}");
    }
}
