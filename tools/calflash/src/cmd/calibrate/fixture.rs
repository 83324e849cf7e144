//! A fixture that holds several units on one table (issue 18): one observation file whose
//! columns are per unit (`u3_a_x`, or `IMU-0007_a_x`: a prefix, `_`, a column name) beside
//! the columns all units share (the table's `f_x`, `w_x`, `temp`, ...; a unit's own prefixed
//! reference column, for a unit mounted another way, overrides the shared one). Each unit's
//! columns are split into its own observation file in `--out-dir` (`SERIAL.obs.csv`, kept
//! beside its blob for traceability) and the units are calibrated as a batch.

use crate::cmd::Failure;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::CalibrateArgs;
use crate::cmd::values::SensorKind;
use crate::columns;

/// Every column name a workflow reads.
fn known() -> Vec<&'static str> {
    let mut k = vec![
        columns::INPUT,
        columns::INPUT_P,
        columns::INPUT_O,
        columns::OUTPUT,
        columns::TEMP,
        columns::CHAMBER_TEMP,
        columns::TIME,
        columns::VOLT,
        columns::DIR,
    ];
    for set in [
        columns::F,
        columns::W,
        columns::DW,
        columns::H,
        columns::A,
        columns::GYRO,
    ] {
        k.extend(set);
    }
    k
}

/// The count columns every unit of `sensor` must have.
fn counts(sensor: SensorKind) -> Vec<&'static str> {
    match sensor {
        SensorKind::SingleAccel | SensorKind::SingleGyro => vec![columns::OUTPUT],
        SensorKind::Accel => columns::A.to_vec(),
        SensorKind::Gyro => columns::GYRO.to_vec(),
        SensorKind::Imu => columns::A.iter().chain(&columns::GYRO).copied().collect(),
    }
}

/// The units of a fixture file's header: per prefix, its columns (name without prefix ->
/// index); and the shared columns.
type Split = (
    BTreeMap<String, BTreeMap<String, usize>>,
    BTreeMap<String, usize>,
);

fn split_header(header: &csv::StringRecord) -> Split {
    let known = known();
    let mut units: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut shared = BTreeMap::new();
    for (i, name) in header.iter().enumerate() {
        let name = name.trim();
        if known.contains(&name) {
            shared.insert(name.to_string(), i);
            continue;
        }
        // The first `_` after which a column name follows.
        let unit = name
            .match_indices('_')
            .map(|(at, _)| (&name[..at], &name[at + 1..]))
            .find(|(prefix, rest)| !prefix.is_empty() && known.contains(rest));
        if let Some((prefix, rest)) = unit {
            units
                .entry(prefix.to_string())
                .or_default()
                .insert(rest.to_string(), i);
        }
    }
    (units, shared)
}

/// `--serials u1=SERIAL,...`: prefix to serial; a prefix given twice, or two prefixes given one
/// serial, are refused (one unit would be dropped, or two written into one file).
fn unit_map(text: &[String]) -> Result<BTreeMap<String, String>, String> {
    let mut map = BTreeMap::new();
    for pair in text {
        let (prefix, serial) = pair
            .split_once('=')
            .ok_or_else(|| format!("--serials {pair}: expected PREFIX=SERIAL, e.g. u3=IMU-0007"))?;
        crate::sensor::blob::serial(serial).map_err(|e| format!("--serials {pair}: {e}"))?;
        if let Some(before) = map.get(prefix) {
            return Err(format!(
                "--serials {pair}: unit {prefix} is named twice ({prefix}={before} and {pair}); name each unit once"
            ));
        }
        if let Some((other, _)) = map.iter().find(|(_, s)| *s == serial) {
            return Err(format!(
                "--serials {pair}: serial {serial} is given to {other} and {prefix}; each unit needs its own serial"
            ));
        }
        map.insert(prefix.to_string(), serial.to_string());
    }
    Ok(map)
}

/// Splits the fixture file `data` into one observation file per unit in `out_dir`; the units
/// (serial, file) in prefix order.
///
/// # Errors
/// A file that cannot be read, a unit whose columns are incomplete (named: the unit and the
/// column), a `--serials` prefix the file does not have, or a file with no unit columns.
pub fn split(
    data: &Path,
    sensor: SensorKind,
    units_arg: &[String],
    out_dir: &Path,
) -> Result<Vec<(String, PathBuf)>, String> {
    let name = data.display();
    let file = std::fs::File::open(data).map_err(|e| format!("{name}: {e}"))?;
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(crate::files::LineBound::new(
            file,
            crate::obs::fields::LONGEST_HEAD_LINE,
        ));
    let header = reader
        .headers()
        .map_err(|e| format!("{name}: {e}"))?
        .clone();
    let (units, shared) = split_header(&header);
    if units.is_empty() {
        return Err(format!(
            "{name}: no unit columns (PREFIX_COLUMN, e.g. u1_a_x) in the header: a fixture file holds several units' columns"
        ));
    }
    let map = unit_map(units_arg)?;
    if let Some(p) = map.keys().find(|p| !units.contains_key(*p)) {
        return Err(format!(
            "--serials: {name} has no unit {p}; its units are {}",
            units.keys().cloned().collect::<Vec<_>>().join(", ")
        ));
    }
    let needed = counts(sensor);
    for (prefix, cols) in &units {
        let missing: Vec<String> = needed
            .iter()
            .filter(|c| !cols.contains_key(**c))
            .map(|c| format!("{prefix}_{c}"))
            .collect();
        if !missing.is_empty() {
            return Err(format!(
                "{name}: unit {prefix} is incomplete: no column {} (it has {})",
                missing.join(", "),
                cols.keys()
                    .map(|c| format!("{prefix}_{c}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    }
    // Each unit's columns: the shared ones, its own overriding them.
    let plan: Vec<(String, Vec<(String, usize)>)> = units
        .iter()
        .map(|(prefix, own)| {
            let mut cols: BTreeMap<String, usize> = shared.clone();
            cols.extend(own.iter().map(|(k, v)| (k.clone(), *v)));
            let serial = map.get(prefix).cloned().unwrap_or_else(|| prefix.clone());
            (serial, cols.into_iter().collect())
        })
        .collect();
    let unnamed: Vec<&str> = plan
        .iter()
        .filter(|(serial, _)| !map.values().any(|s| s == serial))
        .map(|(s, _)| s.as_str())
        .collect();
    if !unnamed.is_empty() {
        eprintln!(
            "calflash: {name}: unit(s) {} recorded under their column prefix as serial (name them with --serials PREFIX=SERIAL)",
            unnamed.join(", ")
        );
    }
    let mut paths = crate::files::Paths::new().input("the fixture", Some(data));
    let mut files = Vec::with_capacity(plan.len());
    for (serial, _) in &plan {
        crate::sensor::blob::serial(serial).map_err(|e| {
            format!("{name}: unit {serial}: {e} (name it with --serials PREFIX=SERIAL)")
        })?;
        if plan.iter().filter(|(s, _)| s == serial).count() > 1 {
            return Err(format!(
                "{name}: two units are named {serial} (a column prefix and a --serials serial); each unit needs its own serial"
            ));
        }
        let path =
            crate::files::unit_file(out_dir, serial, "obs.csv").map_err(|e| e.to_string())?;
        paths = paths.output(
            &format!("--out-dir (unit {serial}'s observations)"),
            Some(&path),
        );
        files.push(path);
    }
    paths.check().map_err(|e| e.to_string())?;
    let rows = reader
        .records()
        .enumerate()
        .map(|(line, row)| {
            let row = row.map_err(|e| format!("{name}: {e}"))?;
            if let Some((k, _)) = plan
                .iter()
                .flat_map(|(_, cols)| cols)
                .find(|(_, i)| row.get(*i).is_none())
            {
                return Err(format!(
                    "{name}:{}: no value for column {k} (the row is short)",
                    line + 2
                ));
            }
            Ok(row)
        })
        .collect::<Result<Vec<_>, String>>()?;
    // Every unit's file staged, then all renamed into place: a failure leaves none.
    let mut staged = crate::files::Staged::new();
    for ((_, cols), path) in plan.iter().zip(&files) {
        staged
            .write(path, |w| {
                let mut w = csv::Writer::from_writer(w);
                w.write_record(cols.iter().map(|(k, _)| k.as_str()))?;
                for row in &rows {
                    w.write_record(cols.iter().map(|(_, i)| row.get(*i).unwrap_or_default()))?;
                }
                w.flush()
            })
            .map_err(|e| e.to_string())?;
    }
    staged.commit().map_err(|e| e.to_string())?;
    Ok(plan.into_iter().map(|(s, _)| s).zip(files).collect())
}

/// Runs `calflash calibrate FIXTURE --fixture --out-dir OUT`: splits, then the batch.
///
/// # Errors
/// As [`split`] and the batch.
pub fn run(args: &CalibrateArgs) -> Result<crate::sensor::Verdict, Failure> {
    let [data] = args.data.as_slice() else {
        return Err("--fixture: give one fixture file".into());
    };
    let out_dir = args
        .out_dir
        .as_ref()
        .ok_or("--fixture writes each unit's files into --out-dir: give it")?;
    super::batch::ready_out_dir(out_dir)?;
    let units = split(data, args.sensor, &args.serials, out_dir)?;
    super::batch::run_units(args, &units, out_dir)
}
