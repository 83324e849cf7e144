//! The timestamps of a recording: its own (in the unit its steps show where its name states
//! none), checked against a stated rate (`--sample-rate`, a logger's preamble), or made from that
//! rate.

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
    if rows.counter {
        return by_counter(rows, path, stated);
    }
    let own = rows.t.take().map(|t| {
        if rows.t_stated {
            t
        } else {
            unit_from_steps(t, path)
        }
    });
    match (own, stated) {
        // --sample-rate is the user's word over the file's own timestamps (a logger's host
        // stamps samples as its radio delivers them, in batches): the samples are taken as
        // evenly spaced from the first timestamp, and said so.
        (Some(t), Some((r, _))) if t.len() > 1 && rate.is_some() => {
            let period = median_step(&t);
            if differ(1.0 / period, r) {
                eprintln!(
                    "calflash: note: {}: --sample-rate {r} Hz over the file's timestamps ({}): the samples are taken as evenly spaced from its first timestamp",
                    path.display(),
                    describe(&t)
                );
                return Ok((0..t.len()).map(|k| t[0] + k as f64 / r).collect());
            }
            Ok(t)
        }
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

/// The rates a time column may be sampled at when its unit is read from its steps, Hz: an
/// inertial sensor's, and far enough apart that one unit only (of s, ms, us, ns, a thousand
/// apart) puts a recording's rate among them.
const STEP_READ_RATES: std::ops::Range<f64> = 1.0..50_000.0;

/// A time column whose name states no unit (`TIME`, `timestamp`), read as seconds: kept where
/// its steps are a rate in seconds; where they are not (a logger's microseconds step by 10,000
/// at 100 Hz), read in the one unit of ms, us, ns whose rate lies in [`STEP_READ_RATES`], and
/// said. Left as read where no unit or more than one does (the rate's check then names it).
fn unit_from_steps(t: Vec<f64>, path: &Path) -> Vec<f64> {
    if t.len() < 2 {
        return t;
    }
    let step = median_step(&t);
    if step <= 10.0 {
        return t;
    }
    let fits: Vec<(&str, f64)> = [("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)]
        .into_iter()
        .filter(|(_, s)| STEP_READ_RATES.contains(&(1.0 / (step * s))))
        .collect();
    let [(unit, scale)] = fits[..] else {
        return t;
    };
    eprintln!(
        "calflash: note: {}: the time column states no unit and steps by {step} (as seconds, {:.3e} Hz): read as {unit}, {:.2} Hz; name its unit (--columns t=NAME:s) if it is another",
        path.display(),
        1.0 / step,
        1.0 / (step * scale)
    );
    t.into_iter().map(|x| x * scale).collect()
}

/// The times of `rows` whose time column is a sample counter, at the `stated` rate (and who
/// stated it), said on stderr with the samples the count shows dropped.
fn by_counter(
    rows: &mut layout::Rows,
    path: &Path,
    stated: Option<(f64, String)>,
) -> Result<Vec<f64>, RecordingError> {
    let conflict = |line: u32, what: String| RecordingError::RateConflict {
        path: path.to_path_buf(),
        line: line as usize,
        what,
    };
    let Some(counter) = rows.t.take() else {
        return Err(RecordingError::NoRate {
            path: path.to_path_buf(),
        });
    };
    let Some((r, who)) = stated else {
        return Err(conflict(
            rows.line[0],
            "the sample counter (--columns index=) counts samples: give --sample-rate to time them"
                .into(),
        ));
    };
    let t = counted(&counter, r).map_err(|k| {
        conflict(
            rows.line[k],
            format!(
                "the sample counter goes from {} to {}: a counter steps up by one a sample (or wraps to 0)",
                counter[k - 1],
                counter[k]
            ),
        )
    })?;
    let dropped = (t[t.len() - 1] - t[0]) * r + 1.0 - t.len() as f64;
    eprintln!(
        "calflash: note: {}: timed by its sample counter at {r} Hz ({who}): {}",
        path.display(),
        if dropped > 0.5 {
            format!("{dropped:.0} samples dropped by its count")
        } else {
            "none dropped by its count".into()
        }
    );
    Ok(t)
}

/// A sample counter's values as seconds from its first at `rate` Hz: a counter that falls back
/// wraps (at the power of two above its largest value), and the samples it skips are gaps.
/// `Err(k)`: sample `k` repeats its counter or falls back where it cannot have wrapped.
fn counted(counter: &[f64], rate: f64) -> Result<Vec<f64>, usize> {
    let top = counter.iter().copied().fold(0.0f64, f64::max);
    let modulus = 2f64.powi((top + 1.0).log2().ceil() as i32);
    let mut t = Vec::with_capacity(counter.len());
    let mut wraps = 0.0;
    for (k, &c) in counter.iter().enumerate() {
        if k > 0 {
            let prev = counter[k - 1];
            if c == prev || (c < prev && prev - c < 0.5 * modulus) {
                return Err(k);
            }
            if c < prev {
                wraps += modulus;
            }
        }
        t.push((c + wraps - counter[0]) / rate);
    }
    Ok(t)
}

/// What timestamps say of the rate: their median step's and their mean over the record.
fn describe(t: &[f64]) -> String {
    let span = t[t.len() - 1] - t[0];
    format!(
        "they step by {:.6} s at the median ({:.3} Hz) and hold {} samples over {:.3} s ({:.3} Hz)",
        median_step(t),
        1.0 / median_step(t),
        t.len(),
        span,
        (t.len() - 1) as f64 / span
    )
}

/// Timestamps that come in batches: more samples over the record than their median step
/// allows (dropped samples can only make fewer), by over 2 %. The sentence that says so.
pub(super) fn batched(t: &[f64]) -> Option<String> {
    if t.len() < 3 {
        return None;
    }
    let span = t[t.len() - 1] - t[0];
    let (mean, median) = ((t.len() - 1) as f64 / span, 1.0 / median_step(t));
    (span > 0.0 && mean > 1.02 * median).then(|| {
        format!(
            "the timestamps come in batches: {}, more than their steps allow, so what looks like gaps between them is the batching, not samples dropped; --sample-rate {mean:.3} (or a sample counter, when the file has one) times the samples evenly",
            describe(t)
        )
    })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batched_timestamps_are_told_from_dropped_samples() {
        // 100 Hz stamped as a radio delivers them: nine steps of 11 ms, then one of 1 ms as
        // the next batch catches up (91 Hz by the median step, 100 Hz over the record).
        let mut t = vec![0.0];
        for k in 1..1000 {
            let step = if k % 10 == 0 { 0.001 } else { 0.011 };
            t.push(t[k - 1] + step);
        }
        let said = batched(&t).expect("batched");
        assert!(
            said.contains("come in batches") && said.contains("--sample-rate 99.9"),
            "{said}"
        );
        // Samples dropped from an even 100 Hz: fewer over the record, not batches.
        let dropped: Vec<f64> = (0..1000)
            .filter(|k| k % 50 != 7)
            .map(|k| f64::from(k) * 0.01)
            .collect();
        assert_eq!(batched(&dropped), None);
        let even: Vec<f64> = (0..1000).map(|k| f64::from(k) * 0.01).collect();
        assert_eq!(batched(&even), None);
    }
}
