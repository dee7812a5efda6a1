//! A model run over a run file row by row, in bounded memory: what `eval`
//! and `predict` do on files, whatever their length.
//!
//! The file is read by a [`RowStream`] (the reader's own checks and
//! errors), each row is stepped through the model as the hub would
//! ([`RowStepper`]) and handed to a [`RowSink`] with its predictions, then
//! dropped. Static models need nothing else. A dynamic model needs its
//! run's sampling before the first step: a first pass over the file
//! tallies the time steps ([`SamplingTally`]) and the missing input cells.
//! On the model's own grid with every input present, the rows are stepped
//! as they come; otherwise (a run the runner resamples, or missing inputs
//! it bridges by interpolation between rows) the run is read whole and
//! goes through [`runner::predict`], the only case that keeps a whole run
//! in memory. Either way the rows, predictions and notes are those of
//! [`runner::predict`] on the whole run.

use crate::data::runfile::{
    ReadOptions, RowError, RowStream, RunFile, SamplingTally, SkippedRow, StreamItem,
};
use crate::fivepoint::TOOL_COLUMN;
use crate::runner::{self, ColumnMap, RowStepper};
use anyhow::{anyhow, Result};
use model_core::ValidModel;
use std::path::Path;

/// A run's columns, as seen before its first row.
pub struct Layout<'a> {
    /// The file name as given.
    pub file: &'a str,
    /// Header names other than `t_s`, in file order.
    pub columns: &'a [String],
    /// Whether each column is read (its cells parsed).
    read: Vec<bool>,
}

impl Layout<'_> {
    /// The index in [`PredictedRow::cells`] of the read column `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        let i = self.columns.iter().position(|c| c == name)?;
        self.read.get(i).copied().unwrap_or(false).then_some(i)
    }
}

/// One row with the model's predictions.
pub struct PredictedRow<'a> {
    /// The row's time.
    pub t_s: f64,
    /// The row's cells in [`Layout::columns`] order (`None`: empty or not read).
    pub cells: &'a [Option<f64>],
    /// One value per [`runner::prediction_names`].
    pub values: &'a [Option<f64>],
    /// Band half-width per model output; empty without bounds.
    pub bands: &'a [Option<f64>],
}

/// What a streamed run is handed to.
pub trait RowSink {
    /// The run's columns, before any row: check what is needed here.
    fn begin(&mut self, layout: &Layout<'_>) -> Result<()>;
    /// A good row and its predictions, in file order.
    fn row(&mut self, row: &PredictedRow<'_>) -> Result<()>;
    /// A row skipped as bad (`--skip-bad-rows`), in file order.
    fn skipped(&mut self, row: &SkippedRow) -> Result<()>;
}

/// How a streamed run ended.
pub struct RunEnd {
    /// What the runner did that the user should know ([`runner::Prediction::notes`]).
    pub notes: Vec<String>,
    /// Good rows.
    pub rows: usize,
    /// Rows skipped as bad.
    pub skipped: usize,
    /// The first skipped row's error.
    pub first_skipped: Option<RowError>,
}

/// Runs `model` over the run file at `path` (its `opts.only` columns
/// read), handing each row to `sink`; see the module docs.
pub fn stream_run(
    model: &ValidModel,
    path: &Path,
    opts: &ReadOptions,
    map: &ColumnMap,
    sink: &mut impl RowSink,
) -> Result<RunEnd> {
    if model.kind().is_dynamic() && !steps_on_rows(model, path, opts, map)? {
        return whole_run(model, path, opts, map, sink);
    }
    let mut stream = RowStream::open(path, opts)?;
    let inputs = input_indices(model, &stream, map)?;
    let read = (0..stream.columns().len())
        .map(|i| stream.index_of(&stream.columns()[i]).is_some())
        .collect();
    sink.begin(&Layout {
        file: stream.file(),
        columns: stream.columns(),
        read,
    })?;
    let tool = model
        .five_point()
        .and_then(|_| stream.index_of(map.column(TOOL_COLUMN)));
    let n_model = model.outputs().len();
    let n_values = runner::prediction_names(model).len();
    let n_bands = if model.model().bounds.is_some() {
        n_model
    } else {
        0
    };
    let (mut values, mut bands) = (vec![None; n_values], vec![None; n_bands]);
    let mut stepper = RowStepper::new(model);
    let mut first_skipped = None;
    while let Some(item) = stream.next_item()? {
        match item {
            StreamItem::Row(t_s) => {
                let cells = stream.row();
                let x = inputs.iter().map(|&i| cells.get(i).copied().flatten());
                let (outputs, tip) = values.split_at_mut(n_model);
                stepper.step(x, outputs, &mut bands);
                if let Some(map) = model.five_point() {
                    let tool_mm = tool.and_then(|i| cells.get(i).copied().flatten());
                    let drift = runner::tool_tip_row(map, outputs, tool_mm);
                    for (slot, d) in tip.iter_mut().zip(drift) {
                        *slot = d;
                    }
                }
                sink.row(&PredictedRow {
                    t_s,
                    cells,
                    values: &values,
                    bands: &bands,
                })?;
            }
            StreamItem::Skipped(s) => {
                sink.skipped(&s)?;
                first_skipped.get_or_insert(s.reason);
            }
        }
    }
    stream.finish(first_skipped.as_ref())?;
    let mut notes = Vec::new();
    stepper.notes(&mut notes);
    if model.five_point().is_some() && tool.is_none() {
        notes.push(tool_note());
    }
    Ok(RunEnd {
        notes,
        rows: stream.rows(),
        skipped: stream.skipped(),
        first_skipped,
    })
}

/// The note of a five-point model on a run without tool lengths.
fn tool_note() -> String {
    format!("no {TOOL_COLUMN} column: the tool-tip dx_um, dy_um, dz_um are left empty")
}

/// The first pass for a dynamic model: whether the run is on the model's
/// grid ([`runner::on_model_grid`]) with every input cell present, so the
/// runner would step its rows as they are.
fn steps_on_rows(
    model: &ValidModel,
    path: &Path,
    opts: &ReadOptions,
    map: &ColumnMap,
) -> Result<bool> {
    // The same columns as the second pass, so the same rows are kept.
    let mut stream = RowStream::open(path, opts)?;
    let Ok(inputs) = input_indices(model, &stream, map) else {
        return Ok(false); // The whole-run path gives the error.
    };
    let mut tally = SamplingTally::default();
    let mut missing = false;
    while let Some(item) = stream.next_item()? {
        if let StreamItem::Row(t) = item {
            tally.push(t);
            let cells = stream.row();
            missing |= inputs
                .iter()
                .any(|&i| cells.get(i).copied().flatten().is_none());
        }
    }
    Ok(!missing && runner::on_model_grid(&tally.sampling(), model.model().dt_s))
}

/// Where each model input is in a streamed row; the runner's error if a
/// column is absent.
fn input_indices<R>(
    model: &ValidModel,
    stream: &RowStream<R>,
    map: &ColumnMap,
) -> Result<Vec<usize>> {
    model
        .inputs()
        .iter()
        .map(|ch| {
            let col = map.column(&ch.name);
            stream.index_of(col).ok_or_else(|| {
                let via = if col == ch.name.as_str() {
                    String::new()
                } else {
                    format!(" (mapped to \"{col}\")")
                };
                anyhow!(
                    "{}: the model needs input \"{}\"{via} but the run has no such column (columns: {})",
                    stream.file(),
                    ch.name,
                    stream.columns().join(", ")
                )
            })
        })
        .collect()
}

/// The run read whole and predicted by [`runner::predict`] (resampled or
/// bridged), then handed to `sink` row by row as a stream would.
fn whole_run(
    model: &ValidModel,
    path: &Path,
    opts: &ReadOptions,
    map: &ColumnMap,
    sink: &mut impl RowSink,
) -> Result<RunEnd> {
    let run = RunFile::read(path, opts)?;
    let p = runner::predict(model, &run, map)?;
    let file = run.path.display().to_string();
    let read: Vec<bool> = run
        .columns
        .iter()
        .map(|c| run.column(c).is_some())
        .collect();
    let columns: Vec<Option<&[Option<f64>]>> = run.columns.iter().map(|c| run.column(c)).collect();
    sink.begin(&Layout {
        file: &file,
        columns: &run.columns,
        read,
    })?;
    let mut skipped = run.skipped.iter().peekable();
    let (mut cells, mut values, mut bands) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &t_s) in run.t_s.iter().enumerate() {
        while let Some(s) = skipped.next_if(|s| s.before <= i) {
            sink.skipped(s)?;
        }
        let at = |c: &Vec<Option<f64>>| c.get(i).copied().flatten();
        cells.clear();
        cells.extend(
            columns
                .iter()
                .map(|c| c.and_then(|c| c.get(i).copied().flatten())),
        );
        values.clear();
        values.extend(p.values.iter().map(at));
        bands.clear();
        bands.extend(p.bands.iter().map(at));
        sink.row(&PredictedRow {
            t_s,
            cells: &cells,
            values: &values,
            bands: &bands,
        })?;
    }
    for s in skipped {
        sink.skipped(s)?;
    }
    Ok(RunEnd {
        notes: p.notes,
        rows: run.len(),
        skipped: run.skipped.len(),
        first_skipped: run.skipped.first().map(|s| s.reason.clone()),
    })
}
