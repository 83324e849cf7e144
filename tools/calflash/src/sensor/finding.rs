//! The acceptance summary's unit: a finding and its verdict (accept, review, reject).

/// Accept, review or reject.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Every check passed.
    Accept,
    /// A person should look at a finding before accepting.
    Review,
    /// The unit or the calibration does not meet its requirements.
    Reject,
}

impl Verdict {
    /// The word the reports print: `ACCEPT`, `REVIEW` or `REJECT`.
    #[must_use]
    pub fn word(self) -> &'static str {
        match self {
            Self::Accept => "ACCEPT",
            Self::Review => "REVIEW",
            Self::Reject => "REJECT",
        }
    }
}

/// One check of the acceptance summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Finding {
    /// Its outcome.
    pub verdict: Verdict,
    /// What it found, in words.
    pub text: String,
}
