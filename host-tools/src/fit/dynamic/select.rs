//! Forward input selection shared by `arx` and `tf` (`--select-inputs
//! forward`): a dataset or grid restricted to a subset of its inputs, the
//! cap on how many inputs a bank can hold (the dataset's side is
//! [`Dataset::with_inputs`]), and the greedy search that adds
//! the input with the best score until the gain falls below a threshold.

use super::options::DynamicOptions;
use super::orders::Orders;
use crate::data::dataset::{Dataset, GridRun};
use crate::num::progress::progress;
use anyhow::{bail, Result};
use model_core::tf::MAX_TF_ENTRIES;
use serde::Serialize;
use std::collections::BTreeMap;

/// Grid runs with only the inputs `idx`.
pub fn sub_grid(grid: &[GridRun], idx: &[usize]) -> Vec<GridRun> {
    grid.iter()
        .map(|g| GridRun {
            name: g.name.clone(),
            t_s: Vec::new(),
            x: idx.iter().map(|&i| g.x[i].clone()).collect(),
            x_lead: idx
                .iter()
                .map(|&i| g.x_lead.get(i).cloned().unwrap_or_default())
                .collect(),
            y: g.y.clone(),
            calib_end: g.calib_end,
        })
        .collect()
}

/// Names only (no rows): enough for [`bank`]'s model-core check.
pub fn names_only(ds: &Dataset, idx: &[usize]) -> Dataset<'static> {
    Dataset {
        inputs: idx.iter().map(|&i| ds.inputs[i].clone()).collect(),
        targets: ds.targets.clone(),
        form: ds.form,
        runs: Vec::new(),
    }
}

/// The most inputs forward selection may keep: `--max-inputs`, and the
/// 16-entry bank shared by all targets.
pub fn max_selected(args: &DynamicOptions, ds: &Dataset) -> Result<usize> {
    let k = args
        .max_inputs
        .min(MAX_TF_ENTRIES / ds.targets.len().max(1))
        .min(ds.inputs.len());
    if k == 0 {
        bail!("--max-inputs 0 (or more than {MAX_TF_ENTRIES} targets): nothing to select");
    }
    Ok(k)
}

/// What forward selection did (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SelectionReport {
    /// The inputs it chose among.
    pub candidates: Vec<String>,
    /// Most inputs it could keep ([`max_selected`]).
    pub max_inputs: usize,
    /// `forward`.
    pub method: &'static str,
    /// `--min-gain-pct`: smallest gain in search fit, percentage points,
    /// that adds an input.
    pub min_gain_pct: f64,
    /// The orders each trial set was scored with.
    pub orders_during_selection: TrialOrders,
    /// Each step, in order.
    pub path: Vec<SelectionStep>,
    /// The ridge penalty during selection (arx).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ridge_during_selection: Option<f64>,
    /// The inputs chosen, in the order they were added.
    pub selected: Vec<String>,
    /// Why it stopped.
    pub stopped: String,
}

/// The orders a trainer scores each trial set of inputs with.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TrialOrders {
    /// How they are chosen (arx: the full order search at every trial).
    Searched(&'static str),
    /// One structure for every input (tf: the smallest of the ranges).
    Fixed(Orders),
}

/// One step of forward selection: the best candidate added, or rejected
/// because it gained too little (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum SelectionStep {
    /// The best candidate, added.
    Added {
        /// The input added.
        added: String,
        /// Every candidate's search fit, %, with the inputs chosen so far
        /// (`null`: no stable model).
        candidates: BTreeMap<String, Option<f64>>,
        /// Gain over the previous step, percentage points (`null` at the first).
        gain_pct: Option<f64>,
        /// The orders of the trial's best model.
        model: Orders,
        /// Its search fit, % (mean over the targets).
        search_fit_pct: f64,
    },
    /// The best candidate, rejected: it gains less than `--min-gain-pct`.
    Rejected {
        /// Every candidate's search fit, % (`null`: no stable model).
        candidates: BTreeMap<String, Option<f64>>,
        /// Gain over the previous step, percentage points.
        gain_pct: Option<f64>,
        /// The input rejected.
        rejected: String,
        /// Its search fit, % (mean over the targets).
        search_fit_pct: f64,
    },
}

/// How a trainer runs [`forward_select`] (what the report says of it).
pub struct Forward<'a> {
    /// Most inputs kept.
    pub k_max: usize,
    /// `--min-gain-pct`.
    pub min_gain: f64,
    /// The progress bar's and the errors' name.
    pub what: &'a str,
    /// The orders each trial set is scored with.
    pub orders: TrialOrders,
    /// The ridge penalty during selection (arx), if any.
    pub ridge: Option<f64>,
}

/// Greedy forward selection over `ds.inputs`. `score(idx)` returns the
/// search fit (mean over targets) of the model on inputs `idx`, with the
/// orders of that model, or `None` when no stable model exists. Each step
/// adds the candidate with the best score; it stops at `k_max` inputs or
/// when the best addition gains less than `min_gain` points (the first
/// input is always taken). Returns the chosen indices and the path.
pub fn forward_select(
    ds: &Dataset,
    sel: Forward,
    mut score: impl FnMut(&[usize]) -> Option<(f64, Orders)>,
) -> Result<(Vec<usize>, SelectionReport)> {
    let Forward {
        k_max,
        min_gain,
        what,
        orders,
        ridge,
    } = sel;
    let n = ds.inputs.len();
    let pb = progress((0..k_max).map(|s| n - s).sum(), what);
    let mut chosen: Vec<usize> = Vec::new();
    let mut current: Option<f64> = None;
    let mut path = Vec::new();
    let mut stop = format!("reached {k_max} inputs");
    while chosen.len() < k_max {
        let mut tried = BTreeMap::new();
        let mut best: Option<(usize, f64, Orders)> = None;
        for c in (0..n).filter(|c| !chosen.contains(c)) {
            pb.inc(1);
            let mut trial = chosen.clone();
            trial.push(c);
            let r = score(&trial);
            tried.insert(ds.inputs[c].clone(), r.as_ref().map(|r| r.0));
            if let Some((f, note)) = r {
                if best.as_ref().is_none_or(|b| f > b.1) {
                    best = Some((c, f, note));
                }
            }
        }
        let Some((c, f, note)) = best else {
            stop = "no addition gave a stable model".into();
            break;
        };
        let gain = current.map(|cur| f - cur);
        if gain.is_some_and(|g| g < min_gain) {
            stop = format!(
                "best addition {} gains {:.2} points < --min-gain-pct {min_gain}",
                ds.inputs[c],
                gain.unwrap_or(0.0)
            );
            path.push(SelectionStep::Rejected {
                candidates: tried,
                gain_pct: gain,
                rejected: ds.inputs[c].clone(),
                search_fit_pct: f,
            });
            break;
        }
        chosen.push(c);
        current = Some(f);
        path.push(SelectionStep::Added {
            added: ds.inputs[c].clone(),
            candidates: tried,
            gain_pct: gain,
            model: note,
            search_fit_pct: f,
        });
    }
    pb.finish_and_clear();
    if chosen.is_empty() {
        bail!("{what}: no single input gave a stable model");
    }
    let report = SelectionReport {
        candidates: ds.inputs.clone(),
        max_inputs: k_max,
        method: "forward",
        min_gain_pct: min_gain,
        orders_during_selection: orders,
        path,
        ridge_during_selection: ridge,
        selected: chosen.iter().map(|&i| ds.inputs[i].clone()).collect(),
        stopped: stop,
    };
    Ok((chosen, report))
}
