//! The unit history: every fit, flash and health report of every unit.
//!
//! In a SQLite file on the station (the default: `$CALFLASH_DB`, else
//! `$XDG_DATA_HOME/calflash/units.sqlite`, else `~/.local/share/calflash/units.sqlite`), or in
//! a PostgreSQL database that several stations share (`--db postgres://...`, or that URL in
//! `$CALFLASH_DB`). Both keep one schema and the same guarantees: a record is whole or absent,
//! two stations writing at once lose nothing, a history of a newer schema is refused, and a
//! record the history cannot take is saved as JSON beside the outputs.

mod error;
mod location;
mod postgresql;
mod schema;
mod sqlite;

use std::path::{Path, PathBuf};

pub use error::{Cause, Error, NotRecorded};
pub use location::{Given, Location, LocationError, redact};
pub use schema::SCHEMA_VERSION;
use schema::{Listed, Row};

use crate::sensor::record::Record;
use crate::sensor::selfcal::record::SelfcalRecord;

/// Where a record that the database cannot take is saved: the directory of the first output
/// file given, else the current directory.
#[must_use]
pub fn beside(outputs: &[Option<&Path>]) -> PathBuf {
    outputs
        .iter()
        .flatten()
        .find_map(|p| p.parent().map(Path::to_path_buf))
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Records with `f` in the history at `location`; when that fails, saves `fallback` as JSON
/// in `beside` so that nothing is lost.
///
/// # Errors
/// When the database could not take the record: why, and where the record was saved instead
/// (or that it could not be).
pub fn record_or_save(
    location: &Location,
    f: impl FnOnce(&mut Db) -> Result<i64, Error>,
    fallback: &serde_json::Value,
    beside: &Path,
    serial: &str,
) -> Result<String, NotRecorded> {
    match Db::open(location).and_then(|mut d| f(&mut d)) {
        Ok(id) => Ok(format!("recorded as db:{id} in {location}")),
        Err(cause) => {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos());
            let safe: String = serial
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let file = beside.join(format!("calflash-unrecorded-{safe}-{nanos}.json"));
            let body = serde_json::to_vec_pretty(fallback).unwrap_or_default();
            let saved =
                crate::files::write_atomically(&file, |w| std::io::Write::write_all(w, &body));
            Err(match saved {
                Ok(()) => NotRecorded::Saved {
                    cause: Box::new(cause),
                    saved: file,
                },
                Err(why) => NotRecorded::Lost {
                    cause: Box::new(cause),
                    file,
                    why,
                },
            })
        }
    }
}

/// One row of a unit's history.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Entry {
    /// Record id (for `calflash compare db:ID`).
    pub id: i64,
    /// `fit` or `flash`.
    pub kind: String,
    /// Seconds since 1970.
    pub time: i64,
    /// Hash of the observation data.
    pub data_hash: String,
    /// The models (fits).
    pub model: Option<String>,
    /// Verdict (fits) or verification outcome (flashes).
    pub outcome: String,
    /// The report's path, if any.
    pub report: Option<String>,
    /// Blob bytes (a signed blob's trailer included).
    pub blob_len: usize,
    /// The station key that signed the blob and its counter (`KEYID #COUNTER`), when signed.
    pub signed_by: Option<String>,
    /// Whether that signature was checked: a fit's blob is signed here with the key named; a
    /// flash's is checked by a provisioned unit that committed it. A refused or failed flash,
    /// or one to an unprovisioned unit, only claims the key.
    pub signature_checked: bool,
    /// The production lot the unit was calibrated in (empty: none given).
    pub lot: String,
}

/// The coefficients of a fit as the history keeps them (and `calflash lot` reads them): per
/// table point its temperature and voltage, and per axis the output, terms, coefficients and
/// standard errors.
#[must_use]
pub fn fit_coefficients(rec: &Record) -> Vec<serde_json::Value> {
    rec.points
        .iter()
        .map(|p| serde_json::json!({"temp": p.temp, "volt": p.volt, "axes": p.axes.iter().map(|a| serde_json::json!({"output": a.output, "terms": a.terms, "coefficients": a.coefficients, "std_errors": a.std_errors})).collect::<Vec<_>>()}))
        .collect()
}

/// Which units' newest fits `calflash lot` takes.
#[derive(Debug, Clone, Copy)]
pub struct Selection<'a> {
    /// Serials that start with this (all for an empty one).
    pub prefix: &'a str,
    /// Recorded in this production lot (`calibrate --lot`), when given.
    pub lot: Option<&'a str>,
    /// Fits recorded from this time (Unix seconds, inclusive).
    pub since: i64,
    /// Fits recorded up to this time (inclusive).
    pub until: i64,
    /// Recorded by this station, when given.
    pub station: Option<&'a str>,
}

impl Selection<'_> {
    /// Every unit's newest fit, ever.
    #[must_use]
    pub fn all() -> Selection<'static> {
        Selection {
            prefix: "",
            lot: None,
            since: i64::MIN,
            until: i64::MAX,
            station: None,
        }
    }
}

impl std::fmt::Display for Selection<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.lot, self.prefix) {
            (Some(lot), "") => write!(f, "lot `{lot}`"),
            (Some(lot), p) => write!(f, "lot `{lot}`, serials `{p}*`"),
            (None, "") => f.write_str("every unit"),
            (None, p) => write!(f, "`{p}`"),
        }
    }
}

/// A unit's newest fit, for `calflash lot`.
#[derive(Debug, Clone)]
pub struct FitRow {
    /// Serial.
    pub serial: String,
    /// When (Unix seconds).
    pub time: i64,
    /// The station that recorded it (empty before schema 3).
    pub station: String,
    /// The coefficients' JSON (as the history's `coefficients` column holds it: no seal
    /// covers it).
    pub coefficients: String,
    /// The fit's record (`calflash.calibration/1` or `calflash.selfcal/1` JSON), whose seal
    /// does cover its coefficients.
    pub record: Option<String>,
}

/// The station recording: `$CALFLASH_STATION`, else the machine's host name, else empty.
#[must_use]
pub fn station() -> String {
    std::env::var("CALFLASH_STATION")
        .ok()
        .filter(|s| !s.trim().is_empty())
        .or_else(|| {
            std::fs::read_to_string("/proc/sys/kernel/hostname")
                .ok()
                .map(|h| h.trim().to_string())
        })
        .unwrap_or_default()
}

/// The observation-data hash a blob carries, hex; `None` when it does not decode.
fn blob_hash(blob: &[u8]) -> Option<String> {
    let cal = crate::signing::calibration(blob).ok()?;
    Some(
        cal.data()
            .identity
            .data_hash
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
    )
}

fn now() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64)
}

/// What a history's store does; each failure is why, in the station's words (the caller
/// names the history).
trait Backend: Send {
    /// Writes one record, whole or not at all; its id.
    fn insert(&mut self, row: &Row) -> Result<i64, Cause>;
    /// Writes `rows` in one transaction, skipping those the history held before (the same
    /// unit, kind, time, data, outcome, station and blob); how many it wrote.
    fn copy(&mut self, rows: &[Row]) -> Result<usize, Cause>;
    /// A unit's records, oldest first.
    fn history(&mut self, serial: &str) -> Result<Vec<Listed>, Cause>;
    /// See [`Db::latest_fits`].
    fn latest_fits(&mut self, sel: &Selection<'_>) -> Result<Vec<FitRow>, Cause>;
    /// The blobs of a unit's records.
    fn blobs(&mut self, serial: &str) -> Result<Vec<Vec<u8>>, Cause>;
    /// The JSON record of record `id`: `None` for no such record, `Some(None)` for a flash.
    fn record(&mut self, id: i64) -> Result<Option<Option<String>>, Cause>;
    /// Every record, in the order written.
    fn rows(&mut self) -> Result<Vec<Row>, Cause>;
}

/// A unit history, open.
pub struct Db {
    backend: Box<dyn Backend>,
    location: Location,
}

impl Db {
    /// Opens the history at `location`, creating it (a SQLite file, or the tables in an empty
    /// PostgreSQL database) when needed, migrating an older SQLite schema.
    ///
    /// # Errors
    /// The history (a URL without its password) and why.
    pub fn open(location: impl Into<Location>) -> Result<Self, Error> {
        let location = location.into();
        let backend: Result<Box<dyn Backend>, Cause> = match &location {
            Location::File(p) => sqlite::Sqlite::open(p).map(|b| Box::new(b) as _),
            Location::Server(url) => postgresql::Postgres::open(url).map(|b| Box::new(b) as _),
        };
        Self::opened(backend, location)
    }

    /// Opens an existing history to read it (`history`, `compare db:ID`, `lot`): never
    /// creates one, never writes.
    ///
    /// # Errors
    /// No history there, or not a calflash history of a schema this calflash reads.
    pub fn open_existing(location: impl Into<Location>) -> Result<Self, Error> {
        let location = location.into();
        let backend: Result<Box<dyn Backend>, Cause> = match &location {
            Location::File(p) => sqlite::Sqlite::open_existing(p).map(|b| Box::new(b) as _),
            Location::Server(url) => {
                postgresql::Postgres::open_existing(url).map(|b| Box::new(b) as _)
            }
        };
        Self::opened(backend, location)
    }

    fn opened(backend: Result<Box<dyn Backend>, Cause>, location: Location) -> Result<Self, Error> {
        match backend {
            Ok(backend) => Ok(Self { backend, location }),
            Err(cause) => Err(cause.at(&location)),
        }
    }

    /// Names the history in a failure.
    fn named<T>(&self, r: Result<T, Cause>) -> Result<T, Error> {
        r.map_err(|cause| cause.at(&self.location))
    }

    /// Records a fit.
    ///
    /// # Errors
    /// A message naming the history and why; nothing is written then.
    pub fn record_fit(
        &mut self,
        rec: &Record,
        report: Option<&Path>,
        blob: &[u8],
    ) -> Result<i64, Error> {
        let models: Vec<&str> = rec
            .points
            .first()
            .map(|p| p.axes.iter().map(|a| a.model.as_str()).collect())
            .unwrap_or_default();
        let coefficients = fit_coefficients(rec);
        let covariance: Vec<Vec<&Vec<Vec<f64>>>> = rec
            .points
            .iter()
            .map(|p| p.axes.iter().map(|a| &a.covariance).collect())
            .collect();
        self.insert(Row {
            serial: rec.serial.clone(),
            kind: "fit".into(),
            time: rec.created_unix_s as i64,
            data_hash: rec.data_hash.clone(),
            model: Some(models.join("; ")),
            coefficients: Some(serde_json::to_string(&coefficients).unwrap_or_default()),
            covariance: Some(serde_json::to_string(&covariance).unwrap_or_default()),
            report: report.map(|p| p.display().to_string()),
            blob: blob.to_vec(),
            verification: None,
            outcome: format!("{:?}", rec.verdict).to_lowercase(),
            record: Some(serde_json::to_string(rec).unwrap_or_default()),
            station: station(),
            lot: rec.lot.clone().unwrap_or_default(),
        })
    }

    /// Records a calibration without equipment (`calflash selfcal`): its JSON record
    /// (`calflash.selfcal/1`, which `calflash compare` reads), its coefficients and covariance,
    /// the report and the blob.
    ///
    /// # Errors
    /// A message naming the history and why; nothing is written then.
    pub fn record_selfcal(
        &mut self,
        serial: &str,
        record: &SelfcalRecord<'_>,
        report: Option<&Path>,
        blob: &[u8],
    ) -> Result<i64, Error> {
        let coefficients = serde_json::json!({
            "accel": record.accel,
            "gyro": record.gyro.matrix_rad_s_per_count,
            "gyro_bias_counts": record.gyro.bias_counts,
        });
        let covariance = serde_json::json!({
            "accel": record.accel.covariance,
            "gyro": record.gyro.covariance,
        });
        self.insert(Row {
            serial: serial.into(),
            kind: "fit".into(),
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: Some("selfcal: accelerometer from |a| = g, gyro from rotations".into()),
            coefficients: Some(coefficients.to_string()),
            covariance: Some(covariance.to_string()),
            report: report.map(|p| p.display().to_string()),
            blob: blob.to_vec(),
            verification: None,
            outcome: record.verdict.word().to_lowercase(),
            record: Some(serde_json::to_string(record).unwrap_or_default()),
            station: station(),
            lot: String::new(),
        })
    }

    /// Records a health report read from the unit (`calflash health`): the verdict as the
    /// outcome, the refined terms as the coefficients and covariance, the whole report as the
    /// record, and the blob of the calibration it judged.
    ///
    /// # Errors
    /// A message naming the history and why; nothing is written then.
    pub fn record_health(
        &mut self,
        serial: &str,
        blob: &[u8],
        record: &serde_json::Value,
    ) -> Result<i64, Error> {
        let health = &record["health"];
        let coefficients = serde_json::json!({"bias": health["bias"]});
        let covariance = serde_json::json!({"bias_sigma": health["bias_sigma"], "accel_covariance": health["accel_covariance"]});
        self.insert(Row {
            serial: serial.into(),
            kind: "health".into(),
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: Some("health at rest: refined biases (spincal::health)".into()),
            coefficients: Some(coefficients.to_string()),
            covariance: Some(covariance.to_string()),
            report: None,
            blob: blob.to_vec(),
            verification: None,
            outcome: health["verdict"].as_str().unwrap_or("").to_lowercase(),
            record: Some(record.to_string()),
            station: station(),
            lot: String::new(),
        })
    }

    /// Records an in-flight check (`calflash flight`): the verdict as the outcome, each sensor
    /// error's in-flight estimate as the coefficients and their 1-sigma as the covariance, the
    /// whole result as the record, and the blob of the calibration it checked.
    ///
    /// # Errors
    /// A message naming the history and why; nothing is written then.
    pub fn record_flight(
        &mut self,
        serial: &str,
        blob: &[u8],
        record: &serde_json::Value,
    ) -> Result<i64, Error> {
        let terms = record["terms"].as_array().cloned().unwrap_or_default();
        let pick = |key: &str| -> serde_json::Value {
            terms
                .iter()
                .map(|t| (t["name"].as_str().unwrap_or("").to_string(), t[key].clone()))
                .collect::<serde_json::Map<_, _>>()
                .into()
        };
        self.insert(Row {
            serial: serial.into(),
            kind: "flight".into(),
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: Some(
                "in flight: biases and scale factors against GNSS and a barometer (spincal::nav)"
                    .into(),
            ),
            coefficients: Some(pick("estimate").to_string()),
            covariance: Some(pick("sigma").to_string()),
            report: None,
            blob: blob.to_vec(),
            verification: None,
            outcome: record["verdict"].as_str().unwrap_or("").to_lowercase(),
            record: Some(record.to_string()),
            station: station(),
            lot: String::new(),
        })
    }

    /// Records a flash (done or failed): the unit, the blob, the verification.
    ///
    /// # Errors
    /// A message naming the history and why; nothing is written then.
    pub fn record_flash(
        &mut self,
        unit: &str,
        blob: &[u8],
        verification: &serde_json::Value,
        outcome: &str,
    ) -> Result<i64, Error> {
        let sensor = crate::signing::calibration(blob)
            .ok()
            .map(|cal| format!("{:?}", cal.data().sensor));
        self.insert(Row {
            serial: unit.into(),
            kind: "flash".into(),
            time: now(),
            data_hash: blob_hash(blob).unwrap_or_default(),
            model: None,
            coefficients: sensor,
            covariance: None,
            report: None,
            blob: blob.to_vec(),
            verification: Some(verification.to_string()),
            outcome: outcome.into(),
            record: None,
            station: station(),
            lot: String::new(),
        })
    }

    fn insert(&mut self, row: Row) -> Result<i64, Error> {
        let r = self.backend.insert(&row);
        self.named(r)
    }

    /// A unit's history, oldest first.
    ///
    /// # Errors
    /// A message naming the history and why.
    pub fn history(&mut self, serial: &str) -> Result<Vec<Entry>, Error> {
        let r = self.backend.history(serial);
        Ok(self
            .named(r)?
            .into_iter()
            .map(|l| Entry {
                signed_by: crate::signing::signer(&l.blob)
                    .map(|(key, counter)| format!("{key} #{counter}")),
                signature_checked: l.kind == "fit"
                    || (l.kind == "flash"
                        && l.outcome == "verified"
                        && l.verification
                            .as_deref()
                            .and_then(|v| serde_json::from_str::<serde_json::Value>(v).ok())
                            .is_some_and(|v| v["trust"] == "provisioned")),
                id: l.id,
                kind: l.kind,
                time: l.time,
                data_hash: l.data_hash,
                model: l.model,
                outcome: l.outcome,
                report: l.report,
                blob_len: l.blob.len(),
                lot: l.lot,
            })
            .collect())
    }

    /// The newest fit in the time range of every unit `sel` takes, oldest first.
    ///
    /// # Errors
    /// A message naming the history and why; a station or lot asked of a history without
    /// them.
    pub fn latest_fits(&mut self, sel: &Selection<'_>) -> Result<Vec<FitRow>, Error> {
        let r = self.backend.latest_fits(sel);
        self.named(r)
    }

    /// The highest counter of the signed blobs recorded for unit `serial` (0 for none).
    ///
    /// # Errors
    /// A message naming the history and why.
    pub fn highest_counter(&mut self, serial: &str) -> Result<u32, Error> {
        let r = self.backend.blobs(serial);
        Ok(self
            .named(r)?
            .iter()
            .filter_map(|b| crate::signing::signer(b).map(|(_, c)| c))
            .max()
            .unwrap_or(0))
    }

    /// The JSON record of calibration `id` (of `calflash calibrate` or `calflash selfcal`).
    ///
    /// # Errors
    /// No such record, or a flash.
    pub fn record(&mut self, id: i64) -> Result<String, Error> {
        let r = self.backend.record(id);
        match self.named(r)? {
            None => Err(Error::NoRecord {
                location: self.location.clone(),
                id,
            }),
            Some(None) => Err(Error::NotACalibration {
                location: self.location.clone(),
                id,
            }),
            Some(Some(t)) => Ok(t),
        }
    }

    /// Copies every record of `from` that this history does not hold yet, in one transaction
    /// (all or nothing; a second copy adds nothing); records of `from` without a station
    /// (schema 2 and before) are given `station`. How many records `from` has and how many
    /// were copied.
    ///
    /// # Errors
    /// Either history's failure, named; nothing is written then.
    pub fn copy_from(&mut self, from: &mut Db, station: &str) -> Result<(usize, usize), Error> {
        let r = from.backend.rows();
        let mut rows = from.named(r)?;
        for row in &mut rows {
            if row.station.is_empty() {
                row.station = station.to_string();
            }
        }
        let r = self.backend.copy(&rows);
        Ok((rows.len(), self.named(r)?))
    }

    /// Where the history is.
    #[must_use]
    pub fn location(&self) -> &Location {
        &self.location
    }
}
