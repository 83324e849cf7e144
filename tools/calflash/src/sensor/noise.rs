//! Where a fit's noise figure comes from: the residuals, or a reference the user gives (a rest
//! recording, a datasheet), and the reference as read.

/// The noise of a fit's observations estimated without its model's form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseReference {
    /// The estimate, in the response's units.
    pub noise: crate::stats::pure_error::Noise,
    /// Where it comes from.
    pub source: NoiseSource,
}

/// Where a [`NoiseReference`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseSource {
    /// Repeated observations of one condition (pure error).
    Replicates,
    /// The observations at rest (no rate, no angular acceleration), fitted alone.
    Rest,
}

impl NoiseSource {
    /// In words, for a finding.
    #[must_use]
    pub(super) fn words(self) -> &'static str {
        match self {
            Self::Replicates => "its repeated observations",
            Self::Rest => "its observations at rest fitted alone",
        }
    }
}

/// The noise of `table`'s observations without the model's form: the pure
/// error of replicated rows, else the rows at rest fitted alone when some rows turn.
/// `(x, y)` are the design's rows and response.
pub(super) fn noise_reference(
    (x, y): (&nalgebra::DMatrix<f64>, &[f64]),
    table: &crate::obs::Table,
) -> Option<NoiseReference> {
    use crate::stats::pure_error;
    if let Some(noise) = pure_error::replicates(x, y) {
        return Some(NoiseReference {
            noise,
            source: NoiseSource::Replicates,
        });
    }
    let motion: Vec<&[f64]> = crate::columns::W
        .iter()
        .chain(&crate::columns::DW)
        .filter_map(|c| table.column(c))
        .collect();
    if motion.is_empty() {
        return None;
    }
    let rest: Vec<usize> = (0..table.len())
        .filter(|&r| motion.iter().all(|c| c[r] == 0.0))
        .collect();
    if rest.len() == table.len() {
        return None;
    }
    pure_error::subset(x, y, &rest).map(|noise| NoiseReference {
        noise,
        source: NoiseSource::Rest,
    })
}
