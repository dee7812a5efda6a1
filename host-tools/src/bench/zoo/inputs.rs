//! What the spindle does over a zoo run: speed and cutting load.
//!
//! | profile | |
//! |---|---|
//! | `steps` | 25, 50, 75, 100 % of top speed, each first air-cutting then machining; a stop; top speed machining hard; then a final quarter at 15 % speed machining (a speed the first half never saw) |
//! | `spectrum` | random speeds among 0, 20, .. 100 % for 20-150 min each, half of the running stretches machining at a random load and cycle; the last fifth at 10 % or 90 % (never drawn before) machining |
//! | `shifts` | a production day: two shifts from 06:00 to 22:00 with breaks, a part program of four operations repeated; from 55 % of the run on a new part program with other speeds and loads; nights idle |
//!
//! Machining is a duty cycle: the load for the first 60 % of every cycle.
//! Every profile machines, so the presence of cutting load tells the
//! diagnosis nothing about the cause.

use super::noise::Gauss;
use anyhow::{bail, Result};

/// Seed stream of the profiles.
const PROFILE_STREAM: u64 = 21;
/// Share of a machining cycle under load.
const DUTY: f64 = 0.6;

/// The profiles of the zoo.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileKind {
    /// Speed steps, stop, final low-speed regime.
    Steps,
    /// Random speed spectrum with a final unseen speed.
    Spectrum,
    /// Production shifts with a new part program at the end.
    Shifts,
}

impl ProfileKind {
    /// Every profile, in the order cases cycle through them.
    pub const ALL: [ProfileKind; 3] = [
        ProfileKind::Spectrum,
        ProfileKind::Shifts,
        ProfileKind::Steps,
    ];

    /// Name of the profile.
    pub fn label(self) -> &'static str {
        match self {
            ProfileKind::Steps => "steps",
            ProfileKind::Spectrum => "spectrum",
            ProfileKind::Shifts => "shifts",
        }
    }
}

/// The true inputs of a run on its time grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Spindle speed, rpm.
    pub speed_rpm: Vec<f64>,
    /// Cutting power, kW.
    pub cut_kw: Vec<f64>,
}

/// A stretch of constant speed and machining load.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stretch {
    len_s: f64,
    /// Fraction of top speed.
    speed: f64,
    /// Fraction of the plant's largest cutting load (0: air cutting).
    cut: f64,
    /// Machining cycle, s.
    cycle_s: f64,
}

fn stretch(len_s: f64, speed: f64, cut: f64, cycle_s: f64) -> Stretch {
    Stretch {
        len_s,
        speed,
        cut,
        cycle_s,
    }
}

/// `steps` over `total_s`.
fn steps(total_s: f64) -> Vec<Stretch> {
    let e = total_s / 16.0;
    let mut v = Vec::new();
    for (speed, cut) in [(0.25, 0.4), (0.5, 0.6), (0.75, 0.8), (1.0, 0.5)] {
        v.push(stretch(e, speed, 0.0, 600.0));
        v.push(stretch(e, speed, cut, 600.0));
    }
    v.push(stretch(2.0 * e, 0.0, 0.0, 600.0));
    v.push(stretch(2.0 * e, 1.0, 1.0, 900.0));
    v.push(stretch(4.0 * e, 0.15, 0.7, 480.0));
    v
}

/// `spectrum` over `total_s`.
fn spectrum(total_s: f64, g: &mut Gauss) -> Vec<Stretch> {
    const LEVELS: [f64; 6] = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0];
    let body_s = 0.8 * total_s;
    let mut v = Vec::new();
    let (mut t, mut last) = (0.0, usize::MAX);
    while t < body_s {
        let mut l = g.below(LEVELS.len());
        if l == last {
            l = (l + 1 + g.below(LEVELS.len() - 1)) % LEVELS.len();
        }
        last = l;
        let len = (1200.0 + 7800.0 * g.uniform()).min(body_s - t).max(60.0);
        let cut = if LEVELS[l] > 0.0 && g.uniform() < 0.5 {
            0.3 + 0.7 * g.uniform()
        } else {
            0.0
        };
        v.push(stretch(len, LEVELS[l], cut, 360.0 + 840.0 * g.uniform()));
        t += len;
    }
    let final_speed = if g.uniform() < 0.5 { 0.1 } else { 0.9 };
    v.push(stretch(total_s - t + 60.0, final_speed, 0.8, 600.0));
    v
}

/// A part program: (speed, load) of four operations and their lengths, s.
fn program(g: &mut Gauss, speeds: [f64; 3], cuts: [f64; 3]) -> Vec<Stretch> {
    let mut ops: Vec<Stretch> = speeds
        .iter()
        .zip(cuts)
        .map(|(&s, c)| {
            let jitter = 1.0 + 0.1 * g.symmetric();
            stretch(
                600.0 + 900.0 * g.uniform(),
                (s * jitter).min(1.0),
                c,
                300.0 + 300.0 * g.uniform(),
            )
        })
        .collect();
    ops.push(stretch(180.0 + 120.0 * g.uniform(), 0.0, 0.0, 600.0));
    ops
}

/// Whether clock hour `h` (0..24) is inside a shift and not a break.
fn working(h: f64) -> bool {
    let breaks = [(10.0, 10.5), (14.0, 14.5), (18.0, 18.5)];
    (6.0..22.0).contains(&h) && !breaks.iter().any(|(a, b)| (*a..*b).contains(&h))
}

/// `shifts` over `total_s`, starting at 06:00, on a 5-min clock.
fn shifts(total_s: f64, g: &mut Gauss) -> Vec<Stretch> {
    const TICK_S: f64 = 300.0;
    let a = program(g, [0.7, 1.0, 0.35], [0.8, 0.3, 0.9]);
    let b = program(g, [0.5, 0.15, 0.85], [1.0, 0.6, 0.5]);
    let mut v: Vec<Stretch> = Vec::new();
    let (mut t, mut op, mut left) = (0.0, 0usize, a[0].len_s);
    while t < total_s + TICK_S {
        let clock = (6.0 + t / 3600.0) % 24.0;
        let prog = if t < 0.55 * total_s { &a } else { &b };
        let s = if working(clock) {
            let s = prog[op % prog.len()];
            left -= TICK_S;
            if left <= 0.0 {
                op += 1;
                left = prog[op % prog.len()].len_s;
            }
            s
        } else {
            stretch(TICK_S, 0.0, 0.0, 600.0)
        };
        v.push(stretch(TICK_S, s.speed, s.cut, s.cycle_s));
        t += TICK_S;
    }
    v
}

/// The schedule of `kind` for a plant with top speed `max_rpm` and largest
/// cutting load `cut_max_kw`: `hours` long at `dt_s`.
pub fn schedule(
    kind: ProfileKind,
    max_rpm: f64,
    cut_max_kw: f64,
    hours: f64,
    dt_s: f64,
    seed: u64,
) -> Result<Schedule> {
    if !(hours.is_finite() && hours >= 4.0 && dt_s > 0.0 && hours * 3600.0 / dt_s <= 1e6) {
        bail!("a zoo run needs >= 4 h and at most a million rows (got {hours} h at {dt_s} s)");
    }
    let total_s = hours * 3600.0;
    let mut g = Gauss::new(seed, PROFILE_STREAM);
    let stretches = match kind {
        ProfileKind::Steps => steps(total_s),
        ProfileKind::Spectrum => spectrum(total_s, &mut g),
        ProfileKind::Shifts => shifts(total_s, &mut g),
    };
    let n = (total_s / dt_s).floor() as usize + 1;
    let t_s: Vec<f64> = (0..n).map(|k| k as f64 * dt_s).collect();
    let (mut speed_rpm, mut cut_kw) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut j, mut start) = (0usize, 0.0);
    for &t in &t_s {
        while j + 1 < stretches.len() && t >= start + stretches[j].len_s {
            start += stretches[j].len_s;
            j += 1;
        }
        let s = stretches[j];
        let cutting = s.speed > 0.0 && (t - start).rem_euclid(s.cycle_s) < DUTY * s.cycle_s;
        speed_rpm.push((s.speed * max_rpm / 10.0).round() * 10.0);
        cut_kw.push(if cutting { s.cut * cut_max_kw } else { 0.0 });
    }
    Ok(Schedule {
        t_s,
        speed_rpm,
        cut_kw,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_profile_machines_and_ends_in_an_unseen_regime() {
        for kind in ProfileKind::ALL {
            let s = schedule(kind, 10_000.0, 5.0, 48.0, 60.0, 3).unwrap();
            assert_eq!(s.t_s.len(), 2881, "{kind:?}");
            assert!(s.cut_kw.iter().any(|&c| c > 0.0), "{kind:?} machines");
            // The end of the run holds a running speed the first half never
            // saw (farther than 5 % of top speed from each one it did).
            let n = s.t_s.len();
            let seen = &s.speed_rpm[..n / 2];
            let unseen = s.speed_rpm[(0.55 * n as f64) as usize..]
                .iter()
                .any(|&v| v > 0.0 && seen.iter().all(|&u| (u - v).abs() > 500.0));
            assert!(unseen, "{kind:?}");
        }
        let a = schedule(ProfileKind::Spectrum, 10_000.0, 5.0, 24.0, 60.0, 3).unwrap();
        let b = schedule(ProfileKind::Spectrum, 10_000.0, 5.0, 24.0, 60.0, 4).unwrap();
        assert_ne!(a.speed_rpm, b.speed_rpm);
    }
}
