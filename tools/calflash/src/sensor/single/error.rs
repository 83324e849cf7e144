//! Observations or a model the single-axis workflow cannot use.

use crate::columns as col;

/// Observations or a model the single-axis workflow cannot use.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SingleError {
    /// The file lacks the input or the output column.
    #[error("{}: missing the column `{column}` ({what}); the file has: {header}", path.display())]
    MissingColumn {
        /// The observations.
        path: std::path::PathBuf,
        /// The column.
        column: &'static str,
        /// What it holds.
        what: &'static str,
        /// The file's columns, listed.
        header: String,
    },
    /// A model of another response than the output counts.
    #[error(
        "--model `{model}`: the single-axis workflow's response is the `{output}` column (counts); fit models of other responses with `calflash fit`",
        output = col::OUTPUT
    )]
    Response {
        /// The model, as parsed.
        model: String,
    },
    /// A model without the input term.
    #[error(
        "--model `{model}`: without the term `{input}` the model has no scale factor, and the device has nothing to correct with",
        input = col::INPUT
    )]
    NoScaleFactor {
        /// The model, as parsed.
        model: String,
    },
    /// Asymmetry asked for about a breakpoint with too few inputs on one side.
    #[error(
        "{}: asymmetry about {breakpoint} is not observable: {below} inputs below and {above} above it; each side needs at least 2",
        path.display()
    )]
    Asymmetry {
        /// The observations.
        path: std::path::PathBuf,
        /// The breakpoint (SI).
        breakpoint: f64,
        /// Inputs below it.
        below: usize,
        /// Inputs at or above it.
        above: usize,
    },
    /// A term over a column the file does not have.
    #[error("{}: the model term {term} uses a column the file does not have", path.display())]
    TermColumn {
        /// The observations.
        path: std::path::PathBuf,
        /// The term.
        term: String,
    },
}
