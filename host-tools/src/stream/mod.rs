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
//! it bridges by interpolation between rows) [`regrid`] does the runner's
//! resampling as the rows come, holding only the rows between the grid
//! points that bracket them. Either way the rows, predictions and notes
//! are those of [`runner::predict`] on the whole run, to the bit.

mod regrid;

use crate::data::cells::LastLogged;
use crate::data::runfile::{ReadOptions, RowError, RowStream, SkippedRow, StreamItem};
use crate::fivepoint::TOOL_COLUMN;
use crate::runner::{self, ColumnMap, RowStepper};
use anyhow::Result;
use model_core::ValidModel;
use std::fs::File;
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

/// Refuses a run a second pass cannot read again: a FIFO or a pipe
/// (`--data <(...)`) was read once, then waited on for ever (a FIFO) or
/// found empty (a pipe); so is a socket. Anything else (a missing path, a
/// directory, a device) is left to the reader's own error.
fn rereadable(path: &Path) -> Result<()> {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::metadata(path).map(|m| m.file_type()) {
        Ok(t) if t.is_fifo() || t.is_socket() => anyhow::bail!(
            "{}: a pipe or FIFO: a dynamic model reads its run twice (its time steps first), \
             so give the run as a file",
            path.display()
        ),
        _ => Ok(()),
    }
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
    if model.kind().is_dynamic() {
        rereadable(path)?;
        let plan = regrid::Plan::first_pass(model, path, opts, map)?;
        if !plan.on_rows(model) {
            return regrid::stream_run(model, path, opts, map, sink, &plan);
        }
    }
    let mut run = Opened::open(model, path, opts, map, sink)?;
    let mut out = RowOut::new(model, run.tool);
    let mut stepper = RowStepper::new(model);
    let mut first_skipped = None;
    while let Some(item) = run.stream.next_item()? {
        match item {
            StreamItem::Row(t_s) => {
                let cells = run.stream.row();
                let x = run.inputs.iter().map(|&i| cells.get(i).copied().flatten());
                let (outputs, bands) = out.outputs_mut();
                stepper.step(x, outputs, bands);
                out.emit(sink, t_s, cells)?;
            }
            StreamItem::Skipped(s) => {
                sink.skipped(&s)?;
                first_skipped.get_or_insert(s.reason);
            }
        }
    }
    let mut notes = Vec::new();
    stepper.notes(&mut notes);
    run.end(model, notes, first_skipped)
}

/// A run file opened for a model: the reader, where each model input and
/// the tool length are in its rows; the sink has been told the layout.
struct Opened {
    stream: RowStream<File>,
    inputs: Vec<usize>,
    tool: Option<usize>,
}

impl Opened {
    /// Opens the file, finds the model's columns, and begins `sink`.
    fn open(
        model: &ValidModel,
        path: &Path,
        opts: &ReadOptions,
        map: &ColumnMap,
        sink: &mut impl RowSink,
    ) -> Result<Self> {
        let stream = RowStream::open(path, opts)?;
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
        Ok(Self {
            stream,
            inputs,
            tool,
        })
    }

    /// The end of the run: the reader's final check, and the run's notes
    /// (`notes`, then a five-point model's note on missing tool lengths).
    fn end(
        self,
        model: &ValidModel,
        mut notes: Vec<String>,
        first_skipped: Option<RowError>,
    ) -> Result<RunEnd> {
        self.stream.finish(first_skipped.as_ref())?;
        if model.five_point().is_some() && self.tool.is_none() {
            notes.push(runner::tool_note());
        }
        Ok(RunEnd {
            notes,
            rows: self.stream.rows(),
            skipped: self.stream.skipped(),
            first_skipped,
        })
    }
}

/// The values and bands handed on with each row: the model's outputs,
/// then a five-point model's tool-tip drift from them and the row's tool
/// length (the last one logged where the cell is empty), as the hub
/// computes it.
struct RowOut<'m> {
    model: &'m ValidModel,
    values: Vec<Option<f64>>,
    bands: Vec<Option<f64>>,
    tool: Option<usize>,
    tool_hold: LastLogged,
}

impl<'m> RowOut<'m> {
    fn new(model: &'m ValidModel, tool: Option<usize>) -> Self {
        let n_bands = if model.model().bounds.is_some() {
            model.outputs().len()
        } else {
            0
        };
        Self {
            model,
            values: vec![None; runner::prediction_names(model).len()],
            bands: vec![None; n_bands],
            tool,
            tool_hold: LastLogged::default(),
        }
    }

    /// The model's outputs and bands, to be filled for the next row.
    fn outputs_mut(&mut self) -> (&mut [Option<f64>], &mut [Option<f64>]) {
        let n_model = self.model.outputs().len();
        (&mut self.values[..n_model], &mut self.bands)
    }

    /// Completes the row (the tool tip) and hands it to `sink`.
    fn emit(&mut self, sink: &mut impl RowSink, t_s: f64, cells: &[Option<f64>]) -> Result<()> {
        if let Some(map) = self.model.five_point() {
            let (outputs, tip) = self.values.split_at_mut(self.model.outputs().len());
            let tool_mm = self
                .tool_hold
                .next(self.tool.and_then(|i| cells.get(i).copied().flatten()));
            for (slot, d) in tip
                .iter_mut()
                .zip(runner::tool_tip_row(map, outputs, tool_mm))
            {
                *slot = d;
            }
        }
        sink.row(&PredictedRow {
            t_s,
            cells,
            values: &self.values,
            bands: &self.bands,
        })
    }
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
                runner::missing_input(stream.file(), &ch.name, col, stream.columns())
            })
        })
        .collect()
}
