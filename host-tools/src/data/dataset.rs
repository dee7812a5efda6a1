//! Training data for `fit`: the input and target columns of every run,
//! aligned, in the form the model will see them, and split into a
//! calibration part and a held-out part.
//!
//! A run is split in time (`--holdout-from-s`: rows at or after it are held
//! out, as "calibrate on the first 24 h, validate on the rest"); runs given
//! with `--validate` are held out whole. Fits only ever see calibration
//! rows; every figure reported as held-out comes from rows no fit touched.

use crate::data::runfile::{resample_linear, uniform_grid, RunFile};
use anyhow::{anyhow, bail, Result};
use model_core::Reference;

/// How temperatures enter a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum InputForm {
    /// Changes from each run's first sample (the model's `reference = "first"`).
    Change,
    /// Values as logged.
    Absolute,
}

impl InputForm {
    /// The model reference that reproduces this form on the hub.
    pub fn reference(self) -> Reference {
        match self {
            Self::Change => Reference::First,
            Self::Absolute => Reference::Absolute,
        }
    }

    /// The name used in specs and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Change => "first",
            Self::Absolute => "absolute",
        }
    }
}

/// One run's columns, inputs already in the model's form.
#[derive(Clone, Debug)]
pub struct RunData {
    /// The file, for messages.
    pub name: String,
    /// Sample times.
    pub t_s: Vec<f64>,
    /// `x[i][row]`: input `i` (reference-adjusted; `None` where missing).
    pub x: Vec<Vec<Option<f64>>>,
    /// `y[k][row]`: target `k`.
    pub y: Vec<Vec<Option<f64>>>,
    /// Rows `..calib_end` are calibration, the rest held out.
    pub calib_end: usize,
}

/// A run resampled to a model's sample time, gaps bridged, trimmed to where
/// every column has a value: what a dynamic model is fitted on.
#[derive(Clone, Debug)]
pub struct GridRun {
    /// The file, for messages.
    pub name: String,
    /// Grid times `t0 + k dt`.
    pub t_s: Vec<f64>,
    /// `x[i][k]`.
    pub x: Vec<Vec<f64>>,
    /// `y[j][k]`.
    pub y: Vec<Vec<f64>>,
    /// Samples `..calib_end` are calibration.
    pub calib_end: usize,
}

/// Every run of a fit, with the names of its inputs and targets.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Input column names.
    pub inputs: Vec<String>,
    /// Target column names.
    pub targets: Vec<String>,
    /// The form of the inputs.
    pub form: InputForm,
    /// Calibration runs (possibly with a held-out tail) and validation runs.
    pub runs: Vec<RunData>,
}

/// `out[i] = cols[i][r]`; false when a cell is missing.
fn fill(out: &mut [f64], cols: &[Vec<Option<f64>>], r: usize) -> bool {
    for (o, c) in out.iter_mut().zip(cols) {
        match c[r] {
            Some(v) => *o = v,
            None => return false,
        }
    }
    true
}

fn column<'a>(run: &'a RunFile, name: &str) -> Result<&'a [Option<f64>]> {
    run.column(name).ok_or_else(|| {
        anyhow!(
            "{}: no column \"{name}\" (columns: {})",
            run.path.display(),
            run.columns.join(", ")
        )
    })
}

impl Dataset {
    /// Assembles the data: `runs` are split at `holdout_from_s` (if given),
    /// `validate` runs are held out whole.
    pub fn new(
        runs: &[RunFile],
        validate: &[RunFile],
        inputs: &[String],
        targets: &[String],
        form: InputForm,
        holdout_from_s: Option<f64>,
    ) -> Result<Self> {
        if inputs.is_empty() || targets.is_empty() {
            bail!("a fit needs at least one --inputs column and one --target column");
        }
        let mut out = Vec::new();
        for (run, held_out_whole) in runs
            .iter()
            .map(|r| (r, false))
            .chain(validate.iter().map(|r| (r, true)))
        {
            let raw: Vec<&[Option<f64>]> = inputs
                .iter()
                .map(|c| column(run, c))
                .collect::<Result<_>>()?;
            let y: Vec<Vec<Option<f64>>> = targets
                .iter()
                .map(|c| column(run, c).map(<[_]>::to_vec))
                .collect::<Result<_>>()?;
            for (name, c) in inputs.iter().zip(&raw) {
                check_column(run, name, c)?;
            }
            for (name, c) in targets.iter().zip(&y) {
                check_column(run, name, c)?;
            }
            // The reference is the first row where every input has a value:
            // the same row at which the hub (and `predict`) captures it.
            let first = (0..run.len()).find(|&r| raw.iter().all(|c| c[r].is_some()));
            let x = raw
                .iter()
                .map(|c| {
                    let r0 = first.and_then(|r| c[r]).unwrap_or(0.0);
                    c.iter()
                        .map(|v| match form {
                            InputForm::Absolute => *v,
                            InputForm::Change => v.map(|v| v - r0),
                        })
                        .collect()
                })
                .collect();
            let calib_end = if held_out_whole {
                0
            } else {
                holdout_from_s.map_or(run.len(), |h| run.t_s.partition_point(|t| *t < h))
            };
            out.push(RunData {
                name: run.path.display().to_string(),
                t_s: run.t_s.clone(),
                x,
                y,
                calib_end,
            });
        }
        let ds = Self {
            inputs: inputs.to_vec(),
            targets: targets.to_vec(),
            form,
            runs: out,
        };
        if ds.calibration_len() == 0 {
            bail!("no calibration rows: every row is held out or lacks a value (check --holdout-from-s and the columns)");
        }
        Ok(ds)
    }

    /// Calibration rows with every input and target present, as row vectors
    /// `(x rows, y rows)`: what a static fit (mlr, pcr) is fitted on.
    pub fn calibration_rows(&self) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for run in &self.runs {
            for r in 0..run.calib_end {
                let x: Option<Vec<f64>> = run.x.iter().map(|c| c[r]).collect();
                let y: Option<Vec<f64>> = run.y.iter().map(|c| c[r]).collect();
                if let (Some(x), Some(y)) = (x, y) {
                    xs.push(x);
                    ys.push(y);
                }
            }
        }
        (xs, ys)
    }

    /// Each run file with the row where its held-out part starts: the
    /// calibration runs (`runs`, in this dataset's order) at their split,
    /// the validation runs (`validate`) held out whole. What scoring a
    /// fitted model on calibration and held-out rows needs.
    pub fn scoring_split<'a>(
        &self,
        runs: &'a [RunFile],
        validate: &'a [RunFile],
    ) -> Vec<(&'a RunFile, usize)> {
        runs.iter()
            .zip(&self.runs)
            .map(|(r, d)| (r, d.calib_end))
            .chain(validate.iter().map(|r| (r, 0)))
            .collect()
    }

    /// Calls `f(x, y)` for every calibration row with every input and
    /// target, in the order of [`Dataset::calibration_rows`], from one
    /// reused buffer: the rows are never copied out.
    pub fn visit_calibration_rows(&self, f: &mut dyn FnMut(&[f64], &[f64])) {
        let mut x = vec![0.0; self.inputs.len()];
        let mut y = vec![0.0; self.targets.len()];
        for run in &self.runs {
            for r in 0..run.calib_end {
                if fill(&mut x, &run.x, r) && fill(&mut y, &run.y, r) {
                    f(&x, &y);
                }
            }
        }
    }

    /// How many calibration rows have every input and target (what
    /// [`Dataset::calibration_rows`] returns), counted without copying them.
    pub fn calibration_len(&self) -> usize {
        self.runs
            .iter()
            .map(|run| {
                (0..run.calib_end)
                    .filter(|&r| run.x.iter().chain(&run.y).all(|c| c[r].is_some()))
                    .count()
            })
            .sum()
    }

    /// Rows held out from calibration (in held-out tails and validation runs).
    pub fn holdout_len(&self) -> usize {
        self.runs.iter().map(|r| r.t_s.len() - r.calib_end).sum()
    }

    /// Every run resampled to `dt_s` (linear interpolation, gaps bridged),
    /// trimmed to the span where every input and target has a value.
    pub fn on_grid(&self, dt_s: f64) -> Result<Vec<GridRun>> {
        let mut out = Vec::new();
        for run in &self.runs {
            let cols = run.x.iter().chain(&run.y);
            // Span where every column has at least started and not yet ended.
            let mut lo = f64::NEG_INFINITY;
            let mut hi = f64::INFINITY;
            for c in cols {
                let first = c.iter().position(Option::is_some);
                let last = c.iter().rposition(Option::is_some);
                match (first, last) {
                    (Some(a), Some(b)) => {
                        lo = lo.max(run.t_s[a]);
                        hi = hi.min(run.t_s[b]);
                    }
                    _ => bail!("{}: a column has no values", run.name),
                }
            }
            if hi <= lo {
                continue;
            }
            let grid = uniform_grid(lo, hi, dt_s).map_err(|e| anyhow!("{}: {e}", run.name))?;
            let fill = |c: &Vec<Option<f64>>| -> Vec<f64> {
                resample_linear(&run.t_s, c, &grid)
                    .into_iter()
                    .map(|v| v.unwrap_or(0.0))
                    .collect()
            };
            let split_t = run.t_s.get(run.calib_end).copied().unwrap_or(f64::INFINITY);
            out.push(GridRun {
                name: run.name.clone(),
                calib_end: grid.partition_point(|t| *t < split_t),
                x: run.x.iter().map(fill).collect(),
                y: run.y.iter().map(fill).collect(),
                t_s: grid,
            });
        }
        Ok(out)
    }
}

/// Refuses a column too large to centre and scale, naming file and column
/// (see [`crate::num::linalg::check_scalable`]).
fn check_column(run: &RunFile, name: &str, values: &[Option<f64>]) -> Result<()> {
    let label = format!("{}: column {name}", run.path.display());
    crate::num::linalg::check_scalable(&label, values.iter().flatten().copied())
}

/// Refuses any column read from `run` that is too large to centre and
/// scale, naming file and column: for callers that fit or rank on every
/// column they read (refit, select).
pub fn check_scalable_columns(run: &RunFile) -> Result<()> {
    for (name, values) in run.iter_columns() {
        check_column(run, name, values)?;
    }
    Ok(())
}
