//! `thermcomp eval`: a model's predictions scored against the measured
//! columns, over all runs together and per run (CONTRACT.md section 1).

use crate::data::runfile::{ReadOptions, RunFile};
use crate::runner;
use crate::runner::ColumnMap;
use anyhow::{anyhow, bail, Result};
use model_core::metrics::{Metrics, MetricsAccumulator};
use model_core::ValidModel;
use serde::Serialize;

/// One set of figures under the contract's metric keys (CONTRACT.md
/// section 1) and a few more: what `eval --json` and `fit --json` print.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MetricsReport {
    /// Rows scored.
    pub n: usize,
    /// Root-mean-square residual.
    pub rmse_um: f64,
    /// (1 - ||r|| / ||y - mean(y)||) * 100.
    pub fit_pct: f64,
    /// 1 - SSE / SST.
    pub r2: f64,
    /// (1 - ||r|| / ||y||) * 100 (the seeds' predictive ability).
    pub eta_pct: f64,
    /// max |r|.
    pub max_abs_um: f64,
    /// mean |r|.
    pub mean_abs_um: f64,
    /// min |r|.
    pub min_abs_um: f64,
    /// |max r| + |min r|.
    pub dpk_um: f64,
    /// (1 - mean|r| / mean|y|) * 100.
    pub reduction_pct: f64,
    /// mean r.
    pub residual_mean_um: f64,
    /// min r.
    pub residual_min_um: f64,
    /// max r.
    pub residual_max_um: f64,
}

impl From<&Metrics> for MetricsReport {
    fn from(m: &Metrics) -> Self {
        Self {
            n: m.n,
            rmse_um: m.rmse,
            fit_pct: m.fit_pct,
            r2: m.r2,
            eta_pct: m.eta_pct,
            max_abs_um: m.max_abs,
            mean_abs_um: m.mean_abs,
            min_abs_um: m.min_abs,
            dpk_um: m.dpk,
            reduction_pct: m.reduction_pct,
            residual_mean_um: m.mean,
            residual_min_um: m.residual_min,
            residual_max_um: m.residual_max,
        }
    }
}

/// `eval`'s figures for one model output, over all runs and per run.
#[derive(Clone, Debug, Serialize)]
pub struct TargetEval {
    /// Over every run together.
    #[serde(flatten)]
    pub metrics: MetricsReport,
    /// The measured column compared with (the output's name unless mapped).
    pub column: String,
    /// Rows with no prediction or no measured value, over all runs.
    pub rows_not_scored: usize,
    /// Rows the reader left out (`--skip-bad-rows`), over all runs.
    pub skipped_rows: usize,
    /// Per run, in the order given.
    pub per_run: Vec<RunEval>,
}

/// One run's figures for one output, or why there are none.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum RunEval {
    /// Scored.
    Scored {
        /// The figures.
        #[serde(flatten)]
        metrics: MetricsReport,
        /// The run's file (or in-memory name).
        file: String,
        /// Rows of this run not scored.
        rows_not_scored: usize,
    },
    /// Nothing to score in this run.
    Failed {
        /// Why.
        error: String,
        /// The run's file (or in-memory name).
        file: String,
        /// Rows of this run not scored.
        rows_not_scored: usize,
    },
}

/// What `eval` found: one entry per model output, keyed by its name (the
/// object `eval --json` prints).
pub type EvalOutcome = std::collections::BTreeMap<String, TargetEval>;

/// Scores `model` on `runs` (in memory): predictions against the measured
/// columns, `map` naming a measured column per output where it differs.
/// Notes (unscored rows, an arma model's caveat) go to stderr.
pub fn evaluate(model: &ValidModel, runs: &[RunFile], map: &ColumnMap) -> Result<EvalOutcome> {
    let skipped_rows = crate::data::source::skipped_rows(runs);
    let Tally {
        names,
        n_model,
        mut all,
        mut per_run,
        mut unscored,
    } = Tally::new(model);
    for run in runs {
        let p = runner::predict(model, run, map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        for (k, name) in names.iter().enumerate() {
            if k >= n_model && run.column(map.column(name)).is_none() {
                eprintln!(
                    "note: {}: no measured {}: the tool-tip {name} is not scored",
                    run.path.display(),
                    map.column(name)
                );
                continue;
            }
            let (entry, skipped) = score_run(run, name, map, &p.values[k], &mut all[k])?;
            unscored[k] += skipped;
            per_run[k].push(entry);
        }
    }
    outcome(&names, n_model, map, &all, per_run, &unscored, skipped_rows)
}

/// The running figures of an evaluation: per output (a five-point model's
/// tip drift too, where the run has it) the accumulator over every run,
/// the per-run entries and the rows not scored.
struct Tally {
    names: Vec<String>,
    n_model: usize,
    all: Vec<MetricsAccumulator>,
    per_run: Vec<Vec<RunEval>>,
    unscored: Vec<usize>,
}

impl Tally {
    /// Empty figures for `model`'s outputs; an arma model's caveat on stderr.
    fn new(model: &ValidModel) -> Tally {
        if model.kind() == model_core::ModelKind::Arma {
            eprintln!("note: an arma model forecasts one step ahead from the measured series itself: these figures hold only where the error is measured every dt_s on the machine (docs/arma.md)");
        }
        let names = runner::prediction_names(model);
        let n_out = names.len();
        Tally {
            names,
            n_model: model.outputs().len(),
            all: vec![MetricsAccumulator::new(); n_out],
            per_run: vec![Vec::new(); n_out],
            unscored: vec![0; n_out],
        }
    }
}

/// The outcome from the accumulated figures (every run's rows in `all`).
fn outcome(
    names: &[String],
    n_model: usize,
    map: &ColumnMap,
    all: &[MetricsAccumulator],
    mut per_run: Vec<Vec<RunEval>>,
    unscored: &[usize],
    skipped_rows: usize,
) -> Result<EvalOutcome> {
    let mut out = EvalOutcome::new();
    for (k, name) in names.iter().enumerate() {
        if k >= n_model && per_run[k].is_empty() {
            continue;
        }
        let m = all[k].clone().finish().map_err(|e| {
            anyhow!("output \"{name}\": nothing to score ({e}): no row has both a prediction and a measurement")
        })?;
        let entry = TargetEval {
            metrics: MetricsReport::from(&m),
            column: map.column(name).to_string(),
            rows_not_scored: unscored[k],
            skipped_rows,
            per_run: std::mem::take(&mut per_run[k]),
        };
        out.insert(name.to_string(), entry);
    }
    Ok(out)
}

/// Scores `model` on the run files at `paths`, each streamed row by row
/// ([`crate::stream::stream_run`]): [`evaluate`] on the runs read, in
/// memory bounded by a row, not by a run (except the runs a dynamic model
/// resamples; see `stream`). The figures are [`evaluate`]'s bit for bit:
/// the same rows reach the same accumulators in the same order.
pub fn evaluate_files(
    model: &ValidModel,
    paths: &[std::path::PathBuf],
    opts: &ReadOptions,
    map: &ColumnMap,
) -> Result<EvalOutcome> {
    let Tally {
        names,
        n_model,
        mut all,
        mut per_run,
        mut unscored,
    } = Tally::new(model);
    let mut skipped_rows = 0;
    for path in paths {
        let mut sink = EvalSink {
            names: &names,
            n_model,
            map,
            all: &mut all,
            targets: Vec::new(),
        };
        let end = crate::stream::stream_run(model, path, opts, map, &mut sink)?;
        let targets = std::mem::take(&mut sink.targets);
        crate::data::source::note_skipped(path, end.skipped, end.first_skipped.as_ref());
        skipped_rows += end.skipped;
        let file = path.display().to_string();
        for note in &end.notes {
            eprintln!("note: {file}: {note}");
        }
        for (k, target) in targets.into_iter().enumerate() {
            let name = &names[k];
            let col = map.column(name);
            let Some(target) = target else {
                eprintln!("note: {file}: no measured {col}: the tool-tip {name} is not scored");
                continue;
            };
            let entry = run_entry(&file, name, col, end.rows, target.skipped, &target.acc);
            unscored[k] += target.skipped;
            per_run[k].push(entry);
        }
    }
    outcome(&names, n_model, map, &all, per_run, &unscored, skipped_rows)
}

/// One output's tally over one streamed run.
struct RunTarget {
    /// The measured column's index in the row.
    index: usize,
    acc: MetricsAccumulator,
    skipped: usize,
}

/// Scores streamed rows: per output, the run's accumulator and `all`.
struct EvalSink<'a> {
    names: &'a [String],
    n_model: usize,
    map: &'a ColumnMap,
    all: &'a mut [MetricsAccumulator],
    /// Per output: `None` for a tool-tip output the run does not measure.
    targets: Vec<Option<RunTarget>>,
}

impl crate::stream::RowSink for EvalSink<'_> {
    fn begin(&mut self, layout: &crate::stream::Layout<'_>) -> Result<()> {
        self.targets.clear();
        for (k, name) in self.names.iter().enumerate() {
            let col = self.map.column(name);
            let index = layout.index_of(col);
            if index.is_none() && k < self.n_model {
                bail!(
                    "{}: no measured column \"{col}\" to compare output \"{name}\" with (use --map {name}=COLUMN)",
                    layout.file
                );
            }
            self.targets.push(index.map(|index| RunTarget {
                index,
                acc: MetricsAccumulator::new(),
                skipped: 0,
            }));
        }
        Ok(())
    }

    fn row(&mut self, row: &crate::stream::PredictedRow<'_>) -> Result<()> {
        for (k, target) in self.targets.iter_mut().enumerate() {
            let Some(target) = target else { continue };
            let y = row.cells.get(target.index).copied().flatten();
            match (y, row.values.get(k).copied().flatten()) {
                (Some(y), Some(yhat)) => {
                    let name = &self.names[k];
                    target
                        .acc
                        .push(y, yhat)
                        .map_err(|e| anyhow!("{name}: {e}"))?;
                    self.all[k]
                        .push(y, yhat)
                        .map_err(|e| anyhow!("{name}: {e}"))?;
                }
                _ => target.skipped += 1,
            }
        }
        Ok(())
    }

    fn skipped(&mut self, _: &crate::data::runfile::SkippedRow) -> Result<()> {
        Ok(())
    }
}

/// One run's entry for output `name` (`rows` rows, `skipped` not scored),
/// with the note on the rows not scored.
fn run_entry(
    file: &str,
    name: &str,
    col: &str,
    rows: usize,
    skipped: usize,
    acc: &MetricsAccumulator,
) -> RunEval {
    let file = file.to_string();
    if skipped > 0 {
        eprintln!(
            "note: {file}: {name}: {skipped} of {rows} rows not scored (no prediction or no measured {col}); n counts the scored rows"
        );
    }
    match acc.clone().finish() {
        Ok(m) => RunEval::Scored {
            metrics: MetricsReport::from(&m),
            file,
            rows_not_scored: skipped,
        },
        Err(e) => RunEval::Failed {
            error: e.to_string(),
            file,
            rows_not_scored: skipped,
        },
    }
}

/// One run's figures for output `name` (also pushed into `all`), and how
/// many of its rows could not be scored.
fn score_run(
    run: &RunFile,
    name: &str,
    map: &ColumnMap,
    yhat: &[Option<f64>],
    all: &mut MetricsAccumulator,
) -> Result<(RunEval, usize)> {
    let col = map.column(name);
    let y = run.column(col).ok_or_else(|| {
        anyhow!(
            "{}: no measured column \"{col}\" to compare output \"{name}\" with (use --map {name}=COLUMN)",
            run.path.display()
        )
    })?;
    let mut acc = MetricsAccumulator::new();
    let mut skipped = 0usize;
    for (row, yi) in y.iter().enumerate() {
        match (yi, yhat.get(row).copied().flatten()) {
            (Some(yi), Some(yhat)) => {
                // Both are finite: the reader rejects non-finite
                // cells and the runner non-finite outputs.
                acc.push(yi, yhat).map_err(|e| anyhow!("{name}: {e}"))?;
                all.push(yi, yhat).map_err(|e| anyhow!("{name}: {e}"))?;
            }
            _ => skipped += 1,
        }
    }
    let file = run.path.display().to_string();
    let entry = run_entry(&file, name, col, run.len(), skipped, &acc);
    Ok((entry, skipped))
}
