//! Scores a model on runs split into calibration and held-out rows: the
//! figures `fit` and `refit` report. The model runs over each whole run (a
//! dynamic model's state carries from the calibration part into the held-out
//! part, as it would on the machine); rows are then scored by which part
//! they belong to.

use crate::eval::metrics_json;
use crate::runfile::RunFile;
use crate::runner::{self, ColumnMap};
use anyhow::{anyhow, Result};
use model_core::metrics::{Metrics, MetricsAccumulator};
use model_core::ValidModel;
use serde_json::{json, Value};

/// One output's figures.
#[derive(Clone, Debug)]
pub struct TargetScore {
    /// Model output name (= the measured column).
    pub output: String,
    /// Over calibration rows (None if there were none).
    pub calibration: Option<Metrics>,
    /// Over held-out rows (None if there were none).
    pub holdout: Option<Metrics>,
}

impl TargetScore {
    /// `{"calibration": {...}, "holdout": {...}}` with eval's keys.
    pub fn json(&self) -> Value {
        json!({
            "calibration": self.calibration.as_ref().map(metrics_json),
            "holdout": self.holdout.as_ref().map(metrics_json),
        })
    }
}

/// Runs `model` over each run and scores rows `< calib_end` as calibration
/// and the rest as held out.
pub fn score(model: &ValidModel, runs: &[(&RunFile, usize)]) -> Result<Vec<TargetScore>> {
    let map = ColumnMap::default();
    let n_out = model.outputs().len();
    let mut calib = vec![MetricsAccumulator::new(); n_out];
    let mut held = vec![MetricsAccumulator::new(); n_out];
    for (run, calib_end) in runs {
        let p = runner::predict(model, run, &map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        for (k, name) in model.outputs().iter().enumerate() {
            let y = run
                .column(name)
                .ok_or_else(|| anyhow!("{}: no column \"{name}\"", run.path.display()))?;
            for (row, (yi, yhat)) in y.iter().zip(&p.values[k]).enumerate() {
                if let (Some(yi), Some(yhat)) = (yi, yhat) {
                    let acc = if row < *calib_end {
                        &mut calib[k]
                    } else {
                        &mut held[k]
                    };
                    acc.push(*yi, *yhat).map_err(|e| anyhow!("{name}: {e}"))?;
                }
            }
        }
    }
    Ok(model
        .outputs()
        .iter()
        .enumerate()
        .map(|(k, name)| TargetScore {
            output: name.to_string(),
            calibration: calib[k].finish().ok(),
            holdout: held[k].finish().ok(),
        })
        .collect())
}
