//! Step 1, the test: the old model's residual on the new runs per output
//! (bias, drift, gain; the HAC Wald test of [`super::stats`]) and, with
//! baseline runs, the tolerance rule on rmse and dpk.

use super::stats::{drift_test, DriftTest, Sample};
use super::ValidRefitParams;
use crate::data::cells::{Cells, Level};
use crate::data::runfile::RunFile;
use crate::runner::{self, ColumnMap};
use crate::score::{score, TargetScore};
use anyhow::{anyhow, bail, Result};
use model_core::ValidModel;
use serde::Serialize;

/// One target's test outcome.
pub struct Verdict {
    /// The drift test (`None`: too few samples).
    pub test: Option<DriftTest>,
    /// Its p-value is below `alpha`.
    pub significant: bool,
    /// Its fitted systematic error reaches `min_effect_um`.
    pub relevant: bool,
    /// With baseline runs: their figures and the new runs'.
    pub baseline: Option<BaselineFigures>,
    /// The tolerance rule flags a change.
    pub baseline_flag: bool,
    /// Significant and relevant, or flagged by the baseline rule.
    pub changed: bool,
}

/// The baseline runs' rmse and dpk beside the new runs'.
#[derive(Clone, Debug, Serialize)]
pub struct BaselineFigures {
    /// Baseline rmse, um.
    pub rmse_um: f64,
    /// Baseline dpk, um.
    pub dpk_um: f64,
    /// New runs' rmse, um.
    pub new_rmse_um: f64,
    /// New runs' dpk, um.
    pub new_dpk_um: f64,
    /// New over baseline rmse.
    pub rmse_ratio: f64,
    /// New over baseline dpk.
    pub dpk_ratio: f64,
}

/// Each run's measured column of each model output: `ys[run][output]`.
pub(crate) fn measured_outputs<'r>(
    runs: &'r [RunFile],
    outputs: &[String],
) -> Result<Vec<Vec<Cells<'r>>>> {
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

/// Refuses an output measured nowhere, or with one value over every new
/// run (a stuck probe, a column zeroed by mistake): the test would compare
/// the model with a flat line, call it changed and fit an update that
/// cancels the model (seen: a Wald statistic of 4.5e31, the gain -1).
pub(crate) fn refuse_flat_outputs(outputs: &[String], ys: &[Vec<Cells<'_>>]) -> Result<()> {
    for (k, o) in outputs.iter().enumerate() {
        let values = ys
            .iter()
            .filter_map(|run| run.get(k))
            .flat_map(|c| c.present());
        match Level::of(values) {
            Level::Empty => bail!(
                "{o} has no measured value in the new runs: nothing to test the model against"
            ),
            Level::Flat(v) => bail!(
                "{o} is measured as {v} on every row of the new runs: a stuck probe or a \
                 wrong column, nothing to test the model against"
            ),
            Level::Moves => {}
        }
    }
    Ok(())
}

/// Where each run's held-out tail starts: the last `fraction` of its time.
pub(crate) fn holdout_starts(runs: &[RunFile], fraction: f64) -> Vec<usize> {
    runs.iter()
        .map(|r| match holdout_from_s(r, fraction) {
            Some(ts) => r.t_s.partition_point(|t| *t < ts),
            None => 0,
        })
        .collect()
}

/// The time from which a run's last `fraction` of its span is held out
/// (`None` for a run without rows): rows at or after it are the tail.
pub fn holdout_from_s(run: &RunFile, fraction: f64) -> Option<f64> {
    match (run.t_s.first(), run.t_s.last()) {
        (Some(t0), Some(t1)) => Some(t0 + (1.0 - fraction) * (t1 - t0)),
        _ => None,
    }
}

/// The old model's predictions on each run (the runner's notes on stderr).
pub(crate) fn predictions(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<runner::Prediction>> {
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
pub(crate) fn residual_samples(
    runs: &[RunFile],
    preds: &[runner::Prediction],
    ys: &[Vec<Cells<'_>>],
    k: usize,
) -> Vec<Vec<Sample>> {
    runs.iter()
        .zip(preds)
        .zip(ys)
        .map(|((run, p), y)| {
            let t0 = run.t_s.first().copied().unwrap_or(0.0);
            (0..run.len())
                .filter_map(|row| match (y[k].get(row), p.values[k][row]) {
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
pub(crate) fn baseline_rule(
    a: &ValidRefitParams,
    base: &TargetScore,
    new: &TargetScore,
) -> (Option<BaselineFigures>, bool) {
    let (Some(bm), Some(nm)) = (&base.calibration, &new.calibration) else {
        return (None, false);
    };
    let exceeds = |new: f64, base: f64| new > a.tolerance * base && new - base >= a.min_effect_um;
    let flag = exceeds(nm.rmse, bm.rmse) || exceeds(nm.dpk, bm.dpk);
    let figures = BaselineFigures {
        rmse_um: bm.rmse,
        dpk_um: bm.dpk,
        new_rmse_um: nm.rmse,
        new_dpk_um: nm.dpk,
        rmse_ratio: nm.rmse / bm.rmse,
        dpk_ratio: nm.dpk / bm.dpk,
    };
    (Some(figures), flag)
}

/// Step 1: each output's test on every row of the new runs (and the
/// baseline rule with `--baseline`).
pub(crate) fn test_outputs(
    a: &ValidRefitParams,
    old: &ValidModel,
    (runs, baseline): (&[RunFile], &[RunFile]),
    preds: &[runner::Prediction],
    ys: &[Vec<Cells<'_>>],
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
