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
//! It looks at no period and no phase, so a drifting period does not
//! matter, and it uses quiet rows only, so no load cycle of a part program
//! (whose response the twin gets roughly right) can pass for a chiller.

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
}

impl QuietCycle {
    /// Whether the channel carries a cycle ([`CYCLE_RATIO`]).
    pub fn cycles(&self) -> bool {
        self.ratio >= CYCLE_RATIO
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

/// What a least-squares quadratic in time leaves of `y` on the times `t`
/// (time centred and scaled to +-1 first, so the columns are of one size).
pub fn quadratic_residual(t: &[f64], y: &[f64]) -> Vec<f64> {
    let tm = t.iter().sum::<f64>() / t.len().max(1) as f64;
    let span = t.iter().map(|v| (v - tm).abs()).fold(1e-12, f64::max);
    let x: Vec<f64> = t.iter().map(|v| (v - tm) / span).collect();
    let cols = vec![vec![1.0; x.len()], x.iter().map(|v| v * v).collect(), x];
    match lsq::fit(&cols, y, y.len()) {
        Some(f) => y.iter().zip(&f.pred).map(|(v, p)| v - p).collect(),
        None => y.to_vec(),
    }
}

/// What the windows' quadratics leave of `resid`, over its white noise.
pub fn quiet_ratio(t: &[f64], resid: &[f64], windows: &[Range<usize>]) -> f64 {
    let left: Vec<f64> = windows
        .iter()
        .flat_map(|w| quadratic_residual(&t[w.clone()], &resid[w.clone()]))
        .collect();
    lsq::rms(&left) / lsq::white_sigma(resid).max(1e-12)
}

/// The strongest quiet cycle over every channel of `al`, or `None` when
/// the run has fewer than [`MIN_WINDOWS`] quiet windows.
pub fn quiet_cycle(al: &Aligned) -> Option<QuietCycle> {
    let windows = quiet_windows(&al.t_s, &changes(al));
    if windows.len() < MIN_WINDOWS {
        return None;
    }
    (0..al.channels.len())
        .map(|i| QuietCycle {
            channel: al.channels.name(i).to_string(),
            ratio: quiet_ratio(&al.t_s, &al.channels.resid(i), &windows),
            windows: windows.len(),
        })
        .max_by(|a, b| a.ratio.total_cmp(&b.ratio))
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
}
