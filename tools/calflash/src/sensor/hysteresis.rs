//! Hysteresis: the separation of the output between ascending and descending inputs. The test
//! itself is part of the single-axis workflow (an offset by direction, partial F test); this
//! module gives the figure's data.

use super::AxisFit;

/// `(input, residual)` pairs.
pub type Points = Vec<(f64, f64)>;

/// Residuals of the fit (which has no direction term), split by sweep direction:
/// `(ascending, descending)`, each as `(input, residual)` pairs; `None` without directions.
#[must_use]
pub fn by_direction(fit: &AxisFit) -> Option<(Points, Points)> {
    let dir = fit.dir.as_ref()?;
    let mut up = Vec::new();
    let mut down = Vec::new();
    for ((x, e), d) in fit.input.iter().zip(&fit.fit.residuals).zip(dir) {
        if *d > 0.0 {
            up.push((*x, *e));
        } else if *d < 0.0 {
            down.push((*x, *e));
        }
    }
    (!up.is_empty() && !down.is_empty()).then_some((up, down))
}
