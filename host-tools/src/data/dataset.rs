//! Training data for `fit`: the input and target columns of every run,
//! aligned, in the form the model will see them, and split into a
//! calibration part and a held-out part.
//!
//! A run is split in time (`--holdout-from-s`: rows at or after it are held
//! out, as "calibrate on the first 24 h, validate on the rest"); runs given
//! with `--validate` are held out whole. Fits only ever see calibration
//! rows; every figure reported as held-out comes from rows no fit touched.

use crate::data::cells::{self, Cells};
use crate::data::runfile::{resample_linear, uniform_grid, uniform_grid_len, RunFile, Sampling};
use anyhow::{anyhow, bail, Result};
use model_core::Reference;
use std::borrow::Cow;

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

/// One run's columns: the inputs as the model sees them (see
/// [`RunData::x`]), the targets, and where the held-out part starts.
///
/// The columns are the run file's own, borrowed (no copy: a 1 M-row fit
/// would otherwise hold every input twice), or owned when they were derived
/// (a grid, a reduced input set); either way stored as
/// [`crate::data::cells`] (`NaN` for a missing cell).
#[derive(Clone, Debug)]
pub struct RunData<'a> {
    /// The file, for messages.
    pub name: String,
    /// Sample times.
    pub t_s: Cow<'a, [f64]>,
    /// `x[i]`: input `i` as stored, before `x_ref[i]` is taken off.
    x: Vec<Cow<'a, [f64]>>,
    /// `x_ref[i]`: what is subtracted from input `i` (its reference value
    /// in the change form, 0 in the absolute form).
    x_ref: Vec<f64>,
    /// `y[k]`: target `k` as stored.
    y: Vec<Cow<'a, [f64]>>,
    /// Rows `..calib_end` are calibration, the rest held out.
    pub calib_end: usize,
}

impl<'a> RunData<'a> {
    /// A run of derived columns (no reference taken off: `x` is as the model
    /// sees it), every cell present.
    pub fn owned(
        name: String,
        t_s: Vec<f64>,
        x: Vec<Vec<f64>>,
        y: Vec<Vec<f64>>,
        calib_end: usize,
    ) -> RunData<'static> {
        RunData {
            name,
            t_s: Cow::Owned(t_s),
            x_ref: vec![0.0; x.len()],
            x: x.into_iter().map(Cow::Owned).collect(),
            y: y.into_iter().map(Cow::Owned).collect(),
            calib_end,
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether the run has no rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Input `i` at `row` in the model's form (`None` where missing).
    pub fn x(&self, i: usize, row: usize) -> Option<f64> {
        let stored = self.x.get(i)?.get(row)?;
        cells::read(stored - self.x_ref[i])
    }

    /// Target `k` at `row` (`None` where missing).
    pub fn y(&self, k: usize, row: usize) -> Option<f64> {
        cells::read(*self.y.get(k)?.get(row)?)
    }

    /// Input `i` in the model's form, every row.
    pub fn x_column(&self, i: usize) -> Vec<Option<f64>> {
        (0..self.len()).map(|r| self.x(i, r)).collect()
    }

    /// Target `k`, every row.
    pub fn y_column(&self, k: usize) -> Cells<'_> {
        self.y.get(k).map_or_else(Cells::default, |c| Cells::new(c))
    }

    /// The inputs at `row` in the model's form, `None` if one is missing.
    pub fn x_row(&self, row: usize) -> Option<Vec<f64>> {
        (0..self.x.len()).map(|i| self.x(i, row)).collect()
    }

    /// The targets at `row`, `None` if one is missing.
    pub fn y_row(&self, row: usize) -> Option<Vec<f64>> {
        (0..self.y.len()).map(|k| self.y(k, row)).collect()
    }

    /// `x[i] = input i at row` and `y[k] = target k at row`; false when a
    /// cell is missing (the buffers then hold `NaN`s).
    fn fill(&self, row: usize, x: &mut [f64], y: &mut [f64]) -> bool {
        for ((o, c), r0) in x.iter_mut().zip(&self.x).zip(&self.x_ref) {
            *o = c[row] - r0;
        }
        for (o, c) in y.iter_mut().zip(&self.y) {
            *o = c[row];
        }
        !x.iter().chain(y.iter()).any(|v| v.is_nan())
    }

    /// This run with only the inputs `idx` (in that order). In the change
    /// form the reference is re-taken at the first row where every kept
    /// input has a value (from the inputs as they were, so the values are
    /// those of subtracting it from them).
    pub fn with_inputs(&self, idx: &[usize], form: InputForm) -> RunData<'a> {
        let mut out = RunData {
            x: idx.iter().map(|&i| self.x[i].clone()).collect(),
            x_ref: idx.iter().map(|&i| self.x_ref[i]).collect(),
            ..self.clone_without_inputs()
        };
        if form == InputForm::Change {
            if let Some(first) =
                (0..out.len()).find(|&r| (0..idx.len()).all(|i| out.x(i, r).is_some()))
            {
                for i in 0..idx.len() {
                    let column = out.x_column(i);
                    out.x[i] = Cow::Owned(column.iter().map(|v| cells::stored(*v)).collect());
                    out.x_ref[i] = column[first].unwrap_or(0.0);
                }
            }
        }
        out
    }

    /// A copy with no inputs (the rest borrowed as it is).
    fn clone_without_inputs(&self) -> RunData<'a> {
        RunData {
            name: self.name.clone(),
            t_s: self.t_s.clone(),
            x: Vec::new(),
            x_ref: Vec::new(),
            y: self.y.clone(),
            calib_end: self.calib_end,
        }
    }
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
    /// `x_lead[i][k]`: input `i` on the same grid before `t0`, from where
    /// every input has a value (where the hub starts and takes its
    /// references) to where the targets start; empty when they start
    /// together. A model's state and a change's reference start here.
    /// One per input, all of the same length (or every one empty).
    pub x_lead: Vec<Vec<f64>>,
    /// `y[j][k]`.
    pub y: Vec<Vec<f64>>,
    /// Samples `..calib_end` are calibration.
    pub calib_end: usize,
}

/// Every run of a fit, with the names of its inputs and targets.
#[derive(Clone, Debug)]
pub struct Dataset<'a> {
    /// Input column names.
    pub inputs: Vec<String>,
    /// Target column names.
    pub targets: Vec<String>,
    /// The form of the inputs.
    pub form: InputForm,
    /// Calibration runs (possibly with a held-out tail) and validation runs.
    pub runs: Vec<RunData<'a>>,
}

fn column<'a>(run: &'a RunFile, name: &str) -> Result<Cells<'a>> {
    run.column(name).ok_or_else(|| {
        anyhow!(
            "{}: no column \"{name}\" (columns: {})",
            run.path.display(),
            run.columns.join(", ")
        )
    })
}

/// The columns `names` of `run`.
fn columns<'a>(run: &'a RunFile, names: &[String]) -> Result<Vec<Cells<'a>>> {
    names.iter().map(|c| column(run, c)).collect()
}

/// `run`'s inputs and targets, borrowed, with the inputs' reference in
/// `form`: the first row where every input has a value, the same row at
/// which the hub (and `predict`) captures it.
fn run_data<'a>(
    run: &'a RunFile,
    inputs: &[String],
    targets: &[String],
    form: InputForm,
    calib_end: usize,
) -> Result<RunData<'a>> {
    // No overflow check: a run file's columns always centre and scale (the
    // assertion beside `runfile::MAX_CELL_MAGNITUDE`).
    let x = columns(run, inputs)?;
    let y = columns(run, targets)?;
    let first = (0..run.len()).find(|&r| x.iter().all(|c| c.get(r).is_some()));
    let x_ref = x
        .iter()
        .map(|c| match form {
            InputForm::Absolute => 0.0,
            InputForm::Change => first.and_then(|r| c.get(r)).unwrap_or(0.0),
        })
        .collect();
    let borrow = |c: &Cells<'a>| Cow::Borrowed(c.stored());
    Ok(RunData {
        name: run.path.display().to_string(),
        t_s: Cow::Borrowed(&run.t_s),
        x: x.iter().map(borrow).collect(),
        x_ref,
        y: y.iter().map(borrow).collect(),
        calib_end,
    })
}

impl<'a> Dataset<'a> {
    /// Assembles the data: `runs` are split at `holdout_from_s` (if given),
    /// `validate` runs are held out whole. The columns are borrowed.
    pub fn new(
        runs: &'a [RunFile],
        validate: &'a [RunFile],
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
            let calib_end = if held_out_whole {
                0
            } else {
                holdout_from_s.map_or(run.len(), |h| run.t_s.partition_point(|t| *t < h))
            };
            out.push(run_data(run, inputs, targets, form, calib_end)?);
        }
        let ds = Self {
            inputs: inputs.to_vec(),
            targets: targets.to_vec(),
            form,
            runs: out,
        };
        if ds.complete_calibration_rows().next().is_none() {
            bail!("no calibration rows: every row is held out or lacks a value (check --holdout-from-s and the columns)");
        }
        Ok(ds)
    }

    /// This dataset restricted to the inputs `idx` (in that order), each
    /// run by [`RunData::with_inputs`].
    pub fn with_inputs(&self, idx: &[usize]) -> Dataset<'a> {
        Dataset {
            inputs: idx.iter().map(|&i| self.inputs[i].clone()).collect(),
            targets: self.targets.clone(),
            form: self.form,
            runs: self
                .runs
                .iter()
                .map(|r| r.with_inputs(idx, self.form))
                .collect(),
        }
    }

    /// Calibration rows with every input and target present, as row vectors
    /// `(x rows, y rows)`: what a static fit (mlr, pcr) is fitted on.
    pub fn calibration_rows(&self) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for run in &self.runs {
            for r in 0..run.calib_end {
                if let (Some(x), Some(y)) = (run.x_row(r), run.y_row(r)) {
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
    pub fn scoring_split<'r>(
        &self,
        runs: &'r [RunFile],
        validate: &'r [RunFile],
    ) -> Vec<(&'r RunFile, usize)> {
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
                if run.fill(r, &mut x, &mut y) {
                    f(&x, &y);
                }
            }
        }
    }

    /// How many calibration rows have every input and target (what
    /// [`Dataset::calibration_rows`] returns), counted without copying them.
    pub fn calibration_len(&self) -> usize {
        self.complete_calibration_rows().count()
    }

    /// The calibration rows with every input and target, as (run, row).
    fn complete_calibration_rows(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let mut x = vec![0.0; self.inputs.len()];
        let mut y = vec![0.0; self.targets.len()];
        self.runs
            .iter()
            .enumerate()
            .flat_map(|(i, run)| (0..run.calib_end).map(move |r| (i, r)))
            .filter(move |&(i, r)| self.runs[i].fill(r, &mut x, &mut y))
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
            let x: Vec<Vec<Option<f64>>> =
                (0..self.inputs.len()).map(|i| run.x_column(i)).collect();
            let y: Vec<Vec<Option<f64>>> = (0..self.targets.len())
                .map(|k| run.y_column(k).to_options())
                .collect();
            // Span where every column has at least started and not yet
            // ended; the inputs' own start (`lo_x`) opens the lead.
            let span = |cols: &[Vec<Option<f64>>], names: &[String]| -> Result<(f64, f64)> {
                let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
                for (c, name) in cols.iter().zip(names) {
                    let first = c.iter().position(Option::is_some);
                    let last = c.iter().rposition(Option::is_some);
                    match (first, last) {
                        (Some(a), Some(b)) => {
                            lo = lo.max(run.t_s[a]);
                            hi = hi.min(run.t_s[b]);
                        }
                        _ => bail!("{}: column {name} has no values", run.name),
                    }
                }
                Ok((lo, hi))
            };
            let (lo_x, hi_x) = span(&x, &self.inputs)?;
            let (lo_y, hi_y) = span(&y, &self.targets)?;
            let (lo, hi) = (lo_x.max(lo_y), hi_x.min(hi_y));
            if hi <= lo {
                continue;
            }
            let points =
                uniform_grid_len(lo_x, hi, dt_s).map_err(|e| anyhow!("{}: {e}", run.name))?;
            Sampling::of(&run.t_s)
                .check_grid(points, dt_s)
                .map_err(|e| anyhow!("{}: {e}", run.name))?;
            let mut grid =
                uniform_grid(lo_x, hi, dt_s).map_err(|e| anyhow!("{}: {e}", run.name))?;
            let lead_t: Vec<f64> = grid.drain(..grid.partition_point(|t| *t < lo)).collect();
            if grid.is_empty() {
                continue;
            }
            let fill = |c: &Vec<Option<f64>>| -> Vec<f64> {
                resample_linear(&run.t_s, c.iter().copied(), &grid)
                    .into_iter()
                    .map(|v| v.unwrap_or(0.0))
                    .collect()
            };
            // Calibration samples: those every column brackets with
            // calibration rows (no value of a held-out row interpolated in).
            let calib_t = x
                .iter()
                .chain(&y)
                .map(|c| {
                    c[..run.calib_end]
                        .iter()
                        .rposition(Option::is_some)
                        .map_or(f64::NEG_INFINITY, |i| run.t_s[i])
                })
                .fold(f64::INFINITY, f64::min);
            let lead = |c: &Vec<Option<f64>>| -> Vec<f64> {
                resample_linear(&run.t_s, c.iter().copied(), &lead_t)
                    .into_iter()
                    .map(|v| v.unwrap_or(0.0))
                    .collect()
            };
            out.push(GridRun {
                name: run.name.clone(),
                calib_end: grid.partition_point(|t| *t <= calib_t),
                x_lead: x.iter().map(lead).collect(),
                x: x.iter().map(fill).collect(),
                y: y.iter().map(fill).collect(),
                t_s: grid,
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::runfile::ReadOptions;

    fn run(csv: &str) -> RunFile {
        RunFile::from_reader("run.csv", csv.as_bytes(), &ReadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
    }

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| (*s).to_string()).collect()
    }

    /// Row 0 lacks T2, row 2 lacks the target: the reference is row 1's,
    /// and only rows 1 and 3 are calibration rows.
    const GAPPY: &str = "t_s,T1,T2,dz_um\n0,10,,1\n1,11,20,2\n2,12,21,\n3,13.5,22,4\n";

    #[test]
    fn empty_cells_stay_missing_and_the_reference_is_the_first_complete_row() {
        let runs = [run(GAPPY)];
        let ds = Dataset::new(
            &runs,
            &[],
            &names(&["T1", "T2"]),
            &names(&["dz_um"]),
            InputForm::Change,
            None,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let r = &ds.runs[0];
        // Exact: differences of the decimal values as doubles.
        assert_eq!(r.x_column(0), [Some(-1.0), Some(0.0), Some(1.0), Some(2.5)]);
        assert_eq!(r.x_column(1), [None, Some(0.0), Some(1.0), Some(2.0)]);
        assert_eq!(
            r.y_column(0).to_options(),
            [Some(1.0), Some(2.0), None, Some(4.0)]
        );
        assert_eq!(ds.calibration_len(), 2);
        let (xs, ys) = ds.calibration_rows();
        assert_eq!(xs, [vec![0.0, 0.0], vec![2.5, 2.0]]);
        assert_eq!(ys, [vec![2.0], vec![4.0]]);
        let mut visited = Vec::new();
        ds.visit_calibration_rows(&mut |x, y| visited.push((x.to_vec(), y.to_vec())));
        assert_eq!(visited, xs.into_iter().zip(ys).collect::<Vec<_>>());
    }

    #[test]
    fn the_absolute_form_is_the_logged_values_and_a_subset_re_references() {
        let runs = [run(GAPPY)];
        let (inputs, targets) = (names(&["T1", "T2"]), names(&["dz_um"]));
        let abs = Dataset::new(&runs, &[], &inputs, &targets, InputForm::Absolute, None)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            abs.runs[0].x_column(0),
            [Some(10.0), Some(11.0), Some(12.0), Some(13.5)]
        );
        let change = Dataset::new(&runs, &[], &inputs, &targets, InputForm::Change, None)
            .unwrap_or_else(|e| panic!("{e}"));
        // T1 alone is complete from row 0: its reference moves there.
        let t1 = change.with_inputs(&[0]);
        assert_eq!(t1.inputs, ["T1"]);
        assert_eq!(
            t1.runs[0].x_column(0),
            [Some(0.0), Some(1.0), Some(2.0), Some(3.5)]
        );
    }

    /// The grid's calibration samples never interpolate a held-out row:
    /// the target is blank from t = 3 to 5 and rows from t = 4.5 are held
    /// out, so the calibration grid ends at t = 2 (the target's last
    /// calibration value), whatever the held-out rows hold. Before, it ran
    /// to t = 5 (the first held-out row), its samples at 3 and 4 drawn
    /// towards the held-out value.
    #[test]
    fn the_grid_s_calibration_samples_never_reach_a_held_out_value() {
        let grid_of = |held_out_dz: f64| {
            let csv = format!(
                "t_s,T1,dz_um\n0,10,0\n1,11,1\n2,12,2\n3,13,\n4,14,\n5,15,{held_out_dz}\n6,16,6\n"
            );
            let runs = [run(&csv)];
            let ds = Dataset::new(
                &runs,
                &[],
                &names(&["T1"]),
                &names(&["dz_um"]),
                InputForm::Absolute,
                Some(4.5),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            ds.on_grid(1.0).unwrap_or_else(|e| panic!("{e}")).remove(0)
        };
        let (a, b) = (grid_of(5.0), grid_of(500.0));
        assert_eq!(a.t_s, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(a.calib_end, 3);
        assert_eq!(a.y[0][..3], b.y[0][..3]);
        assert_eq!(a.x[0][..3], b.x[0][..3]);
        // On the rows' own times the samples are the rows' values.
        assert_eq!(a.y[0][..3], [0.0, 1.0, 2.0]);
    }

    /// The target starts 2.5 s after the inputs (T2 at t = 1): the grid
    /// starts at the first sample of the hub's lattice (from t = 1, where
    /// every input has a value) at which the target has one, t = 3, and the
    /// inputs before it are the lead. Rows on the lattice: exact values.
    #[test]
    fn inputs_before_the_target_starts_are_the_grid_s_lead() {
        let csv =
            "t_s,T1,T2,dz_um\n0,10,,\n1,11,20,\n2,12,21,\n2.5,12.5,21.5,5\n3,13,22,6\n4,14,23,7\n";
        let runs = [run(csv)];
        let ds = Dataset::new(
            &runs,
            &[],
            &names(&["T1", "T2"]),
            &names(&["dz_um"]),
            InputForm::Absolute,
            None,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let g = ds.on_grid(1.0).unwrap_or_else(|e| panic!("{e}")).remove(0);
        assert_eq!(g.t_s, [3.0, 4.0]);
        assert_eq!(g.x_lead, [vec![11.0, 12.0], vec![20.0, 21.0]]);
        assert_eq!(g.x, [vec![13.0, 14.0], vec![22.0, 23.0]]);
        assert_eq!(g.y, [vec![6.0, 7.0]]);
        assert_eq!(g.calib_end, 2);
        // T1 as input, T2 as target: T1's row 0 is the lead; the other
        // way round the input starts after the target: no lead.
        let grid = |input: &str, target: &str| {
            let ds = Dataset::new(
                &runs,
                &[],
                &names(&[input]),
                &names(&[target]),
                InputForm::Absolute,
                None,
            )
            .unwrap_or_else(|e| panic!("{e}"));
            ds.on_grid(1.0).unwrap_or_else(|e| panic!("{e}")).remove(0)
        };
        let g = grid("T1", "T2");
        assert_eq!((g.t_s[0], &g.x_lead[0][..]), (1.0, &[10.0][..]));
        let g = grid("T2", "T1");
        assert_eq!((g.t_s[0], g.x_lead[0].len()), (1.0, 0));
    }

    #[test]
    fn a_missing_column_and_no_complete_row_are_errors_as_before() {
        let runs = [run(GAPPY)];
        let e = Dataset::new(
            &runs,
            &[],
            &names(&["T9"]),
            &names(&["dz_um"]),
            InputForm::Change,
            None,
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "run.csv: no column \"T9\" (columns: T1, T2, dz_um)"
        );
        let e = Dataset::new(
            &runs,
            &[],
            &names(&["T1"]),
            &names(&["dz_um"]),
            InputForm::Change,
            Some(0.0),
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("no calibration rows"), "{e}");
    }
}
