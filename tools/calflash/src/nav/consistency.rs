//! The filter's fit to its aiding data, judged per kind of measurement: GNSS horizontal
//! position, GNSS height, GNSS velocity and the barometer, each held to the inside-bounds rule
//! on its own. Pooled, the many barometer readings hide the fixes: on the real Hedy flight
//! 98.8 % of 2,208 pressures were inside their bounds and the pool said 95.8 %, while the fixes
//! north were 63.2 % inside and every one from 14.8 s on was refused.
//!
//! A run of refused innovations of one kind is named by its time span: a filter that has lost
//! the track refuses every fix that would bring it back.

use serde::Serialize;

use super::run::{Kind, Said};

/// The share of innovations inside their 95 % bounds a filter that fits has at least: 95 % when
/// its covariance is right, less what the innovations' correlation (a receiver's error over
/// tens of seconds) spreads it by over a flight. A rocket's filter with 90.6 % inside and its
/// velocity innovations drifting to 6 sigma does not fit.
pub const INSIDE_AT_LEAST: f64 = 0.93;

/// The share of innovations a filter that fits may refuse beyond its gate (outliers: a
/// receiver at high dynamics, a barometer in a gust).
pub const REFUSED_AT_MOST: f64 = 0.05;

/// A kind with fewer innovations than its rule's shares would turn one chance outlier into a
/// misfit is held to a binomial test instead: its count outside (or refused) fails only when a
/// filter that fits would give as many less than once in a hundred.
const CHANCE: f64 = 0.01;

/// The least number of refused innovations named as a run.
const RUN_AT_LEAST: usize = 3;

/// The longest time between two refused innovations of one run, s.
const RUN_GAP_S: f64 = 2.0;

/// The kinds of aiding measurement judged apart.
pub const KINDS: [&str; 4] = [
    "GNSS horizontal position",
    "GNSS height",
    "GNSS velocity",
    "barometer",
];

/// Which of [`KINDS`] an innovation is; `None` for the pad's.
#[must_use]
pub fn kind_of(k: Kind) -> Option<usize> {
    match k {
        Kind::Pad => None,
        Kind::Position(axis) if axis < 2 => Some(0),
        Kind::Position(_) => Some(1),
        Kind::Velocity(_) => Some(2),
        Kind::Baro => Some(3),
    }
}

/// A run of refused innovations of one kind.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RefusedRun {
    /// The first refused, s.
    pub from: f64,
    /// The last refused, s.
    pub to: f64,
    /// How many.
    pub count: usize,
}

impl std::fmt::Display for RefusedRun {
    /// "12 refused from 17.0 to 36.4 s".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} refused from {:.1} to {:.1} s",
            self.count, self.from, self.to
        )
    }
}

/// One kind's fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KindFit {
    /// The kind ([`KINDS`]).
    pub kind: &'static str,
    /// Innovations taken or refused.
    pub innovations: usize,
    /// Of them, inside their 95 % bounds.
    pub inside_95: usize,
    /// Refused beyond the gate.
    pub refused: usize,
    /// Mean NIS of those taken.
    pub mean_nis: f64,
    /// This kind fits.
    pub fits: bool,
    /// Its runs of refused innovations.
    pub refused_runs: Vec<RefusedRun>,
}

/// The filter's fit to the data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Consistency {
    /// Innovations of GNSS and barometer taken or refused.
    pub innovations: usize,
    /// Of them, inside their 95 % bounds (|nu| <= 1.96 sigma).
    pub inside_95: usize,
    /// Refused beyond the gate.
    pub refused: usize,
    /// Mean of nu^2 / sigma^2 over those taken (1 when the filter's covariance is right).
    pub mean_nis: f64,
    /// The filter fits the data: every kind with innovations fits
    /// ([`KindFit::fits`]).
    pub fits: bool,
    /// Each kind's fit, in [`KINDS`]' order, those with innovations.
    pub kinds: Vec<KindFit>,
}

impl Consistency {
    /// The kinds that do not fit.
    #[must_use]
    pub fn failing(&self) -> Vec<&KindFit> {
        self.kinds.iter().filter(|k| !k.fits).collect()
    }

    /// The sentence that says which kinds do not fit and where they were refused.
    #[must_use]
    pub fn failure(&self) -> String {
        let parts: Vec<String> = self
            .failing()
            .iter()
            .map(|k| {
                let runs: Vec<String> = k.refused_runs.iter().map(ToString::to_string).collect();
                format!(
                    "{}: {} of {} inside their 95 % bounds ({:.1} %), mean NIS {:.2}, {} refused{}",
                    k.kind,
                    k.inside_95,
                    k.innovations,
                    100.0 * k.inside_95 as f64 / k.innovations.max(1) as f64,
                    k.mean_nis,
                    k.refused,
                    if runs.is_empty() {
                        String::new()
                    } else {
                        format!(" ({})", runs.join("; "))
                    }
                )
            })
            .collect();
        parts.join("; ")
    }
}

/// `P(X >= k)` for `X ~ Binomial(n, p)`.
fn binomial_tail(n: usize, k: usize, p: f64) -> f64 {
    use statrs::distribution::{Binomial, DiscreteCDF};
    if k == 0 {
        return 1.0;
    }
    Binomial::new(p, n as u64).map_or(0.0, |b| b.sf(k as u64 - 1))
}

/// Whether `count` of `n` beyond a rule that allows a share `share` is a misfit: over the
/// share, and improbable for a filter that fits (a binomial tail under [`CHANCE`]).
fn beyond(count: usize, n: usize, share: f64) -> bool {
    count as f64 > share * n as f64 && binomial_tail(n, count, share) < CHANCE
}

/// Innovations, those inside their 95 % bounds, those refused, and the mean NIS of those
/// taken (NaN when none was).
fn counts(said: &[&Said]) -> (usize, usize, usize, f64) {
    let inside = said
        .iter()
        .filter(|s| s.value.abs() <= 1.96 * s.sigma)
        .count();
    let taken: Vec<f64> = said
        .iter()
        .filter(|s| s.taken)
        .map(|s| (s.value / s.sigma).powi(2))
        .collect();
    let mean_nis = if taken.is_empty() {
        f64::NAN
    } else {
        taken.iter().sum::<f64>() / taken.len() as f64
    };
    (said.len(), inside, said.len() - taken.len(), mean_nis)
}

fn judge<'a>(kind: &'static str, said: impl Iterator<Item = &'a Said>) -> Option<KindFit> {
    let mut said: Vec<&Said> = said.collect();
    if said.is_empty() {
        return None;
    }
    said.sort_by(|a, b| a.t.total_cmp(&b.t));
    let (n, inside, refused, mean_nis) = counts(&said);
    // Refused innovations less than RUN_GAP_S apart are one run, whatever was taken between
    // them (a filter pulled off by a fault still takes some).
    let mut refused_runs = Vec::new();
    let mut run: Option<RefusedRun> = None;
    for s in said.iter().filter(|s| !s.taken) {
        match &mut run {
            Some(r) if s.t - r.to <= RUN_GAP_S => {
                r.to = s.t;
                r.count += 1;
            }
            _ => {
                if let Some(r) = run.take().filter(|r| r.count >= RUN_AT_LEAST) {
                    refused_runs.push(r);
                }
                run = Some(RefusedRun {
                    from: s.t,
                    to: s.t,
                    count: 1,
                });
            }
        }
    }
    if let Some(r) = run.filter(|r| r.count >= RUN_AT_LEAST) {
        refused_runs.push(r);
    }
    let fits = refused < n
        && !beyond(n - inside, n, 1.0 - INSIDE_AT_LEAST)
        && mean_nis < 2.0
        && !beyond(refused, n, REFUSED_AT_MOST);
    Some(KindFit {
        kind,
        innovations: n,
        inside_95: inside,
        refused,
        mean_nis,
        fits,
        refused_runs,
    })
}

/// The consistency of the aiding innovations (GNSS and barometer; the pad's are left out):
/// pooled, and per kind, each kind judged on its own.
#[must_use]
pub fn consistency(said: &[Said]) -> Consistency {
    let aiding: Vec<&Said> = said
        .iter()
        .filter(|s| kind_of(s.kind).is_some() && s.sigma > 0.0)
        .collect();
    let (n, inside, refused, mean_nis) = counts(&aiding);
    let kinds: Vec<KindFit> = KINDS
        .iter()
        .enumerate()
        .filter_map(|(k, name)| {
            judge(
                name,
                aiding
                    .iter()
                    .copied()
                    .filter(|s| kind_of(s.kind) == Some(k)),
            )
        })
        .collect();
    Consistency {
        innovations: n,
        inside_95: inside,
        refused,
        mean_nis,
        fits: n > 0 && kinds.iter().all(|k| k.fits),
        kinds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn said(t: f64, kind: Kind, z: f64, taken: bool) -> Said {
        Said {
            t,
            kind,
            value: z,
            sigma: 1.0,
            taken,
        }
    }

    /// Many good pressures do not hide fixes that do not fit, and a run of refused fixes is
    /// named by its span.
    #[test]
    fn a_kind_that_does_not_fit_is_not_hidden_by_the_pool() {
        let mut s: Vec<Said> = (0..2000)
            .map(|i| said(f64::from(i) * 0.1, Kind::Baro, 0.5, true))
            .collect();
        for i in 0..60 {
            let t = f64::from(i);
            let bad = (20..36).contains(&i);
            s.push(said(
                t,
                Kind::Position(0),
                if bad { 30.0 } else { 0.3 },
                !bad,
            ));
            s.push(said(
                t,
                Kind::Position(1),
                if bad { 40.0 } else { -0.2 },
                !bad,
            ));
        }
        let c = consistency(&s);
        assert!(
            c.inside_95 as f64 >= INSIDE_AT_LEAST * c.innovations as f64,
            "the pool alone passes"
        );
        assert!(!c.fits);
        let gnss = &c.kinds[0];
        assert_eq!(gnss.kind, "GNSS horizontal position");
        assert!(!gnss.fits);
        assert_eq!(gnss.refused_runs.len(), 1);
        let r = gnss.refused_runs[0];
        assert_eq!((r.from, r.to, r.count), (20.0, 35.0, 32));
        assert!(c.kinds[1].fits, "the barometer fits");
        assert!(
            c.failure().contains("32 refused from 20.0 to 35.0 s"),
            "{}",
            c.failure()
        );
    }

    /// A kind with few innovations is not failed for one chance outlier.
    #[test]
    fn one_outlier_among_few_fixes_is_chance() {
        let mut s: Vec<Said> = (0..12)
            .map(|i| said(f64::from(i), Kind::Position(2), 0.4, true))
            .collect();
        s[5].value = 2.5;
        let c = consistency(&s);
        assert!(c.fits, "{c:?}");
        // Five of twelve outside is not chance.
        for x in s.iter_mut().take(5) {
            x.value = 2.5;
        }
        assert!(!consistency(&s).fits);
    }
}

/// The share of held-out fixes within 3 sigma of the track a track that can be believed has
/// at least.
pub const HELD_OUT_AT_LEAST: f64 = 0.9;

/// Every `k`-th fix after the launch kept out of the filter and the smoother
/// (`flight --hold-out K`): the fixes the filter takes, and those held out.
#[must_use]
pub fn hold_out(
    fixes: &[super::input::Fix],
    k: usize,
    launch: f64,
) -> (Vec<super::input::Fix>, Vec<super::input::Fix>) {
    let (mut taken, mut held) = (Vec::new(), Vec::new());
    let mut after = 0usize;
    for f in fixes {
        if f.t >= launch && k > 1 {
            after += 1;
            if after.is_multiple_of(k) {
                held.push(*f);
                continue;
            }
        }
        taken.push(*f);
    }
    (taken, held)
}

/// The fixes the filter never saw, against the smoothed track at their instants: each fix's
/// distance from the track in sigmas, its components (east, north, and up where the fix has a
/// height) each over the track's stated 1-sigma together with the fix's, taken together
/// (`sqrt(z_e^2 + z_n^2 + z_u^2)`). Where the stated sigmas are true, 97.1 % of fixes with a
/// height are within 3 (98.9 % of those without), and 95 % within their 95 % bound.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOut {
    /// Every k-th fix after the launch was held out.
    pub every: usize,
    /// Held-out fixes compared (inside the track's span).
    pub fixes: usize,
    /// Their components compared.
    pub components: usize,
    /// Of the fixes, those whose distance from the track is within 3 sigma.
    pub within_3_sigma: usize,
    /// Of the fixes, those within their 95 % bound (the chi-square 95 % point of their
    /// components: 2.45 sigma with two, 2.80 with three): about 95 % where the track's and the
    /// fixes' stated 1-sigma are true.
    pub within_95: usize,
    /// The RMS horizontal distance from the track, m.
    pub rms_m: f64,
    /// The largest distance in sigmas and its fix's time, s.
    pub worst: (f64, f64),
    /// At least [`HELD_OUT_AT_LEAST`] within 3 sigma: the track can be believed.
    pub believed: bool,
}

impl HeldOut {
    /// Its share of fixes within 3 sigma.
    #[must_use]
    pub fn share(&self) -> f64 {
        self.within_3_sigma as f64 / self.fixes.max(1) as f64
    }

    /// Its share of fixes within their 95 % bound.
    #[must_use]
    pub fn share_95(&self) -> f64 {
        self.within_95 as f64 / self.fixes.max(1) as f64
    }
}

/// The `held` fixes (every `every`-th) against the smoothed `track`; `noise` the fixes'
/// 1-sigma (horizontal, vertical), `latency` how late they are stamped and `correlated` the
/// receiver's slowly varying error the track's 1-sigma carries.
#[must_use]
pub fn held_out(
    track: &super::track::Track,
    held: &[super::input::Fix],
    every: usize,
    noise: (f64, f64),
    (latency, correlated): (f64, f64),
) -> HeldOut {
    let traj = &track.trajectory;
    let at = |t: f64| -> Option<([f64; 3], [f64; 3])> {
        let k = traj.partition_point(|e| e.0 < t);
        let (a, b) = (traj.get(k.checked_sub(1)?)?, traj.get(k)?);
        let u = if b.0 > a.0 {
            (t - a.0) / (b.0 - a.0)
        } else {
            0.0
        };
        let mix = |x: &[f64; 3], y: &[f64; 3]| std::array::from_fn(|i| x[i] * (1.0 - u) + y[i] * u);
        Some((mix(&a.1, &b.1), mix(&a.2, &b.2)))
    };
    let (mut fixes, mut components, mut within, mut sq) = (0usize, 0usize, 0usize, 0.0f64);
    let mut within_95 = 0usize;
    // The chi-square 95 % points of a fix's two or three components.
    let bound_95 = [2.0, 3.0].map(|dof| crate::stats::dist::chi2_upper_quantile(0.05, dof));
    let mut worst = (0.0f64, f64::NAN);
    for f in held {
        let t = f.t - latency;
        let Some((p, s)) = at(t) else { continue };
        let z = super::frame::level_position(f, track.origin);
        fixes += 1;
        sq += (p[0] - z[0]).powi(2) + (p[1] - z[1]).powi(2);
        let axes = if f.height.is_some() { 3 } else { 2 };
        let mut d2 = 0.0;
        for i in 0..axes {
            let r = if i == 2 { noise.1 } else { noise.0 };
            // The receiver's slowly varying error is in the held-out fix and in the track its
            // neighbours pulled, alike: their difference holds the fix's own noise and the
            // track's error without it.
            let own = (s[i] * s[i] - correlated * correlated).max(0.0).sqrt();
            d2 += ((p[i] - z[i]) / own.hypot(r)).powi(2);
            components += 1;
        }
        within += usize::from(d2 <= 9.0);
        within_95 += usize::from(d2 <= bound_95[axes - 2]);
        let d = d2.sqrt();
        if d > worst.0 {
            worst = (d, f.t);
        }
    }
    let share = within as f64 / fixes.max(1) as f64;
    HeldOut {
        every,
        fixes,
        components,
        within_3_sigma: within,
        within_95,
        rms_m: if fixes > 0 {
            (sq / fixes as f64).sqrt()
        } else {
            f64::NAN
        },
        worst,
        believed: fixes > 0 && share >= HELD_OUT_AT_LEAST,
    }
}
