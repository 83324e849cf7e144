//! What a calibration command writes: the blob, the HTML report, the JSON record, and the
//! entry in the unit history. Shared by `calflash calibrate` and `calflash selfcal`.

use crate::cmd::Failure;
use std::path::PathBuf;

use clap::Args;

use crate::db::{self, Db};
use crate::files::{Paths, Staged};

/// Where a calibration goes.
#[derive(Debug, Args)]
pub struct Outputs {
    /// Write the blob here.
    #[arg(long)]
    pub blob: Option<PathBuf>,
    /// Write the HTML report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the calibration record (JSON, for `calflash compare`) here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// The unit history: a SQLite file, or a PostgreSQL database shared by stations
    /// (postgres://USER:PASSWORD@HOST/DB); default $CALFLASH_DB, else the user's data directory.
    #[arg(long, value_name = "FILE|URL")]
    pub db: Option<crate::db::Given>,
    /// Do not record the calibration.
    #[arg(long)]
    pub no_db: bool,
    /// Write the blob even when the calibration is judged REJECT; its identity then says so, and
    /// `calflash flash` refuses it without `--force-rejected`.
    #[arg(long)]
    pub force_blob: bool,
    /// Sign the blob with the station's private key (default: $CALFLASH_SIGN_KEY), for a
    /// unit provisioned with its public key. Only a calibration judged ACCEPT is signed: one
    /// judged REVIEW only with --sign-review, one judged REJECT never.
    #[arg(long)]
    pub sign_key: Option<PathBuf>,
    /// Sign a calibration judged REVIEW too: a person has reviewed it (or the station's policy
    /// says so). Without it, a REVIEW blob is written unsigned, to be signed with `calflash
    /// sign` after the review.
    #[arg(long)]
    pub sign_review: bool,
    /// The signed blob's counter: above the one the unit holds (default: one above the
    /// highest counter of the unit's blobs in the history).
    #[arg(long)]
    pub counter: Option<u32>,
    /// The unit's production lot: recorded with its calibration (`calflash lot --lot NAME`
    /// takes the lot's units), and the unit compared with the lot's other units in the
    /// history: one unlike them is a REVIEW that names the coefficients that make it so.
    #[arg(long, value_name = "NAME")]
    pub lot: Option<String>,
    /// The lot as it stood before a batch, judged once, for every unit of the batch (`None`:
    /// read from the history for the unit).
    #[arg(skip)]
    pub lot_before: Option<std::sync::Arc<Result<crate::lot::Lot, String>>>,
}

/// A blob as written: signed or not, and what to say about it.
#[derive(Debug)]
pub struct Signed {
    /// The bytes to write.
    pub bytes: Vec<u8>,
    /// A line for the summary (`None` when no key was asked for).
    pub note: Option<String>,
}

impl Outputs {
    /// Checks, before any work, that no output is one of `inputs` or another output.
    ///
    /// # Errors
    /// The two options that name one file.
    pub fn check(&self, inputs: Paths) -> Result<(), Failure> {
        let db = (!self.no_db)
            .then(|| crate::db::Location::or_default(self.db.as_ref()))
            .transpose()?;
        inputs
            .output("--blob", self.blob.as_deref())
            .output("--report", self.report.as_deref())
            .output("--json", self.json.as_deref())
            .created("the unit history", db.as_ref().and_then(db::Location::file))
            .check()?;
        Ok(())
    }

    /// Where the unit with `coefficients` stands against its lot (`--lot`), as a finding: a
    /// REVIEW when it is outside the lot or cannot be compared with it; `None` without `--lot`.
    #[must_use]
    pub fn lot_finding(
        &self,
        serial: &str,
        coefficients: &std::collections::BTreeMap<String, f64>,
        alpha: f64,
    ) -> Option<crate::sensor::Finding> {
        use crate::sensor::{Finding, Verdict};
        let name = self.lot.as_deref()?;
        let read;
        let lot = match &self.lot_before {
            Some(before) => before.as_ref().as_ref(),
            None => {
                let sel = crate::db::Selection {
                    lot: Some(name),
                    ..crate::db::Selection::all()
                };
                read = crate::db::Location::or_default(self.db.as_ref())
                    .map_err(|e| e.to_string())
                    .and_then(|path| {
                        crate::lot::history::load_without(&path, &sel, |s| s == serial, alpha)
                            .map_err(|e| e.to_string())
                    });
                read.as_ref()
            }
        };
        let placed = lot.map_err(Clone::clone).and_then(|lot| {
            lot.place(coefficients)
                .map(|(o, outside)| (o, outside, lot.units.len(), lot.distance_limit()))
                .map_err(|e| e.to_string())
        });
        Some(match placed {
            Ok((o, outside, n, limit)) => {
                let why: Vec<String> = o
                    .coefficients
                    .iter()
                    .map(|(k, z)| format!("{k} z={z:+.1}"))
                    .collect();
                Finding {
                    verdict: if outside {
                        Verdict::Review
                    } else {
                        Verdict::Accept
                    },
                    text: format!(
                        "lot `{name}` ({n} units): distance {:.2} {} the limit {limit:.2}{}",
                        o.distance,
                        if outside { "beyond" } else { "within" },
                        if outside {
                            format!("; unlike its lot in {}", why.join(", "))
                        } else {
                            String::new()
                        }
                    ),
                }
            }
            Err(e) => Finding {
                verdict: Verdict::Review,
                text: format!("not compared with its lot: {e}"),
            },
        })
    }

    /// `record`, sealed, and signed with the station's key when one is given (`--sign-key` or
    /// `$CALFLASH_SIGN_KEY`): whatever its verdict, for the signature says which station wrote
    /// the record, not that the unit passed.
    ///
    /// # Errors
    /// An unreadable key or one others may read.
    pub fn seal_record(
        &self,
        record: crate::sensor::record::Record,
    ) -> Result<crate::sensor::record::Record, Failure> {
        Ok(match crate::signing::key_path(self.sign_key.as_deref()) {
            Some(path) => record.signed(&crate::signing::load_private(&path)?),
            None => record.sealed(),
        })
    }

    /// The station keys whose records this station takes as its own: the public keys `given`
    /// (`--trust-key`) and the public half of its own signing key, when one is given.
    ///
    /// # Errors
    /// A key file that cannot be read, or is the wrong half.
    pub fn trusted(&self, given: &[PathBuf]) -> Result<Vec<spincal::signed::StationKey>, Failure> {
        let mut keys = crate::signing::load_publics(given)?;
        if let Some(path) = crate::signing::key_path(self.sign_key.as_deref()) {
            let own = spincal::signed::StationKey {
                public: crate::signing::load_private(&path)?
                    .verifying_key()
                    .to_bytes(),
            };
            if !keys.contains(&own) {
                keys.push(own);
            }
        }
        Ok(keys)
    }

    /// Signs `blob` (the calibration of unit `serial`, judged `verdict`) when a key is given
    /// (`--sign-key` or `$CALFLASH_SIGN_KEY`, the same policy for both): ACCEPT is signed,
    /// REVIEW only with `--sign-review`, REJECT never. The counter is `--counter`, else one
    /// above the highest in the unit's history.
    ///
    /// # Errors
    /// An unreadable key or one others may read, a history that cannot be read, or no counter.
    pub fn sign(
        &self,
        blob: Vec<u8>,
        serial: &str,
        verdict: crate::sensor::Verdict,
    ) -> Result<Signed, Failure> {
        use crate::sensor::Verdict;
        let Some(key_path) = crate::signing::key_path(self.sign_key.as_deref()) else {
            return Ok(Signed {
                bytes: blob,
                note: None,
            });
        };
        let refused = match verdict {
            Verdict::Reject => Some("a calibration judged REJECT is never signed".to_string()),
            Verdict::Review if !self.sign_review => Some(
                "a calibration judged REVIEW is signed only after a review: `calflash sign` it then, or calibrate with --sign-review"
                    .to_string(),
            ),
            _ => None,
        };
        if let Some(why) = refused {
            return Ok(Signed {
                bytes: blob,
                note: Some(format!("  not signed with {}: {why}", key_path.display())),
            });
        }
        let key = crate::signing::load_private(&key_path)?;
        let counter = match self.counter {
            Some(c) => c,
            None if self.no_db => {
                return Err(
                    "--sign-key with --no-db: give --counter (above the one the unit holds)".into(),
                );
            }
            None => {
                let path = crate::db::Location::or_default(self.db.as_ref())?;
                let held = match path.file() {
                    Some(f) if !f.exists() => 0,
                    _ => Db::open(&path).and_then(|mut d| d.highest_counter(serial))?,
                };
                held.checked_add(1)
                    .ok_or("the unit's history holds the highest counter there is")?
            }
        };
        let bytes = crate::signing::sign(&blob, &key, counter, false)?;
        let id = crate::signing::signer(&bytes)
            .map(|(id, _)| id)
            .unwrap_or_default();
        let reviewed = if verdict == Verdict::Review {
            " (REVIEW, signed on --sign-review)"
        } else {
            ""
        };
        Ok(Signed {
            note: Some(format!(
                "  signed by station key {id} ({}), counter {counter}{reviewed}",
                key_path.display()
            )),
            bytes,
        })
    }

    /// Writes the files asked for, all or none (the report stamped with `provenance`, and the
    /// blob's hash): each is staged beside its destination and
    /// they are renamed into place together, so a report that cannot be drawn or a directory
    /// that does not exist leaves no file. `blob` is `None` when none may be written (a
    /// REJECT without `--force-blob`): a file at the blob's path is then removed in the same
    /// commit, so that no earlier run's blob stays beside this run's record.
    ///
    /// # Errors
    /// A file that cannot be written, or the report's error.
    pub fn write(
        &self,
        blob: Option<&[u8]>,
        record: &impl serde::Serialize,
        provenance: crate::report::provenance::Provenance,
        html: impl FnOnce() -> Result<String, crate::report::Error>,
    ) -> Result<(), Failure> {
        // The page names the blob written beside it, by its hash.
        let provenance = match (&self.blob, blob) {
            (Some(p), Some(b)) => provenance.blob(&p.display().to_string(), b),
            _ => provenance,
        };
        let html = self
            .report
            .as_ref()
            .map(|_| html().map(|page| provenance.stamp(&page)))
            .transpose()?;
        let mut staged = Staged::new();
        match (&self.blob, blob) {
            (Some(p), Some(blob)) => staged.write(p, |w| w.write_all(blob))?,
            // No blob of an earlier run stays beside this run's record.
            (Some(p), None) => staged.remove(p),
            _ => {}
        }
        if let (Some(p), Some(html)) = (&self.report, &html) {
            staged.write(p, |w| w.write_all(html.as_bytes()))?;
            crate::report::written::page(p);
        }
        if let Some(p) = &self.json {
            staged.write(p, |w| {
                serde_json::to_writer_pretty(&mut *w, record).map_err(std::io::Error::other)
            })?;
        }
        Ok(staged.commit()?)
    }

    /// Records the calibration in the unit history with `save` (unless `--no-db`) and says
    /// where (`None` with `--no-db`); when the database cannot take it, `record` is saved as
    /// JSON beside the outputs.
    ///
    /// # Errors
    /// The database's error, saying where the record went instead.
    pub fn record(
        &self,
        serial: &str,
        record: &serde_json::Value,
        save: impl FnOnce(&mut Db) -> Result<i64, db::Error>,
    ) -> Result<Option<String>, String> {
        if self.no_db {
            return Ok(None);
        }
        let path = crate::db::Location::or_default(self.db.as_ref()).map_err(|e| e.to_string())?;
        let beside = db::beside(&[
            self.blob.as_deref(),
            self.json.as_deref(),
            self.report.as_deref(),
        ]);
        let said = db::record_or_save(&path, save, record, &beside, serial).map_err(|e| {
            if self.blob.is_some() || self.json.is_some() || self.report.is_some() {
                format!("the calibration's files are written but it is {e}")
            } else {
                format!("the calibration is {e}")
            }
        })?;
        Ok(Some(said))
    }
}
