//! Runs a model over run files the way the hub would: channel by channel,
//! sample by sample, with each run restarting the model's state.
//!
//! Static models (regressions, BP) are evaluated row by row. Dynamic models
//! (TF banks, ARMA) have a fixed sample time: when a run's sampling is
//! irregular or differs from it, the inputs are resampled to the model's
//! grid by linear interpolation, the model runs on the grid, and its outputs
//! are interpolated back to the run's rows. Whatever was done is reported as
//! a note, never silently.
//!
//! A five-point model's predictions also carry the tool-tip drift from its
//! outputs and each row's `tool_mm`, as the hub computes it.

use crate::data::cells::{CellColumn, Cells, LastLogged};
use crate::data::runfile::{resample_linear, uniform_grid_len, RunFile, Sampling, TIME_COLUMN};
use crate::fivepoint::TOOL_COLUMN;
use anyhow::{bail, Result};
use model_core::fivepoint::{TipMap, TIP_OUTPUTS};
use model_core::model::{ModelState, StepError, MAX_OUTPUTS};
use model_core::ValidModel;
use std::collections::HashMap;

/// `--map NAME=COLUMN`: read a model name from a differently named column.
#[derive(Clone, Debug, Default)]
pub struct ColumnMap(HashMap<String, String>);

impl ColumnMap {
    /// Parses `NAME=COLUMN` pairs.
    pub fn parse(pairs: &[String]) -> Result<Self> {
        let mut map = HashMap::new();
        for p in pairs {
            let Some((name, col)) = p.split_once('=') else {
                bail!("--map {p}: expected NAME=COLUMN");
            };
            let (name, col) = (name.trim(), col.trim());
            if name.is_empty() || col.is_empty() {
                bail!("--map {p}: expected NAME=COLUMN");
            }
            if col == TIME_COLUMN {
                bail!(
                    "--map {p}: {TIME_COLUMN} is the run's time, not an input or a measured column"
                );
            }
            if let Some(before) = map.insert(name.to_string(), col.to_string()) {
                bail!("--map {p}: {name} is mapped twice (to {before} and to {col})");
            }
        }
        Ok(Self(map))
    }

    /// Refuses a pair whose NAME the model neither reads nor predicts (a
    /// typo would otherwise be ignored without a word).
    pub fn check_names(&self, model: &ValidModel) -> Result<()> {
        let inputs: Vec<&str> = model.inputs().iter().map(|c| c.name.as_str()).collect();
        let outputs = prediction_names(model);
        let mut names: Vec<&String> = self.0.keys().collect();
        names.sort();
        for name in names {
            let known = inputs.contains(&name.as_str())
                || outputs.contains(name)
                || (model.five_point().is_some() && name == TOOL_COLUMN);
            if !known {
                bail!(
                    "--map {name}={}: the model has no input or output {name} (inputs: {}; \
                     outputs: {})",
                    self.0[name],
                    inputs.join(", "),
                    outputs.join(", ")
                );
            }
        }
        Ok(())
    }

    /// The columns a model reads (and, with `outputs`, the measured columns
    /// its outputs are compared with).
    pub fn model_columns(&self, model: &ValidModel, outputs: bool) -> Vec<String> {
        let inputs = model.inputs().iter().map(|c| c.name.as_str());
        let names = prediction_names(model);
        let outs = names.iter().map(String::as_str).filter(|_| outputs);
        // A five-point model's tip needs each row's tool length.
        let tool = model.five_point().map(|_| TOOL_COLUMN);
        inputs
            .chain(outs)
            .chain(tool)
            .map(|n| self.column(n).to_string())
            .collect()
    }

    /// The column that carries model name `name`.
    pub fn column<'a>(&'a self, name: &'a str) -> &'a str {
        self.0.get(name).map_or(name, String::as_str)
    }
}

/// A model's predictions for one run, row for row.
#[derive(Clone, Debug)]
pub struct Prediction {
    /// `values[k][row]`: output `k` at each row (None where it cannot be had).
    pub values: Vec<Vec<Option<f64>>>,
    /// `bands[k][row]`: half-width of output `k`'s 95 % band at each row
    /// (the model's calibration-CV band widened by how far the inputs lie
    /// outside its calibration envelope); empty when the model carries no
    /// bounds.
    pub bands: Vec<Vec<Option<f64>>>,
    /// What the runner did that the user should know.
    pub notes: Vec<String>,
}

/// The error of a run without the column model input `name` is read from
/// (`col`, which a `--map` may have renamed), listing the run's columns.
pub fn missing_input(file: &str, name: &str, col: &str, columns: &[String]) -> anyhow::Error {
    let via = if col == name {
        String::new()
    } else {
        format!(" (mapped to \"{col}\")")
    };
    anyhow::anyhow!(
        "{file}: the model needs input \"{name}\"{via} but the run has no such column (columns: {})",
        columns.join(", ")
    )
}

/// The input columns of `model` in `run`, in channel order.
fn input_columns<'r>(
    model: &ValidModel,
    run: &'r RunFile,
    map: &ColumnMap,
) -> Result<Vec<Cells<'r>>> {
    model
        .inputs()
        .iter()
        .map(|ch| {
            let col = map.column(&ch.name);
            run.column(col).ok_or_else(|| {
                missing_input(&run.path.display().to_string(), &ch.name, col, &run.columns)
            })
        })
        .collect()
}

/// Outputs and band half-widths, `[output][sample]`.
pub type Stepped = (Vec<Vec<Option<f64>>>, Vec<Vec<Option<f64>>>);

/// The model stepped one row at a time from a fresh state, counting the
/// rows it could not predict (the notes of [`step_all`]).
pub struct RowStepper<'m> {
    model: &'m ValidModel,
    state: ModelState,
    x: Vec<f64>,
    out: [f64; MAX_OUTPUTS],
    rows: usize,
    missing: usize,
    overflow: usize,
    /// Samples refused for an input beyond the hub's magnitude limit.
    out_of_range: usize,
    /// Rows the hub would flag "extrapolating" (model-core
    /// `EXTRAPOLATION_FLAG_AT`).
    extrapolating: usize,
}

impl<'m> RowStepper<'m> {
    /// A fresh state for `model` (a run starts here).
    pub fn new(model: &'m ValidModel) -> Self {
        RowStepper {
            model,
            state: ModelState::new(),
            x: vec![0.0; model.inputs().len()],
            out: [0.0; MAX_OUTPUTS],
            rows: 0,
            missing: 0,
            overflow: 0,
            out_of_range: 0,
            extrapolating: 0,
        }
    }

    /// Steps one row of raw inputs (channel order): each output's value in
    /// `values` and, when the model carries bounds, its band half-width in
    /// `bands`; `None` where an input is missing or the step was refused.
    pub fn step(
        &mut self,
        inputs: impl IntoIterator<Item = Option<f64>>,
        values: &mut [Option<f64>],
        bands: &mut [Option<f64>],
    ) {
        self.rows += 1;
        values.iter_mut().for_each(|v| *v = None);
        bands.iter_mut().for_each(|b| *b = None);
        let mut complete = true;
        for (xi, v) in self.x.iter_mut().zip(inputs) {
            match v {
                Some(v) => *xi = v,
                None => complete = false,
            }
        }
        if !complete {
            self.missing += 1;
            return;
        }
        match self.model.step(&mut self.state, &self.x, &mut self.out) {
            Ok(()) => {
                for (slot, v) in values.iter_mut().zip(&self.out) {
                    *slot = Some(*v);
                }
                // After the step: a `First` reference is captured by then.
                let d = self.model.extrapolation(&self.state, &self.x);
                if d > ValidModel::EXTRAPOLATION_FLAG_AT {
                    self.extrapolating += 1;
                }
                for (k, slot) in bands.iter_mut().enumerate() {
                    *slot = self.model.band_half_width(k, d);
                }
            }
            Err(StepError::NonFiniteOutput) => self.overflow += 1,
            Err(StepError::InputOutOfRange { .. }) => self.out_of_range += 1,
            // Inputs are finite (the reader rejects the rest) and sized by
            // construction; count anything else with the overflows.
            Err(_) => self.overflow += 1,
        }
    }

    /// What the user should know about the rows stepped so far.
    pub fn notes(&self, notes: &mut Vec<String>) {
        let (missing, overflow, len) = (self.missing, self.overflow, self.rows);
        if missing > 0 {
            notes.push(format!(
                "{missing} of {len} samples lack an input value: no prediction there"
            ));
        }
        if overflow > 0 {
            notes.push(format!(
                "{overflow} samples gave a non-finite output and were held out"
            ));
        }
        if self.out_of_range > 0 {
            notes.push(format!(
                "{} of {len} samples have an input beyond {:e} in magnitude, which the hub \
                 refuses as a broken reading: no prediction there",
                self.out_of_range,
                model_core::model::MAX_INPUT_MAGNITUDE
            ));
        }
        if self.extrapolating > 0 {
            let pct = 100.0 * self.extrapolating as f64 / len.max(1) as f64;
            notes.push(format!(
                "{} of {len} samples ({pct:.1} %) lie outside the model's calibration envelope \
                 (the hub flags them \"extrapolating\"; the error band widens there)",
                self.extrapolating
            ));
        }
    }
}

/// Steps the model over aligned input samples (`inputs[channel][sample]`,
/// raw values in channel order) from a fresh state; `None` where an input
/// is missing or the step was refused. With bounds, also each output's band.
pub fn step_all<C: CellColumn>(
    model: &ValidModel,
    inputs: &[C],
    len: usize,
    notes: &mut Vec<String>,
) -> Stepped {
    let n_out = model.outputs().len();
    let with_bands = model.model().bounds.is_some();
    let n_bands = if with_bands { n_out } else { 0 };
    let mut values = vec![Vec::with_capacity(len); n_out];
    let mut bands = vec![Vec::with_capacity(len); n_bands];
    let mut stepper = RowStepper::new(model);
    let (mut row_values, mut row_bands) = (vec![None; n_out], vec![None; n_bands]);
    for i in 0..len {
        let row = inputs.iter().map(|c| c.cell(i));
        stepper.step(row, &mut row_values, &mut row_bands);
        for (col, v) in values.iter_mut().zip(&row_values) {
            col.push(*v);
        }
        for (col, b) in bands.iter_mut().zip(&row_bands) {
            col.push(*b);
        }
    }
    stepper.notes(notes);
    (values, bands)
}

/// The columns [`predict`] fills, in [`Prediction::values`] order: the
/// model's outputs, then, for a five-point model, the tool-tip drift
/// `dx_um`, `dy_um`, `dz_um` (docs/fivepoint.md).
pub fn prediction_names(model: &ValidModel) -> Vec<String> {
    let tip = model.five_point().map_or(&[][..], |_| &TIP_OUTPUTS[..]);
    model
        .outputs()
        .iter()
        .map(|o| o.to_string())
        .chain(tip.iter().map(|t| (*t).to_string()))
        .collect()
}

/// Runs `model` over one run file: one value per [`prediction_names`] and row.
pub fn predict(model: &ValidModel, run: &RunFile, map: &ColumnMap) -> Result<Prediction> {
    let mut p = predict_outputs(model, run, map)?;
    if let Some(tip) = model.five_point() {
        let tool = run.column(map.column(TOOL_COLUMN));
        if tool.is_none() {
            p.notes.push(tool_note());
        }
        let tip_values = tool_tip_columns(tip, &p.values, tool, run.len());
        p.values.extend(tip_values);
    }
    Ok(p)
}

/// The note of a five-point model on a run without tool lengths.
pub fn tool_note() -> String {
    format!("no {TOOL_COLUMN} column: the tool-tip dx_um, dy_um, dz_um are left empty")
}

/// The tip drift per row from a five-point model's outputs and the row's
/// tool length (the last one logged where the cell is empty; empty where
/// an output or every tool length so far is missing), as the hub computes
/// it.
fn tool_tip_columns(
    tip: &TipMap,
    outputs: &[Vec<Option<f64>>],
    tool: Option<Cells<'_>>,
    len: usize,
) -> [Vec<Option<f64>>; 3] {
    let mut cols: [Vec<Option<f64>>; 3] = Default::default();
    let mut values = Vec::with_capacity(outputs.len());
    let mut hold = LastLogged::default();
    for row in 0..len {
        values.clear();
        values.extend(outputs.iter().map(|c| c.get(row).copied().flatten()));
        let tool_mm = hold.next(tool.and_then(|t| t.get(row)));
        let drift = tool_tip_row(tip, &values, tool_mm);
        for (col, d) in cols.iter_mut().zip(drift) {
            col.push(d);
        }
    }
    cols
}

/// One row's tip drift `dx_um`, `dy_um`, `dz_um` from its outputs and tool
/// length (`None` where either is missing or the tip is refused).
pub fn tool_tip_row(
    tip: &TipMap,
    outputs: &[Option<f64>],
    tool_mm: Option<f64>,
) -> [Option<f64>; 3] {
    let values: Option<Vec<f64>> = outputs.iter().copied().collect();
    let drift = values
        .zip(tool_mm)
        .and_then(|(v, t)| tip.tool_tip(&v, t).ok());
    [0, 1, 2].map(|k| drift.map(|d| d[k]))
}

/// Whether a dynamic model of step `dt` runs on a run's own rows (else its
/// inputs are resampled to the model's grid).
pub fn on_model_grid(sampling: &Sampling, dt: f64) -> bool {
    let median = sampling.dt_median_s.unwrap_or(dt);
    sampling.n < 2 || (sampling.is_uniform && (median - dt).abs() <= 1e-6 * dt.max(1e-9))
}

/// A dynamic model's grid over a run it cannot step row by row: the points
/// `(t0 + k dt).min(t_end)` of [`uniform_grid`], and one more step,
/// `t0 + len dt`, when the run ends after the last whole step (the rows
/// there would have no grid point to their right; that step reads the
/// inputs at the run's last time, held). docs/models.md, "Sampling".
#[derive(Clone, Copy, Debug)]
pub struct ModelGrid {
    t0: f64,
    t_end: f64,
    dt: f64,
    whole: usize,
    extra: bool,
}

impl ModelGrid {
    /// The grid over a run's first and last times `span` (`None`: no rows),
    /// refused when it would be mostly interpolation between the run's
    /// rows (`sampling`; [`Sampling::check_grid`]).
    pub fn new(span: Option<(f64, f64)>, dt: f64, sampling: &Sampling) -> Result<Self> {
        let Some((t0, t_end)) = span else {
            bail!("no rows");
        };
        let whole = uniform_grid_len(t0, t_end, dt).map_err(|e| anyhow::anyhow!("{e}"))?;
        sampling
            .check_grid(whole, dt)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let last = (t0 + (whole - 1) as f64 * dt).min(t_end);
        Ok(Self {
            t0,
            t_end,
            dt,
            whole,
            extra: last < t_end,
        })
    }

    /// The step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Points, the extra step included (at least one: a run has a row).
    pub fn points(&self) -> usize {
        self.whole + usize::from(self.extra)
    }

    /// Point `k` (`k < points`).
    pub fn point(&self, k: usize) -> f64 {
        let t = self.t0 + k as f64 * self.dt;
        if k < self.whole {
            t.min(self.t_end)
        } else {
            t
        }
    }

    /// The time at which point `k`'s inputs are read: the point, or the
    /// run's last time for the extra step.
    pub fn input_time(&self, k: usize) -> f64 {
        self.point(k).min(self.t_end)
    }

    /// The last whole step when an extra step follows it.
    pub fn last_whole_step(&self) -> Option<f64> {
        self.extra.then(|| self.point(self.whole - 1))
    }

    /// The note of the extra step, `tail` rows lying after the last whole one.
    pub fn extra_step_note(&self, tail: usize) -> String {
        let last = self.point(self.whole - 1);
        format!(
            "the last {tail} row(s) lie after the last whole step ({last} s): the model takes one more step, to {} s, with the inputs held at their values at {} s",
            self.point(self.whole),
            self.t_end
        )
    }
}

/// The note of a run whose inputs are resampled to a dynamic model's step
/// `dt` (`rows`: the run's rows).
pub fn resampled_note(sampling: &Sampling, dt: f64, rows: usize) -> String {
    let median = sampling.dt_median_s.unwrap_or(dt);
    let why = if sampling.is_uniform {
        format!("sampled every {median} s")
    } else {
        format!(
            "sampling irregular (steps {}..{} s)",
            sampling.dt_min_s.unwrap_or(median),
            sampling.dt_max_s.unwrap_or(median)
        )
    };
    format!(
        "{why}: inputs resampled to the model's dt {dt} s by linear interpolation, outputs interpolated back to the {rows} rows"
    )
}

/// Missing cells of one input column that lie between two present ones
/// (a gap linear interpolation bridges), counted row by row: cells before
/// the first value or after the last are not bridged (no prediction
/// there, which a note of its own says).
#[derive(Clone, Copy, Debug, Default)]
pub struct BridgedCells {
    seen: bool,
    pending: usize,
    bridged: usize,
}

impl BridgedCells {
    /// Takes the next row's cell: present or missing.
    pub fn push(&mut self, present: bool) {
        if present {
            self.bridged += if self.seen { self.pending } else { 0 };
            self.pending = 0;
            self.seen = true;
        } else {
            self.pending += 1;
        }
    }

    /// Cells bridged so far.
    pub fn bridged(&self) -> usize {
        self.bridged
    }
}

/// The note of missing input cells bridged for a dynamic model.
pub fn bridged_note(bridged: usize) -> String {
    format!(
        "{bridged} missing input cells bridged by linear interpolation (the model's state needs every sample)"
    )
}

/// Runs `model` over one run file: its own outputs only.
fn predict_outputs(model: &ValidModel, run: &RunFile, map: &ColumnMap) -> Result<Prediction> {
    let columns = input_columns(model, run, map)?;
    let mut notes = Vec::new();
    let n = run.len();
    let dt = model.model().dt_s;
    if !model.kind().is_dynamic() {
        let (values, bands) = step_all(model, &columns, n, &mut notes);
        return Ok(Prediction {
            values,
            bands,
            notes,
        });
    }
    let sampling = run.sampling();
    let on_grid = on_model_grid(&sampling, dt);
    let grid: Vec<f64> = if on_grid {
        run.t_s.clone()
    } else {
        let span = run.t_s.first().copied().zip(run.t_s.last().copied());
        let grid = ModelGrid::new(span, dt, &sampling)
            .map_err(|e| anyhow::anyhow!("{}: {e}", run.path.display()))?;
        notes.push(resampled_note(&sampling, dt, n));
        if let Some(last) = grid.last_whole_step() {
            let tail = run.t_s.iter().filter(|&&t| t > last).count();
            notes.push(grid.extra_step_note(tail));
        }
        (0..grid.points()).map(|k| grid.point(k)).collect()
    };
    // The times at which the inputs are read for each grid point: the grid
    // itself, except a point past the run's end, which reads the inputs at
    // the last row (held, not extrapolated). docs/models.md, "Sampling".
    let t_end = run.t_s.last().copied().unwrap_or(0.0);
    let input_t: Vec<f64> = grid.iter().map(|&g| g.min(t_end)).collect();
    let mut bridged = 0usize;
    let inputs: Vec<Vec<Option<f64>>> = columns
        .iter()
        .map(|c| {
            let mut count = BridgedCells::default();
            c.iter().for_each(|v| count.push(v.is_some()));
            bridged += count.bridged();
            resample_linear(&run.t_s, *c, &input_t)
        })
        .collect();
    if bridged > 0 {
        notes.push(bridged_note(bridged));
    }
    let (on_grid_values, on_grid_bands) = step_all(model, &inputs, grid.len(), &mut notes);
    let back = |cols: Vec<Vec<Option<f64>>>| -> Vec<Vec<Option<f64>>> {
        if on_grid {
            cols
        } else {
            cols.iter()
                .map(|v| resample_linear(&grid, v.iter().copied(), &run.t_s))
                .collect()
        }
    };
    Ok(Prediction {
        values: back(on_grid_values),
        bands: back(on_grid_bands),
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::runfile::ReadOptions;

    fn run(csv: &str) -> RunFile {
        RunFile::from_reader("t.csv", csv.as_bytes(), &ReadOptions::default()).unwrap()
    }

    fn first_order() -> ValidModel {
        crate::data::spec::parse(
            "m.toml",
            "kind = \"tf\"\ndt_s = 1.0\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\na = [0.5]\nb = [1.0, -0.5]\n",
        )
        .unwrap()
    }

    #[test]
    fn uniform_run_steps_row_by_row() {
        let p = predict(
            &first_order(),
            &run("t_s,T1\n0,20\n1,21\n2,21\n3,21\n"),
            &ColumnMap::default(),
        )
        .unwrap();
        // Step of +1 K from the first sample: 0, 0.5, 0.75, 0.875 exactly.
        assert_eq!(p.values[0], [Some(0.0), Some(0.5), Some(0.75), Some(0.875)]);
        assert!(p.notes.is_empty());
    }

    #[test]
    fn coarser_run_is_resampled_and_says_so() {
        // Rows every 2 s, model dt 1 s: the grid adds t = 1, 3 with T1 = 20.5, 21.
        let p = predict(
            &first_order(),
            &run("t_s,T1\n0,20\n2,21\n4,21\n"),
            &ColumnMap::default(),
        )
        .unwrap();
        // Grid outputs: k0 0; k1 0.25; k2 0.625; k3 0.8125; k4 0.90625.
        assert_eq!(p.values[0], [Some(0.0), Some(0.625), Some(0.90625)]);
        assert!(p.notes[0].contains("resampled"), "{:?}", p.notes);
    }

    #[test]
    fn rows_after_the_last_whole_step_are_predicted() {
        // Rows at 0, 1.5, 3.5 s, model dt 1 s: the grid 0..3 s gets one more
        // step, to 4 s, with T1 held at its value at 3.5 s. Grid inputs
        // (minus the first, 20): 0, 2/3, 1, 1, 1; outputs y = y/2 + u/2:
        // 0, 1/3, 2/3, 5/6, 11/12. Rows: 0; (1/3 + 2/3)/2 = 0.5;
        // (5/6 + 11/12)/2 = 0.875.
        let p = predict(
            &first_order(),
            &run("t_s,T1\n0,20\n1.5,21\n3.5,21\n"),
            &ColumnMap::default(),
        )
        .unwrap();
        let want = [0.0, 0.5, 0.875];
        assert_eq!(p.values[0].len(), 3);
        for (got, want) in p.values[0].iter().zip(want) {
            let got = got.expect("every row has a prediction");
            assert!((got - want).abs() <= 1e-12, "{got} vs {want}");
        }
        assert!(
            p.notes.iter().any(|n| n.contains("one more step, to 4 s")),
            "{:?}",
            p.notes
        );
    }

    #[test]
    fn missing_column_and_mapping() {
        let r = run("t_s,temp1\n0,20\n1,21\n");
        let e = predict(&first_order(), &r, &ColumnMap::default()).unwrap_err();
        assert!(e.to_string().contains("needs input \"T1\""), "{e}");
        let map = ColumnMap::parse(&["T1=temp1".into()]).unwrap();
        assert_eq!(
            predict(&first_order(), &r, &map).unwrap().values[0][1],
            Some(0.5)
        );
    }
}
