//! Forward input selection shared by `arx` and `tf` (`--select-inputs
//! forward`): a dataset or grid restricted to a subset of its inputs, the
//! cap on how many inputs a bank can hold (the dataset's side is
//! [`Dataset::with_inputs`]), and the greedy search that adds
//! the input with the best score until the gain falls below a threshold.

use super::options::DynamicOptions;
use crate::data::dataset::{Dataset, GridRun};
use crate::num::progress::progress;
use anyhow::{bail, Result};
use model_core::tf::MAX_TF_ENTRIES;
use serde_json::{json, Map, Value};

/// Grid runs with only the inputs `idx`.
pub fn sub_grid(grid: &[GridRun], idx: &[usize]) -> Vec<GridRun> {
    grid.iter()
        .map(|g| GridRun {
            name: g.name.clone(),
            t_s: Vec::new(),
            x: idx.iter().map(|&i| g.x[i].clone()).collect(),
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

/// Greedy forward selection over `ds.inputs`. `score(idx)` returns the
/// search fit (mean over targets) of the model on inputs `idx`, with a JSON
/// note (e.g. the orders), or `None` when no stable model exists. Each step
/// adds the candidate with the best score; it stops at `k_max` inputs or
/// when the best addition gains less than `min_gain` points (the first
/// input is always taken). Returns the chosen indices and the path.
pub fn forward_select(
    ds: &Dataset,
    k_max: usize,
    min_gain: f64,
    what: &str,
    mut score: impl FnMut(&[usize]) -> Option<(f64, Value)>,
) -> Result<(Vec<usize>, Value)> {
    let n = ds.inputs.len();
    let pb = progress((0..k_max).map(|s| n - s).sum(), what);
    let mut chosen: Vec<usize> = Vec::new();
    let mut current: Option<f64> = None;
    let mut path = Vec::new();
    let mut stop = format!("reached {k_max} inputs");
    while chosen.len() < k_max {
        let mut tried = Map::new();
        let mut best: Option<(usize, f64, Value)> = None;
        for c in (0..n).filter(|c| !chosen.contains(c)) {
            pb.inc(1);
            let mut trial = chosen.clone();
            trial.push(c);
            let r = score(&trial);
            tried.insert(ds.inputs[c].clone(), json!(r.as_ref().map(|r| r.0)));
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
            path.push(
                json!({"rejected": ds.inputs[c], "search_fit_pct": f, "gain_pct": gain,
                             "candidates": tried}),
            );
            break;
        }
        chosen.push(c);
        current = Some(f);
        path.push(
            json!({"added": ds.inputs[c], "search_fit_pct": f, "gain_pct": gain,
                         "model": note, "candidates": tried}),
        );
    }
    pb.finish_and_clear();
    if chosen.is_empty() {
        bail!("{what}: no single input gave a stable model");
    }
    let names: Vec<&String> = chosen.iter().map(|&i| &ds.inputs[i]).collect();
    Ok((
        chosen,
        json!({"method": "forward", "candidates": ds.inputs, "selected": names,
               "max_inputs": k_max, "min_gain_pct": min_gain, "stopped": stop, "path": path}),
    ))
}
