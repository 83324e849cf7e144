//! Converter code formats: their names (`unsigned16`, `signed16`, or `LO:HI`) and what codes
//! beyond a format's rails say about the format the data were really written in.

use spincal::model::Rails;

/// How a code format is named in messages and records: `unsigned16`, `signed16`, or `LO:HI`.
#[must_use]
pub fn name(r: Rails) -> String {
    for bits in 8..=32 {
        if r == Rails::signed(bits) {
            return format!("signed{bits}");
        }
        if bits < 32 && r == Rails::unsigned(bits) {
            return format!("unsigned{bits}");
        }
    }
    format!("{}:{}", r.lo, r.hi)
}

/// The fewest codes beyond the rails, on one side, that say the format is wrong rather than
/// that a value is damaged.
pub const MISMATCH: usize = 10;

/// What `below` codes under the low rail and `above` over the high one (strictly beyond, not
/// at: those are saturated) say of the format: `Some(advice)` when they show another format
/// of the same width (signed codes read as unsigned, or the reverse).
#[must_use]
pub fn mismatch(below: usize, above: usize, rails: Rails) -> Option<String> {
    let bits =
        (8..=32).find(|&b| rails == Rails::signed(b) || (b < 32 && rails == Rails::unsigned(b)))?;
    let signed = rails == Rails::signed(bits);
    if !signed && below >= MISMATCH && above == 0 {
        Some(format!(
            "{below} codes below zero: the codes look signed; add --codes signed{bits}"
        ))
    } else if signed && above >= MISMATCH && below == 0 && bits < 32 {
        Some(format!(
            "{above} codes above {}: the codes look unsigned (or offset binary); add --codes unsigned{bits}",
            rails.hi
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_format_read_as_the_other_is_named() {
        assert_eq!(name(Rails::signed(16)), "signed16");
        assert_eq!(name(Rails::unsigned(12)), "unsigned12");
        assert_eq!(name(Rails::new(-5, 5)), "-5:5");
        assert_eq!(
            mismatch(1812, 0, Rails::unsigned(16)).unwrap(),
            "1812 codes below zero: the codes look signed; add --codes signed16"
        );
        assert!(
            mismatch(0, 40, Rails::signed(16))
                .unwrap()
                .ends_with("add --codes unsigned16")
        );
        // A few damaged values, or codes beyond both rails, are not a format.
        assert_eq!(mismatch(3, 0, Rails::unsigned(16)), None);
        assert_eq!(mismatch(20, 20, Rails::unsigned(16)), None);
        assert_eq!(mismatch(20, 0, Rails::new(-5, 5)), None);
    }
}
