//! Bounds of what a set can output for any code inside the rails, and the check that they stay
//! below the output limit.

use super::OUTPUT_LIMIT;
use crate::Error;
use crate::error::Part;
use crate::model::interval::{Bound, affine_bound, axis_bound};
use crate::model::sets::TriadSet;
use crate::model::{Channel, Rails};

/// Bound of a triad's outputs over every code inside its rails.
pub(crate) fn triad_output_bound(
    set: &TriadSet,
    channels: &[Channel; 3],
    rails: &Rails,
) -> [Bound; 3] {
    let mut u = [Bound::point(0.0); 3];
    for ((b, n), c) in u.iter_mut().zip(&set.axes).zip(channels) {
        let (lo, hi) = c.rail_offsets(rails);
        *b = axis_bound(n, lo, hi);
    }
    let mut y = [Bound::point(0.0); 3];
    for ((b, row), o) in y.iter_mut().zip(&set.matrix).zip(&set.offset) {
        *b = affine_bound(row, *o, &u);
    }
    y
}

pub(super) fn check_bounded(bounds: &[Bound], part: Part, set: u8) -> Result<(), Error> {
    for b in bounds {
        if !(b.is_finite()
            && b.lo >= -OUTPUT_LIMIT
            && b.hi <= OUTPUT_LIMIT
            && b.mag <= OUTPUT_LIMIT)
        {
            return Err(Error::InvalidUnboundedOutput { part, set });
        }
    }
    Ok(())
}
