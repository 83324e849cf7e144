//! The one rule for a calibration that goes into a unit or is signed for one: a blob whose fit
//! was judged REJECT (written only with `calibrate --force-blob`, its identity marked
//! `fit_rejected`) is refused by `flash`, `image` (every output: `--bin`, `--hex`, the probe)
//! and `sign` alike, unless a person insists with `--force-rejected`. The mark stays in the
//! blob's identity, so a forced blob says what it is in the signed record, in the unit's image,
//! on the unit and in the history.

use std::path::{Path, PathBuf};

use spincal::model::Identity;

/// What is done with the blob.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Act {
    /// Written into a unit over its link.
    Flash,
    /// Written into a unit image (file or probe).
    Image,
    /// Signed for a unit.
    Sign,
}

impl Act {
    fn verb(self) -> &'static str {
        match self {
            Self::Flash => "written into a unit",
            Self::Image => "put into a unit image",
            Self::Sign => "signed",
        }
    }
}

/// A blob refused by the rule.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Refused {
    /// Its fit was judged REJECT.
    #[error(
        "{}: the blob's fit was judged REJECT (it was written with --force-blob); it is not {} \
         (use --force-rejected to insist; the blob keeps the mark)",
        .path.display(),
        .act.verb()
    )]
    RejectedFit {
        /// The blob.
        path: PathBuf,
        /// What was refused.
        act: Act,
    },
}

/// The rule itself: true when a blob of `identity` may not go on (its fit was judged REJECT and
/// nobody insisted with `force_rejected`).
#[must_use]
pub const fn refused(identity: &Identity, force_rejected: bool) -> bool {
    identity.fit_rejected && !force_rejected
}

/// Applies the rule to the blob at `path` whose identity is `identity`: `Ok(None)` for an
/// approved blob, `Ok(Some(warning))` for a rejected one a person insists on
/// (`force_rejected`), the warning to print.
///
/// # Errors
/// [`Refused`].
pub fn admit(
    identity: &Identity,
    path: &Path,
    act: Act,
    force_rejected: bool,
) -> Result<Option<String>, Refused> {
    if refused(identity, force_rejected) {
        return Err(Refused::RejectedFit {
            path: path.to_path_buf(),
            act,
        });
    }
    if !identity.fit_rejected {
        return Ok(None);
    }
    Ok(Some(format!(
        "WARNING: {}: the blob's fit was judged REJECT; {} on --force-rejected (its identity keeps the mark fit_rejected)",
        path.display(),
        act.verb()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rejected_fit_is_refused_for_every_act_unless_insisted_on() {
        let mut id = spincal::model::CalibrationData::example_imu().identity;
        let p = Path::new("r.blob");
        for act in [Act::Flash, Act::Image, Act::Sign] {
            assert_eq!(admit(&id, p, act, false), Ok(None));
        }
        id.fit_rejected = true;
        for act in [Act::Flash, Act::Image, Act::Sign] {
            let e = admit(&id, p, act, false).unwrap_err();
            assert!(e.to_string().contains("--force-rejected"), "{e}");
            let w = admit(&id, p, act, true).unwrap().unwrap();
            assert!(w.contains("REJECT") && w.contains("r.blob"), "{w}");
        }
    }
}
