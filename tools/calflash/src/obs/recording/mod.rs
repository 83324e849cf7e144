//! Raw IMU recordings: ADC counts of each sensor, with a timestamp or at a stated rate, as
//! whitespace-separated text (the layout of the Xsens MTi test data) or CSV; separate
//! accelerometer and gyro files, or one file of both (t, ax, ay, az, gx, gy, gz, or without t).
//! A preamble of logger settings and a header naming the columns are read as
//! [`super::layout`] says; lines starting with `#` are skipped.
//!
//! Every error names the file and line (and the field); timestamps must increase; gaps (a step
//! longer than 1.5 sampling periods) are reported, as are samples at the converter's rails,
//! which are kept but marked so that no fit uses them.

use std::path::{Path, PathBuf};

use spincal::model::Rails;

pub mod clipping;
mod error;
mod halves;
pub mod header;
pub mod layout;
pub mod mat;
mod rate;

pub use error::RecordingError;
use rate::median_step;

use super::units::{self, Sensor, Unit};

/// A step in time longer than 1.5 sampling periods: samples were dropped.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Gap {
    /// Line of the first sample after the gap.
    pub line: usize,
    /// Time before the gap, s.
    pub from: f64,
    /// Time after it, s.
    pub to: f64,
    /// Samples missing, about.
    pub missing: usize,
}

/// A raw IMU recording.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Where it came from (one or two files).
    pub source: String,
    /// Timestamps, s, increasing.
    pub t: Vec<f64>,
    /// Accelerometer counts (empty when [`Options::keep`] left them out).
    pub acc: Vec<[f64; 3]>,
    /// Gyro counts (likewise).
    pub gyro: Vec<[f64; 3]>,
    /// Line in the (accelerometer) file of each sample.
    pub line: Vec<u32>,
    /// Samples with an axis at or beyond a rail (any sensor).
    pub saturated: Vec<bool>,
    /// How many were saturated, accelerometer and gyro.
    pub saturated_count: (usize, usize),
    /// Gaps in the timestamps.
    pub gaps: Vec<Gap>,
    /// Median sampling period, s.
    pub period: f64,
    /// The initial rest a logger's preamble states, s.
    pub rest: Option<f64>,
    /// What the accelerometer's and the gyro's values are: counts, or SI values read from a
    /// physical unit (or codes made from one with a stated LSB).
    pub units: [units::Read; 2],
    /// A temperature column's name and values (from the accelerometer's file, or the one file).
    pub temperature: Option<(String, Vec<f64>)>,
}

/// How to read a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// The converter's rails: samples at or beyond them are marked saturated, and codes well
    /// beyond them show another format (refused, naming it).
    pub rails: Rails,
    /// The sample rate, Hz: for files without timestamps, or over a file's own (said).
    pub rate: Option<f64>,
    /// The sensors to keep: a command that needs one reads only its file, or only its
    /// columns of a file of both.
    pub keep: layout::Keep,
    /// The units of the files' values, as the user states them.
    pub units: units::Units,
    /// Columns the user chose by name.
    pub columns: header::Chosen,
}

impl Recording {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Sampling rate, Hz.
    #[must_use]
    pub fn rate(&self) -> f64 {
        1.0 / self.period
    }
}

/// Reads a recording: `acc` with seven columns, or `acc` and `gyro` with four each. Samples at or
/// beyond `rails` are marked saturated.
///
/// # Errors
/// A [`RecordingError`] naming the file and line.
pub fn read(acc: &Path, gyro: Option<&Path>, rails: Rails) -> Result<Recording, RecordingError> {
    read_with(
        acc,
        gyro,
        &Options {
            rails,
            rate: None,
            keep: layout::Keep::Both,
            units: units::Units::DEFAULT,
            columns: header::Chosen::default(),
        },
    )
}

/// Reads a recording: `acc` holding both sensors, or `acc` and `gyro` one each, as `opts` say.
///
/// # Errors
/// A [`RecordingError`] naming the file and line.
pub fn read_with(
    acc: &Path,
    gyro: Option<&Path>,
    opts: &Options,
) -> Result<Recording, RecordingError> {
    let rails = opts.rails;
    let want = match opts.keep {
        layout::Keep::Both => (true, true),
        layout::Keep::Accel => (true, false),
        layout::Keep::Gyro => (false, true),
    };
    let (want_acc, want_gyro) = want;
    let halves::Halves {
        t,
        acc: a,
        gyro: g,
        line,
        source,
        rest,
        stated: header_units,
        temperature,
        places,
    } = match gyro {
        None => halves::one_file(acc, opts, want)?,
        Some(gp) => halves::two_files(acc, gp, opts, want)?,
    };
    if t.len() == 1 {
        return Err(RecordingError::OneSample {
            path: acc.to_path_buf(),
        });
    }
    let period = median_step(&t);
    // From 0.1 Hz to 10 MHz: anything else is a time read in the wrong unit.
    if !(1e-7..=10.0).contains(&period) {
        return Err(RecordingError::ImplausibleRate {
            path: acc.to_path_buf(),
            period,
            rate: 1.0 / period,
        });
    }
    if let Some(said) = rate::batched(&t) {
        eprintln!("calflash: note: {}: {said}", acc.display());
    }
    let gaps = t
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] - w[0] > 1.5 * period)
        .map(|(k, w)| Gap {
            line: line[k + 1] as usize,
            from: w[0],
            to: w[1],
            missing: ((w[1] - w[0]) / period).round() as usize - 1,
        })
        .collect();
    let read = [
        if want_acc {
            resolve(Sensor::Accel, opts, header_units[0].as_ref(), acc)?
        } else {
            units::Read::COUNTS
        },
        if want_gyro {
            resolve(
                Sensor::Gyro,
                opts,
                header_units[1].as_ref(),
                gyro.unwrap_or(acc),
            )?
        } else {
            units::Read::COUNTS
        },
    ];
    let (mut a, mut g) = (a, g);
    for (values, r) in [(&mut a, read[0]), (&mut g, read[1])] {
        let f = r.factor();
        if f != 1.0 {
            values.iter_mut().flatten().for_each(|x| *x *= f);
        }
    }
    // Rails and formats are the converter's: SI values have none.
    let none = Vec::new();
    let ca = if read[0].is_si() { &none } else { &a };
    let cg = if read[1].is_si() { &none } else { &g };
    let code_places: Vec<(PathBuf, usize)> = {
        let n_acc = if a.is_empty() { 0 } else { 3 };
        places
            .iter()
            .enumerate()
            .filter(|(i, _)| {
                if *i < n_acc {
                    !read[0].is_si()
                } else {
                    !read[1].is_si()
                }
            })
            .map(|(_, p)| p.clone())
            .collect()
    };
    check_codes(&[ca, cg], &line, rails, &code_places)?;
    let at_rail = |s: &[f64; 3]| {
        s.iter()
            .any(|x| *x <= f64::from(rails.lo) || *x >= f64::from(rails.hi))
    };
    let mut sa: Vec<bool> = ca.iter().map(at_rail).collect();
    let mut sg: Vec<bool> = cg.iter().map(at_rail).collect();
    // Values in a physical unit have no rails: their clipping is found from the data.
    for (name, values, r, marks) in [
        ("accelerometer", &a, read[0], &mut sa),
        ("gyro", &g, read[1], &mut sg),
    ] {
        if !r.is_si() || values.is_empty() {
            continue;
        }
        let found = clipping::clips(values);
        if found.is_empty() {
            continue;
        }
        let said: Vec<String> = found.iter().map(ToString::to_string).collect();
        eprintln!(
            "calflash: note: {}: the {name} clips: {}; the samples there are excluded as saturated",
            acc.display(),
            said.join(", ")
        );
        *marks = values
            .iter()
            .map(|v| found.iter().any(|c| c.holds(v)))
            .collect();
    }
    let saturated_count = (
        sa.iter().filter(|x| **x).count(),
        sg.iter().filter(|x| **x).count(),
    );
    let saturated = (0..t.len())
        .map(|k| sa.get(k).copied().unwrap_or(false) || sg.get(k).copied().unwrap_or(false))
        .collect();
    Ok(Recording {
        source,
        t,
        acc: a,
        gyro: g,
        line,
        saturated,
        saturated_count,
        gaps,
        period,
        rest,
        units: read,
        temperature,
    })
}

/// One file's rows: a MATLAB file by its variables, text by its layout.
fn read_file(
    path: &Path,
    holds: layout::Holds,
    keep: layout::Keep,
    columns: &header::Chosen,
) -> Result<layout::Rows, RecordingError> {
    if mat::is_mat(path) {
        if !columns.is_empty() {
            return Err(RecordingError::Mat {
                path: path.to_path_buf(),
                what: "--columns chooses a text file's columns by their header names; a MATLAB \
                       file's variables are found by their names (t, acc, gyro) or shape"
                    .into(),
            });
        }
        return mat::read(path, holds, keep);
    }
    layout::read_chosen(path, holds, keep, columns)
}

/// The units a header named for one sensor's three axes, its file and the header's line.
type Stated = (Vec<Option<Unit>>, PathBuf, Option<usize>);

/// What one sensor's values are: the unit the user gave or the header named (they must agree,
/// and a header must name one unit for the three axes), counts when neither says, and the LSB
/// the user gave (for physical units only).
fn resolve(
    sensor: Sensor,
    opts: &Options,
    stated: Option<&Stated>,
    fallback: &Path,
) -> Result<units::Read, RecordingError> {
    let k = usize::from(sensor == Sensor::Gyro);
    let what = match sensor {
        Sensor::Accel => "accelerometer",
        Sensor::Gyro => "gyro",
    };
    let (path, line) = stated.map_or((fallback.to_path_buf(), 1), |(_, p, l)| {
        (p.clone(), l.unwrap_or(1))
    });
    let err = |what: String| RecordingError::Units {
        path: path.clone(),
        line,
        what,
    };
    let header = match stated {
        Some((u, _, _)) if u.iter().any(Option::is_some) => {
            let first = u[0];
            if u.iter().any(|x| *x != first) {
                let names: Vec<&str> = u.iter().map(|x| x.map_or("no unit", Unit::name)).collect();
                return Err(err(format!(
                    "the header names the {what}'s axes in mixed units ({}); expected one unit \
                     for the three",
                    names.join(", ")
                )));
            }
            first
        }
        _ => None,
    };
    let given = opts.units.given[k];
    if let (Some(g), Some(h)) = (given, header)
        && g != h
    {
        return Err(err(format!(
            "--units gives the {what} in {} where the header names {}; drop --units or fix \
             the header",
            g.name(),
            h.name()
        )));
    }
    let file = given.or(header).unwrap_or(Unit::Counts);
    let lsb = opts.units.lsb[k];
    if lsb.is_some() && !file.is_physical() {
        return Err(err(format!(
            "--lsb gives the value of one code, for values in a physical unit; the {what} is \
             in counts"
        )));
    }
    Ok(units::Read { file, lsb })
}

/// Refuses a recording whose codes beyond the rails show another format of the same width
/// (signed codes read as unsigned, or the reverse); a few damaged codes stay, marked saturated.
fn check_codes(
    triads: &[&Vec<[f64; 3]>],
    line: &[u32],
    rails: Rails,
    places: &[(PathBuf, usize)],
) -> Result<(), RecordingError> {
    let (lo, hi) = (f64::from(rails.lo), f64::from(rails.hi));
    // Every kept count as (sample, count index among the kept, value).
    let codes = || {
        triads
            .iter()
            .filter(|t| !t.is_empty())
            .enumerate()
            .flat_map(|(n, t)| {
                t.iter().enumerate().flat_map(move |(k, x)| {
                    x.iter().enumerate().map(move |(j, v)| (k, 3 * n + j, *v))
                })
            })
    };
    let below = codes().filter(|c| c.2 < lo).count();
    let above = codes().filter(|c| c.2 > hi).count();
    let Some(advice) = super::codes::mismatch(below, above, rails) else {
        return Ok(());
    };
    let (k, j, value) = codes()
        .find(|c| c.2 < lo || c.2 > hi)
        .expect("mismatch counts codes beyond the rails");
    let (path, field) = &places[j];
    Err(RecordingError::WrongCodes {
        path: path.clone(),
        line: line[k] as usize,
        field: *field,
        value,
        format: super::codes::name(rails),
        advice,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes `text` to `dir/name` and returns the path (the recording tests' files, also
    /// used by the layout's).
    pub(super) fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_both_layouts_and_reports_gaps_and_rails() {
        let d = tempfile::tempdir().unwrap();
        let a = write(
            d.path(),
            "a.txt",
            "# rest\n0.00 1 2 3\n0.01 1 2 3\n0.02 0 2 3\n0.05 1 2 3\n",
        );
        let g = write(
            d.path(),
            "g.txt",
            "0.00 5 6 7\n0.01 5 6 7\n0.02 5 6 7\n0.05 5 6 65535\n",
        );
        let r = read(&a, Some(&g), Rails::unsigned(16)).unwrap();
        assert_eq!(r.len(), 4);
        assert_eq!(r.gyro[3], [5.0, 6.0, 65535.0]);
        assert_eq!(r.saturated, [false, false, true, true]);
        assert_eq!(r.saturated_count, (1, 1));
        assert_eq!(
            r.gaps,
            [Gap {
                line: 5,
                from: 0.02,
                to: 0.05,
                missing: 2
            }]
        );
        let one = write(
            d.path(),
            "imu.csv",
            "t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n",
        );
        let r = read(&one, None, Rails::unsigned(16)).unwrap();
        assert_eq!((r.acc[1], r.gyro[1]), ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]));
    }

    /// Issue 66: a logger's sample counter as the time base (`--columns index=NAME` with the
    /// rate): the host's batched timestamps are not taken, the counter's wrap at 2^16 is
    /// followed, and the one sample it skips is a gap of one; without a rate it is refused.
    #[test]
    fn a_sample_counter_times_the_samples() {
        let d = tempfile::tempdir().unwrap();
        let mut text = String::from("time_us,count,ax,ay,az,gx,gy,gz\n");
        let mut n = 0;
        for k in 0..300u32 {
            if k == 200 {
                continue; // dropped by the logger: its count skips one
            }
            // The host stamps ten samples at a time, as its radio delivers them.
            let stamp = (k / 10) * 100_000 + 7;
            let count = (65_436 + k) % 65_536;
            text.push_str(&format!("{stamp},{count},1,2,3,4,5,6\n"));
            n += 1;
        }
        let p = write(d.path(), "counted.csv", &text);
        let opts = |rate| Options {
            rails: Rails::new(i32::MIN, i32::MAX),
            rate,
            keep: layout::Keep::Both,
            units: units::Units::DEFAULT,
            columns: header::Chosen::parse("index=count").unwrap(),
        };
        let r = read_with(&p, None, &opts(Some(100.0))).unwrap();
        assert_eq!(r.len(), n);
        assert!((r.period - 0.01).abs() < 1e-12, "{}", r.period);
        assert_eq!(r.gaps.len(), 1, "{:?}", r.gaps);
        assert_eq!(r.gaps[0].missing, 1);
        assert!(
            (r.t[r.len() - 1] - 2.99).abs() < 1e-9,
            "{}",
            r.t[r.len() - 1]
        );
        let e = read_with(&p, None, &opts(None)).unwrap_err().to_string();
        assert!(e.contains("give --sample-rate"), "{e}");
        assert!(
            header::Chosen::parse("t=time_us,index=count")
                .unwrap_err()
                .to_string()
                .contains("the time base (t= or index=) is given twice"),
        );
    }

    /// Issue 66: a logger's `TIME` column in microseconds (its name states no unit) is read in
    /// microseconds from its steps, by itself and when named with `--columns t=TIME`; named with
    /// its unit it is taken as given; milliseconds are read so too; a column whose steps fit two
    /// units (1,000: 1 Hz in ms or 1 kHz in us) is left for the user to name, and the rate's
    /// check says so. (Steps of 10 s or less stay seconds: a slow log is one.)
    #[test]
    fn a_time_column_without_a_unit_is_read_in_the_unit_its_steps_show() {
        let d = tempfile::tempdir().unwrap();
        let file = |name: &str, step: u64| -> PathBuf {
            let mut text = String::from("TIME,ax,ay,az,gx,gy,gz\n");
            for k in 0..500u64 {
                text.push_str(&format!("{},1,2,3,4,5,6\n", 1_700_000_000 + k * step));
            }
            write(d.path(), name, &text)
        };
        let opts = |columns: &str| Options {
            rails: Rails::new(i32::MIN, i32::MAX),
            rate: None,
            keep: layout::Keep::Both,
            units: units::Units::DEFAULT,
            columns: header::Chosen::parse(columns).unwrap(),
        };
        let us = file("us.csv", 9_994);
        for columns in ["", "t=TIME"] {
            let r = read_with(&us, None, &opts(columns)).unwrap();
            assert!((1.0 / r.period - 100.06).abs() < 0.01, "{}", 1.0 / r.period);
        }
        let r = read_with(&us, None, &opts("t=TIME:ns")).unwrap();
        assert!((1.0 / r.period - 100_060.0).abs() < 10.0, "{}", r.period);
        // Milliseconds at 50 Hz (20 s a step as seconds, 50 kHz as microseconds).
        let ms = file("ms.csv", 20);
        let r = read_with(&ms, None, &opts("")).unwrap();
        assert!((r.period - 0.02).abs() < 1e-9, "{}", r.period);
        let both = file("both.csv", 1_000);
        let e = read_with(&both, None, &opts("")).unwrap_err().to_string();
        assert!(e.contains("--columns t=NAME:ms"), "{e}");
    }

    /// Issue 66: an accelerometer read in m/s^2 that clips at +-20.48 (an ADXL355) has its
    /// samples at the clip excluded as saturated, as codes at a rail are; the same motion
    /// below the clip excludes nothing.
    #[test]
    fn clipping_in_a_physical_unit_is_found_from_the_data() {
        let d = tempfile::tempdir().unwrap();
        let file = |peak: f64| -> String {
            let mut text = String::from("t,ax,ay,az,gx,gy,gz\n");
            for k in 0..3000 {
                let t = k as f64 * 0.01;
                let ax = (peak * (t * 0.9).sin()).clamp(-20.48, 20.48);
                text.push_str(&format!(
                    "{t:.2},{ax:.5},{:.5},9.80665,0.001,0.002,{:.4}\n",
                    0.01 * (k % 3) as f64,
                    0.9 * (t * 0.9).cos()
                ));
            }
            text
        };
        let opts = Options {
            rails: Rails::new(i32::MIN, i32::MAX),
            rate: None,
            keep: layout::Keep::Both,
            units: units::Units {
                given: [
                    units::Unit::parse("m/s2", units::Sensor::Accel),
                    units::Unit::parse("rad/s", units::Sensor::Gyro),
                ],
                lsb: [None, None],
            },
            columns: header::Chosen::default(),
        };
        let clipped = write(d.path(), "clipped.csv", &file(25.0));
        let r = read_with(&clipped, None, &opts).unwrap();
        assert!(r.saturated_count.0 > 100, "{:?}", r.saturated_count);
        assert_eq!(r.saturated_count.1, 0);
        let k = r.acc.iter().position(|a| a[0] >= 20.48).unwrap();
        assert!(r.saturated[k]);
        let free = write(d.path(), "free.csv", &file(19.0));
        let r = read_with(&free, None, &opts).unwrap();
        assert_eq!(r.saturated_count, (0, 0));
    }

    #[test]
    fn the_rate_is_stated_or_read_and_never_contradicted() {
        let d = tempfile::tempdir().unwrap();
        let signed = Rails::signed(16);
        let opts = |rate| Options {
            rails: signed,
            rate,
            keep: layout::Keep::Both,
            units: units::Units::DEFAULT,
            columns: header::Chosen::default(),
        };
        let six = "-12 -812 15032 -447 156 -86\n-208 -828 14796 -398 132 -63\n-1 -2 -3 -4 -5 -6\n";
        let bare = write(d.path(), "bare.txt", six);
        assert_eq!(
            read_with(&bare, None, &opts(None)).unwrap_err().to_string(),
            format!(
                "{}: no timestamp column and no sample rate: give --sample-rate HZ (or a preamble line `Fs,HZ`)",
                bare.display()
            )
        );
        let r = read_with(&bare, None, &opts(Some(50.0))).unwrap();
        assert_eq!(r.t, [0.0, 0.02, 0.04]);
        assert_eq!(r.acc[0], [-12.0, -812.0, 15032.0]);
        // The preamble's rate, and an option that contradicts it.
        let pre = write(
            d.path(),
            "pre.csv",
            &format!("Fs,100\nax,ay,az,gx,gy,gz\n{}", six.replace(' ', ",")),
        );
        assert_eq!(read_with(&pre, None, &opts(None)).unwrap().period, 0.01);
        assert_eq!(
            read_with(&pre, None, &opts(Some(200.0)))
                .unwrap_err()
                .to_string(),
            format!(
                "{}:1: the preamble states 100 Hz and --sample-rate 200 Hz; drop --sample-rate or fix the file",
                pre.display()
            )
        );
        // Timestamps that disagree with --sample-rate: the option is the user's word over
        // them (issue 66: a host's timestamps in radio batches), the samples evenly spaced.
        let timed = write(
            d.path(),
            "timed.txt",
            "0 1 2 3 4 5 6\n0.01 1 2 3 4 5 6\n0.02 1 2 3 4 5 6\n",
        );
        let r = read_with(&timed, None, &opts(Some(50.0))).unwrap();
        assert_eq!(r.t, [0.0, 0.02, 0.04]);
        // Against a logger's preamble they are refused.
        let stated = write(
            d.path(),
            "stated.csv",
            "Fs,50\nt,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n0.02,1,2,3,4,5,6\n",
        );
        assert!(
            read_with(&stated, None, &opts(None))
                .unwrap_err()
                .to_string()
                .contains("the timestamps step by 0.01 s (100.0000 Hz) where the preamble (line 1) states 50 Hz"),
        );
        // Signed codes read as unsigned are named, with the option that reads them.
        let e = read_with(
            &bare,
            None,
            &Options {
                rails: Rails::unsigned(16),
                rate: Some(100.0),
                keep: layout::Keep::Both,
                units: units::Units::DEFAULT,
                columns: header::Chosen::default(),
            },
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            format!(
                "{}:1: 14 codes below zero: the codes look signed; add --codes signed16 (the first is -12, field 1; the format given is unsigned16)",
                bare.display()
            )
        );
    }

    #[test]
    fn bad_input_names_file_line_and_field() {
        let d = tempfile::tempdir().unwrap();
        let rails = Rails::unsigned(16);
        let msg = |a: &Path, g: Option<&Path>| read(a, g, rails).unwrap_err().to_string();
        let back = write(d.path(), "back.txt", "0.00 1 2 3\n0.02 1 2 3\n0.01 1 2 3\n");
        assert_eq!(
            msg(&back, Some(&back)),
            format!(
                "{}:3: timestamp 0.01 s is not after the previous line's 0.02 s; timestamps must increase",
                back.display()
            )
        );
        let word = write(d.path(), "word.txt", "0.00 1 2 3\n0.01 1 x 3\n");
        assert_eq!(
            msg(&word, Some(&word)),
            format!(
                "{}:2: field 3 (y count) is `x`; expected a number",
                word.display()
            )
        );
        let short = write(d.path(), "short.txt", "0.00 1 2 3\n0.01 1 2\n");
        assert_eq!(
            msg(&short, Some(&short)),
            format!(
                "{}:2: 3 fields; expected 4, as on the first sample line",
                short.display()
            )
        );
        let other = write(d.path(), "other.txt", "0.00 1 2 3\n0.015 1 2 3\n");
        let ok = write(d.path(), "ok.txt", "0.00 1 2 3\n0.01 1 2 3\n");
        assert_eq!(
            msg(&ok, Some(&other)),
            format!(
                "{}:2: timestamp 0.015 s where the accelerometer's is 0.01 s; the accelerometer file {} and the gyro file must hold the same samples, line for line",
                other.display(),
                ok.display()
            )
        );
        assert_eq!(
            msg(&ok, None),
            format!(
                "{}:1: 4 fields; expected 7 (timestamp, accelerometer x, y, z, gyro x, y, z counts) or 6 without the timestamp (then give --sample-rate), or give the gyro file too",
                ok.display()
            )
        );
        let empty = write(d.path(), "empty.txt", "# nothing\n");
        assert_eq!(
            msg(&empty, Some(&ok)),
            format!(
                "{}: no samples; expected a timestamp and three counts per line",
                empty.display()
            )
        );
    }
}
