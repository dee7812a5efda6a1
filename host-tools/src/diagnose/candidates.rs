//! The candidate explanations of a residual, one per effect of the
//! vocabulary (CONTRACT.md section 3) plus the `none` baseline, each a
//! physically shaped linear model over a small grid of nonlinear parameters
//! ([`super::variants`]), nested on the mismatch baseline
//! ([`super::baseline`]): every candidate contains the baseline's
//! regressors, so it can only add explanation.
//!
//! `F(u; tau)` is the first-order response [`lsq::lowpass`]. The linear
//! coefficients come from SVD least squares on the fit part only (rows
//! before the hold-out time); among the grid the variant with the smallest
//! fit-part error wins. Gains are steady-state gains of the channel per unit
//! input (`gain_um_per_k`, `gain_um_per_kw`, ...). Each candidate's held-out
//! errors are then compared with the baseline's ([`super::signif`]).

use super::align::Col;
use super::baseline::{self, Baseline};
use super::chiller::CHILLER_BAND_S;
use super::outcome::{Effect, Param, Params};
use super::problem::{Problem, Rows};
use super::signif;
use super::variants::{high_pass, variants, Variant};
use crate::num::batch::{self, Batched};
use crate::num::lsq::{self, LinearFit};

/// Names of the candidates, in CONTRACT order.
pub const NAMES: [&str; 5] = ["ambient", "coolant", "cutting", "motor_loss", "sensor_lag"];

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
    pub params: Params,
    /// Which model form was used.
    pub model: String,
    /// Whether its prediction is the baseline's on every row (no usable
    /// input, or its regressors are zero): then it is no test. The
    /// prediction itself is not kept (a run's length per candidate and
    /// look); [`prediction`] fits it again where it is drawn.
    pub as_baseline: bool,
    /// One-sided block-bootstrap p-value that the candidate's held-out
    /// errors are smaller than the baseline's (`None` for the baseline).
    pub p_value: Option<f64>,
    /// `p_value` after Holm's adjustment over the candidates tested.
    pub p_adjusted: Option<f64>,
    /// Held-out rms over the baseline's (for `coolant`: of the errors in
    /// the chiller band); 1 for the baseline itself.
    pub ratio_to_none: f64,
}

impl Scored {
    /// The CONTRACT's effect object (plus `model`, `fit_rms`, `p_value`,
    /// `p_adjusted`, `confidence` = 1 - `p_adjusted`; `None` for `none`),
    /// figures rounded as printed.
    pub fn effect(&self) -> Effect {
        Effect {
            confidence: self.confidence().map(round),
            fit_rms: round(self.fit_rms),
            model: self.model.clone(),
            name: self.name.clone(),
            p_adjusted: self.p_adjusted.map(round),
            p_value: self.p_value.map(round),
            pair: None,
            params: self.params.clone(),
            ratio_to_none: round(self.ratio_to_none),
            rms_after: round(self.rms_after),
            rms_after_first_alone: None,
            rms_before: round(self.rms_before),
            shrink_pct: round(self.shrink_pct),
        }
    }

    /// The held-out rms left over the better of two references: the
    /// baseline's ([`Scored::ratio_to_none`]) and the raw residual's
    /// (`rms_after / rms_before`: doing nothing). A baseline whose mismatch
    /// terms extrapolate into the hold-out worse than doing nothing (a slow
    /// node it cannot follow, a second heat cluster joined only through the
    /// bed) makes every candidate look good against it; a claim that rests
    /// on one sensor is held to both (see `Rule::raw_reference`).
    pub fn ratio_to_reference(&self) -> f64 {
        if self.rms_before > 0.0 {
            self.ratio_to_none.max(self.rms_after / self.rms_before)
        } else {
            self.ratio_to_none
        }
    }

    /// `1 - p_adjusted`: how sure the test is that the candidate beats the
    /// baseline on the hold-out, with five candidates tested at once.
    pub fn confidence(&self) -> Option<f64> {
        self.p_adjusted.map(|p| 1.0 - p)
    }
}

/// The errors a prediction `pred` leaves on `p`'s test rows, in time order.
fn errors_of(p: &Problem, pred: &[f64]) -> Vec<f64> {
    p.test_rows().map(|k| p.ch.resid[k] - pred[k]).collect()
}

/// Rounds to 4 significant-ish decimals for output.
pub fn round(v: f64) -> f64 {
    if v.abs() >= 1000.0 {
        v.round()
    } else {
        (v * 1e4).round() / 1e4
    }
}

/// The baseline of a channel as a design: its columns, their ridge
/// penalties for the channel's residual and their scales on the fit rows
/// (computed once: every fit of a grid shares the baseline's columns).
#[derive(Debug, Clone)]
pub(super) struct Design {
    base: Baseline,
    penalty: Vec<f64>,
    rows: Rows,
    scales: Vec<f64>,
}

impl Design {
    /// The mismatch baseline of `p`'s channel.
    pub(super) fn of(p: &Problem) -> Self {
        Design::on(p, baseline::mismatch_baseline(p.al, p.ch))
    }

    /// `p`'s design with the baseline `base` of its channel already made
    /// (its columns depend on the channel only, not on the fit rows: both
    /// folds of a look share them).
    fn on(p: &Problem, base: Baseline) -> Self {
        let rows = p.fit_rows();
        let penalty = base.penalties(&p.ch.resid, rows.clone());
        let scales = lsq::column_scales(&base.slices(), &rows);
        Design {
            base,
            penalty,
            rows,
            scales,
        }
    }

    /// Number of baseline columns (where a variant's gains start).
    pub(super) fn len(&self) -> usize {
        self.base.cols.len()
    }

    /// The scales on `rows` of the baseline's columns and then `extra`
    /// (the baseline's kept ones where `rows` are the fit rows).
    fn scales_with(&self, extra: &[Col], rows: &Rows) -> Vec<f64> {
        let extra: Vec<&[f64]> = extra.iter().map(|c| c.as_slice()).collect();
        let mut all = if *rows == self.rows {
            self.scales.clone()
        } else {
            lsq::column_scales(&self.base.slices(), rows)
        };
        all.extend(lsq::column_scales(&extra, rows));
        all
    }

    /// The baseline fitted alone.
    pub(super) fn fit_alone(&self, y: &[f64], rows: &Rows) -> Option<LinearFit> {
        let cols = self.base.slices();
        let scales = self.scales_with(&[], rows);
        let s = batch::solve_scaled(&cols, &scales, y, None, rows.clone(), &self.penalty)?;
        Some(LinearFit {
            pred: lsq::predict(&cols, &s.coef, None, y.len()),
            coef: s.coef,
            sse_fit: s.sse_fit,
        })
    }

    /// The baseline's columns and then `v`'s regressors.
    fn columns<'v>(&'v self, v: &'v Variant) -> Vec<&'v [f64]> {
        self.base
            .cols
            .iter()
            .chain(&v.extra)
            .map(|c| c.as_slice())
            .collect()
    }

    /// The baseline and variant `v` solved on rows `rows`: `v`'s fixed
    /// part (gain 1) is taken off `y`. One streamed pass over the shared
    /// columns, none copied, and no prediction made. Returns the
    /// coefficients (baseline, then `v`'s regressors) and the fit-part
    /// error, or `None` if the fit fails or breaks `v`'s sign rule.
    pub(super) fn solve(&self, v: &Variant, y: &[f64], rows: &Rows) -> Option<batch::Solved> {
        self.solve_many(&[v], y, rows).pop().flatten()
    }

    /// [`Design::solve`] of each of `vars` (a batch of a grid,
    /// [`super::batch::batches`]), in one walk of the rows for all: the
    /// same bits as one at a time ([`crate::num::batch`]). A column that
    /// several variants share has its scale computed once.
    pub(super) fn solve_many(
        &self,
        vars: &[&Variant],
        y: &[f64],
        rows: &Rows,
    ) -> Vec<Option<batch::Solved>> {
        let mut known = super::batch::Scales::new(rows.clone());
        let designs: Vec<Batched> = vars
            .iter()
            .map(|v| {
                let mut scales = self.scales_with(&[], rows);
                scales.extend(v.extra.iter().map(|c| known.of(c)));
                Batched {
                    cols: self.columns(v),
                    scales,
                    fixed: v.fixed_part.as_deref(),
                    penalty: &self.penalty,
                }
            })
            .collect();
        let solved = batch::solve_batch(&designs, y, rows.clone());
        solved
            .into_iter()
            .zip(vars)
            .map(|(f, v)| {
                let f = f?;
                let total: f64 = f.coef[self.len()..].iter().sum();
                (!v.sign.is_some_and(|s| s * total <= 0.0)).then_some(f)
            })
            .collect()
    }

    /// The fit `s` of variant `v` ([`Design::solve`]) with its prediction
    /// on every row (`v`'s fixed part added back).
    fn predicted(&self, v: &Variant, s: batch::Solved, n: usize) -> LinearFit {
        LinearFit {
            pred: lsq::predict(&self.columns(v), &s.coef, v.fixed_part.as_deref(), n),
            coef: s.coef,
            sse_fit: s.sse_fit,
        }
    }

    /// [`Design::solve`] with the prediction on every row.
    pub(super) fn fit(&self, v: &Variant, y: &[f64], rows: &Rows) -> Option<LinearFit> {
        let s = self.solve(v, y, rows)?;
        Some(self.predicted(v, s, y.len()))
    }

    /// Fits each variant of the grid (walked once) and keeps the best on
    /// the fit part (the first of equal ones).
    pub(super) fn best(
        &self,
        vars: impl IntoIterator<Item = Variant>,
        y: &[f64],
        rows: &Rows,
    ) -> Option<(LinearFit, Variant)> {
        let mut best: Option<(batch::Solved, Variant)> = None;
        for batch in super::batch::batches(vars.into_iter(), |v| v) {
            let refs: Vec<&Variant> = batch.iter().collect();
            let solved = self.solve_many(&refs, y, rows);
            for (f, v) in solved.into_iter().zip(batch) {
                let Some(f) = f else {
                    continue;
                };
                if best.as_ref().is_none_or(|b| below(f.sse_fit, b.0.sse_fit)) {
                    best = Some((f, v));
                }
            }
        }
        best.map(|(s, v)| (self.predicted(&v, s, y.len()), v))
    }

    /// `self` with `v`'s regressors appended to the baseline (free) and
    /// `v`'s fixed part returned apart (the columns are shared, not
    /// copied).
    pub(super) fn with_variant(&self, v: &Variant) -> (Design, Option<Vec<f64>>) {
        let mut e = self.clone();
        e.scales = self.scales_with(&v.extra, &self.rows);
        e.penalty.extend(v.extra.iter().map(|_| 0.0));
        e.base.cols.extend(v.extra.iter().cloned());
        e.base.names.extend(v.gains.iter().cloned());
        e.base.prior_sd.extend(v.extra.iter().map(|_| None));
        (e, v.fixed_part.clone())
    }

    /// What variant `v` fitted as `f` adds on row `k`: its regressors
    /// (coefficients from `from` on) times their coefficients plus its
    /// fixed part.
    pub(super) fn part(v: &Variant, f: &LinearFit, from: usize, k: usize) -> f64 {
        let lin: f64 = v
            .extra
            .iter()
            .enumerate()
            .map(|(j, c)| f.coef[from + j] * c[k])
            .sum();
        lin + v.fixed_part.as_ref().map_or(0.0, |fp| fp[k])
    }
}

/// Whether fit-part error `a` is smaller than `b` (the first of equal
/// errors is kept, as `min_by` and a stable sort keep it).
pub(super) fn below(a: f64, b: f64) -> bool {
    a.total_cmp(&b).is_lt()
}

/// Scores a fit on the hold-out rows of `p`'s channel (p-values unset),
/// `base_pred` the baseline's prediction; also returns the held-out errors
/// (the test rows only: the prediction is dropped).
pub(super) fn score(
    name: &str,
    p: &Problem,
    (f, base_pred): (&LinearFit, &[f64]),
    model: String,
    params: Params,
) -> (Scored, Vec<f64>) {
    let r = &p.ch.resid;
    let after = errors_of(p, &f.pred);
    let rms_before = lsq::rms(&r[p.test_rows()]);
    let rms_after = lsq::rms(&after);
    let scored = Scored {
        name: name.to_string(),
        rms_before,
        rms_after,
        shrink_pct: if rms_before > 0.0 {
            100.0 * (1.0 - rms_after / rms_before)
        } else {
            0.0
        },
        fit_rms: (f.sse_fit / p.fit_rows().len().max(1) as f64).sqrt(),
        params,
        model,
        as_baseline: f.pred == base_pred,
        p_value: None,
        p_adjusted: None,
        ratio_to_none: 1.0,
    };
    (scored, after)
}

/// The parameters of variant `v` fitted with coefficients `coef` (the
/// variant's own start at `n_base`): grid point, labels, gains, their sum
/// and the dominant time constant.
pub(super) fn params_of(v: &Variant, coef: &[f64], n_base: usize) -> Params {
    let number = |x: f64| Param::Number(round(x));
    let mut m = Params::new();
    let g = &coef[n_base..(n_base + v.gains.len()).min(coef.len())];
    for (k, val) in &v.fixed {
        m.insert(k.clone(), number(*val));
    }
    for (k, val) in &v.labels {
        m.insert(k.clone(), Param::Label(val.clone()));
    }
    for (k, val) in v.gains.iter().zip(g) {
        m.insert(k.clone(), number(*val));
    }
    if let Some(total) = &v.total {
        m.insert(total.clone(), number(g.iter().sum::<f64>()));
    }
    if !v.taus.is_empty() {
        let (i, _) = g.iter().enumerate().fold((0, -1.0), |(bi, bv), (i, &c)| {
            if c.abs() > bv {
                (i, c.abs())
            } else {
                (bi, bv)
            }
        });
        m.insert("tau_s".into(), Param::Number(v.taus[i]));
    }
    m
}

/// The baseline's fit scored as the `none` candidate.
fn score_none(p: &Problem, base: &Baseline, bf: &LinearFit) -> (Scored, Vec<f64>) {
    let mut params: Params = base
        .names
        .iter()
        .zip(&bf.coef)
        .map(|(k, c)| (k.clone(), Param::Number(round(*c))))
        .collect();
    params.insert("tau_c_s".into(), Param::Number(base.tau_c_s));
    score(
        "none",
        p,
        (bf, &bf.pred),
        "mismatch baseline: offset + drift + twin gain + twin time-constant error + speed and speed^2 heat gains at the channel's time constant (every candidate adds to it)".into(),
        params,
    )
}

/// Fits and scores the baseline (first) and every candidate on `p`'s
/// channel, each candidate with its block-bootstrap p-value against the
/// baseline and their Holm adjustment. The p-value pools both folds of a
/// two-fold split: the hold-out predicted from the fit part (the figures
/// reported) and the fit part predicted from the hold-out, so an effect
/// seen in both parts counts twice as much evidence as one seen once. A
/// candidate without a usable input falls back to the baseline (and says so
/// in `model`; p = 1).
pub fn fit_all(p: &Problem) -> Vec<Scored> {
    let base = baseline::mismatch_baseline(p.al, p.ch);
    let Some(Fold {
        scored: mut forward,
        errors: e_fwd,
    }) = fit_fold(p, base.clone())
    else {
        return Vec::new();
    };
    let back = p.swapped();
    let e_back = fit_fold(&back, base).map_or_else(Vec::new, |f| f.errors);
    // Held-out errors of candidate `i`, both folds in time order, in the
    // band the candidate is judged in.
    let errors = |i: usize, band: Option<f64>| -> Vec<f64> {
        let mut e = e_back
            .get(i)
            .map_or_else(Vec::new, |e| judged(&back, band, e.clone()));
        e.extend(judged(p, band, e_fwd[i].clone()));
        e
    };
    let tested: Vec<usize> = (1..forward.len())
        .filter(|&i| !forward[i].as_baseline)
        .collect();
    let raw: Vec<f64> = tested
        .iter()
        .map(|&i| {
            let band = judged_band(&forward[i].name);
            signif::p_better(&errors(0, band), &errors(i, band), BOOT_SEED + i as u64)
        })
        .collect();
    set_p_values(&mut forward, &tested, &raw);
    for i in 1..forward.len() {
        let band = judged_band(&forward[i].name);
        let e0 = judged(p, band, e_fwd[0].clone());
        let ei = judged(p, band, e_fwd[i].clone());
        forward[i].ratio_to_none = lsq::rms(&ei) / lsq::rms(&e0).max(f64::MIN_POSITIVE);
    }
    forward
}

/// The slowest period a candidate is judged on, s: the chiller band's for
/// `coolant` (its regressors hold nothing slower, and a room's or a
/// sensor's slow wander that nothing explains would hide a clear chiller
/// cycle in the ratio to the baseline), none for the others.
fn judged_band(name: &str) -> Option<f64> {
    (name == "coolant").then_some(CHILLER_BAND_S.1)
}

/// `e` (errors on `p`'s test rows) limited to periods below `band`, if any.
fn judged(p: &Problem, band: Option<f64>, e: Vec<f64>) -> Vec<f64> {
    match band {
        Some(slow) => high_pass(&p.al.t_s[p.test_rows()], &e, slow),
        None => e,
    }
}

/// One fold: the baseline (first) and every candidate, scored, and the
/// errors each leaves on the fold's test rows.
struct Fold {
    scored: Vec<Scored>,
    errors: Vec<Vec<f64>>,
}

/// The baseline (first) and every candidate fitted on `p`'s fit rows and
/// scored on its test rows (p-values unset); `None` if the baseline fails.
/// Each fit's prediction is dropped once scored (only the errors on the
/// test rows are kept).
fn fit_fold(p: &Problem, base: Baseline) -> Option<Fold> {
    let d = Design::on(p, base);
    let bf = d.fit_alone(&p.ch.resid, &p.fit_rows())?;
    let (none, e_none) = score_none(p, &d.base, &bf);
    let mut fold = Fold {
        scored: vec![none],
        errors: vec![e_none],
    };
    for name in NAMES {
        let (best, model) = fit_candidate(p, &d, &bf, name);
        let (s, e) = match best {
            Some((f, v)) => {
                let params = params_of(&v, &f.coef, d.len());
                score(name, p, (&f, &bf.pred), model, params)
            }
            None => score(
                name,
                p,
                (&bf, &bf.pred),
                format!("{model} (baseline only)"),
                Params::new(),
            ),
        };
        fold.scored.push(s);
        fold.errors.push(e);
    }
    Some(fold)
}

/// Candidate `name` fitted with the baseline `d` (fitted alone as `bf`) on
/// `p`'s fit rows: the best grid point's fit and variant (`None` when it
/// has no usable input or every fit fails), and the model form's text.
fn fit_candidate(
    p: &Problem,
    d: &Design,
    bf: &LinearFit,
    name: &str,
) -> (Option<(LinearFit, Variant)>, String) {
    let (vars, model) = variants(name, p, &bf.pred);
    (d.best(vars, &p.ch.resid, &p.fit_rows()), model)
}

/// The prediction of candidate `name` (or `none`) on every row of `p`'s
/// channel, fitted again exactly as [`fit_all`] fits it (the baseline's
/// when the candidate falls back to it); `None` if the baseline fails.
/// For the few places that need a whole prediction after the looks (the
/// pair test, the report's plot), so no look keeps one.
pub fn prediction(p: &Problem, name: &str) -> Option<Vec<f64>> {
    let d = Design::of(p);
    let bf = d.fit_alone(&p.ch.resid, &p.fit_rows())?;
    if name == "none" {
        return Some(bf.pred);
    }
    Some(
        fit_candidate(p, &d, &bf, name)
            .0
            .map_or(bf.pred, |(f, _)| f.pred),
    )
}

/// The errors candidate `name` leaves on `p`'s test rows ([`prediction`]).
pub fn held_out_errors(p: &Problem, name: &str) -> Option<Vec<f64>> {
    prediction(p, name).map(|pred| errors_of(p, &pred))
}

/// Seed of the bootstrap of candidate `i` (fixed: the same files give the
/// same p-values).
const BOOT_SEED: u64 = 0x007E_570F_5EED;

/// Sets the p-values of the candidates `tested` (indices into `scored`)
/// to `raw` and their Holm adjustment over the tested ones; a candidate
/// that fell back to the baseline (no usable input) is no test (p = 1, not
/// counted in the adjustment).
fn set_p_values(scored: &mut [Scored], tested: &[usize], raw: &[f64]) {
    let adj = signif::holm(raw);
    for s in scored[1..].iter_mut() {
        s.p_value = Some(1.0);
        s.p_adjusted = Some(1.0);
    }
    for (k, &i) in tested.iter().enumerate() {
        scored[i].p_value = Some(raw[k]);
        scored[i].p_adjusted = Some(adj[k]);
    }
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
/// fit-part error); the baseline's part is left out (it is the twin's
/// mismatch, not the effect). `None` when the candidate has no usable input
/// on this channel (e.g. `sensor_lag` on a displacement) or a fit fails.
pub fn effect_part(name: &str, p: &Problem) -> Option<EffectPart> {
    let d = Design::of(p);
    let y = &p.ch.resid;
    let bf = d.fit_alone(y, &p.fit_rows())?;
    let (f, v) = fit_candidate(p, &d, &bf, name).0?;
    let n_fit = p.fit_rows().len().max(1) as f64;
    Some(EffectPart {
        values: (0..y.len())
            .map(|k| Design::part(&v, &f, d.len(), k))
            .collect(),
        fit_rms_base: (bf.sse_fit / n_fit).sqrt(),
        fit_rms_with: (f.sse_fit / n_fit).sqrt(),
    })
}

/// A scored candidate for tests: held-out rms 10 before, `after` after,
/// `after / none_after` of the baseline, p-values `p`.
#[cfg(test)]
pub fn test_scored(name: &str, after: f64, none_after: f64, p: f64) -> Scored {
    Scored {
        name: name.into(),
        rms_before: 10.0,
        rms_after: after,
        shrink_pct: 100.0 * (1.0 - after / 10.0),
        fit_rms: 0.0,
        params: Params::new(),
        model: String::new(),
        as_baseline: false,
        p_value: Some(p),
        p_adjusted: Some(p),
        ratio_to_none: after / none_after,
    }
}
