//! The grids of the effect candidates: for each effect of the vocabulary,
//! the regressors it adds to the baseline at each point of a small grid of
//! nonlinear parameters (time constants, knees, periods, sources).
//!
//! ```text
//! ambient:     F(Ta - Ta(0); tau1), F(Ta - Ta(0); tau2)            logged ambient_c, 0.5..8 h
//!              F(sin w t; tau), F(cos w t - 1; tau), w = 2 pi/24 h  not logged (inferred day cycle)
//! coolant:     x, F(x; tau)  (or F(x; tau1), F(x; tau2))            x = logged coolant_c, high-passed (> 2 h removed)
//!              x = band-passed (5-120 min) residual of the         not logged: a temperature channel that
//!                  temperature channel carrying a chiller cycle     follows the chiller, period and phase tracked
//!              sin/cos(2 pi t/P), sin/cos(4 pi t/P)                 no such channel: P from the residual's peak
//! cutting:     F(Pcut; tau1), F(Pcut; tau2)                         Pcut = power_kw beyond air cutting
//! motor_loss:  F(w; tau1), F(w; tau2), w = [n > 0] max(0, 1 - n/knee)
//! sensor_lag:  F(sim; tau) - sim   on a temperature channel only
//! ```

use super::align::Aligned;
use super::align::Col;
use super::baseline;
use super::chiller::CHILLER_BAND_S;
use super::problem::Problem;
use super::regime;
use super::spectrum;
use crate::num::{batch, lsq};

/// Time constants of ambient responses, s (0.5 h .. 8 h).
const AMBIENT_TAUS_S: [f64; 5] = [1800.0, 3600.0, 7200.0, 14400.0, 28800.0];
/// Time constants of the responses to a coolant signal, s; 0 is the signal
/// itself (the jacket and motor follow the supply within minutes).
const COOLANT_TAUS_S: [f64; 6] = [0.0, 300.0, 900.0, 1800.0, 3600.0, 7200.0];
/// Time constants of responses to extra heat, s (twin: 0.6 h dz 63 % time,
/// slowest node 1.9 h).
const HEAT_TAUS_S: [f64; 5] = [600.0, 1800.0, 3600.0, 7200.0, 14400.0];
/// Sensor lags tried, s.
const LAG_TAUS_S: [f64; 8] = [60.0, 120.0, 300.0, 600.0, 900.0, 1200.0, 1800.0, 3600.0];
/// Knee speeds of the low-speed loss weight, shares of the top speed
/// logged (the twin's knee is 4000 of 12 000 rpm; asynchronous motors lose
/// efficiency below a quarter to a half of their rated speed).
const KNEE_SHARES: [f64; 5] = [0.15, 0.25, 0.35, 0.5, 0.7];
/// A logged ambient moving less than this (peak to peak) is treated as
/// constant, K.
const MIN_SWING_K: f64 = 0.1;
/// Cutting needs at least this much power beyond air cutting somewhere, kW.
const MIN_CUT_KW: f64 = 0.1;
/// Day period of the inferred ambient, s.
const DAY_S: f64 = 86_400.0;
/// A channel carries a chiller cycle when its band-passed
/// residual (after its own mismatch baseline) has at least this many times
/// the rms that white noise of the channel's level leaves in the band
/// (0.45 sigma at 60 s).
pub const MIN_TRACK_SNR: f64 = 3.0;
/// Channels tried as chiller trackers (the strongest first).
const MAX_TRACK_SOURCES: usize = 2;

/// One grid point: the extra regressors and what they mean.
#[derive(Debug, Clone)]
pub struct Variant {
    /// The regressors added to the baseline, every row (shared between
    /// the grid points that use the same response).
    pub extra: Vec<Col>,
    /// Nonlinear parameters of this grid point.
    pub fixed: Vec<(String, f64)>,
    /// Named text parameters (e.g. the tracked channel).
    pub labels: Vec<(String, String)>,
    /// Name of each extra regressor's coefficient.
    pub gains: Vec<String>,
    /// Time constant of each extra regressor, if it is a response.
    pub taus: Vec<f64>,
    /// Name of the sum of the gains (the steady-state gain), if meaningful.
    pub total: Option<String>,
    /// Required sign of that sum, if physics fixes it (extra heat moves a
    /// channel the way the machine's own heat does).
    pub sign: Option<f64>,
    /// A part of the prediction with a gain fixed by physics (1), every
    /// row: the baseline is fitted to what it leaves.
    pub fixed_part: Option<Vec<f64>>,
}

impl Variant {
    /// A variant with regressors `extra` and gains named `gains`, nothing
    /// else set.
    fn plain(extra: Vec<Col>, gains: Vec<String>, fixed: Vec<(String, f64)>) -> Self {
        Variant {
            extra,
            fixed,
            labels: Vec::new(),
            gains,
            taus: Vec::new(),
            total: None,
            sign: None,
            fixed_part: None,
        }
    }
}

/// A grid of variants, made one at a time as it is walked (each grid
/// point's columns exist only while it is looked at, or shared with its
/// neighbours).
pub type Vars<'a> = Box<dyn Iterator<Item = Variant> + 'a>;

/// Peak-to-peak range of `x`.
fn swing(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    hi - lo
}

/// First-order responses of `u` at each of `taus`, or `u` itself for a
/// `tau_s` of 0 (all of them in one pass: [`lsq::lowpass_each`]).
fn responses(t: &[f64], u: &Col, taus: &[f64], y0: f64) -> Vec<Col> {
    let lagged: Vec<lsq::Response> = taus
        .iter()
        .filter(|&&tau| tau > 0.0)
        .map(|&tau| (u.as_slice(), tau, y0))
        .collect();
    let mut made = lsq::lowpass_each(t, &lagged).into_iter();
    taus.iter()
        .map(|&tau| {
            if tau > 0.0 {
                Col::new(made.next().unwrap_or_default())
            } else {
                u.clone()
            }
        })
        .collect()
}

/// Two-time-constant response variants of input `u` (`y0` initial state).
/// Each response is computed once and shared by the pairs that use it.
fn response_pairs<'a>(
    p: &Problem,
    u: &Col,
    y0: f64,
    taus: &'static [f64],
    in_unit: &'a str,
    extra_fixed: Vec<(String, f64)>,
) -> Vars<'a> {
    let unit = p.ch.unit();
    let f = responses(&p.al.t_s, u, taus, y0);
    let pairs = (0..taus.len()).flat_map(move |i| (i + 1..taus.len()).map(move |j| (i, j)));
    Box::new(pairs.map(move |(i, j)| {
        let mut fixed = vec![
            ("tau1_s".to_string(), taus[i]),
            ("tau2_s".to_string(), taus[j]),
        ];
        fixed.extend_from_slice(&extra_fixed);
        let mut v = Variant::plain(
            vec![f[i].clone(), f[j].clone()],
            vec![
                format!("gain1_{unit}_per_{in_unit}"),
                format!("gain2_{unit}_per_{in_unit}"),
            ],
            fixed,
        );
        v.taus = vec![taus[i], taus[j]];
        v.total = Some(format!("gain_{unit}_per_{in_unit}"));
        v
    }))
}

/// Which way extra heat moves the channel, where physics fixes it: up on
/// a temperature (in a network of positive conductances every node warms
/// when heat is added anywhere); on a displacement either way (heat at a
/// node whose growth pulls the other way, as a column behind the spindle).
fn heat_sign(p: &Problem) -> Option<f64> {
    crate::data::runfile::is_temperature_column(&p.ch.name).then_some(1.0)
}

fn with_sign(v: Vars<'_>, sign: Option<f64>) -> Vars<'_> {
    Box::new(v.map(move |mut x| {
        x.sign = sign;
        x
    }))
}

/// The grid of variants of candidate `name`, and the model form's
/// description. `base_pred` is the baseline's prediction of the channel's
/// residual (fitted on the fit rows).
pub fn variants<'a>(name: &str, p: &Problem<'a>, base_pred: &[f64]) -> (Vars<'a>, String) {
    match name {
        "ambient" => ambient(p),
        "coolant" => coolant(p, base_pred),
        "cutting" => cutting(p),
        "motor_loss" => motor_loss(p),
        "sensor_lag" => sensor_lag(p),
        _ => (none(), "the mismatch baseline only".into()),
    }
}

/// The empty grid.
fn none<'a>() -> Vars<'a> {
    Box::new(std::iter::empty())
}

/// Ambient: responses to the logged ambient, else an inferred day cycle.
fn ambient<'a>(p: &Problem<'a>) -> (Vars<'a>, String) {
    let al = p.al;
    let t = &al.t_s;
    let t0 = t[0];
    let unit = p.ch.unit();
    if let Some(a) = al.ambient_c.as_deref().filter(|a| swing(a) >= MIN_SWING_K) {
        let u = Col::new(a.iter().map(|v| v - a[0]).collect());
        return (
            response_pairs(p, &u, 0.0, &AMBIENT_TAUS_S, "k", Vec::new()),
            "first-order responses to logged ambient_c - first value".into(),
        );
    }
    let w = std::f64::consts::TAU / DAY_S;
    let s: Vec<f64> = t.iter().map(|t| (w * (t - t0)).sin()).collect();
    let c: Vec<f64> = t.iter().map(|t| (w * (t - t0)).cos() - 1.0).collect();
    let drift: Vec<f64> = t.iter().map(|t| (t - t0) / 3600.0).collect();
    let v = AMBIENT_TAUS_S.iter().map(move |&tau| {
        let inputs = [
            (&s[..], tau, 0.0),
            (&c[..], tau, 0.0),
            (&drift[..], tau, 0.0),
        ];
        Variant::plain(
            lsq::lowpass_each(t, &inputs)
                .into_iter()
                .map(Col::new)
                .collect(),
            vec![
                format!("sin_{unit}"),
                format!("cos_{unit}"),
                format!("drift_{unit}_per_h"),
            ],
            vec![("tau_s".into(), tau), ("period_s".into(), DAY_S)],
        )
    });
    (
        Box::new(v),
        "ambient_c not logged: first-order response to an inferred 24 h cycle and a room drift"
            .into(),
    )
}

/// Twice-applied first-order low-pass (a second-order roll-off).
fn lowpass2(t: &[f64], x: &[f64], tau_s: f64) -> Vec<f64> {
    let once = lsq::lowpass(t, x, tau_s, x[0]);
    lsq::lowpass(t, &once, tau_s, x[0])
}

/// `x` without what is slower than `slow_s` (period): `x - LP2(x)`.
pub fn high_pass(t: &[f64], x: &[f64], slow_s: f64) -> Vec<f64> {
    let lp = lowpass2(t, x, slow_s / std::f64::consts::TAU);
    x.iter().zip(&lp).map(|(a, b)| a - b).collect()
}

/// `x` limited to periods `band.0 .. band.1`: `LP2(x; fast) - LP2(x; slow)`,
/// causal (the same filter on the fit part and the hold-out).
pub fn band_pass(t: &[f64], x: &[f64], band: (f64, f64)) -> Vec<f64> {
    let fast = lowpass2(t, x, band.0 / std::f64::consts::TAU);
    let slow = lowpass2(t, x, band.1 / std::f64::consts::TAU);
    fast.iter().zip(&slow).map(|(a, b)| a - b).collect()
}

/// Coolant: responses to the logged coolant (always a candidate when
/// logged), else a tracked chiller component of another temperature
/// channel, else a fixed harmonic at the residual's peak.
fn coolant<'a>(p: &Problem<'a>, base_pred: &[f64]) -> (Vars<'a>, String) {
    let t = &p.al.t_s;
    if let Some(c) = p.al.coolant_c.as_deref() {
        let u = Col::new(high_pass(t, c, CHILLER_BAND_S.1));
        return (
            signal_variants(p, &u, "k", &[]),
            "responses to logged coolant_c (periods above 2 h removed)".into(),
        );
    }
    let sources = chiller_sources(p);
    if !sources.is_empty() {
        let model = format!(
            "coolant_c not logged: responses to the chiller cycle tracked on {} (band-passed 5-120 min residual after its own baseline)",
            sources.iter().map(|s| s.0.as_str()).collect::<Vec<_>>().join(", ")
        );
        let p = p.clone();
        let v = sources.into_iter().flat_map(move |(name, x)| {
            signal_variants(&p, &Col::new(x), "k", &[("source".into(), name)])
        });
        return (Box::new(v), model);
    }
    harmonic_variants(p, base_pred)
}

/// Pairs of responses (the signal itself or first-order responses, so any
/// phase lag up to 90 degrees) of a chiller signal `x`.
fn signal_variants<'a>(
    p: &Problem,
    x: &Col,
    in_unit: &'a str,
    labels: &[(String, String)],
) -> Vars<'a> {
    let labels = labels.to_vec();
    Box::new(
        response_pairs(p, x, 0.0, &COOLANT_TAUS_S, in_unit, Vec::new()).map(move |mut var| {
            var.labels = labels.clone();
            var
        }),
    )
}

/// Whether channel `src` may track a chiller for explaining `ch`: a
/// temperature always; a displacement only for a temperature (two
/// displacements may share probes, hence noise).
fn tracks(ch: &super::align::Channel, src: &str) -> bool {
    crate::data::runfile::is_temperature_column(src)
        || (super::align::is_displacement(src) && !ch.is_displacement())
}

/// Channels other than the one explained ([`tracks`]) whose residual,
/// after their own mismatch baseline (fitted on the fit rows), carries a
/// chiller-band component at least [`MIN_TRACK_SNR`] times above their
/// noise: up to [`MAX_TRACK_SOURCES`] of them, strongest first, with the
/// band-passed component. Only measured signals of those channels enter,
/// so the hold-out of the explained channel leaks nothing.
fn chiller_sources(p: &Problem) -> Vec<(String, Vec<f64>)> {
    let al = p.al;
    let rows = p.fit_rows();
    // The level of every candidate source depends on the source and the
    // fit rows only: computed once per channel and fold, and the band-passed
    // component again for the (at most two) sources kept.
    // A source channel is loaded only to compute its level (once) or its
    // component.
    let mut found: Vec<(f64, usize)> = (0..al.channels.len())
        .filter(|&i| al.channels.name(i) != p.ch.name && tracks(p.ch, al.channels.name(i)))
        .filter_map(|i| {
            let name = al.channels.name(i);
            let key = format!("chiller snr {name} {}..{}", rows.start, rows.end);
            let snr = *al
                .memo
                .get_or(&key, || {
                    chiller_component(al, &al.channels.load(i), &rows)
                        .map_or_else(Vec::new, |(snr, _)| vec![snr])
                })
                .first()?;
            (snr >= MIN_TRACK_SNR).then_some((snr, i))
        })
        .collect();
    found.sort_by(|a, b| b.0.total_cmp(&a.0));
    found
        .into_iter()
        .take(MAX_TRACK_SOURCES)
        .filter_map(|(_, i)| {
            let c = al.channels.load(i);
            Some((c.name.clone(), chiller_component(al, &c, &rows)?.1))
        })
        .collect()
}

/// Channel `c`'s chiller-band component after its own mismatch baseline
/// fitted on `rows`, and its level over the band's share of white noise.
fn chiller_component(
    al: &Aligned,
    c: &super::align::Channel,
    rows: &std::ops::Range<usize>,
) -> Option<(f64, Vec<f64>)> {
    let base = baseline::mismatch_baseline(al, c);
    let penalty = base.penalties(&c.resid, rows.clone());
    let f = batch::fit_streamed(&base.slices(), &c.resid, None, rows.clone(), &penalty)?;
    let left: Vec<f64> = c.resid.iter().zip(&f.pred).map(|(r, q)| r - q).collect();
    let x = band_pass(&al.t_s, &left, CHILLER_BAND_S);
    let white = 0.45 * lsq::noise_sigma(&c.resid).max(1e-12);
    Some((lsq::rms(&x) / white, x))
}

/// Harmonic regression (2 harmonics) at periods around the fit part's
/// 10-120 min spectral peak of what the baseline leaves: the fallback when
/// no channel tracks the chiller (a fixed period and phase).
fn harmonic_variants<'a>(p: &Problem<'a>, base_pred: &[f64]) -> (Vars<'a>, String) {
    let t = &p.al.t_s;
    let t0 = t[0];
    let unit = p.ch.unit();
    let rows = p.fit_rows();
    let r: Vec<f64> = rows.clone().map(|k| p.ch.resid[k] - base_pred[k]).collect();
    let Some(p0) = spectrum::peak_period_s(&t[rows], &r, 600.0, 7200.0) else {
        return (none(), "coolant_c not logged and no 10-120 min peak".into());
    };
    let v = (-6..=6).map(move |k| {
        let period = p0 * (1.0 + 0.01 * k as f64);
        let w = std::f64::consts::TAU / period;
        let h = |m: f64, f: fn(f64) -> f64| -> Col {
            Col::new(t.iter().map(|t| f(m * w * (t - t0))).collect())
        };
        Variant::plain(
            vec![
                h(1.0, f64::sin),
                h(1.0, f64::cos),
                h(2.0, f64::sin),
                h(2.0, f64::cos),
            ],
            ["sin1", "cos1", "sin2", "cos2"]
                .iter()
                .map(|g| format!("{g}_{unit}"))
                .collect(),
            vec![("period_s".into(), period)],
        )
    });
    (Box::new(v), "coolant_c not logged, no channel tracks a chiller: harmonic regression (2 harmonics) at the residual's 10-120 min spectral peak".into())
}

/// Cutting: responses to the power beyond air cutting.
fn cutting<'a>(p: &Problem<'a>) -> (Vars<'a>, String) {
    let al = p.al;
    let Some(pw) = al.power_kw.as_deref() else {
        return (none(), "power_kw not logged".into());
    };
    let u = regime::cutting_excess_kw(&al.speed_rpm, pw);
    if u.iter().fold(0.0f64, |a, &v| a.max(v)) < MIN_CUT_KW {
        return (none(), "no power beyond air cutting in power_kw".into());
    }
    (
        with_sign(
            response_pairs(p, &Col::new(u), 0.0, &HEAT_TAUS_S, "kw", Vec::new()),
            heat_sign(p),
        ),
        "first-order responses to power_kw beyond air cutting (warming, on a temperature)".into(),
    )
}

/// Motor losses: responses to the low-speed weight at each knee (one
/// knee's responses made at a time).
fn motor_loss<'a>(p: &Problem<'a>) -> (Vars<'a>, String) {
    let top = p.al.speed_rpm.iter().fold(0.0f64, |a, &n| a.max(n.abs()));
    // The weight is zero on the fit rows exactly when no speed there is
    // in (0, knee).
    let knees: Vec<f64> = KNEE_SHARES
        .map(|k| (k * top).round())
        .into_iter()
        .filter(|&knee| {
            p.al.speed_rpm[p.fit_rows()]
                .iter()
                .any(|&n| n > 0.0 && (1.0 - n / knee).max(0.0) != 0.0)
        })
        .collect();
    let empty = knees.is_empty();
    let q = p.clone();
    let v = knees.into_iter().flat_map(move |knee| {
        let u = Col::new(regime::low_speed_weight(&q.al.speed_rpm, knee));
        with_sign(
            response_pairs(
                &q,
                &u,
                0.0,
                &HEAT_TAUS_S,
                "weight",
                vec![("knee_rpm".into(), knee)],
            ),
            heat_sign(&q),
        )
    });
    let d = if empty {
        "the spindle never runs below 70 % of its top speed in the fit part".into()
    } else {
        "first-order responses to the low-speed weight [n>0] max(0, 1 - n/knee) (warming, on a temperature)".into()
    };
    (Box::new(v), d)
}

/// Sensor lag: the lag's own signature `F(sim; tau) - sim` on a
/// temperature channel with its gain fixed at 1 (a sensor reading
/// `F(site; tau)` of a site the twin gets right to a few % leaves exactly
/// that), the baseline fitted to the rest. A twin's time-constant error
/// looks like a lag at low frequencies with a gain `dtau / tau` of a few %,
/// so a free gain would let mismatch pass as a lag; nothing on
/// displacements and probes, which do not lag.
fn sensor_lag<'a>(p: &Problem<'a>) -> (Vars<'a>, String) {
    if !crate::data::runfile::is_temperature_column(&p.ch.name) {
        return (
            none(),
            "not a temperature channel: probes and displacements do not lag, no signature".into(),
        );
    }
    let t = &p.al.t_s;
    let sim = &p.ch.sim;
    let v = LAG_TAUS_S.iter().map(move |&tau| {
        let lag: Vec<f64> = lsq::lowpass(t, sim, tau, sim[0])
            .iter()
            .zip(sim.iter())
            .map(|(f, s)| f - s)
            .collect();
        let mut v = Variant::plain(
            Vec::new(),
            Vec::new(),
            vec![("tau_s".into(), tau), ("gain".into(), 1.0)],
        );
        v.fixed_part = Some(lag);
        v
    });
    (
        Box::new(v),
        "lagged simulated temperature with the whole sensor lagging: r = (F(sim; tau) - sim) + baseline"
            .into(),
    )
}
