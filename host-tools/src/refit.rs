//! `thermcomp refit`: self-adaptive compensation (seed 002, section 4: the
//! NC re-builds its model "when the relationship between temperature and
//! deformation changes, such as the working environment, and the
//! re-installation of the machine tool").
//!
//! Three steps, each documented in `docs/fit.md` ("refit"):
//!
//! 1. **Test.** The old model's residual on the new runs is regressed on a
//!    bias, a drift in time and a gain on its own prediction; a HAC Wald test
//!    ([`stats`]) says whether that is more than autocorrelated noise, and the
//!    fitted systematic error must reach `--min-effect-um` to matter. With
//!    `--baseline` runs, a new-run rmse or dpk beyond `--tolerance` times the
//!    baseline's also counts. A target that passes neither is unchanged.
//! 2. **Update** (changed targets only), estimated on the first
//!    `1 - --holdout-fraction` of each new run: linear and PCR models by
//!    recursive least squares with forgetting from the old coefficients
//!    ([`rls`]), PCR on its components (kept); TF banks by a least-squares
//!    gain per entry (seed 004 Eq. 6: each numerator scaled, poles kept);
//!    or, with `--method window`, a plain least-squares refit of the same
//!    structure on the last `--window-h` hours of the update part.
//! 3. **Keep or not.** Old and updated models are scored on the held-out
//!    tail of every run (`crate::score::score`); an updated target is kept
//!    only if its held-out rmse is lower. If no target is kept, or nothing
//!    changed, `--out` gets the old blob byte for byte.

mod rls;
pub mod stats;

use crate::data::runfile::{ReadOptions, RunFile};
use crate::eval::metrics_json;
use crate::runner::{self, ColumnMap};
use crate::score::{score, TargetScore};
use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use model_core::linear::LinearOutput;
use model_core::pcr::{Pcr, PcrOutput};
use model_core::tf::TfEntry;
use model_core::{Model, Params, Reference, ValidModel};
use nalgebra::{DMatrix, DVector};
use rls::Coefs;
use serde_json::{json, Map, Value};
use stats::{drift_test, DriftTest, Sample};
use std::path::PathBuf;

/// How a changed model is updated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Recursive least squares with forgetting from the old coefficients
    /// (TF banks: least-squares entry gains over the whole update part).
    Rls,
    /// Plain least squares of the same structure on the last --window-h hours.
    Window,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Self::Rls => "rls",
            Self::Window => "window",
        }
    }
}

/// Arguments of `thermcomp refit`.
#[derive(Args)]
pub struct RefitArgs {
    /// The model in service (blob).
    #[arg(long)]
    pub model: PathBuf,
    /// A new run (CSV) with the model's inputs and measured outputs; repeatable.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Where to write the model (the old blob, byte for byte, if nothing changed
    /// or the update does not improve the held-out rmse).
    #[arg(long)]
    pub out: PathBuf,
    /// A run the old model was validated on (repeatable): its rmse/dpk is the
    /// expected level for the --tolerance rule.
    #[arg(long)]
    pub baseline: Vec<PathBuf>,
    /// With --baseline: a new-run rmse or dpk above this multiple of the
    /// baseline's (and at least --min-effect-um above it) flags a change.
    #[arg(long, default_value_t = 1.5, value_name = "FACTOR")]
    pub tolerance: f64,
    /// Smallest systematic error (um, largest |bias + drift + gain error|
    /// fitted to the residual) that counts as a change.
    #[arg(long, default_value_t = 1.0, value_name = "UM")]
    pub min_effect_um: f64,
    /// Significance level of the HAC Wald test.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// How to update a changed model.
    #[arg(long, value_enum, default_value = "rls")]
    pub method: Method,
    /// RLS forgetting factor per sample (default: 1 - dt / memory, from the
    /// runs' median sample time and --memory-h).
    #[arg(long, value_name = "LAMBDA")]
    pub forgetting: Option<f64>,
    /// RLS memory, hours: the default forgetting factor's time constant.
    #[arg(long, default_value_t = 4.0, value_name = "HOURS")]
    pub memory_h: f64,
    /// RLS prior: the old coefficients weigh as much as this many hours of
    /// new samples (prior covariance I / n_prior on standardised regressors).
    #[arg(long, default_value_t = 1.0, value_name = "HOURS")]
    pub prior_h: f64,
    /// --method window: refit on the last H hours of each run's update part.
    #[arg(long, value_name = "H", default_value_t = 8.0)]
    pub window_h: f64,
    /// Fraction of each new run (by time, at its end) held out for scoring.
    #[arg(long, default_value_t = 0.3, value_name = "FRACTION")]
    pub holdout_fraction: f64,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Print one JSON object instead of the text report.
    #[arg(long)]
    pub json: bool,
}

/// Per run, per row: one output's regressors (None where any is missing).
type Regressors = Vec<Vec<Option<Vec<f64>>>>;

/// Model-form inputs to one output's regressors.
type RegressorFn = Box<dyn Fn(&[f64]) -> Vec<f64>>;

/// The inputs as a static model sees them, per row (references applied as
/// the runner applies them: `first` is the first row where every input has
/// a value).
fn model_inputs(model: &ValidModel, run: &RunFile) -> Result<Vec<Option<Vec<f64>>>> {
    let cols: Vec<&[Option<f64>]> = model
        .inputs()
        .iter()
        .map(|ch| {
            run.column(&ch.name).ok_or_else(|| {
                anyhow!(
                    "{}: the model needs input \"{}\" but the run has no such column",
                    run.path.display(),
                    ch.name
                )
            })
        })
        .collect::<Result<_>>()?;
    let first = (0..run.len()).find(|&r| cols.iter().all(|c| c[r].is_some()));
    Ok((0..run.len())
        .map(|r| {
            let raw: Option<Vec<f64>> = cols.iter().map(|c| c[r]).collect();
            raw.map(|raw| {
                raw.iter()
                    .zip(model.inputs())
                    .zip(&cols)
                    .map(|((v, ch), col)| match ch.reference {
                        Reference::Absolute => *v,
                        Reference::Value(x) => v - x,
                        Reference::First => v - first.and_then(|f| col[f]).unwrap_or(*v),
                    })
                    .collect()
            })
        })
        .collect())
}

/// What one output's update works on: its regressors and the old coefficients.
struct Structure {
    /// `regs[run][row]`.
    regs: Regressors,
    /// Old `(intercept, slopes)`; for a TF bank `(0, [1; entries])` (gains).
    old: Coefs,
    /// TF banks: the indices of this output's entries; they have no intercept.
    tf_entries: Option<Vec<usize>>,
}

fn linear_eq(model: &Model, k: usize) -> Option<&LinearOutput> {
    match &model.params {
        Params::Linear(l) => l.outputs.iter().find(|e| usize::from(e.output) == k),
        _ => None,
    }
}

fn pcr_eq(model: &Model, k: usize) -> Option<(&Pcr, &PcrOutput)> {
    match &model.params {
        Params::Pcr(p) => p
            .outputs
            .iter()
            .find(|e| usize::from(e.output) == k)
            .map(|e| (p, e)),
        _ => None,
    }
}

/// Output `k` of a linear or PCR model: its regressors as a function of
/// the model-form inputs, and its old coefficients.
fn static_equation(model: &Model, k: usize) -> Result<(RegressorFn, Coefs)> {
    if let Some(eq) = linear_eq(model, k) {
        if eq.position.is_some() {
            bail!("refit does not update positional (slope) regressions");
        }
        let ch: Vec<usize> = eq.coef.iter().map(|c| usize::from(c.channel)).collect();
        Ok((
            Box::new(move |x: &[f64]| ch.iter().map(|&c| x[c]).collect()),
            (eq.intercept, eq.coef.iter().map(|c| c.value).collect()),
        ))
    } else if let Some((pcr, eq)) = pcr_eq(model, k) {
        if eq.position.is_some() {
            bail!("refit does not update positional (slope) regressions");
        }
        // The components stay; the regression on them is updated.
        let (pcr, used) = (pcr.clone(), eq.beta.len());
        Ok((
            Box::new(move |x: &[f64]| pcr.scores(x)[..used].to_vec()),
            (eq.intercept, eq.beta.to_vec()),
        ))
    } else {
        bail!("output #{k} has no equation");
    }
}

/// Every output's [`Structure`] of a linear or PCR model over the new runs.
fn static_structures(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<Structure>> {
    let xs: Vec<Vec<Option<Vec<f64>>>> = runs
        .iter()
        .map(|r| model_inputs(old, r))
        .collect::<Result<_>>()?;
    (0..old.outputs().len())
        .map(|k| {
            let (phi, old_c) = static_equation(old.model(), k)?;
            let regs = xs
                .iter()
                .map(|run| run.iter().map(|x| x.as_deref().map(&phi)).collect())
                .collect();
            Ok(Structure {
                regs,
                old: old_c,
                tf_entries: None,
            })
        })
        .collect()
}

/// Each TF entry simulated alone on each run, through the runner
/// (resampling and state exactly as the whole model runs):
/// `[entry][run][row]`.
fn tf_entry_series(
    old: &ValidModel,
    entries: &[TfEntry],
    runs: &[RunFile],
) -> Result<Vec<Vec<Vec<Option<f64>>>>> {
    let model = old.model();
    let map = ColumnMap::default();
    let mut series = Vec::new();
    for entry in entries {
        let mut single = entry.clone();
        single.output = 0;
        let name = old
            .outputs()
            .get(usize::from(entry.output))
            .cloned()
            .ok_or_else(|| anyhow!("tf entry names a missing output"))?;
        let mut ents = heapless::Vec::new();
        let _ = ents.push(single);
        let mut outputs = heapless::Vec::new();
        let _ = outputs.push(name);
        let m = Model {
            inputs: model.inputs.clone(),
            outputs,
            dt_s: model.dt_s,
            params: Params::Tf(ents),
            bounds: None,
            five_point: None,
        }
        .validate()
        .map_err(|e| anyhow!("tf entry: {e}"))?;
        series.push(
            runs.iter()
                .map(|r| Ok(runner::predict(&m, r, &map)?.values.swap_remove(0)))
                .collect::<Result<_>>()?,
        );
    }
    Ok(series)
}

/// Every output's [`Structure`] of a TF bank: its entries' simulated
/// outputs as regressors, a gain per entry (old gains 1).
fn tf_structures(
    old: &ValidModel,
    entries: &[TfEntry],
    runs: &[RunFile],
) -> Result<Vec<Structure>> {
    let series = tf_entry_series(old, entries, runs)?;
    Ok((0..old.outputs().len())
        .map(|k| {
            let idx: Vec<usize> = entries
                .iter()
                .enumerate()
                .filter(|(_, e)| usize::from(e.output) == k)
                .map(|(i, _)| i)
                .collect();
            let regs = runs
                .iter()
                .enumerate()
                .map(|(ri, run)| {
                    (0..run.len())
                        .map(|row| idx.iter().map(|&e| series[e][ri][row]).collect())
                        .collect()
                })
                .collect();
            Structure {
                regs,
                old: (0.0, vec![1.0; idx.len()]),
                tf_entries: Some(idx),
            }
        })
        .collect())
}

/// Builds every output's [`Structure`] over the new runs.
fn structures(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<Structure>> {
    match &old.model().params {
        Params::Linear(_) | Params::Pcr(_) => static_structures(old, runs),
        Params::Tf(entries) => tf_structures(old, entries, runs),
        _ => bail!(
            "refit updates linear, pcr and tf models; this is a {} model",
            old.kind().name()
        ),
    }
}

/// Least squares without intercept (TF gains): columns scaled to unit rms,
/// SVD with singular values below 1e-10 of the largest treated as zero; a
/// column that is identically zero keeps gain 1.
fn gains_ls(rows: &[Vec<f64>], y: &[f64], m: usize) -> Result<Vec<f64>> {
    let n = rows.len();
    if n <= m {
        bail!("{n} rows for {m} gains: not enough data");
    }
    let rms: Vec<f64> = (0..m)
        .map(|j| (rows.iter().map(|r| r[j] * r[j]).sum::<f64>() / n as f64).sqrt())
        .collect();
    let a = DMatrix::from_fn(n, m, |i, j| {
        if rms[j] > 0.0 {
            rows[i][j] / rms[j]
        } else {
            0.0
        }
    });
    let svd = crate::num::linalg::svd(a)?;
    let tol = 1e-10 * svd.singular_values.max();
    let g = svd
        .solve(&DVector::from_column_slice(y), tol)
        .map_err(|e| anyhow!("SVD failed: {e}"))?;
    Ok((0..m)
        .map(|j| if rms[j] > 0.0 { g[j] / rms[j] } else { 1.0 })
        .collect())
}

/// Update settings after defaults are resolved.
struct UpdateSettings {
    method: Method,
    lambda: f64,
    n_prior: f64,
    window_s: f64,
}

/// The update rows of one output: `(regressors, y)`, in run and time order.
fn update_rows(
    st: &Structure,
    runs: &[RunFile],
    ys: &[&[Option<f64>]],
    split: &[usize],
    from_s: impl Fn(usize) -> f64,
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let (mut xs, mut yv) = (Vec::new(), Vec::new());
    for (ri, run) in runs.iter().enumerate() {
        let lo = from_s(ri);
        let rows = run.t_s.iter().zip(&st.regs[ri]).zip(ys[ri]).take(split[ri]);
        for ((t, x), y) in rows {
            if let (true, Some(x), Some(y)) = (*t >= lo, x, y) {
                xs.push(x.clone());
                yv.push(*y);
            }
        }
    }
    (xs, yv)
}

/// New coefficients for one output (raw units; for TF `(0, gains)`).
fn update_one(
    st: &Structure,
    runs: &[RunFile],
    ys: &[&[Option<f64>]],
    split: &[usize],
    s: &UpdateSettings,
) -> Result<Coefs> {
    let m = st.old.1.len();
    let from = |ri: usize| match s.method {
        Method::Rls => f64::NEG_INFINITY,
        Method::Window => runs[ri]
            .t_s
            .get(split[ri])
            .or(runs[ri].t_s.last())
            .map_or(f64::NEG_INFINITY, |t| t - s.window_s),
    };
    let (xs, yv) = update_rows(st, runs, ys, split, from);
    if xs.len() <= m + 1 {
        bail!(
            "{} update rows for {} coefficients: not enough data",
            xs.len(),
            m + 1
        );
    }
    if st.tf_entries.is_some() {
        return Ok((0.0, gains_ls(&xs, &yv, m)?));
    }
    match s.method {
        Method::Rls => Ok(rls::rls(&xs, &yv, &st.old, s.lambda, s.n_prior)),
        Method::Window => crate::num::linalg::least_squares(&xs, &yv),
    }
}

/// The old model with the outputs in `new` (output index -> coefficients) replaced.
fn with_updates(old: &ValidModel, sts: &[Structure], new: &[(usize, Coefs)]) -> Result<ValidModel> {
    let mut model = old.model().clone();
    // The calibration bounds (input envelope, error band) describe the old
    // coefficients on the old data; a refit model drops them rather than
    // claim a band it was not scored on.
    model.bounds = None;
    for (k, (b0, b)) in new {
        match &mut model.params {
            Params::Linear(l) => {
                for eq in l.outputs.iter_mut().filter(|e| usize::from(e.output) == *k) {
                    eq.intercept = *b0;
                    for (c, v) in eq.coef.iter_mut().zip(b) {
                        c.value = *v;
                    }
                }
            }
            Params::Pcr(p) => {
                for eq in p.outputs.iter_mut().filter(|e| usize::from(e.output) == *k) {
                    eq.intercept = *b0;
                    for (c, v) in eq.beta.iter_mut().zip(b) {
                        *c = *v;
                    }
                }
            }
            Params::Tf(entries) => {
                let idx = sts[*k].tf_entries.as_deref().unwrap_or(&[]);
                for (&e, g) in idx.iter().zip(b) {
                    if let Some(entry) = entries.get_mut(e) {
                        for a in entry.a.iter_mut() {
                            *a *= g;
                        }
                    }
                }
            }
            _ => bail!("cannot update a {} model", old.kind().name()),
        }
    }
    model
        .validate()
        .map_err(|e| anyhow!("the updated model is invalid ({e}); the old one is kept"))
}

fn parts_json(scores: &[TargetScore]) -> Value {
    let m: Map<String, Value> = scores
        .iter()
        .map(|t| {
            (
                t.output.clone(),
                json!({
                    "update_part": t.calibration.as_ref().map(metrics_json),
                    "holdout": t.holdout.as_ref().map(metrics_json),
                }),
            )
        })
        .collect();
    Value::Object(m)
}

fn holdout_rmse(s: &TargetScore) -> Option<f64> {
    s.holdout.as_ref().map(|m| m.rmse)
}

/// One target's test outcome.
struct Verdict {
    test: Option<DriftTest>,
    significant: bool,
    relevant: bool,
    baseline: Option<Value>,
    baseline_flag: bool,
    changed: bool,
}

fn verdict_json(v: &Verdict) -> Value {
    let t = v.test.as_ref();
    json!({
        "n": t.map(|t| t.n),
        "c0_um": t.map(|t| t.c0_um),
        "c1_um_per_h": t.map(|t| t.c1_um_per_h),
        "c2_gain": t.map(|t| t.c2),
        "wald": t.map(|t| t.wald),
        "dof": t.map(|t| t.dof),
        "p_value": t.map(|t| t.p_value),
        "hac_lags": t.map(|t| t.lags),
        "rho1": t.map(|t| t.rho1),
        "n_eff": t.map(|t| t.n_eff),
        "rmse_um": t.map(|t| t.rmse_um),
        "effect_um": t.map(|t| t.effect_um),
        "rmse_reduction_um": t.map(|t| t.rmse_reduction_um),
        "significant": v.significant,
        "relevant": v.relevant,
        "baseline": v.baseline,
        "baseline_flag": v.baseline_flag,
        "changed": v.changed,
    })
}

/// The flags' ranges, and `--out` apart from every file read.
fn check_args(a: &RefitArgs) -> Result<()> {
    if !(a.holdout_fraction > 0.0 && a.holdout_fraction < 1.0) {
        bail!(
            "--holdout-fraction {} must be in (0, 1)",
            a.holdout_fraction
        );
    }
    let reads: Vec<_> = [crate::data::fsio::named("--model", &a.model)]
        .into_iter()
        .chain(a.data.iter().map(|p| crate::data::fsio::named("--data", p)))
        .chain(
            a.baseline
                .iter()
                .map(|p| crate::data::fsio::named("--baseline", p)),
        )
        .collect();
    crate::data::fsio::check_distinct(&reads, &[crate::data::fsio::named("--out", &a.out)])?;
    if !(a.alpha > 0.0 && a.alpha < 1.0) {
        bail!("--alpha {} must be in (0, 1)", a.alpha);
    }
    if !(a.min_effect_um >= 0.0 && a.min_effect_um.is_finite()) {
        bail!("--min-effect-um must be a finite number >= 0");
    }
    if !(a.tolerance >= 1.0 && a.tolerance.is_finite()) {
        bail!("--tolerance must be a finite factor >= 1");
    }
    if let Some(l) = a.forgetting {
        if !(l > 0.0 && l <= 1.0) {
            bail!("--forgetting {l} must be in (0, 1]");
        }
    }
    for (name, v) in [
        ("--memory-h", a.memory_h),
        ("--prior-h", a.prior_h),
        ("--window-h", a.window_h),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            bail!("{name} must be a positive number of hours");
        }
    }
    Ok(())
}

/// What `refit` reads.
struct RefitInputs {
    /// The model in service.
    old: ValidModel,
    /// Its blob, byte for byte.
    old_bytes: Vec<u8>,
    /// The new runs.
    runs: Vec<RunFile>,
    /// The baseline runs.
    baseline: Vec<RunFile>,
}

/// The model in service (decoded, and its bytes), the new runs and the
/// baseline runs, read with only the model's columns.
fn read_inputs(a: &RefitArgs) -> Result<RefitInputs> {
    let (old, old_bytes) = crate::data::blobfile::read(&a.model)?;
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(ColumnMap::default().model_columns(&old, true)),
    };
    let runs = crate::data::source::read_runs(&a.data, &opts)?;
    let baseline = crate::data::source::read_runs(&a.baseline, &opts)?;
    for r in runs.iter().chain(&baseline) {
        crate::data::dataset::check_scalable_columns(r)?;
    }
    Ok(RefitInputs {
        old,
        old_bytes,
        runs,
        baseline,
    })
}

/// Each run's measured column of each model output: `ys[run][output]`.
fn measured_outputs<'r>(
    runs: &'r [RunFile],
    outputs: &[String],
) -> Result<Vec<Vec<&'r [Option<f64>]>>> {
    runs.iter()
        .map(|r| {
            outputs
                .iter()
                .map(|o| {
                    r.column(o).ok_or_else(|| {
                        anyhow!(
                            "{}: no measured column \"{o}\" for the model's output",
                            r.path.display()
                        )
                    })
                })
                .collect::<Result<_>>()
        })
        .collect()
}

/// Where each run's held-out tail starts: the last `fraction` of its time.
fn holdout_starts(runs: &[RunFile], fraction: f64) -> Vec<usize> {
    runs.iter()
        .map(|r| match (r.t_s.first(), r.t_s.last()) {
            (Some(t0), Some(t1)) => {
                let ts = t0 + (1.0 - fraction) * (t1 - t0);
                r.t_s.partition_point(|t| *t < ts)
            }
            _ => 0,
        })
        .collect()
}

/// The old model's predictions on each run (the runner's notes on stderr).
fn predictions(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<runner::Prediction>> {
    let map = ColumnMap::default();
    let preds: Vec<runner::Prediction> = runs
        .iter()
        .map(|r| runner::predict(old, r, &map))
        .collect::<Result<_>>()?;
    for (r, p) in runs.iter().zip(&preds) {
        for note in &p.notes {
            eprintln!("note: {}: {note}", r.path.display());
        }
    }
    Ok(preds)
}

/// Output `k`'s residual samples per run: time since the run's start,
/// prediction and residual, at every row with both.
fn residual_samples(
    runs: &[RunFile],
    preds: &[runner::Prediction],
    ys: &[Vec<&[Option<f64>]>],
    k: usize,
) -> Vec<Vec<Sample>> {
    runs.iter()
        .zip(preds)
        .zip(ys)
        .map(|((run, p), y)| {
            let t0 = run.t_s.first().copied().unwrap_or(0.0);
            (0..run.len())
                .filter_map(|row| match (y[k][row], p.values[k][row]) {
                    (Some(y), Some(yhat)) => Some(Sample {
                        tau_h: (run.t_s[row] - t0) / 3600.0,
                        yhat,
                        r: y - yhat,
                    }),
                    _ => None,
                })
                .collect()
        })
        .collect()
}

/// The `--tolerance` rule on one output: the baseline's and the new runs'
/// figures, and whether the new rmse or dpk exceeds the baseline's.
fn baseline_rule(a: &RefitArgs, base: &TargetScore, new: &TargetScore) -> (Option<Value>, bool) {
    let (Some(bm), Some(nm)) = (&base.calibration, &new.calibration) else {
        return (None, false);
    };
    let exceeds = |new: f64, base: f64| new > a.tolerance * base && new - base >= a.min_effect_um;
    let flag = exceeds(nm.rmse, bm.rmse) || exceeds(nm.dpk, bm.dpk);
    let figures = json!({
        "rmse_um": bm.rmse, "dpk_um": bm.dpk,
        "new_rmse_um": nm.rmse, "new_dpk_um": nm.dpk,
        "rmse_ratio": nm.rmse / bm.rmse, "dpk_ratio": nm.dpk / bm.dpk,
    });
    (Some(figures), flag)
}

/// Step 1: each output's test on every row of the new runs (and the
/// baseline rule with `--baseline`).
fn test_outputs(
    a: &RefitArgs,
    old: &ValidModel,
    (runs, baseline): (&[RunFile], &[RunFile]),
    preds: &[runner::Prediction],
    ys: &[Vec<&[Option<f64>]>],
) -> Result<Vec<Verdict>> {
    let whole = |rs: &[RunFile]| -> Result<Vec<TargetScore>> {
        let pairs: Vec<(&RunFile, usize)> = rs.iter().map(|r| (r, r.len())).collect();
        score(old, &pairs)
    };
    let scores = if baseline.is_empty() {
        None
    } else {
        Some((whole(baseline)?, whole(runs)?))
    };
    let verdicts = (0..old.outputs().len())
        .map(|k| {
            let test = drift_test(&residual_samples(runs, preds, ys, k));
            let significant = test.as_ref().is_some_and(|t| t.p_value < a.alpha);
            let relevant = test
                .as_ref()
                .is_some_and(|t| t.effect_um >= a.min_effect_um);
            let (baseline, baseline_flag) = match &scores {
                Some((b, n)) => baseline_rule(a, &b[k], &n[k]),
                None => (None, false),
            };
            Verdict {
                changed: (significant && relevant) || baseline_flag,
                test,
                significant,
                relevant,
                baseline,
                baseline_flag,
            }
        })
        .collect();
    Ok(verdicts)
}

/// The runs' mean sample time, s, and the update settings it resolves
/// (the default forgetting factor, the prior's weight in samples).
fn update_settings(a: &RefitArgs, runs: &[RunFile]) -> Result<(f64, UpdateSettings)> {
    let dts: Vec<f64> = runs
        .iter()
        .filter_map(|r| r.sampling().dt_median_s)
        .collect();
    if dts.is_empty() {
        bail!("the new runs need at least two rows each");
    }
    let dt_s = dts.iter().sum::<f64>() / dts.len() as f64;
    let settings = UpdateSettings {
        method: a.method,
        lambda: a
            .forgetting
            .unwrap_or_else(|| (1.0 - dt_s / (a.memory_h * 3600.0)).max(0.5)),
        n_prior: a.prior_h * 3600.0 / dt_s,
        window_s: a.window_h * 3600.0,
    };
    Ok((dt_s, settings))
}

/// The data an update works on: the new runs, their measured outputs and
/// where each run's held-out tail starts.
struct UpdateData<'r> {
    runs: &'r [RunFile],
    ys: &'r [Vec<&'r [Option<f64>]>],
    split: &'r [usize],
}

/// Steps 2 and 3: what the update did.
struct Update {
    /// Why an output was not updated or not kept.
    notes: Vec<String>,
    /// Per updated output: old and new coefficients, held-out rmse, kept.
    entries: Map<String, Value>,
    /// The kept model's scores (the old model's if none is kept).
    after: Vec<TargetScore>,
    /// The outputs whose update was kept.
    kept_targets: Vec<String>,
    /// The updated model, if any output's update was kept.
    model: Option<ValidModel>,
}

/// Step 2: new coefficients for every changed output (a note for those
/// that cannot be updated).
fn candidates(
    sts: &[Structure],
    data: &UpdateData,
    verdicts: &[Verdict],
    outputs: &[String],
    settings: &UpdateSettings,
    notes: &mut Vec<String>,
) -> Vec<(usize, Coefs)> {
    let ys_k = |k: usize| -> Vec<&[Option<f64>]> { data.ys.iter().map(|y| y[k]).collect() };
    let mut out = Vec::new();
    for (k, v) in verdicts.iter().enumerate() {
        if !v.changed {
            continue;
        }
        match update_one(&sts[k], data.runs, &ys_k(k), data.split, settings) {
            Ok(c) => out.push((k, c)),
            Err(e) => notes.push(format!("{}: no update: {e:#}", outputs[k])),
        }
    }
    out
}

/// `update`'s entry for one output: old and new equation, their held-out
/// rmse, which is kept.
fn update_entry(
    st: &Structure,
    new: &Coefs,
    rmse: (Option<f64>, Option<f64>),
    better: bool,
) -> Value {
    let (old_b0, old_b) = &st.old;
    let (old_j, new_j) = match &st.tf_entries {
        Some(idx) => (
            json!({"tf_entries": idx, "gains": old_b}),
            json!({"tf_entries": idx, "gains": new.1}),
        ),
        None => (
            json!({"intercept": old_b0, "coef": old_b}),
            json!({"intercept": new.0, "coef": new.1}),
        ),
    };
    json!({
        "old": old_j,
        "new": new_j,
        "holdout_rmse_old_um": rmse.0,
        "holdout_rmse_new_um": rmse.1,
        "kept": if better { "new" } else { "old" },
    })
}

/// Steps 2 and 3 for the changed outputs: update each, keep an update
/// only if it lowers that output's held-out rmse.
fn update_changed(
    old: &ValidModel,
    data: &UpdateData,
    verdicts: &[Verdict],
    settings: &UpdateSettings,
    before: &[TargetScore],
) -> Result<Update> {
    let outputs: Vec<String> = old.outputs().iter().map(|o| o.to_string()).collect();
    let pairs: Vec<(&RunFile, usize)> = data
        .runs
        .iter()
        .zip(data.split)
        .map(|(r, s)| (r, *s))
        .collect();
    let mut u = Update {
        notes: Vec::new(),
        entries: Map::new(),
        after: before.to_vec(),
        kept_targets: Vec::new(),
        model: None,
    };
    let sts = structures(old, data.runs)?;
    let candidates = candidates(&sts, data, verdicts, &outputs, settings, &mut u.notes);
    if candidates.is_empty() {
        return Ok(u);
    }
    let cand = match with_updates(old, &sts, &candidates) {
        Ok(m) => m,
        Err(e) => {
            u.notes.push(format!("{e:#}"));
            return Ok(u);
        }
    };
    let cand_scores = score(&cand, &pairs)?;
    let mut keep: Vec<(usize, Coefs)> = Vec::new();
    for (k, c) in &candidates {
        let (o, n) = (holdout_rmse(&before[*k]), holdout_rmse(&cand_scores[*k]));
        let better = matches!((o, n), (Some(o), Some(n)) if n < o);
        u.entries.insert(
            outputs[*k].clone(),
            update_entry(&sts[*k], c, (o, n), better),
        );
        if better {
            keep.push((*k, c.clone()));
            u.kept_targets.push(outputs[*k].clone());
        } else {
            u.notes.push(format!(
                "{}: the update does not lower the held-out rmse; the old equation is kept",
                outputs[*k]
            ));
        }
    }
    if !keep.is_empty() {
        let m = with_updates(old, &sts, &keep)?;
        u.after = score(&m, &pairs)?;
        u.model = Some(m);
    }
    Ok(u)
}

/// `refit --json`'s object.
#[allow(clippy::too_many_arguments)]
fn report_json(
    a: &RefitArgs,
    outputs: &[String],
    verdicts: &[Verdict],
    (dt_s, settings): (f64, &UpdateSettings),
    before: &[TargetScore],
    u: &Update,
    skipped_rows: usize,
    bytes: usize,
) -> Value {
    let changed = verdicts.iter().any(|v| v.changed);
    let targets: Map<String, Value> = outputs
        .iter()
        .zip(verdicts)
        .map(|(o, v)| (o.clone(), verdict_json(v)))
        .collect();
    json!({
        "changed": changed,
        "test": {
            "rule": "per target: changed if (HAC Wald p < alpha on r ~ c0 + c1 tau_h + c2 yhat, and max|fitted| >= min_effect_um) or (baseline given and new rmse or dpk > tolerance x baseline and >= min_effect_um above it)",
            "alpha": a.alpha,
            "min_effect_um": a.min_effect_um,
            "tolerance": a.tolerance,
            "baseline_runs": a.baseline.len(),
            "targets": targets,
            "decision": if changed { "changed" } else { "unchanged" },
        },
        "method": a.method.name(),
        "settings": {
            "dt_s": dt_s,
            "forgetting": settings.lambda,
            "memory_h": dt_s / (1.0 - settings.lambda).max(f64::MIN_POSITIVE) / 3600.0,
            "prior_h": a.prior_h,
            "window_h": (a.method == Method::Window).then_some(a.window_h),
            "holdout_fraction": a.holdout_fraction,
        },
        "update": u.entries,
        "before": parts_json(before),
        "after": parts_json(&u.after),
        "kept": if u.model.is_some() { "new" } else { "old" },
        "targets_updated": u.kept_targets,
        "notes": u.notes,
        "skipped_rows": skipped_rows,
        "out": a.out.display().to_string(),
        "bytes": bytes,
    })
}

/// Runs `thermcomp refit`.
pub fn run(a: &RefitArgs) -> Result<()> {
    check_args(a)?;
    let RefitInputs {
        old,
        old_bytes,
        runs,
        baseline,
    } = read_inputs(a)?;
    let outputs: Vec<String> = old.outputs().iter().map(|o| o.to_string()).collect();
    let ys = measured_outputs(&runs, &outputs)?;
    let split = holdout_starts(&runs, a.holdout_fraction);

    // 1. The test, on every row of the new runs.
    let preds = predictions(&old, &runs)?;
    let verdicts = test_outputs(a, &old, (&runs, &baseline), &preds, &ys)?;
    let changed = verdicts.iter().any(|v| v.changed);
    let pairs: Vec<(&RunFile, usize)> = runs.iter().zip(&split).map(|(r, s)| (r, *s)).collect();
    let before = score(&old, &pairs)?;

    // 2. and 3. The update of the changed targets only, kept if better.
    let (dt_s, settings) = update_settings(a, &runs)?;
    let u = if changed {
        let data = UpdateData {
            runs: &runs,
            ys: &ys,
            split: &split,
        };
        update_changed(&old, &data, &verdicts, &settings, &before)?
    } else {
        Update {
            notes: Vec::new(),
            entries: Map::new(),
            after: before.clone(),
            kept_targets: Vec::new(),
            model: None,
        }
    };
    let out_bytes = match &u.model {
        Some(m) => crate::data::blobfile::write(m, &a.out)?,
        None => {
            crate::data::fsio::write_bytes_atomic(&a.out, &old_bytes)?;
            old_bytes.clone()
        }
    };
    for n in &u.notes {
        eprintln!("note: {n}");
    }
    if a.json {
        let skipped = crate::data::source::skipped_rows(runs.iter().chain(&baseline));
        let report = report_json(
            a,
            &outputs,
            &verdicts,
            (dt_s, &settings),
            &before,
            &u,
            skipped,
            out_bytes.len(),
        );
        crate::data::fsio::print_line(&report.to_string())?;
    } else {
        let kept = if u.model.is_some() { "new" } else { "old" };
        let decision = if changed { "changed" } else { "unchanged" };
        crate::data::fsio::print(&text_report(
            &outputs,
            &verdicts,
            decision,
            &before,
            &u.after,
            kept,
            &u.kept_targets,
        ))?;
        eprintln!(
            "wrote {} ({} bytes, {} model)",
            a.out.display(),
            out_bytes.len(),
            if kept == "new" {
                "updated"
            } else {
                "unchanged"
            }
        );
    }
    Ok(())
}

fn text_report(
    outputs: &[String],
    verdicts: &[Verdict],
    decision: &str,
    before: &[TargetScore],
    after: &[TargetScore],
    kept: &str,
    kept_targets: &[String],
) -> String {
    let mut s = format!("refit: {decision}\n");
    s.push_str(&format!(
        "{:<10} {:>9} {:>10} {:>8} {:>9} {:>10} {:>6} {:>10} {:>9}\n",
        "target", "bias_um", "drift_um/h", "gain", "wald", "p", "n_eff", "effect_um", "decision"
    ));
    for (o, v) in outputs.iter().zip(verdicts) {
        let d = if v.changed { "changed" } else { "unchanged" };
        match &v.test {
            Some(t) => s.push_str(&format!(
                "{:<10} {:>9.3} {:>10.4} {:>8.4} {:>9.2} {:>10.2e} {:>6.0} {:>10.3} {:>9}\n",
                o, t.c0_um, t.c1_um_per_h, t.c2, t.wald, t.p_value, t.n_eff, t.effect_um, d
            )),
            None => s.push_str(&format!("{o:<10} (too few samples to test) {d}\n")),
        }
    }
    s.push_str(&format!(
        "{:<10} {:<12} {:>12} {:>12}\n",
        "target", "part", "rmse_old_um", "rmse_new_um"
    ));
    for (b, n) in before.iter().zip(after) {
        for (part, mb, mn) in [
            ("update", &b.calibration, &n.calibration),
            ("held-out", &b.holdout, &n.holdout),
        ] {
            if let (Some(mb), Some(mn)) = (mb, mn) {
                s.push_str(&format!(
                    "{:<10} {:<12} {:>12.3} {:>12.3}\n",
                    b.output, part, mb.rmse, mn.rmse
                ));
            }
        }
    }
    if kept == "new" {
        s.push_str(&format!(
            "kept: new ({} updated)\n",
            kept_targets.join(", ")
        ));
    } else {
        s.push_str("kept: old (written unchanged)\n");
    }
    s
}
