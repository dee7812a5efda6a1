//! The `none` baseline: what a slightly wrong twin leaves in a channel's
//! residual, so that an effect has to beat the twin's mismatch, not just an
//! offset and a drift.
//!
//! A twin whose parameters are a few % off (heat capacities, losses,
//! conductances, an expansion coefficient) leaves, to first order, a
//! residual in the span of the sensitivities of the simulated channel `s`
//! to those parameters:
//!
//! ```text
//! r(t) ~ c0 + c1 (t - t0)/1 h                      offset, drift (sensor offset, slow room change)
//!      + c2 s(t)                                   gain error of the whole channel
//!      + c3 (F(s; tau_c) - s)                      time-constant error: for y = F(u; tau),
//!                                                  dy/dtau = (F(y; tau) - y) / tau
//!      + c4 F(q1; tau_c) + c5 F(q2; tau_c)          gain errors per heat source, q1 = n/n_max,
//!                                                  q2 = (n/n_max)^2 (heat laws n^1 .. n^2)
//! ```
//!
//! `tau_c` is the channel's own time constant, estimated from the sim alone
//! (the time constant whose responses to `q1`, `q2` fit `s` best over the
//! whole run: the sim is driven by logged inputs only, so using its
//! held-out part leaks nothing of the real run). The twin's response to each
//! heat source separately is not in the files, hence the speed shapes
//! through the channel's own first-order response.
//!
//! The effects' own regressors are shapes this span cannot produce: a logged
//! boundary temperature, power beyond air cutting, the low-speed weight with
//! its knee and its jump at standstill, a periodic chiller component, a lag
//! of a temperature sensor much faster than its part.

use super::align::{Aligned, Channel, Col};
use crate::num::{batch, lsq};

/// Time constants tried for a channel's own response, s (5 min .. 6 h: the
/// twin's fastest sensor sites to its structure's 1.9 h and beyond).
const CHANNEL_TAUS_S: [f64; 10] = [
    300.0, 600.0, 1200.0, 1800.0, 3600.0, 5400.0, 7200.0, 10_800.0, 14_400.0, 21_600.0,
];

/// Prior size of every mismatch term: a 10 % twin error (gain, time
/// constant, each heat source's gain; the drift over the whole run as 10 %
/// of the channel's simulated swing).
pub const PRIOR_REL: f64 = 0.1;
/// Strength of the prior: a mismatch coefficient one prior size away from
/// 0 costs as much as this share of the residual's fit-part energy (so a
/// 30 % gain error must explain 9 times that). Chosen on the development
/// benchmarks (docs/diagnose.md, "Thresholds"): 0.03 / 0.1 / 0.3 / 1 gave
/// 197 (1 false alarm) / 194 / 197 / 191 (1) of 240 zoo cases and 215 /
/// 212 / 212 / 211 of 216 twin cases.
pub const PRIOR_STRENGTH: f64 = 0.3;

/// The baseline's regressors on one channel.
#[derive(Debug, Clone)]
pub struct Baseline {
    /// Regressors, every row.
    pub cols: Vec<Col>,
    /// Name of each regressor's coefficient (for `params`).
    pub names: Vec<String>,
    /// Prior standard deviation of each coefficient (`None`: free).
    pub prior_sd: Vec<Option<f64>>,
    /// The channel's own time constant, s.
    pub tau_c_s: f64,
}

impl Baseline {
    /// The regressors as slices (for the least-squares solvers).
    pub fn slices(&self) -> Vec<&[f64]> {
        self.cols.iter().map(|c| c.as_slice()).collect()
    }

    /// Ridge penalties of the baseline's columns for explaining `y` on
    /// `rows`: `PRIOR_STRENGTH n var(y) / sd^2` (0 for free ones).
    pub fn penalties(&self, y: &[f64], rows: std::ops::Range<usize>) -> Vec<f64> {
        let part = &y[rows];
        let m = part.iter().sum::<f64>() / part.len().max(1) as f64;
        let energy: f64 = part.iter().map(|v| (v - m).powi(2)).sum();
        self.prior_sd
            .iter()
            .map(|sd| match sd {
                Some(sd) if *sd > 0.0 => PRIOR_STRENGTH * energy / (sd * sd),
                _ => 0.0,
            })
            .collect()
    }
}

/// Rms of `x` about its mean (0 for an empty slice), in one pass after
/// the mean's (the deviations summed as [`lsq::rms`] sums them, never
/// stored).
fn spread(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt()
}

/// The speed shapes of the heat sources: `n/n_max` and `(n/n_max)^2`.
pub fn heat_shapes(al: &Aligned) -> [Vec<f64>; 2] {
    let top = al
        .speed_rpm
        .iter()
        .fold(0.0f64, |a, &n| a.max(n.abs()))
        .max(1.0);
    let q1: Vec<f64> = al.speed_rpm.iter().map(|n| n.abs() / top).collect();
    let q2 = q1.iter().map(|q| q * q).collect();
    [q1, q2]
}

/// The channel's own time constant: the grid value whose first-order
/// responses to the heat shapes (state 0: a machine starting cold) fit the
/// simulated channel best over the whole run.
pub fn channel_tau_s(t_s: &[f64], sim: &[f64], shapes: &[Vec<f64>; 2]) -> f64 {
    let n = sim.len();
    let mut best = (f64::INFINITY, CHANNEL_TAUS_S[4]);
    let one = vec![1.0; n];
    for tau in CHANNEL_TAUS_S {
        let ab = lsq::lowpass_each(t_s, &[(&shapes[0], tau, 0.0), (&shapes[1], tau, 0.0)]);
        let cols = [&one[..], &ab[0], &ab[1]];
        if let Some(f) = batch::solve_streamed(&cols, sim, None, 0..n, &[]) {
            if f.sse_fit < best.0 {
                best = (f.sse_fit, tau);
            }
        }
    }
    best.1
}

/// A load shape: its response, its coefficient's name, and whether it is an
/// input of its own (not a function of speed).
type Load = (Col, String, bool);

/// Knee of the low-speed loss shape in the baseline, share of the top
/// speed (the middle of the motor-loss candidate's knees).
const BASE_KNEE_SHARE: f64 = 0.35;

/// The heat sources the twin may model besides speed: power beyond air
/// cutting (if logged) and a low-speed motor loss, each with its name and
/// whether it is an input of its own (cutting power) rather than a
/// function of speed. Their responses at the channel's time constant are
/// made with the baseline's others ([`mismatch_baseline`]).
fn load_inputs(al: &Aligned, unit: &str) -> Vec<(Vec<f64>, String, bool)> {
    let mut out = Vec::new();
    if let Some(pw) = al.power_kw.as_deref() {
        let cut = super::regime::cutting_excess_kw(&al.speed_rpm, pw);
        out.push((cut, format!("cut_gain_{unit}_per_kw"), true));
    }
    let top = al.speed_rpm.iter().fold(0.0f64, |a, &n| a.max(n.abs()));
    let w = super::regime::low_speed_weight(&al.speed_rpm, BASE_KNEE_SHARE * top);
    out.push((w, format!("low_speed_gain_{unit}"), false));
    out
}

/// Prior sizes of the load shapes' gains: [`PRIOR_REL`] times the twin's
/// own gain on each (the sim regressed on the speed and load shapes over
/// the whole run), plus, as far as that gain is not identifiable, a term
/// worth [`PRIOR_REL`] of the sim's spread (as for the speed shapes). A
/// twin without cutting heat or low-speed losses has gains near 0 there,
/// so its baseline cannot take them up; one that models them may be 10 %
/// off. Not identifiable: when a load moves with the speed (a part program
/// that always cuts at its speeds) its response is nearly a combination of
/// the speed responses, and the regression splits the twin's heat between
/// them at will (on a zoo run that always cuts, the gain of a bearing
/// sensor on cutting power came out 0.007 K/kW at the channel's time
/// constant and 0.5-2 K/kW at the next ones); the share of the load
/// response those explain (R^2) then weighs in the spread-sized prior.
/// Only for a load that is an input of its own: the low-speed weight is a
/// function of speed by construction, always nearly spanned by the speed
/// shapes, and its gain is what the twin says (widening its prior took up
/// the motor-loss effects: 37 -> 27 of 50 found on the development seed).
fn load_priors(sim: &[f64], speed: &[Col; 2], loads: &[Load], swing: f64) -> Vec<f64> {
    let n = sim.len();
    let one = vec![1.0; n];
    let mut cols: Vec<&[f64]> = vec![&one, &speed[0], &speed[1]];
    cols.extend(loads.iter().map(|l| l.0.as_slice()));
    let coef = batch::solve_streamed(&cols, sim, None, 0..n, &[])
        .map_or_else(|| vec![0.0; cols.len()], |f| f.coef);
    (3..cols.len())
        .map(|j| {
            let others: Vec<&[f64]> = (0..cols.len())
                .filter(|&i| i != j)
                .map(|i| cols[i])
                .collect();
            let sst = spread(cols[j]).powi(2) * n as f64;
            let r2 = batch::solve_streamed(&others, cols[j], None, 0..n, &[])
                .map_or(0.0, |f| (1.0 - f.sse_fit / sst.max(1e-300)).clamp(0.0, 1.0));
            let own_input = loads[j - 3].2;
            let unidentified = if own_input {
                r2 * swing / spread(cols[j]).max(1e-12)
            } else {
                0.0
            };
            (PRIOR_REL * (coef[j].abs() + unidentified)).max(1e-12)
        })
        .collect()
}

/// The mismatch baseline of channel `ch` (see the module docs). Its time
/// constant and load priors come from fits over the whole run and depend
/// on the channel only: they are computed once per channel
/// ([`super::align::Memo`]), the columns again each time (a few
/// first-order filters).
pub fn mismatch_baseline(al: &Aligned, ch: &Channel) -> Baseline {
    let t = &al.t_s;
    let t0 = t[0];
    let unit = ch.unit();
    let shapes = heat_shapes(al);
    let tau_c = al.memo.get_or(&format!("tau_c {}", ch.name), || {
        vec![channel_tau_s(t, &ch.sim, &shapes)]
    })[0];
    // The lagged sim, the speed shapes' and the loads' responses at the
    // channel's time constant, in one pass over the rows.
    let inputs = load_inputs(al, unit);
    let mut todo = vec![
        (&ch.sim[..], tau_c, ch.sim[0]),
        (&shapes[0][..], tau_c, 0.0),
        (&shapes[1][..], tau_c, 0.0),
    ];
    todo.extend(inputs.iter().map(|l| (&l.0[..], tau_c, 0.0)));
    let mut made = lsq::lowpass_each(t, &todo).into_iter().map(Col::new);
    let mut next = || made.next().unwrap_or_default();
    let tc_error: Vec<f64> = next()
        .iter()
        .zip(ch.sim.iter())
        .map(|(f, s)| f - s)
        .collect();
    let speed = [next(), next()];
    let loads: Vec<Load> = inputs
        .iter()
        .map(|(_, name, own)| (next(), name.clone(), *own))
        .collect();
    drop(inputs);
    let swing = spread(&ch.sim);
    let span_h = ((t[t.len() - 1] - t0) / 3600.0).max(1e-9);
    let per_shape = |f: &[f64]| (PRIOR_REL * swing / spread(f).max(1e-12)).max(1e-12);
    let mut prior_sd = vec![
        None,
        Some((PRIOR_REL * swing / span_h).max(1e-12)),
        Some(PRIOR_REL),
        Some(PRIOR_REL),
        Some(per_shape(&speed[0])),
        Some(per_shape(&speed[1])),
    ];
    let load_sd = al.memo.get_or(&format!("load priors {}", ch.name), || {
        load_priors(&ch.sim, &speed, &loads, swing)
    });
    prior_sd.extend(load_sd.into_iter().map(Some));
    let mut names = vec![
        "offset".into(),
        format!("drift_{unit}_per_h"),
        "twin_gain".into(),
        "twin_tau_error".into(),
        format!("speed_gain_{unit}"),
        format!("speed2_gain_{unit}"),
    ];
    names.extend(loads.iter().map(|l| l.1.clone()));
    let [f1, f2] = speed;
    let mut cols = vec![
        Col::new(vec![1.0; t.len()]),
        Col::new(t.iter().map(|t| (t - t0) / 3600.0).collect()),
        ch.sim.clone(),
        Col::new(tc_error),
        f1,
        f2,
    ];
    cols.extend(loads.into_iter().map(|l| l.0));
    Baseline {
        cols,
        names,
        prior_sd,
        tau_c_s: tau_c,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_channel_time_constant_of_a_first_order_response_is_found() {
        let t: Vec<f64> = (0..2000).map(|k| 60.0 * k as f64).collect();
        let q: Vec<f64> = (0..2000).map(|k| ((k / 200) % 3) as f64 / 2.0).collect();
        let q2: Vec<f64> = q.iter().map(|v| v * v).collect();
        let s = lsq::lowpass(&t, &q, 3600.0, 0.0);
        assert_eq!(channel_tau_s(&t, &s, &[q, q2]), 3600.0);
    }
}
