//! A dynamic model over a run it cannot step row by row, streamed: a run
//! sampled other than at the model's `dt_s` (or irregularly), or with
//! missing input cells to bridge.
//!
//! [`runner::predict`] does this on a whole run: each input interpolated
//! linearly onto the model's grid ([`ModelGrid`]; the run's own rows when
//! only cells are missing), the model stepped on the grid, its outputs
//! interpolated back to the rows. Here the same sweeps run as the rows come:
//! each column's valid samples wait in a [`Track`] until a later sample
//! brackets the time asked for, a grid point is stepped once every input
//! can be had at it, and a row is handed on once every output can be had
//! at its time. What is held is the rows between the grid points that
//! bracket them (and, where an input cell is missing, the rows until its
//! next value): a few rows, whatever the run's length. Values, notes and
//! their order are [`runner::predict`]'s to the bit (one interpolation
//! rule, [`interpolate_between`]; tests below compare the two).

use super::{Opened, RowOut, RowSink, RunEnd};
use crate::data::runfile::{
    interpolate_between, ReadOptions, RowStream, Sampling, SamplingTally, SkippedRow, StreamItem,
};
use crate::runner::{self, ColumnMap, ModelGrid, RowStepper};
use anyhow::{anyhow, Result};
use model_core::ValidModel;
use std::collections::VecDeque;
use std::path::Path;

/// What the first pass over a run learnt for a dynamic model.
pub(super) struct Plan {
    sampling: Sampling,
    span: Option<(f64, f64)>,
    missing: bool,
}

impl Plan {
    /// Tallies the run's time steps and whether any input cell is missing
    /// (the same columns as the second pass, so the same rows are kept).
    pub(super) fn first_pass(
        model: &ValidModel,
        path: &Path,
        opts: &ReadOptions,
        map: &ColumnMap,
    ) -> Result<Self> {
        let mut stream = RowStream::open(path, opts)?;
        let inputs = super::input_indices(model, &stream, map)?;
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
        Ok(Self {
            sampling: tally.sampling(),
            span: tally.span(),
            missing,
        })
    }

    /// Whether the runner steps the run's rows as they are (on the model's
    /// grid, every input present).
    pub(super) fn on_rows(&self, model: &ValidModel) -> bool {
        !self.missing && runner::on_model_grid(&self.sampling, model.model().dt_s)
    }
}

/// Runs `model` over the run at `path` that [`Plan::on_rows`] refused,
/// handing each row to `sink` in file order.
pub(super) fn stream_run(
    model: &ValidModel,
    path: &Path,
    opts: &ReadOptions,
    map: &ColumnMap,
    sink: &mut impl RowSink,
    plan: &Plan,
) -> Result<RunEnd> {
    let dt = model.model().dt_s;
    let grid = if runner::on_model_grid(&plan.sampling, dt) {
        None
    } else {
        Some(
            ModelGrid::new(plan.span, dt, &plan.sampling)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?,
        )
    };
    let mut run = Opened::open(model, path, opts, map, sink)?;
    let mut out = RowOut::new(model, run.tool);
    let mut regrid = Regrid::new(model, grid);
    let mut first_skipped = None;
    while let Some(item) = run.stream.next_item()? {
        match item {
            StreamItem::Row(t_s) => regrid.push_row(t_s, run.stream.row(), &run.inputs),
            StreamItem::Skipped(s) => {
                first_skipped.get_or_insert_with(|| s.reason.clone());
                regrid.queue.push_back(Held::Skipped(s));
            }
        }
        regrid.advance(&mut out, sink)?;
    }
    regrid.finish(&mut out, sink)?;
    let notes = regrid.notes(plan);
    run.end(model, notes, first_skipped)
}

/// One column's valid samples on their way to linear interpolation:
/// [`crate::data::runfile::resample_linear`]'s sweep, fed as rows come.
#[derive(Default)]
struct Track {
    /// The last sample at or before the last time asked for.
    before: Option<(f64, f64)>,
    /// Samples after it, oldest first.
    ahead: VecDeque<(f64, f64)>,
    /// No more samples will come.
    ended: bool,
}

impl Track {
    /// Adds the next sample (time order); a missing or non-finite one is
    /// skipped, as [`crate::data::runfile::resample_linear`] skips it.
    fn push(&mut self, t: f64, x: Option<f64>) {
        if let Some(x) = x.filter(|x| x.is_finite() && t.is_finite()) {
            self.ahead.push_back((t, x));
        }
    }

    /// The interpolated value at `g` (non-decreasing over calls), or
    /// `None` while a sample yet to come could still change it.
    fn at(&mut self, g: f64) -> Option<Option<f64>> {
        while let Some(&s) = self.ahead.front().filter(|s| s.0 <= g) {
            self.before = Some(s);
            self.ahead.pop_front();
        }
        let exact = self.before.is_some_and(|(t, _)| t == g);
        if self.ahead.is_empty() && !self.ended && !exact {
            return None;
        }
        Some(interpolate_between(
            self.before,
            self.ahead.front().copied(),
            g,
        ))
    }
}

/// A row or a skipped row not yet handed on.
enum Held {
    Row {
        t_s: f64,
        cells: Vec<Option<f64>>,
        /// The model's outputs and bands at this row, when it is its own
        /// grid point and has been stepped.
        stepped: Option<OwnStep>,
    },
    Skipped(SkippedRow),
}

/// A row stepped as its own grid point: the model's outputs and bands.
struct OwnStep {
    values: Vec<Option<f64>>,
    bands: Vec<Option<f64>>,
}

/// The resampling in flight.
struct Regrid<'m> {
    /// The model's grid; `None`: the run's own rows (cells to bridge only).
    grid: Option<ModelGrid>,
    stepper: RowStepper<'m>,
    /// One track per model input.
    inputs: Vec<Track>,
    /// With a grid: one track per output, then per band, fed by the steps.
    outputs: Vec<Track>,
    /// Grid points stepped.
    stepped: usize,
    queue: VecDeque<Held>,
    /// Scratch for one step.
    x: Vec<Option<f64>>,
    values: Vec<Option<f64>>,
    bands: Vec<Option<f64>>,
    /// Missing input cells between two present ones (bridged), per
    /// input, for the note.
    bridged: Vec<runner::BridgedCells>,
    /// Rows after the grid's last whole step, for the note.
    tail: usize,
}

impl<'m> Regrid<'m> {
    fn new(model: &'m ValidModel, grid: Option<ModelGrid>) -> Self {
        let n_out = model.outputs().len();
        let n_bands = if model.model().bounds.is_some() {
            n_out
        } else {
            0
        };
        let n_tracks = if grid.is_some() { n_out + n_bands } else { 0 };
        Self {
            grid,
            stepper: RowStepper::new(model),
            inputs: (0..model.inputs().len())
                .map(|_| Track::default())
                .collect(),
            outputs: (0..n_tracks).map(|_| Track::default()).collect(),
            stepped: 0,
            queue: VecDeque::new(),
            x: Vec::with_capacity(model.inputs().len()),
            values: vec![None; n_out],
            bands: vec![None; n_bands],
            bridged: vec![runner::BridgedCells::default(); model.inputs().len()],
            tail: 0,
        }
    }

    /// Takes a good row: its input cells into the tracks, the row into the queue.
    fn push_row(&mut self, t_s: f64, cells: &[Option<f64>], inputs: &[usize]) {
        for ((track, count), &i) in self.inputs.iter_mut().zip(&mut self.bridged).zip(inputs) {
            let v = cells.get(i).copied().flatten();
            count.push(v.is_some());
            track.push(t_s, v);
        }
        let last = self.grid.and_then(|g| g.last_whole_step());
        self.tail += usize::from(last.is_some_and(|last| t_s > last));
        self.queue.push_back(Held::Row {
            t_s,
            cells: cells.to_vec(),
            stepped: None,
        });
    }

    /// Steps what can be stepped and hands on what is complete.
    fn advance(&mut self, out: &mut RowOut<'_>, sink: &mut impl RowSink) -> Result<()> {
        match self.grid {
            Some(grid) => self.step_grid(grid),
            None => self.step_rows(),
        }
        self.hand_on(out, sink)
    }

    /// The end of the file: every track complete, every row handed on.
    fn finish(&mut self, out: &mut RowOut<'_>, sink: &mut impl RowSink) -> Result<()> {
        self.inputs.iter_mut().for_each(|t| t.ended = true);
        self.advance(out, sink)?;
        if self.queue.is_empty() {
            Ok(())
        } else {
            Err(anyhow!(
                "internal error: {} rows left unpredicted at the end of the run",
                self.queue.len()
            ))
        }
    }

    /// The inputs at `t` (into `self.x`), if every track can give them.
    fn inputs_at(&mut self, t: f64) -> bool {
        self.x.clear();
        for track in &mut self.inputs {
            match track.at(t) {
                Some(v) => self.x.push(v),
                None => return false,
            }
        }
        true
    }

    /// The model's grid: each point whose inputs are known, stepped, its
    /// outputs and bands into the output tracks.
    fn step_grid(&mut self, grid: ModelGrid) {
        while self.stepped < grid.points() && self.inputs_at(grid.input_time(self.stepped)) {
            let t = grid.point(self.stepped);
            self.stepper
                .step(self.x.iter().copied(), &mut self.values, &mut self.bands);
            let stepped = self.values.iter().chain(&self.bands);
            for (track, &v) in self.outputs.iter_mut().zip(stepped) {
                track.push(t, v);
            }
            self.stepped += 1;
        }
        if self.stepped == grid.points() {
            self.outputs.iter_mut().for_each(|t| t.ended = true);
        }
    }

    /// The run's own rows: each row whose inputs are known, stepped.
    fn step_rows(&mut self) {
        for i in 0..self.queue.len() {
            let t_s = match &self.queue[i] {
                Held::Row {
                    t_s, stepped: None, ..
                } => *t_s,
                _ => continue,
            };
            if !self.inputs_at(t_s) {
                return;
            }
            self.stepper
                .step(self.x.iter().copied(), &mut self.values, &mut self.bands);
            if let Held::Row { stepped, .. } = &mut self.queue[i] {
                *stepped = Some(OwnStep {
                    values: self.values.clone(),
                    bands: self.bands.clone(),
                });
            }
        }
    }

    /// Hands on, in file order, the rows whose predictions are complete
    /// and the skipped rows before them.
    fn hand_on(&mut self, out: &mut RowOut<'_>, sink: &mut impl RowSink) -> Result<()> {
        while let Some(front) = self.queue.front() {
            match front {
                Held::Skipped(s) => sink.skipped(s)?,
                Held::Row {
                    t_s,
                    cells,
                    stepped,
                } => {
                    let (values, bands) = out.outputs_mut();
                    let ready = match stepped {
                        Some(own) => {
                            values.copy_from_slice(&own.values);
                            bands.copy_from_slice(&own.bands);
                            true
                        }
                        None => outputs_at(&mut self.outputs, *t_s, values, bands),
                    };
                    if !ready {
                        return Ok(());
                    }
                    out.emit(sink, *t_s, cells)?;
                }
            }
            self.queue.pop_front();
        }
        Ok(())
    }

    /// The runner's notes, in its order.
    fn notes(&self, plan: &Plan) -> Vec<String> {
        let mut notes = Vec::new();
        if let Some(grid) = self.grid {
            let dt = grid.dt();
            notes.push(runner::resampled_note(&plan.sampling, dt, plan.sampling.n));
            if grid.last_whole_step().is_some() {
                notes.push(grid.extra_step_note(self.tail));
            }
        }
        let bridged: usize = self.bridged.iter().map(runner::BridgedCells::bridged).sum();
        if bridged > 0 {
            notes.push(runner::bridged_note(bridged));
        }
        self.stepper.notes(&mut notes);
        notes
    }
}

/// Every output and band at `t` from the grid's output tracks (outputs
/// first, as [`Regrid::step_grid`] feeds them), if all can be had yet.
/// Without a grid there are no tracks, and a row is never asked here
/// before it is stepped.
fn outputs_at(
    tracks: &mut [Track],
    t: f64,
    values: &mut [Option<f64>],
    bands: &mut [Option<f64>],
) -> bool {
    if tracks.is_empty() {
        return false;
    }
    for (track, slot) in tracks.iter_mut().zip(values.iter_mut().chain(bands)) {
        match track.at(t) {
            Some(v) => *slot = v,
            None => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests;
