//! Scores a model on runs split into calibration and held-out rows: the
//! figures `fit` and `refit` report. The model runs over each whole run (a
//! dynamic model's state carries from the calibration part into the held-out
//! part, as it would on the machine); rows are then scored by which part
//! they belong to.

use crate::data::runfile::RunFile;
use crate::eval::MetricsReport;
use crate::runner::{self, ColumnMap};
use anyhow::{anyhow, Result};
use model_core::metrics::{Metrics, MetricsAccumulator};
use model_core::ValidModel;
use serde::Serialize;

/// One output's figures.
#[derive(Clone, Debug)]
pub struct TargetScore {
    /// Model output name (= the measured column).
    pub output: String,
    /// Over calibration rows (None if there were none).
    pub calibration: Option<Metrics>,
    /// Over held-out rows (None if there were none).
    pub holdout: Option<Metrics>,
    /// Rows with no prediction or no measured value: not in either `n`
    /// (and reported on stderr when there are any).
    pub rows_not_scored: usize,
}

/// One target's figures on calibration and held-out rows, under eval's
/// keys: what `fit --json` reports per target.
#[derive(Clone, Debug, Serialize)]
pub struct TargetReport {
    /// Over calibration rows (`null` if none).
    pub calibration: Option<MetricsReport>,
    /// Over held-out rows (`null` if none).
    pub holdout: Option<MetricsReport>,
    /// Rows with no prediction or no measured value.
    pub rows_not_scored: usize,
}

impl From<&TargetScore> for TargetReport {
    fn from(t: &TargetScore) -> Self {
        Self {
            calibration: t.calibration.as_ref().map(MetricsReport::from),
            holdout: t.holdout.as_ref().map(MetricsReport::from),
            rows_not_scored: t.rows_not_scored,
        }
    }
}

/// Runs `model` over each run and scores rows `< calib_end` as calibration
/// and the rest as held out. Each `n` counts the rows scored; rows that
/// cannot be scored (no prediction, or no measured value) are counted and
/// reported on stderr, never dropped silently.
pub fn score(model: &ValidModel, runs: &[(&RunFile, usize)]) -> Result<Vec<TargetScore>> {
    let map = ColumnMap::default();
    let n_out = model.outputs().len();
    let mut calib = vec![MetricsAccumulator::new(); n_out];
    let mut held = vec![MetricsAccumulator::new(); n_out];
    let mut unscored = vec![Unscored::default(); n_out];
    let mut rows = 0usize;
    for (run, calib_end) in runs {
        let p = runner::predict(model, run, &map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        for (k, name) in model.outputs().iter().enumerate() {
            let y = run
                .column(name)
                .ok_or_else(|| anyhow!("{}: no column \"{name}\"", run.path.display()))?;
            for (row, yi) in y.iter().enumerate() {
                let yhat = p.values[k].get(row).copied().flatten();
                match (yi, yhat) {
                    (Some(yi), Some(yhat)) => {
                        let acc = if row < *calib_end {
                            &mut calib[k]
                        } else {
                            &mut held[k]
                        };
                        acc.push(yi, yhat).map_err(|e| anyhow!("{name}: {e}"))?;
                    }
                    (_, None) => unscored[k].no_prediction += 1,
                    (None, Some(_)) => unscored[k].no_measurement += 1,
                }
            }
        }
        rows += run.len();
    }
    for (name, u) in model.outputs().iter().zip(&unscored) {
        if u.total() > 0 {
            eprintln!(
                "note: {name}: {} of {rows} rows not scored ({} without a prediction, {} without a measured value); n counts the scored rows",
                u.total(),
                u.no_prediction,
                u.no_measurement
            );
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
            rows_not_scored: unscored[k].total(),
        })
        .collect())
}

/// Rows of one output left out of the scores, by reason.
#[derive(Clone, Copy, Debug, Default)]
struct Unscored {
    /// The runner had no prediction (an input missing, a non-finite output).
    no_prediction: usize,
    /// The measured column is empty there.
    no_measurement: usize,
}

impl Unscored {
    fn total(self) -> usize {
        self.no_prediction + self.no_measurement
    }
}
