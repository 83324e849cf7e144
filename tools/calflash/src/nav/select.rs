//! Which terms' change at launch a flight needs: forward selection on the innovations'
//! likelihood, one pass per term tried, and what the flight could not have seen of the rest.

use spincal::nav::filter::index;
use spincal::nav::{SensorErrors, StateMatrix};

use super::input::{Fix, ImuSeries, Pressure};
use super::run::{self, Options, Pass, Start};
use super::verdict::{self, Opened, Verdict};

/// A term the held pass names has its prior at rest widened by this (ten times its 1-sigma) for
/// the flight alone: it may have been wrong at rest already.
const SHIFT_OPENED: f64 = 100.0;

/// How wide each kind of term's change at launch is opened for the flight alone, 1-sigma:
/// accelerometer biases (m/s^2), gyro biases (rad/s), accelerometer and gyro scale factors.
/// Far beyond any calibration's (a 0.06 m/s^2 axial shift, a 5e-3 rad/s transverse gyro bias
/// on a rocket). Not always within what the filter's linearisation carries: a rolling rocket's
/// roll gyro bias opened to 0.05 rad/s leaves it (that pass fits the flight far worse than the
/// held one, so it is never chosen; opened to 0.01, its pass fits better than the gain a
/// 2-sigma estimate would give, and it is chosen though it did not move).
const OPEN_WIDE: [f64; 4] = [1.0, 0.05, 1e-3, 1e-3];

/// A term the check did not name, and how large a change at launch of it the flight would
/// have named (Baarda's minimal detectable bias: the shift its test finds [`POWER`] of the
/// time at the bar it was held to).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Unseen {
    /// The term.
    pub term: &'static str,
    /// The flight's own 1-sigma of its change at launch (the term opened alone, every other
    /// held to the calibration).
    pub sigma: f64,
    /// The calibration's own 1-sigma of the term in flight: a change at launch is held against
    /// it as well as against the flight's.
    pub calibration: f64,
    /// The smallest change the flight would have named:
    /// `(sqrt(bar) + z_power) * sqrt(sigma^2 + calibration^2)`.
    pub smallest: f64,
}

/// The power at which [`Unseen::smallest`] is stated: nineteen times in twenty (Baarda's power, taken as the 95 % the flight check is held to).
pub const POWER: f64 = 0.95;

/// The most terms [`select_opened`] opens: each step flies a pass per term still closed, and a
/// launch that moves more than this many terms at once is SHIFTED on the ones it names first.
const MAX_OPENED: usize = 4;

/// How far (twice the log-likelihood) the term chosen must fit the flight better than every
/// other that passes the bar: chi-square on one degree of freedom at 95 %, 6.8 times as likely.
const DISTINGUISHED: f64 = 3.84;

/// What [`select_opened`] found.
pub(super) struct Selection {
    /// The terms chosen, in order, the pass with them opened and what it tells of the launch
    /// (`None`: none chosen).
    pub(super) opened: Option<(Vec<usize>, Pass, Launched)>,
    /// Terms each of which alone explains what the calibration's prior (with the terms
    /// chosen) does not, none clearly better than the others: each with its estimate and
    /// 1-sigma opened alone.
    pub(super) undecided: Vec<(usize, f64, f64)>,
    /// Each term tried at the first step, with its 1-sigma opened alone, and the bar there
    /// (twice the log-likelihood gain a term had to pass).
    pub(super) alone: (Vec<(usize, f64)>, f64),
}

/// The terms whose change at launch the flight needs opened, found by forward selection on the
/// innovations' likelihood (a generalised likelihood-ratio test per term): each step flies one
/// pass per term not yet opened, with that term's change at launch opened wide
/// ([`OPEN_WIDE`]), and keeps the one whose innovations fit best when its gain in
/// log-likelihood (twice it: the drop in [`run::misfit`], chi-square on one degree of freedom
/// under "held") passes the bar at `alpha` shared over the candidates. Opening every term at
/// once instead hands a shift to whichever terms it correlates with over the flight (on a
/// rolling rocket, a transverse gyro bias's to both transverse accelerometer biases at a metre
/// per second squared; on a shell's drag, an axial bias's partly to the axial scale factor);
/// opened one at a time, the term that moved explains the data best. A term the held pass named
/// may have been wrong at rest already (a datasheet's prior, a tilt levelled on a wrong bias):
/// its prior at rest is widened too ([`SHIFT_OPENED`]). Where two or more terms pass the bar
/// within [`DISTINGUISHED`] of the best, none is chosen at that step: the flight cannot tell
/// which of them moved (on a rolling rocket, a transverse gyro bias's tilt before the roll
/// builds up against either transverse accelerometer bias), and they are returned as
/// undecided.
pub(super) fn select_opened(
    imu: &ImuSeries,
    (fixes, baro): (&[Fix], &[Pressure]),
    (start, prior, opened): (&Start, StateMatrix<f64>, &Opened),
    (held, first, first_launched): (&Verdict, &Pass, &Launched),
    opts: &Options,
    (rest_end, launch_at): (usize, usize),
    alpha: f64,
) -> Selection {
    use rayon::prelude::*;
    let end_t = imu.t.last().copied().unwrap_or(0.0);
    let fly = |terms: &[usize]| {
        run::forward(
            imu,
            fixes,
            baro,
            &opened_start(start, prior, held, terms),
            opts,
            (rest_end, launch_at),
        )
    };
    let mut chosen: Vec<usize> = Vec::new();
    let mut best: Option<(Pass, Launched)> = None;
    let mut undecided = Vec::new();
    let mut alone = (Vec::new(), f64::INFINITY);
    let mut misfit = profile_misfit(first, first_launched, &[], end_t, opts.gate);
    while chosen.len() < MAX_OPENED {
        let open: Vec<usize> = (0..12)
            .filter(|i| opened.0[*i].is_none() && !chosen.contains(i))
            .collect();
        // Only a term the flight resolves can explain it (one it does not, opened, moves the
        // misfit by nothing: a spinning shell's transverse terms); the bar is shared over
        // every term still closed all the same.
        let candidates: Vec<usize> = open
            .iter()
            .copied()
            .filter(|&i| held.terms[i].z.is_some())
            .collect();
        if candidates.is_empty() {
            break;
        }
        let bar = chi_square_1_bar(alpha / open.len() as f64);
        let mut trials: Vec<Trial> = candidates
            .par_iter()
            .map(|&c| {
                let mut terms = chosen.clone();
                terms.push(c);
                let pass = fly(&terms);
                let launched = just_after_launch(&pass);
                let misfit = profile_misfit(&pass, &launched, &terms, end_t, opts.gate);
                Trial {
                    misfit,
                    term: c,
                    launched,
                }
            })
            .collect();
        trials.sort_by(|a, b| a.misfit.total_cmp(&b.misfit));
        if chosen.is_empty() {
            alone = (
                trials
                    .iter()
                    .map(|t| (t.term, t.launched.sigma(t.term)))
                    .collect(),
                bar,
            );
        }
        let Some(lead) = trials
            .first()
            .map(|t| t.misfit)
            .filter(|m| misfit - m > bar)
        else {
            break;
        };
        let close: Vec<&Trial> = trials
            .iter()
            .filter(|t| misfit - t.misfit > bar && t.misfit - lead < DISTINGUISHED)
            .collect();
        if close.len() > 1 {
            // Each of these alone explains what the calibration's prior does not, none
            // clearly better: the flight cannot tell which moved.
            undecided = close
                .iter()
                .map(|t| {
                    (
                        t.term,
                        verdict::values(&t.launched.estimate)[t.term],
                        t.launched.sigma(t.term),
                    )
                })
                .collect();
            break;
        }
        let Some(lead) = trials.into_iter().next() else {
            break;
        };
        chosen.push(lead.term);
        misfit = lead.misfit;
        best = Some((fly(&chosen), lead.launched));
    }
    Selection {
        opened: best.map(|(pass, launched)| (chosen, pass, launched)),
        undecided,
        alone,
    }
}

/// The start of a pass with the change at launch of `terms` opened wide ([`OPEN_WIDE`]), and
/// the prior at rest of those the held pass named widened ([`SHIFT_OPENED`]): `start` with the
/// calibration's `prior` at rest otherwise.
pub(super) fn opened_start(
    start: &Start,
    prior: StateMatrix<f64>,
    held: &Verdict,
    terms: &[usize],
) -> Start {
    let (t, mut w) = start
        .launch
        .unwrap_or((StateMatrix::identity(), StateMatrix::zeros()));
    let mut at_rest = prior;
    for &i in terms {
        let k = index::ACCEL_BIAS + i;
        w[(k, k)] += OPEN_WIDE[i / 3].powi(2);
        if held.terms[i].shifted {
            at_rest[(k, k)] *= SHIFT_OPENED;
        }
    }
    Start {
        prior: at_rest,
        launch: Some((t, w)),
        ..*start
    }
}

/// One term tried by [`select_opened`]: the pass with it (and the terms chosen before it)
/// opened, what that pass tells of the launch, and its misfit ([`profile_misfit`]).
/// One term's trial: what its pass says, without the pass (flown again for the term chosen),
/// so that the trials of a round do not hold a pass each at once.
struct Trial {
    misfit: f64,
    term: usize,
    launched: Launched,
}

/// A pass's misfit ([`run::misfit`]) with the opened `terms` at their best: less, for each, the
/// log of its variance at launch before the flight's data over its variance after (the Occam
/// factor of a prior opened wide). The drop from one set of opened terms to a larger is then
/// the generalised likelihood ratio of the terms added (twice its log), whatever width they were
/// opened to.
fn profile_misfit(pass: &Pass, launched: &Launched, terms: &[usize], until: f64, gate: f64) -> f64 {
    let occam: f64 = terms
        .iter()
        .map(|&i| {
            let k = index::ACCEL_BIAS + i;
            let (before, after) = (launched.prior[(k, k)], launched.covariance[(k, k)]);
            if before > 0.0 && after > 0.0 {
                (before / after).ln().max(0.0)
            } else {
                0.0
            }
        })
        .sum();
    run::misfit(pass, until, gate) - occam
}

/// The chi-square on one degree of freedom passed with probability `alpha`.
pub(super) fn chi_square_1_bar(alpha: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    ChiSquared::new(1.0).map_or(f64::INFINITY, |c| c.inverse_cdf(1.0 - alpha))
}

/// The terms neither named nor undecided, each with the smallest change at launch the flight
/// would have named at the bar it was held to (`alone`: each term's 1-sigma opened alone, and
/// the bar).
pub(super) fn unseen(
    (alone, bar): &(Vec<(usize, f64)>, f64),
    calibration: &[f64; 12],
    shifts: &[(&'static str, f64, f64)],
    undecided: &[(&'static str, f64, f64)],
) -> Vec<Unseen> {
    let z_power = statrs::distribution::ContinuousCDF::inverse_cdf(
        &statrs::distribution::Normal::standard(),
        POWER,
    );
    alone
        .iter()
        .map(|&(i, sigma)| (verdict::TERMS[i], sigma, calibration[i]))
        .filter(|(name, ..)| {
            !shifts.iter().any(|s| s.0 == *name) && !undecided.iter().any(|u| u.0 == *name)
        })
        .map(|(term, sigma, calibration)| Unseen {
            term,
            sigma,
            calibration,
            smallest: (bar.sqrt() + z_power) * sigma.hypot(calibration),
        })
        .collect()
}

/// The sensor errors just after the launch, as the whole flight tells them.
pub(super) struct Launched {
    /// Their covariance just after the launch's change, before the flight's data: the
    /// calibration's (its line over the flight) with what the pad taught.
    pub(super) prior: StateMatrix<f64>,
    /// The smoothed estimate there.
    pub(super) estimate: SensorErrors<f64>,
    /// Its covariance.
    pub(super) covariance: StateMatrix<f64>,
}

impl Launched {
    /// Term `i`'s 1-sigma (in [`verdict::TERMS`]' order) just after the launch, as the whole
    /// flight tells it.
    pub(super) fn sigma(&self, i: usize) -> f64 {
        let k = index::ACCEL_BIAS + i;
        self.covariance[(k, k)].max(0.0).sqrt()
    }
}

/// The smoothed sensor errors at the first epoch from the launch on (the launch's own epoch
/// when the pass changes the errors there), with the covariance the pass had there before the
/// flight's data. A shift at launch is a step there; the random walks the filter allows
/// afterwards widen the last epoch's estimate (to ten times the calibration's 1-sigma on an
/// axial bias over 20 s), so the test is made where the step is, on everything the flight
/// says of it.
pub(super) fn just_after_launch(pass: &Pass) -> Launched {
    let k = pass
        .epochs
        .iter()
        .position(|e| e.t >= pass.launch)
        .unwrap_or_else(|| pass.epochs.len().saturating_sub(1));
    let smoothed = super::smooth::smooth(&pass.epochs);
    match (pass.epochs.get(k), smoothed.get(k)) {
        (Some(e), Some((x, p))) => Launched {
            prior: e.filtered.1,
            estimate: x.sensors,
            covariance: *p,
        },
        _ => Launched {
            prior: pass.p0,
            estimate: SensorErrors::default(),
            covariance: pass.p0,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::{POWER, chi_square_1_bar, unseen};

    /// The smallest change named is the bar's root plus the power's normal quantile, in the
    /// 1-sigma its test has (the flight's and the calibration's together); a term named or
    /// undecided is not listed.
    #[test]
    fn the_smallest_change_named_is_baardas_and_named_terms_are_left_out() {
        let bar = chi_square_1_bar(0.05);
        assert!((bar - 3.841).abs() < 1e-3, "{bar}");
        let alone = (vec![(0, 2.0), (4, 1e-3), (9, 3e-6)], bar);
        let mut calibration = [0.0; 12];
        calibration[4] = 0.75e-3;
        let u = unseen(
            &alone,
            &calibration,
            &[("accel bias x", 0.1, 0.01)],
            &[("gyro scale x", 1e-5, 3e-6)],
        );
        assert_eq!(u.len(), 1);
        assert_eq!(u[0].term, "gyro bias y");
        assert!((POWER - 0.95).abs() < 1e-12);
        // 1.960 + 1.645 at alpha 0.05 and power 0.95.
        assert!((u[0].smallest / 1.25e-3 - 3.605).abs() < 1e-3, "{:?}", u[0]);
        assert!((u[0].sigma - 1e-3).abs() < 1e-15);
    }
}
