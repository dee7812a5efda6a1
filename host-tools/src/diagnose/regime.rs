//! Operating regimes of a run from its logged speed and power, and each
//! regime segment's share of a channel's residual energy.
//!
//! A segment is a stretch of constant speed (a change of more than
//! `max(50 rpm, 2 % of the top speed)` starts a new one). A running stretch
//! reached by a speed rise is `warm-up N rpm` for its first hour and
//! `steady N rpm` after; one reached by a fall is `step-down N rpm`, then
//! `steady`. Standing still after running is `cool-down`, before any running
//! `idle`. The hour is the twin's dz 63 % time (0.6 h, docs/twin.md) rounded
//! up. A segment where at least 20 % of the samples draw more than the
//! air-cutting power at their speed gets ` cutting` appended.

/// Length of the warm-up / step-down part of a running stretch, s.
const TRANSIENT_S: f64 = 3600.0;
/// A sample cuts when its power exceeds air cutting by this much, kW
/// (or by 15 % of the air-cutting power, whichever is more).
const CUT_MARGIN_KW: f64 = 0.3;

/// One regime segment, rows `from..to`.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// First row.
    pub from: usize,
    /// One past the last row.
    pub to: usize,
    /// Label such as `warm-up 9000 rpm`.
    pub regime: String,
    /// Share of samples above air-cutting power, %.
    pub cutting_pct: f64,
}

/// Air-cutting power at each row's speed, kW: the 20th percentile of the
/// power logged at that speed (100 rpm bins), or the rising lower envelope
/// over all speeds ([`air_envelope_kw`]) where that percentile lies more
/// than the cutting margin above it.
/// Speed-dependent losses (bearings, motor, even extra low-speed losses)
/// are the same every time a speed comes back; cutting only adds, so a low
/// quantile is air cutting, unless the spindle always cuts at that speed:
/// the envelope, fitted where other speeds air-cut, covers those.
pub fn air_power_kw(speed_rpm: &[f64], power_kw: &[f64]) -> Vec<f64> {
    use std::collections::HashMap;
    let bin = |s: f64| (s / 100.0).round() as i64;
    let mut by_bin: HashMap<i64, Vec<f64>> = HashMap::new();
    for (&s, &p) in speed_rpm.iter().zip(power_kw) {
        by_bin.entry(bin(s)).or_default().push(p);
    }
    let q20: HashMap<i64, f64> = by_bin
        .into_iter()
        .map(|(b, mut v)| {
            let k = (v.len() - 1) / 5;
            (b, crate::num::stats::kth_smallest(&mut v, k))
        })
        .collect();
    let envelope = air_envelope_kw(speed_rpm, power_kw);
    speed_rpm
        .iter()
        .zip(&envelope)
        .map(|(&s, &e)| {
            let q = q20.get(&bin(s)).copied().unwrap_or(0.0);
            if q > e + CUT_MARGIN_KW.max(0.15 * e) {
                e
            } else {
                q
            }
        })
        .collect()
}

/// Speed bins (the most populated) that constrain the envelope; the
/// vertex search is `O(bins^4)`, and 40 bins take ~0.5 ms.
const ENVELOPE_MAX_BINS: usize = 40;
/// A bin constrains the envelope only with at least this many rows (a
/// speed passed through during a ramp says little about air cutting).
const ENVELOPE_MIN_ROWS: usize = 3;

/// A lower envelope of power against speed, kW: the largest curve
/// `c0 + c1 q + c2 q^2` (`q = n / n_max`) with `c0, c1, c2 >= 0` that lies
/// on or below the 20th percentile of the power at every speed bin
/// (100 rpm); "largest" maximises its sum over the running rows (a linear
/// programme, [`crate::num::lp3`]). Why this shape: air-cutting power is a
/// drive's idle draw plus bearing and motor losses that grow with speed
/// (n^1 .. n^2), never falling; and it is the same at every visit of a
/// speed, while cutting only adds. A speed at which the spindle always
/// cuts therefore sits above the envelope that the air-cutting speeds
/// carry, and when every speed cuts (a part program with one operation
/// per speed) the envelope still lies under all of them instead of
/// passing through the cutting power (the trimmed least-squares envelope
/// it replaces did: power beyond air cutting came out ~0 everywhere).
/// `+inf` (no bound) where no bin is populated; 0 at standstill.
pub fn air_envelope_kw(speed_rpm: &[f64], power_kw: &[f64]) -> Vec<f64> {
    use std::collections::HashMap;
    let top = speed_rpm
        .iter()
        .fold(0.0f64, |a, &n| a.max(n.abs()))
        .max(1.0);
    let mut by_bin: HashMap<i64, Vec<f64>> = HashMap::new();
    for (&n, &p) in speed_rpm.iter().zip(power_kw) {
        if n.abs() > 0.0 {
            by_bin
                .entry((n.abs() / 100.0).round() as i64)
                .or_default()
                .push(p);
        }
    }
    let mut bins: Vec<(usize, f64, f64)> = by_bin
        .into_iter()
        .filter(|(_, v)| v.len() >= ENVELOPE_MIN_ROWS)
        .map(|(b, mut v)| {
            let k = (v.len() - 1) / 5;
            (
                v.len(),
                (100.0 * b as f64 / top).max(1e-6),
                crate::num::stats::kth_smallest(&mut v, k),
            )
        })
        .collect();
    bins.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
    bins.truncate(ENVELOPE_MAX_BINS);
    let shape = |q: f64| [1.0, q, q * q];
    let mut g = [0.0; 3];
    for &(count, q, _) in &bins {
        for (gi, si) in g.iter_mut().zip(shape(q)) {
            *gi += count as f64 * si;
        }
    }
    let a: Vec<[f64; 3]> = bins.iter().map(|&(_, q, _)| shape(q)).collect();
    let b: Vec<f64> = bins.iter().map(|&(_, _, p)| p).collect();
    let coef = crate::num::lp3::maximise3(g, &a, &b);
    speed_rpm
        .iter()
        .map(|&n| {
            let q = n.abs() / top;
            match &coef {
                Some(c) if q > 0.0 => c[0] + c[1] * q + c[2] * q * q,
                Some(_) => 0.0,
                None => f64::INFINITY,
            }
        })
        .collect()
}

/// Power beyond air cutting at each row, kW (0 where the spindle stands).
pub fn cutting_excess_kw(speed_rpm: &[f64], power_kw: &[f64]) -> Vec<f64> {
    let air = air_power_kw(speed_rpm, power_kw);
    speed_rpm
        .iter()
        .zip(power_kw.iter().zip(&air))
        .map(|(&s, (&p, &a))| if s > 0.0 { (p - a).max(0.0) } else { 0.0 })
        .collect()
}

/// The low-speed weight `[n > 0] max(0, 1 - n/knee)` of each sample: the
/// regressor of a motor's extra loss below its knee speed.
pub fn low_speed_weight(speed_rpm: &[f64], knee: f64) -> Vec<f64> {
    speed_rpm
        .iter()
        .map(|&n| {
            if n > 0.0 {
                (1.0 - n / knee).max(0.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// Splits a run into regime segments.
pub fn segments(t_s: &[f64], speed_rpm: &[f64], power_kw: Option<&[f64]>) -> Vec<Segment> {
    let n = t_s.len();
    let top = speed_rpm.iter().fold(0.0f64, |a, &s| a.max(s.abs()));
    let step = (0.02 * top).max(50.0);
    let cut: Vec<bool> = match power_kw {
        Some(p) => {
            let air = air_power_kw(speed_rpm, p);
            (0..n)
                .map(|k| speed_rpm[k] > 0.0 && p[k] - air[k] > CUT_MARGIN_KW.max(0.15 * air[k]))
                .collect()
        }
        None => vec![false; n],
    };
    // Constant-speed stretches.
    let mut stretches = Vec::new();
    let mut start = 0;
    for k in 1..=n {
        if k == n || (speed_rpm[k] - speed_rpm[start]).abs() > step {
            stretches.push((start, k));
            start = k;
        }
    }
    let mut out = Vec::new();
    let mut ran = false;
    let mut prev_speed = 0.0;
    for (a, b) in stretches {
        let mean = speed_rpm[a..b].iter().sum::<f64>() / (b - a) as f64;
        let rpm = (mean / 10.0).round() * 10.0;
        let mut push = |from: usize, to: usize, label: String| {
            if from < to {
                let c = cut[from..to].iter().filter(|&&c| c).count();
                let cutting_pct = 100.0 * c as f64 / (to - from) as f64;
                let regime = if cutting_pct >= 20.0 {
                    format!("{label} cutting")
                } else {
                    label
                };
                out.push(Segment {
                    from,
                    to,
                    regime,
                    cutting_pct,
                });
            }
        };
        if mean.abs() <= step {
            push(a, b, if ran { "cool-down" } else { "idle" }.to_string());
        } else {
            let first = if mean > prev_speed {
                "warm-up"
            } else {
                "step-down"
            };
            let split = (a..b)
                .find(|&k| t_s[k] - t_s[a] >= TRANSIENT_S)
                .unwrap_or(b);
            push(a, split, format!("{first} {rpm} rpm"));
            push(split, b, format!("steady {rpm} rpm"));
            ran = true;
        }
        prev_speed = mean;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_a_start_stop_run() {
        let t: Vec<f64> = (0..600).map(|k| 60.0 * k as f64).collect();
        let speed: Vec<f64> = (0..600)
            .map(|k| match k {
                0..=29 => 0.0,
                30..=299 => 9000.0,
                300..=449 => 3000.0,
                _ => 0.0,
            })
            .collect();
        let power: Vec<f64> = (0..600)
            .map(|k| {
                if (300..450).contains(&k) && k % 10 < 5 {
                    5.0
                } else {
                    1.0
                }
            })
            .collect();
        let s = segments(&t, &speed, Some(&power));
        let labels: Vec<&str> = s.iter().map(|s| s.regime.as_str()).collect();
        assert_eq!(
            labels,
            [
                "idle",
                "warm-up 9000 rpm",
                "steady 9000 rpm",
                "step-down 3000 rpm cutting",
                "steady 3000 rpm cutting",
                "cool-down"
            ]
        );
        assert_eq!((s[1].from, s[1].to), (30, 90));
    }

    /// A run at speeds q = 0.2 .. 1.0 (of 10 000 rpm), air power
    /// `0.5 + 2 q^2` kW, noise-free.
    fn stepped(cuts_always: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut speed = Vec::new();
        let mut power = Vec::new();
        let mut truth = Vec::new();
        for q in [0.2, 0.4, 0.6, 0.8, 1.0] {
            for k in 0..100 {
                let cut = if k % 2 == 0 { 2.0 } else { cuts_always(q) };
                speed.push(10_000.0 * q);
                power.push(0.5 + 2.0 * q * q + cut);
                truth.push(cut);
            }
        }
        (speed, power, truth)
    }

    #[test]
    fn an_always_cut_speed_gets_its_cutting_power_from_the_envelope() {
        // Every speed air-cuts half the time except q = 1.0, which always
        // cuts (2 kW): its 20th percentile (4.5 kW) lies 2 kW above the
        // air-cutting law, which the envelope (the law's own shape, set by
        // the four air-cutting speeds) recovers exactly. 1e-9 kW: an exact
        // vertex of noise-free constraints.
        let (speed, power, truth) = stepped(|q| if q >= 1.0 { 2.0 } else { 0.0 });
        let cut = cutting_excess_kw(&speed, &power);
        for (k, (c, t)) in cut.iter().zip(&truth).enumerate() {
            assert!((c - t).abs() < 1e-9, "row {k}: {c} vs {t}");
        }
    }

    #[test]
    fn when_every_speed_cuts_the_envelope_stays_below_every_speed() {
        // Every speed always cuts (2 kW on half its rows, 1 kW on the
        // rest): no speed air-cuts, so air cutting is not identifiable;
        // the envelope must still lie on or below every speed's 20th
        // percentile (1e-9 kW) and rise with speed, so the cutting power
        // keeps its variation between operations (at least the 1 kW
        // difference) instead of vanishing.
        let (speed, power, _) = stepped(|_| 1.0);
        let env = air_envelope_kw(&speed, &power);
        for (k, (e, n)) in env.iter().zip(&speed).enumerate() {
            let q20 = 0.5 + 2.0 * (n / 10_000.0).powi(2) + 1.0;
            assert!(*e <= q20 + 1e-9, "row {k}: envelope {e} above {q20}");
        }
        assert!(env.windows(2).all(|w| w[1] >= w[0] - 1e-12));
        let cut = cutting_excess_kw(&speed, &power);
        let spread = cut.iter().fold(0.0f64, |a, &c| a.max(c))
            - cut.iter().fold(f64::INFINITY, |a, &c| a.min(c));
        assert!(spread >= 1.0 - 1e-9, "{spread}");
    }
}
