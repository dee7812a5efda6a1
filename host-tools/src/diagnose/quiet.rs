//! A cycle in the residual while the machine is quiet: the signature of an
//! on/off chiller that nothing logs.
//!
//! When the speed and the load have not changed for a while, a thermal
//! network relaxes: what a slightly wrong twin leaves is a sum of decaying
//! exponentials with the network's time constants, smooth on the scale of
//! an hour, plus the sensors' noise. A chiller that switches its compressor
//! on and off keeps the coolant swinging by its hysteresis band whatever the
//! machine does (its period drifts with the load, its phase is free), and
//! every node that gives heat to the coolant, every sensor that leans to it,
//! swings with it. So the residual of each channel is cut into windows of
//! [`WINDOW_S`] that begin at least [`SETTLE_S`] after the last change of
//! speed or load and contain none; in each a quadratic in time is fitted
//! (it takes the relaxation and any slow drift of the room or of the sensor)
//! and what it leaves is pooled over the windows. Its rms over the
//! channel's white noise (from second differences, blind to smooth
//! motion) is about 1 without a cycle (0.97 for white noise: a quadratic
//! takes three of sixty degrees of freedom) and grows with the cycle's
//! amplitude at that channel: [`QuietCycle::cycles`].
//!
//! The ratio looks at no period and no phase, so a drifting period does
//! not matter, and it uses quiet rows only, so no load cycle of a part
//! program (whose response the twin gets roughly right) can pass for a
//! chiller.
//!
//! **Its period.** A chiller's on/off cycle takes minutes to about an hour
//! (the tank's heat capacity times the hysteresis band over the compressor's
//! net power); the room's air handling swings over hours (a building's
//! HVAC schedule, the day). A slow swing of large amplitude still leaves a
//! little in each window once the quadratic is out (a cubic-like rest), so
//! the ratio alone could call it a chiller. The cycle's period is therefore
//! measured where the ratio is: a sinusoid of period `P` (free phase per
//! window) is added to each window's quadratic, and the `P` of a log grid
//! ([`PERIOD_GRID_S`]) whose sinusoids take the most of what the quadratics
//! leave, pooled over the windows, is the quiet period
//! ([`QuietCycle::period_s`]). Within one window a swing slower than the
//! window is a near-cubic whatever its period, so every slow `P` explains it
//! about as well and the scan lands at the slow end of the grid; a cycle
//! that turns within the window picks its own period. A cycle counts for a
//! chiller only at a period up to [`MAX_PERIOD_S`].

use super::align::Aligned;
use crate::num::lsq;
use std::ops::Range;

/// Time after a change of speed or load before a quiet window may begin,
/// s: transients of the fast nodes (minutes) have decayed by then to a few
/// % and the slow ones are smooth on the window's scale.
pub const SETTLE_S: f64 = 1800.0;
/// Length of a quiet window, s: one to three chiller periods (15-45 min),
/// short enough that a quadratic follows the relaxation of a network whose
/// time constants from the hour up dominate after [`SETTLE_S`].
pub const WINDOW_S: f64 = 3600.0;
/// Fewest quiet windows for a judgement (three hours of quiet in a run).
pub const MIN_WINDOWS: usize = 3;
/// A channel carries a cycle when what the quadratics leave exceeds its
/// white noise this many times. Development seed 1 (plants a-h): without a
/// chiller (every other cause, `none` included) no channel went above
/// ~1.3 (0.97 is white noise); unlogged chillers reached 2-20 on the
/// channel that leans to the coolant.
pub const CYCLE_RATIO: f64 = 1.6;
/// Periods scanned for the quiet cycle's period: a log grid of
/// [`PERIOD_STEPS`] from 5 min (the chiller band's fast end,
/// [`super::chiller::CHILLER_BAND_S`]) to 8 h, s.
pub const PERIOD_GRID_S: (f64, f64) = (super::chiller::CHILLER_BAND_S.0, 28_800.0);
/// Points of the period grid (about 10 % apart).
const PERIOD_STEPS: usize = 49;
/// Longest quiet period that counts for a chiller, s: minutes to about an
/// hour. A chiller's period at rest is `C band (1/Q_warm + 1/Q_cool)`:
/// the zoo's chillers (plants a-i) cycle in 25-67 min at rest and 10-30 min
/// at top speed at their nominal band. Development seed 1 (the 21 cases of
/// plants a-i where gate 5 or the quiet confirmation of gate 1 named the
/// chiller): quiet periods 13-49 min. On a synthetic quiet day (0.01 K
/// noise) a 30 min triangle scans to 27-33 min and a 1 K room swing of 3 h
/// beyond this limit (unit tests `a_chiller_cycle_has_its_period`,
/// `a_slow_room_swing_is_no_chiller`). The grid points nearest the limit
/// are 71.7 and 78.8 min, so in effect it is 71.7 min. Gate 1's chiller
/// band ([`super::chiller::CHILLER_BAND_S`]) reaches 2 h: a logged supply
/// cycling that slowly still counts there.
pub const MAX_PERIOD_S: f64 = 4500.0;
/// A step of the logged speed larger than this share of the run's top
/// speed is a change.
const SPEED_STEP: f64 = 0.005;
/// Rows of the moving mean that smooths the logged power before its steps
/// are read (its noise is white, the load's steps are not).
const POWER_SMOOTH_ROWS: usize = 5;
/// A step of the smoothed power above this many of its own noise sigmas,
/// or above [`MIN_POWER_STEP_KW`], is a change.
const POWER_STEP_SIGMAS: f64 = 3.0;
/// Smallest power step taken for a change, kW.
const MIN_POWER_STEP_KW: f64 = 0.05;

/// The strongest quiet cycle among a run's channels.
#[derive(Debug, Clone, PartialEq)]
pub struct QuietCycle {
    /// Channel it is strongest on.
    pub channel: String,
    /// Rms of what the windows' quadratics leave over the white noise.
    pub ratio: f64,
    /// Number of quiet windows.
    pub windows: usize,
    /// Period of the sinusoid that takes most of the windows' rest, s.
    pub period_s: f64,
}

impl QuietCycle {
    /// Whether the channel carries a cycle ([`CYCLE_RATIO`]) of a
    /// chiller's period (<= [`MAX_PERIOD_S`]).
    pub fn cycles(&self) -> bool {
        self.ratio >= CYCLE_RATIO && self.period_s <= MAX_PERIOD_S
    }
}

/// Rows at which the speed or the (smoothed) load steps; row 0 counts as
/// one (what came before the log is unknown).
fn changes(al: &Aligned) -> Vec<bool> {
    let n = al.t_s.len();
    let top = al.speed_rpm.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let power = al.power_kw.as_deref().map(|p| {
        let smooth = moving_mean(p, POWER_SMOOTH_ROWS);
        let step = (POWER_STEP_SIGMAS * lsq::noise_sigma(p)).max(MIN_POWER_STEP_KW);
        (smooth, step)
    });
    (0..n)
        .map(|k| {
            k == 0
                || (al.speed_rpm[k] - al.speed_rpm[k - 1]).abs() > SPEED_STEP * top
                || power
                    .as_ref()
                    .is_some_and(|(p, step)| (p[k] - p[k - 1]).abs() > *step)
        })
        .collect()
}

/// Centred moving mean of `x` over `rows` rows (fewer at the ends).
fn moving_mean(x: &[f64], rows: usize) -> Vec<f64> {
    let h = rows / 2;
    (0..x.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h + 1).min(x.len()));
            x[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect()
}

/// Non-overlapping windows of [`WINDOW_S`] with no change in them nor in
/// the [`SETTLE_S`] before them, earliest first.
pub fn quiet_windows(t: &[f64], changed: &[bool]) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut last_change = f64::NEG_INFINITY;
    let mut start: Option<usize> = None;
    for k in 0..t.len() {
        if changed[k] {
            last_change = t[k];
            start = None;
            continue;
        }
        if t[k] - last_change < SETTLE_S {
            continue;
        }
        let a = *start.get_or_insert(k);
        if t[k] - t[a] >= WINDOW_S {
            out.push(a..k);
            start = Some(k);
        }
    }
    out
}

/// A quadratic in time on the times `t` (centred and scaled to +-1, so the
/// columns are of one size): the columns `1, x^2, x`.
fn quadratic_columns(t: &[f64]) -> Vec<Vec<f64>> {
    let tm = t.iter().sum::<f64>() / t.len().max(1) as f64;
    let span = t.iter().map(|v| (v - tm).abs()).fold(1e-12, f64::max);
    let x: Vec<f64> = t.iter().map(|v| (v - tm) / span).collect();
    vec![vec![1.0; x.len()], x.iter().map(|v| v * v).collect(), x]
}

/// What a least-squares fit of `cols` leaves of `y` (all of `y` if the
/// fit fails).
fn left_by(cols: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    match lsq::fit(cols, y, y.len()) {
        Some(f) => y.iter().zip(&f.pred).map(|(v, p)| v - p).collect(),
        None => y.to_vec(),
    }
}

/// What a least-squares quadratic in time leaves of `y` on the times `t`.
pub fn quadratic_residual(t: &[f64], y: &[f64]) -> Vec<f64> {
    left_by(&quadratic_columns(t), y)
}

/// What each window's quadratic in time leaves of `resid`, window by window.
fn quadratic_lefts(t: &[f64], resid: &[f64], windows: &[Range<usize>]) -> Vec<Vec<f64>> {
    windows
        .iter()
        .map(|r| quadratic_residual(&t[r.clone()], &resid[r.clone()]))
        .collect()
}

/// What the windows' quadratics leave (`lefts`, [`quadratic_lefts`]) over
/// the white noise of `resid`.
fn ratio_of(resid: &[f64], lefts: &[Vec<f64>]) -> f64 {
    let left: Vec<f64> = lefts.iter().flatten().copied().collect();
    lsq::rms(&left) / lsq::white_sigma(resid).max(1e-12)
}

/// The energy a sinusoid of period `period_s` (free amplitude and phase)
/// takes from each window's quadratic rest of `resid` (`quad`, its rms per
/// window, and `bases`, the window's quadratic columns), summed.
fn sinusoid_gain(
    t: &[f64],
    resid: &[f64],
    windows: &[Range<usize>],
    (bases, quad): (&[Vec<Vec<f64>>], &[f64]),
    period_s: f64,
) -> f64 {
    let w = std::f64::consts::TAU / period_s;
    windows
        .iter()
        .zip(bases)
        .zip(quad)
        .map(|((r, base), quad)| {
            let (tw, yw) = (&t[r.clone()], &resid[r.clone()]);
            let mut cols = base.clone();
            cols.push(tw.iter().map(|v| (w * v).sin()).collect());
            cols.push(tw.iter().map(|v| (w * v).cos()).collect());
            let with = lsq::rms(&left_by(&cols, yw));
            yw.len() as f64 * (quad * quad - with * with)
        })
        .sum()
}

/// The period of [`PERIOD_GRID_S`] whose sinusoids take the most of what
/// the windows' quadratics leave of `resid` (`lefts`, [`quadratic_lefts`]).
/// The grid runs from fast to slow and a period replaces the best only
/// when its gain is larger (by 1e-9 relative), so of equal gains the
/// fastest is kept.
fn period_of(t: &[f64], resid: &[f64], windows: &[Range<usize>], lefts: &[Vec<f64>]) -> f64 {
    let (lo, hi) = PERIOD_GRID_S;
    let step = (hi / lo).ln() / (PERIOD_STEPS - 1) as f64;
    let quad: Vec<f64> = lefts.iter().map(|l| lsq::rms(l)).collect();
    let bases: Vec<Vec<Vec<f64>>> = windows
        .iter()
        .map(|r| quadratic_columns(&t[r.clone()]))
        .collect();
    (0..PERIOD_STEPS)
        .map(|k| lo * (step * k as f64).exp())
        .map(|p| (p, sinusoid_gain(t, resid, windows, (&bases, &quad), p)))
        .fold((hi, f64::NEG_INFINITY), |best, (p, g)| {
            if g > best.1 * (1.0 + 1e-9) {
                (p, g)
            } else {
                best
            }
        })
        .0
}

/// [`period_of`] from `resid` itself (the tests' entry).
#[cfg(test)]
fn quiet_period_s(t: &[f64], resid: &[f64], windows: &[Range<usize>]) -> f64 {
    period_of(t, resid, windows, &quadratic_lefts(t, resid, windows))
}

/// What the windows' quadratics leave of `resid`, over its white noise
/// (the tests' entry).
#[cfg(test)]
fn quiet_ratio(t: &[f64], resid: &[f64], windows: &[Range<usize>]) -> f64 {
    ratio_of(resid, &quadratic_lefts(t, resid, windows))
}

/// The strongest quiet cycle over every channel of `al`, or `None` when
/// the run has fewer than [`MIN_WINDOWS`] quiet windows.
pub fn quiet_cycle(al: &Aligned) -> Option<QuietCycle> {
    let windows = quiet_windows(&al.t_s, &changes(al));
    if windows.len() < MIN_WINDOWS {
        return None;
    }
    // Each channel's residual is read once (it may come off the spill
    // file) and its windows' quadratics fitted once; the strongest channel
    // (the last of equal ones) keeps them for its period.
    let (i, ratio, resid, lefts) = (0..al.channels.len())
        .map(|i| {
            let resid = al.channels.resid(i);
            let lefts = quadratic_lefts(&al.t_s, &resid, &windows);
            (i, ratio_of(&resid, &lefts), resid, lefts)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(QuietCycle {
        channel: al.channels.name(i).to_string(),
        ratio,
        windows: windows.len(),
        period_s: period_of(&al.t_s, &resid, &windows, &lefts),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::num::rng::SplitMix64;

    /// Gaussian-ish white noise (a sum of 12 uniforms), sigma `s`.
    fn noise(n: usize, s: f64, seed: u64) -> Vec<f64> {
        let mut g = SplitMix64::new(seed);
        (0..n)
            .map(|_| s * ((0..12).map(|_| g.uniform()).sum::<f64>() - 6.0))
            .collect()
    }

    #[test]
    fn a_quadratic_is_removed_exactly() {
        // 1 + 2x - 3x^2 on 60 rows: nothing left (orthogonal projections,
        // rounding only: 1e-9).
        let t: Vec<f64> = (0..60).map(|k| 60.0 * k as f64).collect();
        let y: Vec<f64> = t.iter().map(|v| 1.0 + 2e-3 * v - 3e-7 * v * v).collect();
        let r = quadratic_residual(&t, &y);
        assert!(r.iter().all(|v| v.abs() < 1e-9), "{r:?}");
    }

    #[test]
    fn windows_start_a_settling_time_after_each_change() {
        // 10 h at 60 s; a change at rows 0 and 300 (5 h). Windows begin
        // 30 min after each and last 60 min: 0.5-1.5, 1.5-2.5, 2.5-3.5,
        // 3.5-4.5 h before the change, 5.5-6.5 .. 8.5-9.5 h after it.
        let t: Vec<f64> = (0..600).map(|k| 60.0 * k as f64).collect();
        let mut ch = vec![false; 600];
        (ch[0], ch[300]) = (true, true);
        let w = quiet_windows(&t, &ch);
        assert_eq!(w.len(), 8);
        assert_eq!((w[0].start, w[0].end), (30, 90));
        assert_eq!((w[4].start, w[4].end), (330, 390));
        assert!(w.iter().all(|r| r.end <= 300 || r.start >= 330));
    }

    #[test]
    fn a_relaxation_is_quiet_and_a_drifting_cycle_is_not() {
        // 12 h of quiet rows after one change: a relaxation with a 2 h
        // time constant plus white noise leaves ~1 x the noise (0.97 for
        // white noise, 0.85-1.15 allowed for the sampling of 600 rows); a
        // chiller-like triangle of 0.1 K peak to peak (rms 0.029 K, three
        // times the 0.01 K noise) whose period drifts from 20 to 40 min
        // leaves > 2.
        let n = 12 * 60;
        let t: Vec<f64> = (0..n).map(|k| 60.0 * k as f64).collect();
        let mut ch = vec![false; n];
        ch[0] = true;
        let w = quiet_windows(&t, &ch);
        let e = noise(n, 0.01, 3);
        let relax: Vec<f64> = t
            .iter()
            .zip(&e)
            .map(|(v, e)| 2.0 * (-v / 7200.0).exp() + e)
            .collect();
        let r = quiet_ratio(&t, &relax, &w);
        assert!((0.85..1.15).contains(&r), "{r}");
        let mut phase = 0.0;
        let cycle: Vec<f64> = t
            .iter()
            .zip(&e)
            .map(|(v, e)| {
                phase += 60.0 / (1200.0 + 1200.0 * v / t[n - 1]);
                let ph = phase % 1.0;
                let tri = if ph < 0.5 { 2.0 * ph } else { 2.0 - 2.0 * ph };
                0.1 * (tri - 0.5) + e
            })
            .collect();
        let r = quiet_ratio(&t, &cycle, &w);
        assert!(r > 2.0, "{r} (CYCLE_RATIO {CYCLE_RATIO})");
    }

    /// 24 h of quiet rows after one change, the windows and white noise
    /// of 0.01 K.
    fn quiet_day() -> (Vec<f64>, Vec<Range<usize>>, Vec<f64>) {
        let n = 24 * 60;
        let t: Vec<f64> = (0..n).map(|k| 60.0 * k as f64).collect();
        let mut ch = vec![false; n];
        ch[0] = true;
        let w = quiet_windows(&t, &ch);
        (t, w, noise(n, 0.01, 5))
    }

    fn cycle_of(t: &[f64], w: &[Range<usize>], y: &[f64]) -> QuietCycle {
        QuietCycle {
            channel: "T1".into(),
            ratio: quiet_ratio(t, y, w),
            windows: w.len(),
            period_s: quiet_period_s(t, y, w),
        }
    }

    #[test]
    fn a_chiller_cycle_has_its_period() {
        // A 0.1 K triangle every 30 min: the scan finds 30 min (+-10 %,
        // the grid's step), and it is a chiller's cycle.
        let (t, w, e) = quiet_day();
        let y: Vec<f64> = t
            .iter()
            .zip(&e)
            .map(|(v, e)| {
                let ph = (v / 1800.0).fract();
                0.1 * (if ph < 0.5 { 2.0 * ph } else { 2.0 - 2.0 * ph } - 0.5) + e
            })
            .collect();
        let q = cycle_of(&t, &w, &y);
        assert!((1620.0..1980.0).contains(&q.period_s), "{q:?}");
        assert!(q.cycles(), "{q:?}");
    }

    #[test]
    fn a_slow_room_swing_is_no_chiller() {
        // A room swinging 1 K every 3 h leaves ~2 x the noise in the
        // windows (a near-cubic rest): the ratio alone would call it a
        // chiller, its period (over an hour) does not.
        let (t, w, e) = quiet_day();
        let y: Vec<f64> = t
            .iter()
            .zip(&e)
            .map(|(v, e)| (std::f64::consts::TAU * v / 10_800.0).sin() + e)
            .collect();
        let q = cycle_of(&t, &w, &y);
        assert!(q.ratio >= CYCLE_RATIO, "{q:?}");
        assert!(q.period_s > MAX_PERIOD_S, "{q:?}");
        assert!(!q.cycles());
    }
}
