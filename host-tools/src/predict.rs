//! `thermcomp predict`: a model's outputs for run files, row for row.

use crate::data::rawcells;
use crate::data::runfile::{ReadOptions, RunFile, SkippedRow};
use crate::runner::{self, ColumnMap};
use anyhow::{Context, Result};
use model_core::ValidModel;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes an empty cell for a missing value, else the shortest exact text.
fn cell(v: Option<f64>) -> String {
    v.map_or_else(String::new, |x| format!("{x}"))
}

/// Refuses `--interval` for a model without an error band.
pub fn check_interval(model: &ValidModel, interval: bool) -> Result<()> {
    if interval && model.model().bounds.is_none() {
        anyhow::bail!(
            "--interval: this {} model carries no error band (fit it with --model auto)",
            model.kind().name()
        );
    }
    Ok(())
}

/// One run's predictions in memory, row for row with the run.
#[derive(Clone, Debug, Serialize)]
pub struct PredictionTable {
    /// The run's times, s.
    pub t_s: Vec<f64>,
    /// `<output>_pred` per output, then (with an interval) `<output>_lo95`
    /// and `<output>_hi95` per output: the columns `predict` writes.
    /// `None` where there is no prediction (an empty cell in the file).
    pub columns: Vec<(String, Vec<Option<f64>>)>,
    /// What the runner did that the user should know.
    pub notes: Vec<String>,
}

/// `model`'s predictions for `run` (in memory): what `predict` writes for
/// it, as columns.
pub fn predict_run(
    model: &ValidModel,
    run: &RunFile,
    map: &ColumnMap,
    interval: bool,
) -> Result<PredictionTable> {
    check_interval(model, interval)?;
    let p = runner::predict(model, run, map)?;
    let names = model.outputs().iter().map(|o| o.to_string());
    let mut columns: Vec<(String, Vec<Option<f64>>)> = names
        .clone()
        .zip(&p.values)
        .map(|(o, v)| (format!("{o}_pred"), v.clone()))
        .collect();
    if interval {
        for (o, (v, b)) in names.zip(p.values.iter().zip(&p.bands)) {
            let pair = |i: usize| v.get(i).copied().flatten().zip(b.get(i).copied().flatten());
            let rows = 0..run.len();
            let lo = rows.clone().map(|i| pair(i).map(|(y, h)| y - h)).collect();
            let hi = rows.map(|i| pair(i).map(|(y, h)| y + h)).collect();
            columns.push((format!("{o}_lo95"), lo));
            columns.push((format!("{o}_hi95"), hi));
        }
    }
    Ok(PredictionTable {
        t_s: run.t_s.clone(),
        columns,
        notes: p.notes,
    })
}

/// What `predict` wrote (`predict --json`).
#[derive(Clone, Debug, Serialize)]
pub struct PredictSummary {
    /// The predictions file.
    pub out: String,
    /// Runs predicted.
    pub runs: usize,
    /// Rows written.
    pub rows: usize,
    /// The prediction columns' outputs.
    pub outputs: Vec<String>,
    /// Empty prediction cells.
    pub missing_cells: usize,
    /// Rows skipped as bad (`--skip-bad-rows`; written as empty rows).
    pub skipped_rows: usize,
}

/// `model`'s predictions for the runs `paths` written to `out` (CSV,
/// atomically), each run streamed row by row in bounded memory.
pub fn predict_files(
    model: &ValidModel,
    paths: &[PathBuf],
    opts: &ReadOptions,
    map: &ColumnMap,
    interval: bool,
    out: &Path,
) -> Result<PredictSummary> {
    check_interval(model, interval)?;
    let (rows, missing_cells, skipped_rows) = crate::data::fsio::write_atomic(out, |w| {
        write_predictions(model, paths, interval, out, opts, map, w)
    })?;
    Ok(PredictSummary {
        out: out.display().to_string(),
        runs: paths.len(),
        rows,
        outputs: runner::prediction_names(model),
        missing_cells,
        skipped_rows,
    })
}

/// Writes the predictions CSV, each run streamed row by row
/// ([`crate::stream::stream_run`]) and written as it goes: rows written,
/// empty prediction cells, rows skipped as bad.
fn write_predictions(
    model: &ValidModel,
    paths: &[PathBuf],
    interval: bool,
    out: &Path,
    opts: &ReadOptions,
    map: &ColumnMap,
    w: &mut dyn Write,
) -> Result<(usize, usize, usize)> {
    let several = paths.len() > 1;
    let mut header: Vec<String> = Vec::new();
    if several {
        header.push("run".into());
    }
    header.push("t_s".into());
    let names = runner::prediction_names(model);
    header.extend(names.iter().map(|o| format!("{o}_pred")));
    if interval {
        for o in model.outputs() {
            header.push(format!("{o}_lo95"));
            header.push(format!("{o}_hi95"));
        }
    }
    let header: Vec<String> = header.iter().map(|h| rawcells::csv_field(h)).collect();
    writeln!(w, "{}", header.join(",")).with_context(|| write_err(out))?;
    let (mut rows, mut missing, mut skipped) = (0, 0, 0);
    for path in paths {
        let mut sink = CsvSink {
            interval,
            out,
            name: several.then(|| rawcells::csv_field(&path.display().to_string())),
            blank_cells: names.len()
                + if interval {
                    2 * model.outputs().len()
                } else {
                    0
                },
            n_values: names.len(),
            w: &mut *w,
            line: String::new(),
            rows: 0,
            missing: 0,
        };
        let end = crate::stream::stream_run(model, path, opts, map, &mut sink)?;
        rows += sink.rows;
        missing += sink.missing;
        skipped += end.skipped;
        crate::data::source::note_skipped(path, end.skipped, end.first_skipped.as_ref());
        for note in &end.notes {
            eprintln!("note: {}: {note}", path.display());
        }
    }
    Ok((rows, missing, skipped))
}

fn write_err(out: &Path) -> String {
    format!("cannot write {}", out.display())
}

/// Writes streamed rows as CSV lines.
struct CsvSink<'a> {
    /// Whether the band columns are written.
    interval: bool,
    /// The file written (for errors).
    out: &'a Path,
    /// The run's name in the `run` column, with several runs.
    name: Option<String>,
    /// Cells after `t_s` (the blank row's commas).
    blank_cells: usize,
    /// Prediction columns (their empty cells are counted).
    n_values: usize,
    w: &'a mut dyn Write,
    line: String,
    rows: usize,
    missing: usize,
}

impl crate::stream::RowSink for CsvSink<'_> {
    fn begin(&mut self, _: &crate::stream::Layout<'_>) -> Result<()> {
        Ok(())
    }

    fn row(&mut self, row: &crate::stream::PredictedRow<'_>) -> Result<()> {
        use std::fmt::Write as _;
        let line = &mut self.line;
        line.clear();
        if let Some(name) = &self.name {
            line.push_str(name);
            line.push(',');
        }
        let _ = write!(line, "{}", row.t_s);
        for value in row.values {
            self.missing += usize::from(value.is_none());
            line.push(',');
            line.push_str(&cell(*value));
        }
        if self.interval {
            for (value, half) in row.values.iter().zip(row.bands) {
                let pair = value.zip(*half);
                line.push(',');
                line.push_str(&cell(pair.map(|(y, h)| y - h)));
                line.push(',');
                line.push_str(&cell(pair.map(|(y, h)| y + h)));
            }
        }
        writeln!(self.w, "{line}").with_context(|| write_err(self.out))?;
        self.rows += 1;
        Ok(())
    }

    /// A row skipped as bad (--skip-bad-rows) keeps its place: an empty
    /// time and empty predictions, so the output stays row for row.
    fn skipped(&mut self, _: &SkippedRow) -> Result<()> {
        let lead = self
            .name
            .as_ref()
            .map_or(String::new(), |n| format!("{n},"));
        writeln!(self.w, "{lead}{}", ",".repeat(self.blank_cells))
            .with_context(|| write_err(self.out))?;
        self.rows += 1;
        self.missing += self.n_values;
        Ok(())
    }
}
