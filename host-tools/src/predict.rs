//! `thermcomp predict`: a model's outputs for run files, row for row.

use crate::runfile::{ReadOptions, RunFile};
use crate::runner::{self, ColumnMap};
use anyhow::{Context, Result};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `thermcomp predict`.
#[derive(Args)]
pub struct PredictArgs {
    /// The model blob.
    #[arg(long, required_unless_present = "spec", conflicts_with = "spec")]
    pub model: Option<PathBuf>,
    /// Or a model spec (TOML), built in memory exactly as `model build` would.
    #[arg(long)]
    pub spec: Option<PathBuf>,
    /// A run file (CSV); give it several times for several runs (each
    /// restarts the model's state; the output then has a leading `run` column).
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Where to write `t_s` and one `<output>_pred` column per model output.
    #[arg(long)]
    pub out: PathBuf,
    /// Read model name NAME from column COLUMN (repeatable), e.g. T1=T5.
    #[arg(long = "map", value_name = "NAME=COLUMN")]
    pub map: Vec<String>,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Reads every `--data` file, parsing only the columns in `needed` (other
/// columns are kept by name and ignored), reporting skipped rows on stderr.
pub fn read_runs(
    paths: &[PathBuf],
    skip_bad_rows: bool,
    needed: Vec<String>,
) -> Result<Vec<RunFile>> {
    let opts = ReadOptions {
        skip_bad_rows,
        only: Some(needed),
    };
    paths
        .iter()
        .map(|p| {
            let run = RunFile::read(p, &opts)?;
            if !run.skipped.is_empty() {
                eprintln!(
                    "note: {}: skipped {} bad rows (--skip-bad-rows); first: {}",
                    p.display(),
                    run.skipped.len(),
                    run.skipped[0].reason
                );
            }
            Ok(run)
        })
        .collect()
}

/// Writes an empty cell for a missing value, else the shortest exact text.
fn cell(v: Option<f64>) -> String {
    v.map_or_else(String::new, |x| format!("{x}"))
}

/// Runs `thermcomp predict`.
pub fn run(a: &PredictArgs) -> Result<()> {
    let model = crate::blobfile::load(a.model.as_deref(), a.spec.as_deref())?;
    let map = ColumnMap::parse(&a.map)?;
    let runs = read_runs(&a.data, a.skip_bad_rows, map.model_columns(&model, false))?;
    let file = std::fs::File::create(&a.out)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let several = runs.len() > 1;
    let mut header: Vec<String> = Vec::new();
    if several {
        header.push("run".into());
    }
    header.push("t_s".into());
    header.extend(model.outputs().iter().map(|o| format!("{o}_pred")));
    let write_err = || format!("cannot write {}", a.out.display());
    writeln!(w, "{}", header.join(",")).with_context(write_err)?;
    let mut rows = 0usize;
    let mut missing = 0usize;
    for run in &runs {
        let p = runner::predict(&model, run, &map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        let name = run.path.display().to_string().replace(',', "_");
        for (i, t) in run.t_s.iter().enumerate() {
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
            writeln!(w, "{line}").with_context(write_err)?;
            rows += 1;
        }
    }
    w.flush().with_context(write_err)?;
    if a.json {
        println!(
            "{}",
            serde_json::json!({"out": a.out.display().to_string(), "runs": runs.len(), "rows": rows,
                "outputs": model.outputs().iter().map(|o| o.as_str()).collect::<Vec<_>>(),
                "missing_cells": missing})
        );
    } else {
        eprintln!(
            "wrote {} ({rows} rows from {} run(s))",
            a.out.display(),
            runs.len()
        );
    }
    Ok(())
}
