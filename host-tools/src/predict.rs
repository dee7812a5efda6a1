//! `thermcomp predict`: a model's outputs for run files, row for row.

use crate::data::runfile::RunFile;
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
    let runs = a.runs.read(map.model_columns(&model, false))?;
    let inputs = [a.model.paths(), a.runs.paths()].concat();
    crate::data::fsio::check_distinct(&inputs, &[crate::data::fsio::named("--out", &a.out)])?;
    let (rows, missing) =
        crate::data::fsio::write_atomic(&a.out, |w| write_predictions(a, &model, &runs, &map, w))?;
    if a.json {
        crate::data::fsio::print_line(
            &serde_json::json!({"out": a.out.display().to_string(), "runs": runs.len(), "rows": rows,
                "outputs": runner::prediction_names(&model),
                "missing_cells": missing, "skipped_rows": crate::data::source::skipped_rows(&runs)})
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

/// Writes the prediction table of `runs` to `w`; returns (rows, missing cells).
fn write_predictions(
    a: &PredictArgs,
    model: &ValidModel,
    runs: &[RunFile],
    map: &ColumnMap,
    w: &mut dyn Write,
) -> Result<(usize, usize)> {
    let several = runs.len() > 1;
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
    let write_err = || format!("cannot write {}", a.out.display());
    writeln!(w, "{}", header.join(",")).with_context(write_err)?;
    let mut rows = 0usize;
    let mut missing = 0usize;
    for run in runs {
        let p = runner::predict(model, run, map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        let name = run.path.display().to_string().replace(',', "_");
        // A row skipped as bad (--skip-bad-rows) keeps its place: an empty
        // time and empty predictions, so the output stays row for row.
        let blank_row = |w: &mut dyn Write| -> Result<()> {
            let lead = if several {
                format!("{name},")
            } else {
                String::new()
            };
            let cols = names.len()
                + if a.interval {
                    2 * model.outputs().len()
                } else {
                    0
                };
            writeln!(w, "{lead}{}", ",".repeat(cols)).with_context(write_err)
        };
        let mut skipped = run.skipped.iter().peekable();
        for (i, t) in run.t_s.iter().enumerate() {
            while skipped.next_if(|s| s.before <= i).is_some() {
                blank_row(w)?;
                rows += 1;
                missing += names.len();
            }
            let mut line = String::new();
            if several {
                line.push_str(&name);
                line.push(',');
            }
            line.push_str(&format!("{t}"));
            for v in &p.values {
                let value = v.get(i).copied().flatten();
                missing += usize::from(value.is_none());
                line.push(',');
                line.push_str(&cell(value));
            }
            if a.interval {
                for (v, b) in p.values.iter().zip(&p.bands) {
                    let (value, half) = (v.get(i).copied().flatten(), b.get(i).copied().flatten());
                    let pair = value.zip(half);
                    line.push(',');
                    line.push_str(&cell(pair.map(|(y, h)| y - h)));
                    line.push(',');
                    line.push_str(&cell(pair.map(|(y, h)| y + h)));
                }
            }
            writeln!(w, "{line}").with_context(write_err)?;
            rows += 1;
        }
        for _ in skipped {
            blank_row(w)?;
            rows += 1;
            missing += names.len();
        }
    }
    Ok((rows, missing))
}
