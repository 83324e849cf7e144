//! The timestamps of a recording: its own, checked against a stated rate (`--sample-rate`, a logger's
//! preamble), or made from that rate.

use std::path::Path;

use super::RecordingError;
use crate::obs::layout;

/// The timestamps of a file: its own (taken out of `rows`), checked against a stated rate, or
/// made from the rate.
pub(super) fn timing(
    rows: &mut layout::Rows,
    path: &Path,
    rate: Option<f64>,
) -> Result<Vec<f64>, RecordingError> {
    let pre = rows.preamble.rate;
    let conflict = |line: usize, what: String| RecordingError::RateConflict {
        path: path.to_path_buf(),
        line,
        what,
    };
    let differ = |a: f64, b: f64| (a - b).abs() > 0.01 * b.abs();
    if let (Some(r), Some(p)) = (rate, pre)
        && differ(r, p.value)
    {
        return Err(conflict(
            p.line,
            format!(
                "the preamble states {} Hz and --sample-rate {r} Hz; drop --sample-rate or fix the file",
                p.value
            ),
        ));
    }
    let stated = rate
        .map(|r| (r, "--sample-rate".to_string()))
        .or_else(|| pre.map(|p| (p.value, format!("the preamble (line {})", p.line))));
    if let Some((r, _)) = stated
        && !(r.is_finite() && r > 0.0)
    {
        return Err(conflict(
            pre.map_or(rows.line[0] as usize, |p| p.line),
            format!("a sample rate of {r} Hz; expected a number above 0"),
        ));
    }
    match (rows.t.take(), stated) {
        (Some(t), Some((r, who))) if t.len() > 1 => {
            let period = median_step(&t);
            if differ(1.0 / period, r) {
                return Err(conflict(
                    rows.line[0] as usize,
                    format!(
                        "the timestamps step by {period} s ({:.4} Hz) where {who} states {r} Hz",
                        1.0 / period
                    ),
                ));
            }
            Ok(t)
        }
        (Some(t), _) => Ok(t),
        (None, Some((r, _))) => Ok((0..rows.len()).map(|k| k as f64 / r).collect()),
        (None, None) => Err(RecordingError::NoRate {
            path: path.to_path_buf(),
        }),
    }
}

/// The median step between timestamps, s (NaN for fewer than two).
pub(super) fn median_step(t: &[f64]) -> f64 {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return f64::NAN;
    }
    let mid = steps.len() / 2;
    *steps.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Says what a file's preamble gave.
pub(super) fn note_preamble(path: &Path, p: &layout::Preamble) {
    let mut used = Vec::new();
    if let Some(r) = p.rate {
        used.push(format!("a rate of {} Hz (line {})", r.value, r.line));
    }
    if let Some(r) = p.rest {
        used.push(format!(
            "an initial rest of {} s (line {})",
            r.value, r.line
        ));
    }
    if used.is_empty() && p.ignored.is_empty() {
        return;
    }
    let mut text = format!("calflash: note: {}: a logger's preamble", path.display());
    if !used.is_empty() {
        text.push_str(&format!(" states {}", used.join(" and ")));
    }
    if !p.ignored.is_empty() {
        text.push_str(&format!("; not used: {}", p.ignored.join(", ")));
    }
    eprintln!("{text}");
}
