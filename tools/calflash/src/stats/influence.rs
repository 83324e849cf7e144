//! Per-observation influence (Chatterjee and Hadi), all in closed form from the thin `Q` and
//! `A = D^-1 R^-1`: leverage `h_i = |q_i|^2`, `(X'X)^-1 x_i = A q_i`, and the leave-one-out
//! residual variance `s_(i)^2 = (RSS - e_i^2 / (1 - h_i)) / (n - p - 1)`.

use nalgebra::DMatrix;

use super::dist;

/// Influence measures of every observation. Where a measure is undefined (leverage 1: the
/// observation alone determines a coefficient) it is NaN.
#[derive(Debug, Clone)]
pub struct Influence {
    /// Hat-matrix diagonal.
    pub leverage: Vec<f64>,
    /// Internally studentized residuals `e_i / (s sqrt(1 - h_i))`.
    pub student_internal: Vec<f64>,
    /// Externally studentized residuals `e_i / (s_(i) sqrt(1 - h_i))`.
    pub student_external: Vec<f64>,
    /// Cook's distance.
    pub cooks_distance: Vec<f64>,
    /// DFFITS.
    pub dffits: Vec<f64>,
    /// DFBETAS, observations by terms.
    pub dfbetas: DMatrix<f64>,
    /// Observations whose externally studentized residual exceeds the Bonferroni-corrected t
    /// critical value at `alpha` (the outlier test), with their two-sided Bonferroni p-values.
    pub outliers: Vec<(usize, f64)>,
    /// Observations flagged as influential, with the rules that flagged them.
    pub influential: Vec<(usize, Vec<InfluenceRule>)>,
    /// The thresholds used.
    pub thresholds: Thresholds,
}

/// A rule that flags an observation as influential.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InfluenceRule {
    /// Leverage above `2 p / n`.
    Leverage,
    /// Cook's distance above the median of F(p, n - p).
    CooksDistance,
    /// |DFFITS| above `2 sqrt(p / n)`.
    Dffits,
}

/// The thresholds of the flags.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Thresholds {
    /// |externally studentized residual| above which an observation is an outlier.
    pub outlier: f64,
    /// Leverage above which an observation is a high-leverage point.
    pub leverage: f64,
    /// Cook's distance above which an observation is influential.
    pub cooks_distance: f64,
    /// |DFFITS| above which an observation is influential.
    pub dffits: f64,
}

pub(super) fn compute(
    q: &DMatrix<f64>,
    factor: &DMatrix<f64>,
    residuals: &[f64],
    rss: f64,
    dof: usize,
    p: usize,
    alpha: f64,
) -> Influence {
    let n = residuals.len();
    let s2 = rss / dof as f64;
    let pf = p as f64;
    // diag((X'X)^-1) = row sums of squares of A.
    let cjj: Vec<f64> = factor.row_iter().map(|r| r.norm_squared()).collect();
    let mut leverage = vec![0.0; n];
    let mut student_internal = vec![0.0; n];
    let mut student_external = vec![0.0; n];
    let mut cooks_distance = vec![0.0; n];
    let mut dffits = vec![0.0; n];
    let mut dfbetas = DMatrix::zeros(n, p);
    let mut qi = vec![0.0; p];
    let mut aq = vec![0.0; p];
    for i in 0..n {
        for (j, v) in qi.iter_mut().enumerate() {
            *v = q[(i, j)];
        }
        let h: f64 = qi.iter().map(|v| v * v).sum();
        let e = residuals[i];
        let one_h = 1.0 - h;
        let r = e / (s2 * one_h).sqrt();
        let s2_i = (rss - e * e / one_h) / (dof as f64 - 1.0);
        let t = e / (s2_i * one_h).sqrt();
        leverage[i] = h;
        student_internal[i] = r;
        student_external[i] = t;
        cooks_distance[i] = r * r * h / (pf * one_h);
        dffits[i] = t * (h / one_h).sqrt();
        // (X'X)^-1 x_i = A q_i; A is upper triangular.
        for (j, v) in aq.iter_mut().enumerate() {
            *v = (j..p).map(|k| factor[(j, k)] * qi[k]).sum();
        }
        let scale = e / one_h / s2_i.sqrt();
        for j in 0..p {
            dfbetas[(i, j)] = aq[j] * scale / cjj[j].sqrt();
        }
    }
    let nf = n as f64;
    let thresholds = Thresholds {
        outlier: dist::t_upper_quantile(alpha / (2.0 * nf), dof as f64 - 1.0),
        leverage: 2.0 * pf / nf,
        cooks_distance: dist::f_upper_quantile(0.5, pf, dof as f64),
        dffits: 2.0 * (pf / nf).sqrt(),
    };
    let outliers = outlier_test(&student_external, thresholds.outlier, dof);
    let influential = (0..n)
        .filter_map(|i| {
            let mut rules = Vec::new();
            if leverage[i] > thresholds.leverage {
                rules.push(InfluenceRule::Leverage);
            }
            if cooks_distance[i] > thresholds.cooks_distance {
                rules.push(InfluenceRule::CooksDistance);
            }
            if dffits[i].abs() > thresholds.dffits {
                rules.push(InfluenceRule::Dffits);
            }
            // High leverage alone is a property of the design, not of the data: an observation
            // is influential when its effect on the fit is large.
            let influential = rules.iter().any(|r| *r != InfluenceRule::Leverage);
            influential.then_some((i, rules))
        })
        .collect();
    Influence {
        leverage,
        student_internal,
        student_external,
        cooks_distance,
        dffits,
        dfbetas,
        outliers,
        influential,
        thresholds,
    }
}

/// The Bonferroni outlier test of externally studentized residuals on `dof` residual degrees of
/// freedom.
fn outlier_test(student_external: &[f64], threshold: f64, dof: usize) -> Vec<(usize, f64)> {
    let nf = student_external.len() as f64;
    student_external
        .iter()
        .enumerate()
        .filter(|(_, t)| t.abs() > threshold)
        .map(|(i, t)| (i, (nf * dist::t_two_sided(*t, dof as f64 - 1.0)).min(1.0)))
        .collect()
}

impl Influence {
    /// Studentizes `residuals` again, and tests them for outliers, where residual `i` has
    /// variance `s2 * variance[i]`: for a fit with sampling weights (the errors equal in
    /// variance, the rows weighted to even out where observations crowd) the weighted fit's own
    /// studentized residuals would treat a heavily weighted observation's residual as that
    /// many times larger. The externally studentized residual uses the leave-one-out variance
    /// `s2 (dof - r^2) / (dof - 1)`, exact for least squares and close for a weighted fit.
    pub fn restudentize(&mut self, residuals: &[f64], variance: &[f64], s2: f64, dof: usize) {
        let d = dof as f64;
        for (i, (e, v)) in residuals.iter().zip(variance).enumerate() {
            let r = e / (s2 * v).sqrt();
            self.student_internal[i] = r;
            self.student_external[i] = r * ((d - 1.0) / (d - r * r)).max(0.0).sqrt();
        }
        self.outliers = outlier_test(&self.student_external, self.thresholds.outlier, dof);
    }
}
