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
/// power logged at that speed (100 rpm bins), or a smooth lower envelope
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
            v.sort_by(f64::total_cmp);
            (b, v[(v.len() - 1) / 5])
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

/// Share of the running samples the lower envelope passes through.
const ENVELOPE_SHARE: f64 = 0.25;

/// A smooth lower envelope of power against speed, kW:
/// `c0 + c1 n/n_max + c2 (n/n_max)^2` on running rows (the air-cutting
/// power of bearings and motor, n^1 .. n^2 plus an idle draw; 0 at
/// standstill), fitted by least squares trimmed four times to the rows
/// whose residual lies in the lowest [`ENVELOPE_SHARE`] of the previous
/// fit's. `+inf` (no bound) where the fit is not possible.
pub fn air_envelope_kw(speed_rpm: &[f64], power_kw: &[f64]) -> Vec<f64> {
    let top = speed_rpm
        .iter()
        .fold(0.0f64, |a, &n| a.max(n.abs()))
        .max(1.0);
    let q: Vec<f64> = speed_rpm.iter().map(|n| n.abs() / top).collect();
    let curve = |c: &[f64], x: f64| c[0] + c[1] * x + c[2] * x * x;
    let running: Vec<usize> = (0..q.len()).filter(|&k| q[k] > 0.0).collect();
    let keep = ((ENVELOPE_SHARE * running.len() as f64).ceil() as usize).max(3);
    let mut rows = running.clone();
    let mut coef: Option<Vec<f64>> = None;
    for _ in 0..5 {
        let cols = vec![
            vec![1.0; rows.len()],
            rows.iter().map(|&k| q[k]).collect(),
            rows.iter().map(|&k| q[k] * q[k]).collect(),
        ];
        let y: Vec<f64> = rows.iter().map(|&k| power_kw[k]).collect();
        let Some(f) = crate::num::lsq::fit(&cols, &y, y.len()) else {
            break;
        };
        let mut r: Vec<(f64, usize)> = running
            .iter()
            .map(|&k| (power_kw[k] - curve(&f.coef, q[k]), k))
            .collect();
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
        coef = Some(f.coef);
        if r.len() <= keep {
            break;
        }
        rows = r[..keep].iter().map(|x| x.1).collect();
    }
    q.iter()
        .map(|&x| match &coef {
            Some(c) if x > 0.0 => curve(c, x),
            Some(_) => 0.0,
            None => f64::INFINITY,
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
}
