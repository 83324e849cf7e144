//! Why a report or a figure cannot be drawn.

use plotters::drawing::DrawingAreaErrorKind;

/// A figure plotters cannot draw, one with nothing to draw, or a calibration the device's
/// correction refuses (the thermal report plays it back).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// plotters' drawing error (the SVG is written to a string, so it is a layout error).
    #[error(transparent)]
    Draw(#[from] DrawingAreaErrorKind<std::io::Error>),
    /// A figure whose every point is left out (on log axes, those at or below zero).
    #[error("{0}: nothing to draw")]
    Empty(String),
    /// The blob or the device's corrector refused the calibration.
    #[error(transparent)]
    Device(#[from] spincal::Error),
}
