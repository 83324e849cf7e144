//! Did the calibration survive the launch? The round's own answer, from its forward filter, in
//! `no_std`: each sensor term's in-flight estimate against what the filter would estimate had
//! nothing shifted, only when the aiding's innovations say the filter fits the data.
//!
//! The round cannot smooth back to the launch as `calflash flight` does, so it tests what it
//! has: the estimate `x` now against `m`, the estimate when the launch's shift was opened (the
//! end of the setback, [`FlightConfig::launch_shift`](super::FlightConfig::launch_shift)).
//! The filter took the errors there as `N(m, Pi)`, `Pi` the calibration's prior as the pad left
//! it plus the opened shift `S`; with `P` its covariance now, its estimate moves by `L = (Pi -
//! P) Pi^-1` per unit of true error. Had nothing shifted, the true errors are `N(m, Pi - S)`
//! and the estimate's spread about `m` is `D = (Pi - P) - L S L'` (the static errors' linear
//! estimate, as the host's verdict takes it). A term is observed when what the flight alone
//! determines of it, `1 / sqrt(1/P - 1/Pi)`, is within [`UNRESOLVED`] times its prior's
//! 1-sigma. The terms are named by a step-down over the observed terms whitened by `D`
//! (Holm's, each candidate's column of `L` fitted with those named by modified Gram-Schmidt),
//! and tested together by `x' D^-1 x` (chi-square): the host's `nav::verdict`, on what the
//! round holds.
//!
//! What is approximated, on the side of fewer false alarms: the in-bore samples between the
//! launch and the end of the setback are taken as the filter took them (with the shift open),
//! so `Pi - S` is wider than the spread had nothing shifted, and `D` with it; the random walks
//! after the opening are left out, as the host leaves them out.
//!
//! Computed in `f64` on every target (software double precision on the Cortex-M4F, a few
//! 12 x 12 decompositions when the verdict is read, never per sample), so the round's verdict
//! is the same on the host and the device.

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use super::line::LaunchChange;
use super::stats::{Aiding, FlightStats};

/// The sensor terms: accelerometer biases, gyro biases, accelerometer and gyro scale factors,
/// each `x, y, z` (the filter's order from
/// [`index::ACCEL_BIAS`](crate::nav::filter::index::ACCEL_BIAS)).
pub const TERMS: usize = 12;

/// A matrix over the sensor terms.
pub type TermMatrix = SMatrix<f64, TERMS, TERMS>;

/// A vector over the sensor terms.
pub type TermVector = SVector<f64, TERMS>;

/// The terms' names, in [`TERMS`]' order.
pub const TERM_NAMES: [&str; TERMS] = [
    "accel bias x",
    "accel bias y",
    "accel bias z",
    "gyro bias x",
    "gyro bias y",
    "gyro bias z",
    "accel scale x",
    "accel scale y",
    "accel scale z",
    "gyro scale x",
    "gyro scale y",
    "gyro scale z",
];

/// The false-alarm rate of SHIFTED over all terms together (`calflash flight`'s default).
pub const ALPHA: f64 = 0.01;

/// A term is not observed when what the flight alone determines of it is wider than this many
/// times its prior's 1-sigma (`calflash flight`'s `UNRESOLVED`).
pub const UNRESOLVED: f64 = 100.0;

/// The least variance, as a share of the largest, of a direction of `D` the test keeps.
const RESOLVED_SHARE: f64 = 1e-9;

/// The share of aiding innovations inside their 95 % bounds a filter that fits has at least
/// (`calflash flight`'s).
pub const INSIDE_AT_LEAST: f64 = 0.93;

/// The share of aiding innovations a filter that fits may refuse at its gate.
pub const REFUSED_AT_MOST: f64 = 0.05;

/// The verdict's word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Word {
    /// The launch's shift has not been opened yet (no launch, or the setback goes on).
    NotYet,
    /// The observed terms within what the filter expects had nothing shifted.
    Held,
    /// A term (or the observed terms together) moved beyond it.
    Shifted,
    /// The flight observes no term.
    CannotTell,
    /// The filter's innovations do not fit its model (or its covariance was reset in flight):
    /// its estimates are no findings.
    DoesNotFit,
}

impl Word {
    /// As `calflash flight` prints it.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::NotYet => "NOT YET",
            Self::Held => "HELD",
            Self::Shifted => "SHIFTED",
            Self::CannotTell => "CANNOT TELL",
            Self::DoesNotFit => "FILTER DOES NOT FIT",
        }
    }
}

/// The round's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Verdict {
    /// The word.
    pub word: Word,
    /// Per term its shift since the opening, `x - m`, less what the calibration's own change
    /// of line into the flight moves it by.
    pub shift: [f32; TERMS],
    /// Per term its Wald statistic against "held", NaN when not observed.
    pub z: [f32; TERMS],
    /// Bit `i` set: term `i` observed.
    pub observed: u16,
    /// Bit `i` set: term `i` named shifted.
    pub shifted: u16,
    /// The observed terms' chi-square together, and its p-value (NaN when none observed).
    pub chi2: (f32, f32),
    /// The aiding innovations (GNSS and barometer): how many, the share inside their 95 %
    /// bounds, the share refused at the gate, the mean NIS of those taken.
    pub innovations: (u32, f32, f32, f32),
    /// Covariance resets since the start ([`FlightStats::resets`]).
    pub resets: u32,
    /// "Nothing shifted" carried the calibration's own change of line into the flight
    /// ([`LaunchChange`]); false: the sensor errors' prior alone, as stated or at rest.
    pub carried: bool,
}

impl Verdict {
    /// Before the launch's shift is opened.
    #[must_use]
    pub fn not_yet(stats: &FlightStats) -> Self {
        Self {
            word: Word::NotYet,
            shift: [0.0; TERMS],
            z: [f32::NAN; TERMS],
            observed: 0,
            shifted: 0,
            chi2: (f32::NAN, f32::NAN),
            innovations: consistency(stats).0,
            resets: stats.resets,
            carried: false,
        }
    }

    /// Whether term `i` is observed.
    #[must_use]
    pub fn is_observed(&self, i: usize) -> bool {
        self.observed & (1 << i) != 0
    }

    /// Whether term `i` is named shifted.
    #[must_use]
    pub fn is_shifted(&self, i: usize) -> bool {
        self.shifted & (1 << i) != 0
    }
}

/// The aiding innovations' counts and whether the filter fits them: (count, share inside 95 %,
/// share refused, mean NIS of those taken), fits.
fn consistency(stats: &FlightStats) -> ((u32, f32, f32, f32), bool) {
    let kinds = [Aiding::Position, Aiding::Velocity, Aiding::Baro].map(|k| k as usize);
    let sum = |a: &[u32; 4]| kinds.iter().filter_map(|k| a.get(*k)).copied().sum::<u32>();
    let (taken, refused, inside) = (sum(&stats.taken), sum(&stats.refused), sum(&stats.inside));
    let nis: f32 = kinds.iter().filter_map(|k| stats.nis.get(*k)).sum();
    let n = taken + refused;
    let share = |x: u32| if n > 0 { x as f32 / n as f32 } else { f32::NAN };
    let mean = if taken > 0 {
        nis / taken as f32
    } else {
        f32::NAN
    };
    let fits = n > 0
        && f64::from(inside) >= INSIDE_AT_LEAST * f64::from(n)
        && mean < 2.0
        && f64::from(refused) <= REFUSED_AT_MOST * f64::from(n);
    ((n, share(inside), share(refused), mean), fits)
}

/// What the filter held when it opened the launch's shift, and the shift's variances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opening {
    /// The estimate then, `m`.
    pub estimate: TermVector,
    /// The covariance just after the opening, `Pi`.
    pub covariance: TermMatrix,
    /// The variances opened, `S` (diagonal).
    pub shift: TermVector,
}

/// The directions of the symmetric `m` (symmetrised) above [`RESOLVED_SHARE`] of the largest
/// variance, each as a row scaled by its variance's `power` (`-1/2` whitens, `-1` inverts);
/// the other rows zero.
fn scaled_directions(m: &TermMatrix, power: f64) -> TermMatrix {
    let e = ((m + m.transpose()) * 0.5).symmetric_eigen();
    let top = e.eigenvalues.amax();
    let mut out = TermMatrix::zeros();
    for (mut row, (value, vector)) in out
        .row_iter_mut()
        .zip(e.eigenvalues.iter().zip(e.eigenvectors.column_iter()))
    {
        if top > 0.0 && *value > RESOLVED_SHARE * top {
            row.copy_from(&(vector.transpose() * libm::pow(*value, power)));
        }
    }
    out
}

/// The pseudo-inverse of the symmetric `m`, over its directions above [`RESOLVED_SHARE`] of the
/// largest.
fn pseudo_inverse(m: &TermMatrix) -> TermMatrix {
    let e = ((m + m.transpose()) * 0.5).symmetric_eigen();
    let top = e.eigenvalues.amax();
    let mut out = TermMatrix::zeros();
    for (value, vector) in e.eigenvalues.iter().zip(e.eigenvectors.column_iter()) {
        if top > 0.0 && *value > RESOLVED_SHARE * top {
            out += vector * vector.transpose() / *value;
        }
    }
    out
}

/// Two-sided normal p-value of `z`.
fn normal_two_sided(z: f64) -> f64 {
    libm::erfc(z.abs() / core::f64::consts::SQRT_2)
}

/// The chi-square survival function with `k` (1 ..= [`TERMS`]) degrees of freedom at `x`: the
/// regularised upper gamma `Q(k/2, x/2)` by its finite sums for whole and half-whole orders.
#[must_use]
pub fn chi_square_sf(x: f64, k: usize) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let h = 0.5 * x;
    let e = libm::exp(-h);
    if k % 2 == 0 {
        // Q(n, h) = e^-h sum_{j < n} h^j / j!
        let (mut term, mut sum) = (1.0, 0.0);
        for j in 0..k / 2 {
            if j > 0 {
                term *= h / j as f64;
            }
            sum += term;
        }
        (e * sum).min(1.0)
    } else {
        // Q(n + 1/2, h) = erfc(sqrt h) + e^-h sum_{j < n} h^(j + 1/2) / Gamma(j + 3/2)
        let mut sum = 0.0;
        let mut term = libm::sqrt(h) / (0.5 * libm::sqrt(core::f64::consts::PI));
        for j in 0..(k - 1) / 2 {
            if j > 0 {
                term *= h / (j as f64 + 0.5);
            }
            sum += term;
        }
        (libm::erfc(libm::sqrt(h)) + e * sum).min(1.0)
    }
}

impl Opening {
    /// The verdict on the estimate `x` and covariance `p` now (over the sensor terms), with the
    /// filter's counts.
    #[must_use]
    pub fn judge(
        &self,
        x: &TermVector,
        p: &TermMatrix,
        stats: &FlightStats,
        change: Option<&LaunchChange>,
    ) -> Verdict {
        let (innovations, fits) = consistency(stats);
        let pi = &self.covariance;
        let learnt = pi - p;
        let l = learnt * pseudo_inverse(pi);
        // Had nothing shifted, the errors are those at rest (`Pi - S`) carried into the flight
        // by the calibration's own change of line, `(I + K) x + w`: the filter opened `Pi`
        // less that.
        let (k, w) = change.map_or((TermMatrix::zeros(), TermMatrix::zeros()), terms);
        let carried = TermMatrix::identity() + k;
        let rest = pi - TermMatrix::from_diagonal(&self.shift);
        let held = carried * rest * carried.transpose() + w;
        let d = learnt - l * (pi - held) * l.transpose();
        let d = (d + d.transpose()) * 0.5;
        let shift = x - self.estimate - l * k * self.estimate;
        // Observed: learnt from, and what the flight alone determines within UNRESOLVED
        // times the prior's 1-sigma.
        let seen = TermVector::from_iterator(
            pi.diagonal()
                .iter()
                .zip(p.diagonal().iter())
                .zip(self.shift.iter().zip(d.diagonal().iter()))
                .map(|((was, now), (opened, spread))| {
                    let before = was - opened;
                    let info = if *now > 0.0 && was > now {
                        1.0 / now - 1.0 / was
                    } else {
                        0.0
                    };
                    let seen = info > 0.0
                        && before > 0.0
                        && *spread > 0.0
                        && 1.0 / info <= UNRESOLVED * UNRESOLVED * before;
                    if seen { 1.0 } else { 0.0 }
                }),
        );
        let observed = seen
            .iter()
            .enumerate()
            .filter(|(_, s)| **s > 0.0)
            .fold(0u16, |bits, (i, _)| bits | 1 << i);
        let mut z = [f32::NAN; TERMS];
        for (z, ((s, x), spread)) in z
            .iter_mut()
            .zip(seen.iter().zip(shift.iter()).zip(d.diagonal().iter()))
        {
            if *s > 0.0 {
                *z = (x / libm::sqrt(*spread)) as f32;
            }
        }
        // D, L and the shift over the observed terms (the others zeroed), whitened by D.
        let keep = TermMatrix::from_diagonal(&seen);
        let whiten = scaled_directions(&(keep * d * keep), -0.5);
        let y = whiten * keep * shift;
        let columns = whiten * keep * l;
        let m = observed.count_ones() as usize;
        let chi2 = if m > 0 {
            let c = y.norm_squared();
            (c as f32, chi_square_sf(c, m) as f32)
        } else {
            (f32::NAN, f32::NAN)
        };
        let shifted = step_down(observed, y, &columns, m);
        let word = if stats.resets > 0 || !fits {
            Word::DoesNotFit
        } else if shifted != 0 || chi2.1 < ALPHA as f32 {
            Word::Shifted
        } else if m == 0 {
            Word::CannotTell
        } else {
            Word::Held
        };
        Verdict {
            word,
            shift: shift.map(|v| v as f32).into(),
            z,
            observed,
            shifted,
            chi2,
            innovations,
            resets: stats.resets,
            carried: change.is_some(),
        }
    }
}

/// `K` and `W` of `change` over the sensor terms (each output's bias and scale factor).
fn terms(change: &LaunchChange) -> (TermMatrix, TermMatrix) {
    let (mut k, mut w) = (TermMatrix::zeros(), TermMatrix::zeros());
    for (out, (_, ko, wo)) in change.outputs.iter().enumerate() {
        let at = [out, 6 + out];
        for (i, a) in at.iter().enumerate() {
            for (j, b) in at.iter().enumerate() {
                if let (Some(x), Some(y), Some(kv), Some(wv)) = (
                    k.get_mut((*a, *b)),
                    w.get_mut((*a, *b)),
                    ko.get((i, j)),
                    wo.get((i, j)),
                ) {
                    (*x, *y) = (*kv, *wv);
                }
            }
        }
    }
    (k, w)
}

/// Holm's step-down over the `m` observed terms: at each step the term whose whitened column
/// most lowers what is left of `y` (after the columns named, by modified Gram-Schmidt) is named
/// when its chi-square(1) p-value is under `ALPHA / (m - named)`; the steps stop at the first
/// that names none.
fn step_down(observed: u16, mut y: TermVector, columns: &TermMatrix, m: usize) -> u16 {
    let mut basis: heapless::Vec<TermVector, TERMS> = heapless::Vec::new();
    let mut named = 0u16;
    for k in 0..m {
        let mut best: Option<(u16, f64, TermVector)> = None;
        for (j, column) in columns.column_iter().enumerate() {
            let bit = 1u16 << j;
            if observed & bit == 0 || named & bit != 0 {
                continue;
            }
            let mut c: TermVector = column.into_owned();
            for q in &basis {
                c -= q * q.dot(&c);
            }
            let norm = c.norm();
            if norm.is_nan() || norm <= 1e-9 * column.norm().max(f64::MIN_POSITIVE) {
                continue;
            }
            let q = c / norm;
            let along = q.dot(&y);
            let drop = along * along;
            if best.as_ref().is_none_or(|b| drop > b.1) {
                best = Some((bit, drop, q));
            }
        }
        let Some((bit, drop, q)) = best else {
            break;
        };
        if normal_two_sided(libm::sqrt(drop)) >= ALPHA / (m - k) as f64 {
            break;
        }
        named |= bit;
        y -= q * q.dot(&y);
        if basis.push(q).is_err() {
            break;
        }
    }
    named
}

#[cfg(test)]
#[expect(clippy::indexing_slicing, reason = "test arithmetic on fixed arrays")]
mod tests {
    use super::*;

    #[test]
    fn the_chi_square_tail_is_the_tables() {
        // Tables: chi-square(1) 3.841 -> 0.05, (2) 9.210 -> 0.01, (5) 11.070 -> 0.05,
        // (12) 26.217 -> 0.01.
        for (x, k, p) in [
            (3.841_458_8, 1, 0.05),
            (9.210_340_4, 2, 0.01),
            (11.070_497_7, 5, 0.05),
            (26.216_967_3, 12, 0.01),
            (0.0, 3, 1.0),
        ] {
            let q = chi_square_sf(x, k);
            assert!(
                (q - p).abs() < 1e-6 * p.max(1e-3),
                "{x} {k}: {q} against {p}"
            );
        }
    }

    fn stats_that_fit() -> FlightStats {
        FlightStats {
            taken: [0, 300, 300, 0],
            inside: [0, 590, 0, 0],
            nis: [0.0, 300.0, 300.0, 0.0],
            ..FlightStats::default()
        }
    }

    /// Two terms seen alike by the flight, uncorrelated: the filter's estimates as linear
    /// estimation gives them, judged held or shifted by where they fall.
    #[test]
    fn a_shift_beyond_the_spread_had_nothing_shifted_is_named_and_one_within_it_is_not() {
        let mut pi = TermMatrix::zeros();
        let mut shift = TermVector::zeros();
        let mut p = TermMatrix::zeros();
        for i in 0..TERMS {
            // Calibration 1, shift opened 100, the flight measures to 1 (information 1).
            pi[(i, i)] = 101.0;
            shift[i] = 100.0;
            p[(i, i)] = 1.0 / (1.0 + 1.0 / 101.0);
        }
        let opening = Opening {
            estimate: TermVector::zeros(),
            covariance: pi,
            shift,
        };
        // Had nothing shifted, the estimate's spread: L = 1 - P/Pi, D = (Pi - P) - L^2 S.
        let l = 1.0 - p[(0, 0)] / 101.0;
        let d = (101.0 - p[(0, 0)]) - l * l * 100.0;
        let mut x = TermVector::zeros();
        x[0] = 6.0 * d.sqrt();
        x[4] = 1.0 * d.sqrt();
        let v = opening.judge(&x, &p, &stats_that_fit(), None);
        assert_eq!(v.word, Word::Shifted);
        assert_eq!(v.shifted, 1);
        assert_eq!(v.observed, 0x0fff);
        assert!((f64::from(v.z[0]) - 6.0).abs() < 1e-4, "{:?}", v.z);
        assert!((f64::from(v.z[4]) - 1.0).abs() < 1e-4, "{:?}", v.z);
        x[0] = 2.0 * d.sqrt();
        let v = opening.judge(&x, &p, &stats_that_fit(), None);
        assert_eq!(v.word, Word::Held, "{v:?}");
        // The same with innovations outside their bounds: no finding.
        let mut bad = stats_that_fit();
        bad.inside[1] = 400;
        assert_eq!(opening.judge(&x, &p, &bad, None).word, Word::DoesNotFit);
        // A term the flight does not learn is not observed.
        let mut unseen = p;
        unseen[(3, 3)] = 101.0;
        let v = opening.judge(&x, &unseen, &stats_that_fit(), None);
        assert!(!v.is_observed(3) && v.is_observed(2) && v.z[3].is_nan());
    }
}
