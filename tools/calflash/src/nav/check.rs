//! The whole in-flight check: the prior from the calibration, the noise from the rest before
//! launch, the heading, the pass with the calibration's prior and its verdict, a second pass
//! with each shifted term's prior opened (so its shift is estimated by the flight alone), and
//! the smoothed trajectory against GNSS and the barometer.

use nalgebra::Vector3;
use spincal::nav::filter::index;
use spincal::nav::{NavNoise, SensorErrors};

use super::input::{Fix, ImuSeries, Pressure};
use super::launch;
use super::prior::{InFlight, PriorSource};
use super::run::{self, Options, Pass, Said, Start};
use super::select::{self, Launched, just_after_launch, opened_start, select_opened};
pub use super::select::{POWER, Unseen};
use super::track::{self, Track};
use super::unmodelled::Unmodelled;
use super::verdict::{self, Opened, Verdict};

/// The scale-factor shift a spinning round's check must follow (0.3 %).
const SPIN_SHIFT_TO_FOLLOW: f64 = 3e-3;
/// The roll-angle drift per second, rad/s, beyond which the filter cannot follow a shift from
/// the calibration's prior.
const SPIN_LINEAR_LIMIT: f64 = 0.5;
/// The opened scale factor's prior, 1-sigma (1 %).
const OPEN_SCALE: f64 = 0.01;

/// The spin axis' gyro scale factor the flight's first seconds fit best: one short pass per
/// hypothesis from -1 % to +1 % in steps the filter can follow from (a roll drift under half a
/// radian before the first fixes), the least misfit chosen. A round spinning at 1,900 rad/s
/// whose roll scale factor moved 0.3 % at launch has turned 5.7 rad wrong a second later; a
/// linearised filter cannot find its way back from that, a search over hypotheses can.
fn roll_scale_search(
    imu: &ImuSeries,
    (fixes, baro): (&[Fix], &[Pressure]),
    start: &Start,
    opts: &Options,
    (rest_end, launch_at): (usize, usize),
    k: usize,
) -> f64 {
    use rayon::prelude::*;
    let t_launch = imu.t[launch_at];
    let until = t_launch + SEARCH_WINDOW;
    let end = imu.t.partition_point(|t| *t <= until);
    let head = ImuSeries {
        t: imu.t[..end].to_vec(),
        f: imu.f[..end].to_vec(),
        w: imu.w[..end].to_vec(),
        flagged: imu.flagged[..end].to_vec(),
        temperature: imu.temperature,
    };
    let n = (OPEN_SCALE / SEARCH_STEP).round() as i64;
    let at = index::GYRO_SCALE + k;
    let mut coarse: Vec<(f64, f64)> = (-n..=n)
        .into_par_iter()
        .map(|j| {
            let s = j as f64 * SEARCH_STEP;
            let mut trial = *start;
            trial.sensors.gyro_scale[k] = s;
            trial.prior[(at, at)] = SEARCH_STEP * SEARCH_STEP;
            let pass = run::forward(&head, fixes, baro, &trial, opts, (rest_end, launch_at));
            (run::misfit(&pass, until, opts.gate), s)
        })
        .collect();
    coarse.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The first seconds are noisy evidence: the best few go on through the whole flight.
    let end_t = imu.t.last().copied().unwrap_or(until);
    coarse
        .into_iter()
        .take(SEARCH_FINALISTS)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(_, s)| {
            let mut trial = *start;
            trial.sensors.gyro_scale[k] = s;
            trial.prior[(at, at)] = SEARCH_STEP * SEARCH_STEP;
            let pass = run::forward(imu, fixes, baro, &trial, opts, (rest_end, launch_at));
            (run::misfit(&pass, end_t, opts.gate), s)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(0.0, |b| b.1)
}

/// The largest turn between two samples the navigator follows, rad: a round at 300 rev/s is
/// followed at 2 kHz (0.94 rad) and lost at 1 kHz (1.9 rad), where the specific force's turn
/// within a step is no longer carried by the trapezoid.
pub const MAX_TURN_PER_SAMPLE: f64 = 1.2;

/// At most this many passes again from the opened scale factor a pass found.
const REFLY: usize = 2;
/// A pass is flown again when it moved the opened scale factor by more than this.
const REFLY_CHANGE: f64 = 2e-5;

/// How many of the search's best hypotheses over the first seconds are flown through the whole
/// flight.
const SEARCH_FINALISTS: usize = 5;

/// The seconds after launch the roll scale-factor search looks at.
const SEARCH_WINDOW: f64 = 5.0;
/// The search's step (the roll drift it leaves, at 1,900 rad/s over the first fixes, is
/// under half a radian).
const SEARCH_STEP: f64 = 2e-4;

/// The random walks the filter allows the errors between measurements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Walks {
    /// Accelerometer bias, m/s^2/sqrt(s).
    pub accel: f64,
    /// Gyro bias, rad/s/sqrt(s).
    pub gyro: f64,
    /// Scale factors, 1/sqrt(s).
    pub scale: f64,
    /// Barometer bias, m/sqrt(s).
    pub baro: f64,
}

impl Default for Walks {
    fn default() -> Self {
        Self {
            accel: 1e-3,
            gyro: 1e-4,
            scale: 1e-7,
            baro: 0.5,
        }
    }
}

/// The white-noise densities seen at rest: per sensor the largest axis' standard deviation
/// over the rest, times the square root of the sample interval.
#[must_use]
pub fn rest_noise(imu: &ImuSeries, rest_end: usize) -> (f64, f64) {
    let n = rest_end.max(2);
    let dt = (imu.t.get(n - 1).copied().unwrap_or(1.0) - imu.t.first().copied().unwrap_or(0.0))
        / (n - 1) as f64;
    let sd = |get: &dyn Fn(usize) -> f64| {
        let mean = (0..n).map(get).sum::<f64>() / n as f64;
        ((0..n).map(|i| (get(i) - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    };
    let worst = |v: &[[f64; 3]]| {
        (0..3)
            .map(|a| sd(&|i| v.get(i).map_or(0.0, |x| x[a])))
            .fold(0.0, f64::max)
    };
    (worst(&imu.f) * dt.sqrt(), worst(&imu.w) * dt.sqrt())
}

/// Everything `calflash flight` reports.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The verdict on the calibration (from the pass with its prior).
    pub verdict: Verdict,
    /// The shifted terms' estimates from the pass with their prior opened: name, estimate,
    /// 1-sigma.
    pub shifts: Vec<(&'static str, f64, f64)>,
    /// Terms each of which alone explains what moved, none clearly better (the flight cannot
    /// tell which): name, estimate and 1-sigma with it opened alone.
    pub undecided: Vec<(&'static str, f64, f64)>,
    /// Each term the flight resolves and does not name, with the smallest change at launch it
    /// would have named: below that, the flight cannot tell.
    pub unseen: Vec<Unseen>,
    /// The pass whose smoothed trajectory is reported: the verdict's table, the track and
    /// every figure are of it.
    pub pass: Pass,
    /// Which pass it is, in words.
    pub pass_name: &'static str,
    /// What the "flight alone" 1-sigma of the terms is ([`ALONE_OPENED`] or [`ALONE_ADDED`]).
    pub alone_from: &'static str,
    /// The smoothed flight against GNSS and the barometer.
    pub track: Track,
    /// Heading at rest and its 1-sigma, degrees.
    pub heading_deg: (f64, f64),
    /// The noise densities used: accelerometer, gyro.
    pub noise: (f64, f64),
    /// Where the prior came from.
    pub prior: PriorSource,
    /// The rest before launch, s.
    pub rest_seconds: f64,
}

/// What stops a check before it starts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    /// No launch in the recording.
    #[error(
        "no launch: the specific force never exceeds {0:.1} m/s^2 (or there is less than 0.2 s at rest before it to level the unit on)"
    )]
    NoLaunch(f64),
    /// The clocks do not overlap.
    #[error("the GNSS file's fixes ({gnss}) do not overlap the IMU's recording ({imu})")]
    Clocks {
        /// The GNSS span.
        gnss: String,
        /// The IMU's span.
        imu: String,
    },
    /// No heading.
    #[error(
        "the flight never takes the unit {0:.0} m from the pad by GNSS: its heading cannot be found, so nothing can be told"
    )]
    NoHeading(f64),
    /// Too few samples.
    #[error("{0}")]
    TooShort(String),
    /// Samples too far apart for the spin.
    #[error(
        "the IMU's {rate:.0} Hz is too slow for a spin of {spin:.0} rad/s: the unit turns {turn:.2} rad between samples, and the navigator follows at most {MAX_TURN_PER_SAMPLE} rad (it needs {need:.0} Hz or more)"
    )]
    Rate {
        /// The sampling rate, Hz.
        rate: f64,
        /// The highest spin, rad/s.
        spin: f64,
        /// The turn per sample, rad.
        turn: f64,
        /// The rate it needs, Hz.
        need: f64,
    },
}

/// Runs the check.
///
/// # Errors
/// [`CheckError`].
pub fn check(
    imu: &ImuSeries,
    (fixes, baro): (&[Fix], &[Pressure]),
    (in_flight, source): (InFlight, PriorSource),
    walks: &Walks,
    opts: &Options,
    alpha: f64,
) -> Result<Checked, CheckError> {
    if imu.t.len() < 100 {
        return Err(CheckError::TooShort(format!(
            "{} IMU samples: a flight needs at least 100",
            imu.t.len()
        )));
    }
    let span = |a: f64, b: f64| format!("{a} to {b} s");
    let (t0, t1) = (imu.t[0], imu.t[imu.t.len() - 1]);
    let (Some(g0), Some(g1)) = (fixes.first(), fixes.last()) else {
        return Err(CheckError::TooShort(
            "the GNSS file holds no usable fix".into(),
        ));
    };
    if g1.t < t0 || g0.t > t1 {
        return Err(CheckError::Clocks {
            gnss: span(g0.t, g1.t),
            imu: span(t0, t1),
        });
    }
    let rate = super::input::median_rate(imu.t.iter().copied());
    let spin = imu
        .w
        .iter()
        .map(|w| Vector3::from(*w).norm())
        .fold(0.0, f64::max);
    if spin / rate > MAX_TURN_PER_SAMPLE {
        return Err(CheckError::Rate {
            rate,
            spin,
            turn: spin / rate,
            need: spin / MAX_TURN_PER_SAMPLE,
        });
    }
    let (rest_end, launch_at) =
        launch::launch(imu, opts.launch_force).ok_or(CheckError::NoLaunch(opts.launch_force))?;
    let t_launch = imu.t[launch_at];
    let pad: Vec<&Fix> = fixes.iter().filter(|f| f.t < t_launch).collect();
    let origin = {
        let base: Vec<&Fix> = if pad.is_empty() { vec![g0] } else { pad };
        let n = base.len() as f64;
        let lat = base.iter().map(|f| f.lat_lon.0).sum::<f64>() / n;
        let lon = base.iter().map(|f| f.lat_lon.1).sum::<f64>() / n;
        let h = base.iter().filter_map(|f| f.height).sum::<f64>() / n;
        (
            lat,
            lon,
            if base.iter().all(|f| f.height.is_some()) {
                h
            } else {
                0.0
            },
        )
    };
    let min_distance = (30.0 * opts.gnss_noise.0).max(100.0);
    let heading = run::heading(
        imu,
        fixes,
        origin,
        (rest_end, launch_at),
        opts.gnss_noise.0,
        min_distance,
    )
    .ok_or(CheckError::NoHeading(min_distance))?;
    let (aw, gw) = rest_noise(imu, rest_end);
    let noise = NavNoise {
        accel_white: aw.max(1e-4),
        gyro_white: gw.max(1e-6),
        accel_walk: walks.accel,
        gyro_walk: walks.gyro,
        scale_walk: walks.scale,
        baro_walk: walks.baro,
        // The receiver's correlated error is carried into the smoothed track's 1-sigma
        // (`track.rs`), not as states: the selection's passes were measured so.
        receiver_sigma: nalgebra::Vector3::zeros(),
        receiver_tau: 0.0,
    };
    let mut prior = in_flight.at_rest();
    prior[(index::BARO, index::BARO)] = 1.0;
    // A round that spins fast turns a roll scale-factor shift into a roll angle error that
    // grows faster than the filter can linearise from the calibration's prior (0.3 % at
    // 1,900 rad/s is 5.7 rad/s): the spin axis' gyro scale factor starts open, and the flight's
    // own estimate of it is held against the calibration.
    let (k, spin) = launch::spin(imu, launch_at);
    let mut opened = Opened::default();
    if spin * SPIN_SHIFT_TO_FOLLOW > SPIN_LINEAR_LIMIT {
        let at = index::GYRO_SCALE + k;
        // The calibration's variance of it in flight (its line over the flight's rates).
        let (t, w) = in_flight.at_launch(&[false; 12]);
        opened.0[9 + k] = Some((t * prior * t.transpose() + w)[(at, at)]);
        for j in 0..prior.nrows() {
            prior[(at, j)] = 0.0;
            prior[(j, at)] = 0.0;
        }
        prior[(at, at)] = OPEN_SCALE * OPEN_SCALE;
    }
    let open: [bool; 12] = std::array::from_fn(|i| opened.0[i].is_some());
    let mut start = Start {
        origin,
        prior,
        noise,
        heading,
        sensors: SensorErrors::default(),
        launch: Some(in_flight.at_launch(&open)),
    };
    if opened.0[9 + k].is_some() {
        start.sensors.gyro_scale[k] =
            roll_scale_search(imu, (fixes, baro), &start, opts, (rest_end, launch_at), k);
    }
    let mut first = run::forward(imu, fixes, baro, &start, opts, (rest_end, launch_at));
    // The search's grid leaves the opened scale factor up to half a step off, which the pass
    // pulls most of the way in; flown again from where it ended, the linearisation holds
    // from launch on.
    // Kept only when it fits the whole flight better.
    let end_t = imu.t.last().copied().unwrap_or(0.0);
    for _ in 0..REFLY {
        let Some(end) = first.epochs.last() else {
            break;
        };
        let found = end.filtered.0.sensors.gyro_scale[k];
        if opened.0[9 + k].is_none() || (found - start.sensors.gyro_scale[k]).abs() < REFLY_CHANGE {
            break;
        }
        let mut again = start;
        again.sensors.gyro_scale[k] = found;
        let pass = run::forward(imu, fixes, baro, &again, opts, (rest_end, launch_at));
        if run::misfit(&pass, end_t, opts.gate) >= run::misfit(&first, end_t, opts.gate) {
            break;
        }
        start = again;
        first = pass;
    }
    // The pass with the calibration's prior: held, the flight's data fit it.
    let launched = just_after_launch(&first);
    let held = verdict::judge(
        (&launched.prior, &launched.prior),
        (&opened, &[0.0; 12]),
        (&launched.estimate, &launched.covariance),
        &first.said,
        alpha,
    );
    let with_prior = "the pass with the calibration's prior";
    let mut undecided = Vec::new();
    // Each term's 1-sigma as the flight alone tells its change at launch, and the bar a term
    // is held to: the held pass's where it answers, the selection's first step where it ran.
    let closed = opened.0.iter().filter(|o| o.is_none()).count().max(1);
    let mut alone: (Vec<(usize, f64)>, f64) = (
        (0..12)
            .filter(|&i| held.terms[i].z.is_some())
            .filter_map(|i| held.terms[i].flight_sigma.map(|f| (i, f)))
            .collect(),
        select::chi_square_1_bar(alpha / closed as f64),
    );
    let mut searched = false;
    let (verdict, pass, pass_name) = if held.word == "HELD" {
        (held, first, with_prior)
    } else {
        // Something moved (a term named, or the observed terms together), or the
        // calibration's prior does not fit the flight: which terms' change at launch the
        // flight needs, opened one at a time by the likelihood of its innovations.
        let mut chosen = select_opened(
            imu,
            (fixes, baro),
            (&start, prior, &opened),
            (&held, &first, &launched),
            opts,
            (rest_end, launch_at),
            alpha,
        );
        if !chosen.alone.0.is_empty() {
            alone = std::mem::take(&mut chosen.alone);
            searched = true;
        }
        undecided = chosen
            .undecided
            .iter()
            .map(|&(i, x, sd)| (verdict::TERMS[i], x, sd))
            .collect();
        // Where no chosen term is confirmed, the pass with the calibration's prior answers;
        // its SHIFTED by the overall chi-square alone (no term named) stands only where some
        // term's change, opened, fits the flight better by the bar (the undecided): the
        // overall test rests on the directions the flight barely informs, where what the
        // filter does not model of the calibration's error weighs most (3 in 15 unshifted
        // shells were SHIFTED by it alone).
        let by_prior = |held: Verdict| {
            // Where several terms' changes each explain the flight alone and none better
            // (undecided), a term the held pass names that is none of them is not what the
            // flight's likelihood singles out: it is not named (on the reference rocket, whose
            // transverse gyro bias moved, accel scale z was named at the step-down's edge while
            // either transverse accelerometer bias, opened, explained the flight as well).
            let held = without_names_beside(held, &chosen.undecided);
            let named = held.terms.iter().any(|t| t.shifted);
            if held.word == "SHIFTED" && !named && chosen.undecided.is_empty() {
                held_after_all(held)
            } else {
                held
            }
        };
        match chosen.opened {
            Some((terms, second, second_launched)) => {
                let unmodelled = unmodelled_in(
                    in_flight.unmodelled(),
                    (imu, fixes, baro),
                    &opened_start(&start, prior, &held, &terms),
                    opts,
                    (rest_end, launch_at),
                    (&terms, &second_launched),
                );
                let alone = judge_opened(
                    &second_launched,
                    &second.said,
                    &held,
                    (&opened, &unmodelled),
                    &terms,
                    alpha,
                );
                // The flight alone answers for the terms it needed opened (the held pass
                // names a shift by how far the data pull the calibration's tight prior, but
                // cannot say how large it is) where it names one of them, unless it does not
                // fit where the held pass does.
                let confirmed = terms.iter().any(|&i| alone.terms[i].shifted);
                if confirmed && (alone.consistency.fits || !held.consistency.fits) {
                    (
                        alone,
                        second,
                        "the flight alone for the terms that moved (their change at launch opened)",
                    )
                } else {
                    (by_prior(held), first, with_prior)
                }
            }
            None => (by_prior(held), first, with_prior),
        }
    };
    let mut verdict = verdict;
    if !undecided.is_empty() {
        let names: Vec<&str> = undecided.iter().map(|u| u.0).collect();
        verdict.why = format!(
            "{}; the flight cannot tell what moved ({} each explain it alone)",
            verdict.why,
            names.join(", ")
        );
    }
    let shifts: Vec<(&'static str, f64, f64)> = verdict
        .terms
        .iter()
        .filter(|t| t.shifted)
        .map(|t| (t.name, t.estimate, t.sigma))
        .collect();
    let calibration: [f64; 12] = std::array::from_fn(|i| verdict.terms[i].prior_sigma);
    let unseen = select::unseen(&alone, &calibration, &shifts, &undecided);
    // One figure per term: where the flight was searched, a term's "flight alone" is its
    // change opened alone (as the list of what the flight could not have seen states it), not
    // the held pass's information, which with every other term anchored said 8.0e-4 rad/s of
    // the reference rocket's gyro bias y where its pass opened alone says 1.6e-3.
    if searched {
        for &(i, sd) in &alone.0 {
            if !verdict.terms[i].shifted {
                verdict.terms[i].flight_sigma = Some(sd);
            }
        }
    }
    let track = track::track(
        &pass,
        (fixes, baro),
        &track::Setting {
            origin,
            launch: t_launch,
            latency: opts.gnss_latency,
            correlated: opts.gnss_correlated,
        },
    );
    Ok(Checked {
        verdict,
        shifts,
        undecided,
        unseen,
        track,
        heading_deg: (heading.0.to_degrees(), heading.1.to_degrees()),
        noise: (aw, gw),
        prior: source,
        rest_seconds: imu.t[rest_end] - t0,
        pass,
        pass_name,
        alone_from: if searched { ALONE_OPENED } else { ALONE_ADDED },
    })
}

/// The variance what the filter does not model of the calibration's error adds to the opened
/// `terms`' estimates in the pass flown from `start` (`launched` its estimate just after the
/// launch): measured by flying it again with each of the remainder's principal directions
/// added to the samples of the terms' outputs ([`Unmodelled::variance_in`]). Other terms
/// get none: their estimates are held against the calibration's prior, which holds it.
fn unmodelled_in(
    unmodelled: &Unmodelled,
    (imu, fixes, baro): (&ImuSeries, &[Fix], &[Pressure]),
    start: &Start,
    opts: &Options,
    at: (usize, usize),
    (terms, launched): (&[usize], &Launched),
) -> [f64; 12] {
    let mut outputs: Vec<usize> = terms
        .iter()
        .map(|&i| if i < 6 { i } else { i - 6 })
        .collect();
    outputs.sort_unstable();
    outputs.dedup();
    let fly = |moved: &ImuSeries| {
        let pass = run::forward(moved, fixes, baro, start, opts, at);
        verdict::values(&just_after_launch(&pass).estimate)
    };
    let all = unmodelled.variance_in(imu, &outputs, fly, &verdict::values(&launched.estimate));
    std::array::from_fn(|i| if terms.contains(&i) { all[i] } else { 0.0 })
}

/// The flight alone's 1-sigma of a term where the flight was searched for what moved.
pub const ALONE_OPENED: &str = "each term's change at launch opened alone, one pass each, as the search for what moved flew it (a named term: its own pass's)";

/// The flight alone's 1-sigma of a term where the pass with the calibration's prior answered.
pub const ALONE_ADDED: &str = "what the flight's data add to the calibration's prior of the term, as information (one over the variance after, less one over the variance before)";

/// The held pass's verdict when its SHIFTED rested on the overall chi-square alone and no
/// term's change at launch, opened, fits the flight better by the bar: HELD, saying so.
/// `held` with no term named that is not among the `undecided` (each of whose change at
/// launch, opened alone, explains the flight as well as any other): with none of them named,
/// its word is the overall test's.
fn without_names_beside(mut held: Verdict, undecided: &[(usize, f64, f64)]) -> Verdict {
    if undecided.is_empty() || held.word != "SHIFTED" {
        return held;
    }
    let mut changed = false;
    for (i, t) in held.terms.iter_mut().enumerate() {
        if t.shifted && !undecided.iter().any(|u| u.0 == i) {
            t.shifted = false;
            changed = true;
        }
    }
    if changed && !held.terms.iter().any(|t| t.shifted) {
        held.why = match held.overall {
            Some((chi2, m, p)) => format!(
                "the observed terms together moved beyond their calibration uncertainty (chi-square {chi2:.1} on {m} degrees of freedom, p = {p:.1e}), no one term named on its own"
            ),
            None => "no one term named on its own".to_string(),
        };
    } else if changed {
        let named: Vec<&str> = held
            .terms
            .iter()
            .filter(|t| t.shifted)
            .map(|t| t.name)
            .collect();
        held.why = format!("shifted in flight: {}", named.join(", "));
    }
    held
}

fn held_after_all(mut held: Verdict) -> Verdict {
    held.word = "HELD";
    held.why = match held.overall {
        Some((chi2, m, _)) => format!(
            "no term named, and no term's change at launch, opened on its own, fits the flight better than the calibration by the bar (the observed terms' overall chi-square {chi2:.1} on {m} degrees of freedom is within what the filter does not model)"
        ),
        None => "no term named".to_string(),
    };
    held
}

/// The verdict of a pass with the `terms` chosen by [`select_opened`] opened: each of them, as
/// the flight alone finds its change, held against the calibration's variance of it in flight
/// (and, as in the held pass, every other term against its prior).
fn judge_opened(
    launched: &Launched,
    said: &[Said],
    held: &Verdict,
    (opened, unmodelled): (&Opened, &[f64; 12]),
    terms: &[usize],
    alpha: f64,
) -> Verdict {
    let at_launch = just_after_launch_prior(held);
    let mut alone_opened = *opened;
    for &i in terms {
        alone_opened.0[i] = Some(at_launch[i]);
    }
    verdict::judge(
        (&launched.prior, &launched.prior),
        (&alone_opened, unmodelled),
        (&launched.estimate, &launched.covariance),
        said,
        alpha,
    )
}

/// The calibration's variance of each term just after the launch, as the held pass's verdict
/// states it (its 1-sigma at launch, squared).
fn just_after_launch_prior(held: &Verdict) -> [f64; 12] {
    std::array::from_fn(|i| held.terms[i].prior_sigma.powi(2))
}
