//! Steps 2 and 3, the update: new coefficients for every changed output
//! (recursive least squares from the old ones, least-squares TF entry
//! gains, or a plain refit on a window), kept per output only if they lower
//! its held-out rmse.

use super::change::Verdict;
use super::outcome::{Equation, UpdateEntry};
use super::rls::{self, Coefs};
use super::structure::{structures, with_updates, Hold, Structure};
use super::{Method, UpdateData, ValidRefitParams};
use crate::data::cells::Cells;
use crate::data::runfile::RunFile;
use crate::score::{score, TargetScore};
use anyhow::{anyhow, bail, Result};
use model_core::ValidModel;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// Least squares without intercept (TF gains): columns scaled to unit rms,
/// SVD with singular values below 1e-10 of the largest treated as zero; a
/// column that is identically zero keeps gain 1.
pub(crate) fn gains_ls(rows: &[Vec<f64>], y: &[f64], m: usize) -> Result<Vec<f64>> {
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
    let svd = crate::num::decomp::svd(a)?;
    let tol = 1e-10 * svd.singular_values.max();
    let g = svd
        .solve(&DVector::from_column_slice(y), tol)
        .map_err(|e| anyhow!("SVD failed: {e}"))?;
    Ok((0..m)
        .map(|j| if rms[j] > 0.0 { g[j] / rms[j] } else { 1.0 })
        .collect())
}

/// Update settings after defaults are resolved.
pub(crate) struct UpdateSettings {
    pub(crate) method: Method,
    pub(crate) lambda: f64,
    pub(crate) n_prior: f64,
    pub(crate) window_s: f64,
}

/// The update rows of one output: `(regressors, y)`, in run and time order.
pub(crate) fn update_rows(
    st: &Structure,
    runs: &[RunFile],
    ys: &[Cells<'_>],
    split: &[usize],
    from_s: impl Fn(usize) -> f64,
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let (mut xs, mut yv) = (Vec::new(), Vec::new());
    for (ri, run) in runs.iter().enumerate() {
        let lo = from_s(ri);
        let rows = run.t_s.iter().zip(&st.regs[ri]).zip(ys[ri]).take(split[ri]);
        for ((t, x), y) in rows {
            if let (true, Some(x), Some(y)) = (*t >= lo, x, y) {
                xs.push(Hold::apply(&st.holds, x.clone()));
                yv.push(y);
            }
        }
    }
    (xs, yv)
}

/// New coefficients for one output (raw units; for TF `(0, gains)`).
pub(crate) fn update_one(
    st: &Structure,
    runs: &[RunFile],
    ys: &[Cells<'_>],
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
    let (b0, b) = match s.method {
        Method::Rls => rls::rls(&xs, &yv, &st.old, s.lambda, s.n_prior),
        Method::Window => crate::num::linalg::least_squares(&xs, &yv)?,
    };
    Ok((b0, Hold::tie(&st.holds, b)))
}

/// The runs' mean sample time, s, and the update settings it resolves
/// (the default forgetting factor, the prior's weight in samples).
pub(crate) fn update_settings(
    a: &ValidRefitParams,
    runs: &[RunFile],
) -> Result<(f64, UpdateSettings)> {
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

/// Steps 2 and 3: what the update did.
pub(crate) struct Update {
    /// Why an output was not updated or not kept.
    pub(crate) notes: Vec<String>,
    /// Per updated output: old and new coefficients, held-out rmse, kept.
    pub(crate) entries: BTreeMap<String, UpdateEntry>,
    /// The kept model's scores (the old model's if none is kept).
    pub(crate) after: Vec<TargetScore>,
    /// The outputs whose update was kept.
    pub(crate) kept_targets: Vec<String>,
    /// The updated model, if any output's update was kept.
    pub(crate) model: Option<ValidModel>,
}

/// Step 2: new coefficients for every changed output (a note for those
/// that cannot be updated).
pub(crate) fn candidates(
    sts: &[Structure],
    data: &UpdateData,
    verdicts: &[Verdict],
    outputs: &[String],
    settings: &UpdateSettings,
    notes: &mut Vec<String>,
) -> Vec<(usize, Coefs)> {
    let ys_k = |k: usize| -> Vec<Cells<'_>> { data.ys.iter().map(|y| y[k]).collect() };
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

pub(crate) fn holdout_rmse(s: &TargetScore) -> Option<f64> {
    s.holdout.as_ref().map(|m| m.rmse)
}

/// `update`'s entry for one output: old and new equation, their held-out
/// rmse, which is kept.
pub(crate) fn update_entry(
    st: &Structure,
    new: &Coefs,
    rmse: (Option<f64>, Option<f64>),
    better: bool,
) -> UpdateEntry {
    let equation = |(b0, b): &Coefs| match &st.tf_entries {
        Some(idx) => Equation::Tf {
            tf_entries: idx.clone(),
            gains: b.clone(),
        },
        None => Equation::Static {
            intercept: *b0,
            coef: b.clone(),
        },
    };
    UpdateEntry {
        old: equation(&st.old),
        new: equation(new),
        holdout_rmse_old_um: rmse.0,
        holdout_rmse_new_um: rmse.1,
        kept: if better { "new" } else { "old" },
    }
}

/// Steps 2 and 3 for the changed outputs: update each, keep an update
/// only if it lowers that output's held-out rmse.
pub(crate) fn update_changed(
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
        entries: BTreeMap::new(),
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
        let updated: Vec<usize> = keep.iter().map(|(k, _)| *k).collect();
        let m = super::bounds::carried(old, m, &updated, data, &mut u.notes)?;
        u.after = score(&m, &pairs)?;
        u.model = Some(m);
    }
    Ok(u)
}
