//! The files of a recording read into its two halves: one file that holds both sensors, or an
//! accelerometer file and a gyro file (or one file of one triad read as both) whose samples
//! must pair up.

use std::path::{Path, PathBuf};

use super::rate::{note_preamble, timing};
use super::{Options, RecordingError, Stated, read_file};
use crate::obs::layout;

/// A recording's files, read: the kept halves, before their units and codes are checked.
pub(super) struct Halves {
    /// Timestamps, s.
    pub t: Vec<f64>,
    /// The accelerometer's samples (empty when not kept).
    pub acc: Vec<[f64; 3]>,
    /// The gyro's (empty when not kept).
    pub gyro: Vec<[f64; 3]>,
    /// The file line of each sample (the accelerometer's file when it was read).
    pub line: Vec<u32>,
    /// The files, for messages.
    pub source: String,
    /// The rest a preamble states, s.
    pub rest: Option<f64>,
    /// The units each kept sensor's header names, with its file and the header's line.
    pub stated: [Option<Stated>; 2],
    /// The temperature column, its name and values.
    pub temperature: Option<(String, Vec<f64>)>,
    /// Where each kept count is: its file and 1-based field.
    pub places: Vec<(PathBuf, usize)>,
}

/// One file holding both sensors; `want` says which halves are kept (accelerometer, gyro).
pub(super) fn one_file(
    acc: &Path,
    opts: &Options,
    want: (bool, bool),
) -> Result<Halves, RecordingError> {
    let (want_acc, want_gyro) = want;
    let mut r = read_file(acc, layout::Holds::Both, opts.keep, &opts.columns)?;
    note_preamble(acc, &r.preamble);
    let t = timing(&mut r, acc, opts.rate)?;
    // The kept triads, and the units their header names, in the file's order.
    let mut kept = std::mem::take(&mut r.triads).into_iter();
    let mut named = r.units.chunks(3);
    let mut take = |wanted: bool| {
        wanted.then(|| {
            let stated = (
                named.next().unwrap_or_default().to_vec(),
                acc.to_path_buf(),
                r.header,
            );
            (kept.next().unwrap_or_default(), stated)
        })
    };
    let (a, sa) = take(want_acc).unzip();
    let (g, sg) = take(want_gyro).unzip();
    Ok(Halves {
        t,
        acc: a.unwrap_or_default(),
        gyro: g.unwrap_or_default(),
        source: acc.display().to_string(),
        rest: r.preamble.rest.map(|s| s.value),
        stated: [sa, sg],
        temperature: r.temp.take(),
        places: r.fields.iter().map(|f| (acc.to_path_buf(), *f)).collect(),
        line: r.line,
    })
}

/// An accelerometer file and a gyro file (`gp`), each of one triad, read for the halves
/// `want` keeps; the same file given twice is read once.
pub(super) fn two_files(
    acc: &Path,
    gp: &Path,
    opts: &Options,
    want: (bool, bool),
) -> Result<Halves, RecordingError> {
    let (want_acc, want_gyro) = want;
    // The units each kept sensor's header names, with its file and the header's line.
    let mut header_units: [Option<Stated>; 2] = [None, None];
    // Where each kept count is: its file and 1-based field.
    let mut places: Vec<(PathBuf, usize)> = Vec::with_capacity(6);
    let one = |p: &Path| -> Result<(layout::Rows, Vec<f64>), RecordingError> {
        let mut r = layout::read_chosen(p, layout::Holds::One, layout::Keep::Both, &opts.columns)?;
        note_preamble(p, &r.preamble);
        let t = timing(&mut r, p, opts.rate)?;
        Ok((r, t))
    };
    // One file of one triad read as both halves: read once, used for what is kept.
    let same = gp == acc;
    let mut ra = if want_acc || same {
        Some(one(acc)?)
    } else {
        None
    };
    let mut rg = if want_gyro && !same {
        Some(one(gp)?)
    } else {
        None
    };
    if let (Some((_, ta)), Some((rg, tg))) = (&ra, &rg) {
        same_timing((acc, gp), ta, rg, tg)?;
    }
    let mut a = Vec::new();
    let mut g = Vec::new();
    let mut place = |r: &layout::Rows, p: &Path| {
        places.extend(r.fields.iter().map(|f| (p.to_path_buf(), *f)));
    };
    if let Some((r, _)) = &ra {
        let named = (r.units.clone(), acc.to_path_buf(), r.header);
        if want_acc {
            header_units[0] = Some(named.clone());
        }
        if same && want_gyro {
            header_units[1] = Some(named);
        }
    }
    if let Some((r, _)) = &rg {
        header_units[1] = Some((r.units.clone(), gp.to_path_buf(), r.header));
    }
    let temperature = [&mut ra, &mut rg]
        .into_iter()
        .find_map(|r| r.as_mut().and_then(|(r, _)| r.temp.take()));
    if let Some((r, _)) = &mut ra {
        if want_acc {
            place(r, acc);
        }
        if same && want_gyro {
            place(r, gp);
        }
        let triad = std::mem::take(&mut r.triads[0]);
        match (want_acc, same && want_gyro) {
            // One file read as both halves, both wanted: the one copy it needs.
            (true, true) => {
                g = triad.clone();
                a = triad;
            }
            (true, false) => a = triad,
            (false, true) => g = triad,
            (false, false) => {}
        }
    }
    if let Some((r, _)) = &mut rg {
        place(r, gp);
        g = std::mem::take(&mut r.triads[0]);
    }
    let source = match (&ra, &rg) {
        (Some(_), Some(_)) => format!("{} + {}", acc.display(), gp.display()),
        (None, Some(_)) => gp.display().to_string(),
        _ => acc.display().to_string(),
    };
    let rest = [&ra, &rg]
        .iter()
        .find_map(|r| r.as_ref().and_then(|(r, _)| r.preamble.rest))
        .map(|s| s.value);
    // Lines and times from the accelerometer's file when it was read.
    let (r, t) = ra.or(rg).expect("at least one file is read");
    Ok(Halves {
        t,
        acc: a,
        gyro: g,
        line: r.line,
        source,
        rest,
        stated: header_units,
        temperature,
        places,
    })
}

/// The accelerometer's and the gyro's files (`acc`, `gp`) have as many samples, at the same times
/// (`ta`, `tg`; `rg` the gyro file's rows, for its lines).
fn same_timing(
    (acc, gp): (&Path, &Path),
    ta: &[f64],
    rg: &layout::Rows,
    tg: &[f64],
) -> Result<(), RecordingError> {
    let mismatch = |line: usize, what: String| RecordingError::Mismatch {
        acc: acc.to_path_buf(),
        gyro: gp.to_path_buf(),
        line,
        what,
    };
    if ta.len() != tg.len() {
        let line = rg
            .line
            .get(ta.len().min(tg.len()))
            .or(rg.line.last())
            .map_or(1, |l| *l as usize);
        return Err(mismatch(
            line,
            format!(
                "{} gyro samples against {} accelerometer samples",
                tg.len(),
                ta.len()
            ),
        ));
    }
    let tol = 1e-6 * ta.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    if let Some(k) = (0..ta.len()).find(|&k| (ta[k] - tg[k]).abs() > tol) {
        return Err(mismatch(
            rg.line[k] as usize,
            format!(
                "timestamp {} s where the accelerometer's is {} s",
                tg[k], ta[k]
            ),
        ));
    }

    Ok(())
}
