//! The candidate explanations of a residual, one per effect of the
//! vocabulary (CONTRACT.md section 3) plus the `none` baseline, each a
//! physically shaped linear model over a small grid of nonlinear parameters.
//!
//! Every candidate contains the baseline's regressors (nested models):
//!
//! ```text
//! none:        r(t) = c0 + c1 (t - t0)/1 h + c2 sim(t)                  offset, linear drift, twin gain error
//! ambient:     + g1 F(Ta - Ta(0); tau1) + g2 F(Ta - Ta(0); tau2)         logged ambient_c, tau1 < tau2 in 0.5..8 h
//!              + F(sin w t - 0; tau), F(cos w t - 1; tau), w = 2 pi/24 h  ambient not logged (inferred day cycle)
//! coolant:     + g1 F(Tc - Tc(0); tau1) + g2 F(Tc - Tc(0); tau2)         logged coolant_c, 5 min..2 h
//!              + sin/cos(2 pi t/P), sin/cos(4 pi t/P)                    not logged: P from the residual's 10-120 min peak
//! cutting:     + g1 F(Pcut; tau1) + g2 F(Pcut; tau2)                     Pcut = power_kw - air-cutting power at that speed
//! motor_loss:  + g1 F(w; tau1) + g2 F(w; tau2),  w = [n > 0] max(0, 1 - n/knee)
//! sensor_lag:  + g (F(sim; tau) - sim)  on a temperature channel (r ~ -g tau dsim/dt; g = lagged share);
//!                                 nothing on a displacement (probes do not lag)
//! ```
//!
//! `F(u; tau)` is the first-order response [`lsq::lowpass`] (state 0 for a
//! heat input on a machine starting cold, the first value for boundary
//! temperatures). The linear coefficients come from SVD least squares on the
//! fit part only (rows before the hold-out time); among the grid the variant
//! with the smallest fit-part error wins. Gains are steady-state gains of the
//! channel per unit input (`gain_um_per_k`, `gain_um_per_kw`, ...).

use super::align::{Aligned, Channel};
use super::lsq::{self, LinearFit};
use super::regime;
use super::spectrum;
use serde_json::{json, Map, Value};

/// Time constants of ambient responses, s (0.5 h .. 8 h).
const AMBIENT_TAUS_S: [f64; 5] = [1800.0, 3600.0, 7200.0, 14400.0, 28800.0];
/// Time constants of coolant responses, s (the jacket and motor are fast).
const COOLANT_TAUS_S: [f64; 5] = [300.0, 900.0, 1800.0, 3600.0, 7200.0];
/// Time constants of responses to extra heat, s (twin: 0.6 h dz 63 % time,
/// slowest node 1.9 h).
const HEAT_TAUS_S: [f64; 5] = [600.0, 1800.0, 3600.0, 7200.0, 14400.0];
/// Sensor lags tried, s.
const LAG_TAUS_S: [f64; 8] = [60.0, 120.0, 300.0, 600.0, 900.0, 1200.0, 1800.0, 3600.0];
/// Knee speeds of the low-speed loss weight, rpm.
const KNEES_RPM: [f64; 5] = [2000.0, 3000.0, 4000.0, 6000.0, 8000.0];
/// A logged boundary temperature moving less than this (peak to peak) is
/// treated as constant, K.
const MIN_SWING_K: f64 = 0.1;
/// Cutting needs at least this much power beyond air cutting somewhere, kW.
const MIN_CUT_KW: f64 = 0.1;
/// Day period of the inferred ambient, s.
const DAY_S: f64 = 86_400.0;

/// Names of the candidates, in CONTRACT order.
pub const NAMES: [&str; 5] = ["ambient", "coolant", "cutting", "motor_loss", "sensor_lag"];

/// The problem a candidate is fitted to.
pub struct Problem<'a> {
    /// Aligned runs.
    pub al: &'a Aligned,
    /// Channel whose residual is explained.
    pub ch: &'a Channel,
    /// Rows `0..n_fit` are the fit part, the rest the hold-out.
    pub n_fit: usize,
}

/// One grid point: the extra regressors and what they mean.
#[derive(Debug, Clone)]
struct Variant {
    extra: Vec<Vec<f64>>,
    /// Nonlinear parameters of this grid point.
    fixed: Vec<(String, f64)>,
    /// Name of each extra regressor's coefficient.
    gains: Vec<String>,
    /// Time constant of each extra regressor, if it is a response.
    taus: Vec<f64>,
    /// Name of the sum of the gains (the steady-state gain), if meaningful.
    total: Option<String>,
    /// Required sign of that sum, if physics fixes it (extra heat moves a
    /// channel the way the machine's own heat does).
    sign: Option<f64>,
}

/// A fitted candidate, scored on the hold-out part.
#[derive(Debug, Clone)]
pub struct Scored {
    /// Vocabulary name (or `none`).
    pub name: String,
    /// Rms of the residual on the hold-out rows.
    pub rms_before: f64,
    /// Rms after subtracting the candidate's prediction there.
    pub rms_after: f64,
    /// `100 (1 - after / before)`.
    pub shrink_pct: f64,
    /// Rms of what is left on the fit rows.
    pub fit_rms: f64,
    /// Parameters (nonlinear ones and gains).
    pub params: Map<String, Value>,
    /// Which model form was used.
    pub model: String,
    /// Prediction on every row.
    pub pred: Vec<f64>,
}

impl Scored {
    /// The CONTRACT's effect object (plus `model`, `fit_rms`).
    pub fn to_json(&self) -> Value {
        json!({
            "name": self.name,
            "rms_before": round(self.rms_before),
            "rms_after": round(self.rms_after),
            "shrink_pct": round(self.shrink_pct),
            "params": self.params,
            "model": self.model,
            "fit_rms": round(self.fit_rms),
        })
    }
}

/// Rounds to 4 significant-ish decimals for output.
pub fn round(v: f64) -> f64 {
    if v.abs() >= 1000.0 {
        v.round()
    } else {
        (v * 1e4).round() / 1e4
    }
}

fn baseline(p: &Problem) -> Vec<Vec<f64>> {
    let t0 = p.al.t_s[0];
    vec![
        vec![1.0; p.al.t_s.len()],
        p.al.t_s.iter().map(|t| (t - t0) / 3600.0).collect(),
        p.ch.sim.clone(),
    ]
}

fn swing(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    hi - lo
}

/// Two-time-constant response variants of input `u` (`y0` initial state).
fn response_pairs(
    p: &Problem,
    u: &[f64],
    y0: f64,
    taus: &[f64],
    in_unit: &str,
    extra_fixed: &[(String, f64)],
) -> Vec<Variant> {
    let unit = p.ch.unit();
    let f: Vec<Vec<f64>> = taus
        .iter()
        .map(|&tau| lsq::lowpass(&p.al.t_s, u, tau, y0))
        .collect();
    let mut out = Vec::new();
    for i in 0..taus.len() {
        for j in i + 1..taus.len() {
            let mut fixed = vec![
                ("tau1_s".to_string(), taus[i]),
                ("tau2_s".to_string(), taus[j]),
            ];
            fixed.extend_from_slice(extra_fixed);
            out.push(Variant {
                extra: vec![f[i].clone(), f[j].clone()],
                fixed,
                gains: vec![
                    format!("gain1_{unit}_per_{in_unit}"),
                    format!("gain2_{unit}_per_{in_unit}"),
                ],
                taus: vec![taus[i], taus[j]],
                total: Some(format!("gain_{unit}_per_{in_unit}")),
                sign: None,
            });
        }
    }
    out
}

/// Which way extra heat moves the channel: the sign of the simulated
/// channel's mean change from its first value (dz < 0 and T > 0 on a
/// warming spindle).
fn heat_sign(p: &Problem) -> Option<f64> {
    let s0 = p.ch.sim[0];
    let m = p.ch.sim.iter().map(|v| v - s0).sum::<f64>() / p.ch.sim.len() as f64;
    (m.abs() > 0.0).then(|| m.signum())
}

fn with_sign(mut v: Vec<Variant>, sign: Option<f64>) -> Vec<Variant> {
    for x in &mut v {
        x.sign = sign;
    }
    v
}

/// The grid of variants of one candidate, and the model form's description.
fn variants(name: &str, p: &Problem, base_pred: &[f64]) -> (Vec<Variant>, String) {
    let al = p.al;
    let t = &al.t_s;
    let t0 = t[0];
    let unit = p.ch.unit();
    match name {
        "ambient" => match al.ambient_c.as_deref().filter(|a| swing(a) >= MIN_SWING_K) {
            Some(a) => {
                let u: Vec<f64> = a.iter().map(|v| v - a[0]).collect();
                (
                    response_pairs(p, &u, 0.0, &AMBIENT_TAUS_S, "k", &[]),
                    "first-order responses to logged ambient_c - first value".into(),
                )
            }
            None => {
                let w = std::f64::consts::TAU / DAY_S;
                let s: Vec<f64> = t.iter().map(|t| (w * (t - t0)).sin()).collect();
                let c: Vec<f64> = t.iter().map(|t| (w * (t - t0)).cos() - 1.0).collect();
                let v = AMBIENT_TAUS_S
                    .iter()
                    .map(|&tau| Variant {
                        extra: vec![lsq::lowpass(t, &s, tau, 0.0), lsq::lowpass(t, &c, tau, 0.0)],
                        fixed: vec![("tau_s".into(), tau), ("period_s".into(), DAY_S)],
                        gains: vec![format!("sin_{unit}"), format!("cos_{unit}")],
                        taus: vec![],
                        total: None,
                        sign: None,
                    })
                    .collect();
                (v, "ambient_c not logged: first-order response to an inferred 24 h cycle (+ the baseline's drift)".into())
            }
        },
        "coolant" => match al.coolant_c.as_deref().filter(|c| swing(c) >= MIN_SWING_K) {
            Some(c) => {
                let u: Vec<f64> = c.iter().map(|v| v - c[0]).collect();
                (
                    response_pairs(p, &u, 0.0, &COOLANT_TAUS_S, "k", &[]),
                    "first-order responses to logged coolant_c - first value".into(),
                )
            }
            None => {
                let fit_t = &t[..p.n_fit];
                let r: Vec<f64> = (0..p.n_fit).map(|k| p.ch.resid[k] - base_pred[k]).collect();
                let Some(p0) = spectrum::peak_period_s(fit_t, &r, 600.0, 7200.0) else {
                    return (
                        Vec::new(),
                        "coolant_c not logged and no 10-120 min peak".into(),
                    );
                };
                let v = (-6..=6)
                    .map(|k| {
                        let period = p0 * (1.0 + 0.01 * k as f64);
                        let w = std::f64::consts::TAU / period;
                        let h = |m: f64, f: fn(f64) -> f64| -> Vec<f64> {
                            t.iter().map(|t| f(m * w * (t - t0))).collect()
                        };
                        Variant {
                            extra: vec![
                                h(1.0, f64::sin),
                                h(1.0, f64::cos),
                                h(2.0, f64::sin),
                                h(2.0, f64::cos),
                            ],
                            fixed: vec![("period_s".into(), period)],
                            gains: vec![
                                format!("sin1_{unit}"),
                                format!("cos1_{unit}"),
                                format!("sin2_{unit}"),
                                format!("cos2_{unit}"),
                            ],
                            taus: vec![],
                            total: None,
                            sign: None,
                        }
                    })
                    .collect();
                (v, "coolant_c not logged: harmonic regression (2 harmonics) at the residual's 10-120 min spectral peak".into())
            }
        },
        "cutting" => match al.power_kw.as_deref() {
            Some(pw) => {
                let u = regime::cutting_excess_kw(&al.speed_rpm, pw);
                if u.iter().fold(0.0f64, |a, &v| a.max(v)) < MIN_CUT_KW {
                    return (Vec::new(), "no power beyond air cutting in power_kw".into());
                }
                (
                    with_sign(response_pairs(p, &u, 0.0, &HEAT_TAUS_S, "kw", &[]), heat_sign(p)),
                    "first-order responses to power_kw beyond air cutting (gain of the sign of the twin's own heating)".into(),
                )
            }
            None => (Vec::new(), "power_kw not logged".into()),
        },
        "motor_loss" => {
            let mut v = Vec::new();
            for knee in KNEES_RPM {
                let u: Vec<f64> = al
                    .speed_rpm
                    .iter()
                    .map(|&n| {
                        if n > 0.0 {
                            (1.0 - n / knee).max(0.0)
                        } else {
                            0.0
                        }
                    })
                    .collect();
                if u[..p.n_fit].iter().all(|&x| x == 0.0) {
                    continue;
                }
                v.extend(with_sign(
                    response_pairs(
                        p,
                        &u,
                        0.0,
                        &HEAT_TAUS_S,
                        "weight",
                        &[("knee_rpm".into(), knee)],
                    ),
                    heat_sign(p),
                ));
            }
            let d = if v.is_empty() {
                "the spindle never runs below 8000 rpm in the fit part".into()
            } else {
                "first-order responses to the low-speed weight [n>0] max(0, 1 - n/knee) (gain of the sign of the twin's own heating)".into()
            };
            (v, d)
        }
        "sensor_lag" => {
            if !crate::runfile::is_temperature_column(&p.ch.name) {
                return (
                    Vec::new(),
                    "not a temperature channel: probes and displacements do not lag, no signature"
                        .into(),
                );
            }
            // The lag's own signature F(sim) - sim rather than F(sim): the
            // same column space (sim is a baseline regressor), so the same
            // fit, but the gain is the lagged share (1 for a sensor that
            // lags entirely) and the regressor alone is the effect.
            let v = LAG_TAUS_S
                .iter()
                .map(|&tau| Variant {
                    extra: vec![lsq::lowpass(t, &p.ch.sim, tau, p.ch.sim[0])
                        .iter()
                        .zip(&p.ch.sim)
                        .map(|(f, s)| f - s)
                        .collect()],
                    fixed: vec![("tau_s".into(), tau)],
                    gains: vec!["gain".into()],
                    taus: vec![],
                    total: None,
                    sign: None,
                })
                .collect();
            (
                v,
                "lagged simulated temperature: r ~ g (F(sim; tau) - sim) ~ -g tau dsim/dt".into(),
            )
        }
        _ => (Vec::new(), "offset + linear drift + twin gain".into()),
    }
}

/// Fits each variant on top of `base` and keeps the best on the fit part.
fn best(
    base: &[Vec<f64>],
    vars: Vec<Variant>,
    y: &[f64],
    n_fit: usize,
) -> Option<(LinearFit, Variant, Vec<Vec<f64>>)> {
    vars.into_iter()
        .filter_map(|v| {
            let mut cols = base.to_vec();
            cols.extend(v.extra.iter().cloned());
            let f = lsq::fit(&cols, y, n_fit)?;
            let total: f64 = f.coef[cols.len() - v.extra.len()..].iter().sum();
            if v.sign.is_some_and(|s| s * total <= 0.0) {
                return None;
            }
            Some((f, v, cols))
        })
        .min_by(|a, b| a.0.sse_fit.total_cmp(&b.0.sse_fit))
}

fn score(
    name: &str,
    p: &Problem,
    f: &LinearFit,
    model: String,
    params: Map<String, Value>,
) -> Scored {
    let r = &p.ch.resid;
    let n_fit = p.n_fit;
    let hold: Vec<f64> = r[n_fit..].to_vec();
    let after: Vec<f64> = (n_fit..r.len()).map(|k| r[k] - f.pred[k]).collect();
    let rms_before = lsq::rms(&hold);
    let rms_after = lsq::rms(&after);
    Scored {
        name: name.to_string(),
        rms_before,
        rms_after,
        shrink_pct: if rms_before > 0.0 {
            100.0 * (1.0 - rms_after / rms_before)
        } else {
            0.0
        },
        fit_rms: (f.sse_fit / n_fit.max(1) as f64).sqrt(),
        params,
        model,
        pred: f.pred.clone(),
    }
}

fn params_of(v: &Variant, coef: &[f64], n_base: usize) -> Map<String, Value> {
    let mut m = Map::new();
    let g = &coef[n_base..(n_base + v.gains.len()).min(coef.len())];
    for (k, val) in &v.fixed {
        m.insert(k.clone(), json!(round(*val)));
    }
    for (k, val) in v.gains.iter().zip(g) {
        m.insert(k.clone(), json!(round(*val)));
    }
    if let Some(total) = &v.total {
        m.insert(total.clone(), json!(round(g.iter().sum::<f64>())));
    }
    if !v.taus.is_empty() {
        let (i, _) = g.iter().enumerate().fold((0, -1.0), |(bi, bv), (i, &c)| {
            if c.abs() > bv {
                (i, c.abs())
            } else {
                (bi, bv)
            }
        });
        m.insert("tau_s".into(), json!(v.taus[i]));
    }
    m
}

/// Fits and scores the baseline and every candidate on `p`'s channel.
/// A candidate without a usable input falls back to the baseline (and says
/// so in `model`).
pub fn fit_all(p: &Problem) -> Vec<Scored> {
    let base = baseline(p);
    let y = &p.ch.resid;
    let Some(bf) = lsq::fit(&base, y, p.n_fit) else {
        return Vec::new();
    };
    let mut out = vec![score(
        "none",
        p,
        &bf,
        "offset + linear drift + twin gain (baseline; every candidate adds to it)".into(),
        Map::from_iter([
            ("offset".to_string(), json!(round(bf.coef[0]))),
            (
                format!("drift_{}_per_h", p.ch.unit()),
                json!(round(bf.coef[1])),
            ),
            ("twin_gain".to_string(), json!(round(bf.coef[2]))),
        ]),
    )];
    for name in NAMES {
        let (vars, model) = variants(name, p, &bf.pred);
        let s = match best(&base, vars, y, p.n_fit) {
            Some((f, v, _)) => {
                let params = params_of(&v, &f.coef, base.len());
                score(name, p, &f, model, params)
            }
            None => score(name, p, &bf, format!("{model} (baseline only)"), Map::new()),
        };
        out.push(s);
    }
    out
}

/// Grid points kept per candidate for the pair search.
const PAIR_GRID: usize = 8;

/// The `PAIR_GRID` variants with the smallest fit-part error on their own
/// (sign rule applied), best first.
fn top_variants(base: &[Vec<f64>], vars: Vec<Variant>, y: &[f64], n_fit: usize) -> Vec<Variant> {
    let mut scored: Vec<(f64, Variant)> = vars
        .into_iter()
        .filter_map(|v| {
            let (f, v, _) = best(base, vec![v], y, n_fit)?;
            Some((f.sse_fit, v))
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    scored.into_iter().take(PAIR_GRID).map(|x| x.1).collect()
}

/// The best joint model of two effects: for each pair, coordinate descent
/// over the two grids, each cut to its 8 best variants on their own (start
/// from the second's best, then best first-given-second, best
/// second-given-first, twice). Returns the
/// joint fit (named `a+b`) with its members ordered by importance: the one
/// whose removal from the joint prediction raises the held-out rms more
/// comes first.
pub fn best_pair(p: &Problem) -> Option<(Scored, String, String)> {
    let base = baseline(p);
    let y = &p.ch.resid;
    let bf = lsq::fit(&base, y, p.n_fit)?;
    let grids: Vec<(&str, Vec<Variant>, String)> = NAMES
        .iter()
        .map(|&n| {
            let (v, m) = variants(n, p, &bf.pred);
            (n, v, m)
        })
        .filter(|g| !g.1.is_empty())
        .map(|(n, v, m)| (n, top_variants(&base, v, y, p.n_fit), m))
        .filter(|g| !g.1.is_empty())
        .collect();
    let with = |extra: &Variant| -> Vec<Vec<f64>> {
        let mut c = base.clone();
        c.extend(extra.extra.iter().cloned());
        c
    };
    let mut best_pair: Option<(Scored, String, String)> = None;
    for i in 0..grids.len() {
        for j in i + 1..grids.len() {
            let (na, va, ma) = &grids[i];
            let (nb, vb, mb) = &grids[j];
            let mut sel_b = vb[0].clone();
            let mut sel_a = None;
            for _ in 0..2 {
                let Some((_, a, _)) = best(&with(&sel_b), va.clone(), y, p.n_fit) else {
                    break;
                };
                let Some((_, b, _)) = best(&with(&a), vb.clone(), y, p.n_fit) else {
                    break;
                };
                sel_a = Some(a);
                sel_b = b;
            }
            let Some(sel_a) = sel_a else { continue };
            let mut cols = with(&sel_a);
            cols.extend(sel_b.extra.iter().cloned());
            let Some(f) = lsq::fit(&cols, y, p.n_fit) else {
                continue;
            };
            let (ka, kb) = (base.len(), base.len() + sel_a.extra.len());
            let mut params = Map::new();
            for (prefix, v, from) in [(na, &sel_a, ka), (nb, &sel_b, kb)] {
                for (k, val) in params_of(v, &f.coef[from - base.len()..], base.len()) {
                    params.insert(format!("{prefix}.{k}"), val);
                }
            }
            let name = format!("{na}+{nb}");
            let s = score(&name, p, &f, format!("{ma}; {mb}"), params);
            // Importance: held-out rms without each member's part.
            let without = |from: usize, to: usize| -> f64 {
                let left: Vec<f64> = (p.n_fit..y.len())
                    .map(|k| {
                        let part: f64 = (from..to).map(|c| f.coef[c] * cols[c][k]).sum();
                        y[k] - (f.pred[k] - part)
                    })
                    .collect();
                lsq::rms(&left)
            };
            let (wa, wb) = (without(ka, kb), without(kb, cols.len()));
            let (first, second) = if wa >= wb { (na, nb) } else { (nb, na) };
            if best_pair
                .as_ref()
                .is_none_or(|b| s.rms_after < b.0.rms_after)
            {
                best_pair = Some((s, first.to_string(), second.to_string()));
            }
        }
    }
    best_pair
}

/// An effect's part of one channel (see [`effect_part`]).
#[derive(Debug, Clone)]
pub struct EffectPart {
    /// The effect's regressors times their coefficients, every row.
    pub values: Vec<f64>,
    /// Fit-part rms left by the baseline alone.
    pub fit_rms_base: f64,
    /// Fit-part rms left by the baseline and the effect.
    pub fit_rms_with: f64,
}

/// What candidate `name` adds to `p`'s channel: its own regressors times
/// their coefficients, fitted with the baseline on the fit rows only
/// exactly as [`fit_all`] fits it (the grid point with the smallest
/// fit-part error); the baseline's offset, drift and twin gain are left
/// out (they are the twin's mismatch, not the effect). `None` when the
/// candidate has no usable input on this channel (e.g. `sensor_lag` on a
/// displacement) or a fit fails.
pub fn effect_part(name: &str, p: &Problem) -> Option<EffectPart> {
    let base = baseline(p);
    let y = &p.ch.resid;
    let bf = lsq::fit(&base, y, p.n_fit)?;
    let (vars, _) = variants(name, p, &bf.pred);
    let (f, _, cols) = best(&base, vars, y, p.n_fit)?;
    let n_base = base.len();
    let n_fit = p.n_fit.max(1) as f64;
    Some(EffectPart {
        values: (0..y.len())
            .map(|k| (n_base..cols.len()).map(|j| f.coef[j] * cols[j][k]).sum())
            .collect(),
        fit_rms_base: (bf.sse_fit / n_fit).sqrt(),
        fit_rms_with: (f.sse_fit / n_fit).sqrt(),
    })
}
