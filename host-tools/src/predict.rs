//! `thermcomp predict`: a model's outputs for run files, row for row.

use crate::data::runfile::{ReadOptions, RunFile, SkippedRow};
use crate::data::source::{ModelSource, RunSource};
use crate::runner::{self, ColumnMap};
use anyhow::{Context, Result};
use clap::Args;
use model_core::ValidModel;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `thermcomp predict`.
#[derive(Args)]
pub struct PredictArgs {
    /// The model to run.
    #[command(flatten)]
    pub model: ModelSource,
    /// The runs to run it on.
    #[command(flatten)]
    pub runs: RunSource,
    /// Where to write `t_s` and one `<output>_pred` column per model output
    /// (with several runs, a leading `run` column names each row's file).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write `<output>_lo95` and `<output>_hi95`: the model's 95 %
    /// band (its calibration cross-validation error, widened by
    /// `1 + d` where `d` is how far the inputs lie outside the calibration
    /// envelope, in envelope widths). Needs a model with bounds (`fit --model auto`).
    #[arg(long)]
    pub interval: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

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

/// Runs `thermcomp predict`.
pub fn run(a: &PredictArgs) -> Result<()> {
    let model = a.model.load()?;
    check_interval(&model, a.interval)?;
    let map = a.runs.column_map()?;
    let opts = a.runs.read_options(map.model_columns(&model, false));
    let inputs = [a.model.paths(), a.runs.paths()].concat();
    crate::data::fsio::check_distinct(&inputs, &[crate::data::fsio::named("--out", &a.out)])?;
    let (rows, missing, skipped_rows) =
        crate::data::fsio::write_atomic(&a.out, |w| write_predictions(a, &model, &opts, &map, w))?;
    let runs = &a.runs.data;
    if a.json {
        crate::data::fsio::print_line(
            &serde_json::json!({"out": a.out.display().to_string(), "runs": runs.len(), "rows": rows,
                "outputs": runner::prediction_names(&model),
                "missing_cells": missing, "skipped_rows": skipped_rows})
            .to_string(),
        )?;
    } else {
        eprintln!(
            "wrote {} ({rows} rows from {} run(s))",
            a.out.display(),
            runs.len()
        );
    }
    Ok(())
}

/// Writes the predictions CSV, each run streamed row by row
/// ([`crate::stream::stream_run`]) and written as it goes: rows written,
/// empty prediction cells, rows skipped as bad.
fn write_predictions(
    a: &PredictArgs,
    model: &ValidModel,
    opts: &ReadOptions,
    map: &ColumnMap,
    w: &mut dyn Write,
) -> Result<(usize, usize, usize)> {
    let several = a.runs.data.len() > 1;
    let mut header: Vec<String> = Vec::new();
    if several {
        header.push("run".into());
    }
    header.push("t_s".into());
    let names = runner::prediction_names(model);
    header.extend(names.iter().map(|o| format!("{o}_pred")));
    if a.interval {
        for o in model.outputs() {
            header.push(format!("{o}_lo95"));
            header.push(format!("{o}_hi95"));
        }
    }
    writeln!(w, "{}", header.join(",")).with_context(|| write_err(a))?;
    let (mut rows, mut missing, mut skipped) = (0, 0, 0);
    for path in &a.runs.data {
        let mut sink = CsvSink {
            a,
            name: several.then(|| path.display().to_string().replace(',', "_")),
            blank_cells: names.len()
                + if a.interval {
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

fn write_err(a: &PredictArgs) -> String {
    format!("cannot write {}", a.out.display())
}

/// Writes streamed rows as CSV lines.
struct CsvSink<'a> {
    a: &'a PredictArgs,
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
        if self.a.interval {
            for (value, half) in row.values.iter().zip(row.bands) {
                let pair = value.zip(*half);
                line.push(',');
                line.push_str(&cell(pair.map(|(y, h)| y - h)));
                line.push(',');
                line.push_str(&cell(pair.map(|(y, h)| y + h)));
            }
        }
        writeln!(self.w, "{line}").with_context(|| write_err(self.a))?;
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
            .with_context(|| write_err(self.a))?;
        self.rows += 1;
        self.missing += self.n_values;
        Ok(())
    }
}
