//! `thermcomp eval`: the flags, the model and runs read, the typed job
//! ([`crate::eval::evaluate_files`]) and its outcome printed as a table or
//! one JSON object.

use super::source::{ModelSource, RunSource};
use crate::data::fsio::{check_distinct, named};
use crate::eval::{evaluate, evaluate_files};
use crate::plot::model::{PageRun, PageText};
use anyhow::{bail, Result};
use clap::Args;
use serde_json::{Map, Value};
use std::fmt::Write as _;

/// Arguments of `thermcomp eval`.
#[derive(Args)]
pub struct EvalArgs {
    /// The model to run.
    #[command(flatten)]
    pub model: ModelSource,
    /// The runs to run it on.
    #[command(flatten)]
    pub runs: RunSource,
    /// Print one JSON object keyed by target column.
    #[arg(long)]
    pub json: bool,
    /// Write DIR/index.html: measured, predicted and the 95 % band of every
    /// output on every run, and the residuals (reads the runs into memory).
    #[arg(long, value_name = "DIR")]
    pub report: Option<std::path::PathBuf>,
}

/// Runs `thermcomp eval`: reads the model and the runs, [`evaluate`]s,
/// prints the table or the JSON object.
pub fn run(a: &EvalArgs) -> Result<()> {
    let page = super::report_page(a.report.as_deref())?;
    if let Some(p) = &page {
        let reads: Vec<_> = a.model.paths().into_iter().chain(a.runs.paths()).collect();
        check_distinct(&reads, &[named("--report", p)])?;
    }
    let model = a.model.load()?;
    let map = a.runs.column_map()?;
    map.check_names(&model)?;
    let opts = a.runs.read_options(map.model_columns(&model, true));
    // Streamed, unless the page needs the runs in memory anyway.
    let (out, runs) = match &a.report {
        None => (
            evaluate_files(&model, &a.runs.data, &opts, &map)?,
            Vec::new(),
        ),
        Some(_) => {
            let runs = crate::data::source::read_runs(&a.runs.data, &opts)?;
            (evaluate(&model, &runs, &map)?, runs)
        }
    };
    let json = serde_json::to_value(&out)?;
    let Value::Object(fields) = &json else {
        bail!("eval: the outcome is not a JSON object");
    };
    let table = table_text(fields);
    if let Some(dir) = &a.report {
        write_report(dir, &model, &runs, &map, &table, &json)?;
    }
    if a.json {
        crate::data::fsio::print_line(&json.to_string())
    } else {
        crate::data::fsio::print(&table)
    }
}

/// `eval --report DIR`: the model on every run.
fn write_report(
    dir: &std::path::Path,
    model: &model_core::ValidModel,
    runs: &[crate::data::runfile::RunFile],
    map: &crate::runner::ColumnMap,
    table: &str,
    json: &Value,
) -> Result<()> {
    let page_runs: Vec<PageRun> = runs
        .iter()
        .map(|run| PageRun {
            run,
            holdout_from_s: None,
            role: "evaluated",
        })
        .collect();
    let text = PageText {
        title: "thermcomp eval",
        auto: None,
        summary: table,
    };
    super::publish_page(dir, model, &page_runs, map, &text, json)
}

/// The text table of `eval`: one row per target, then per run.
fn table_text(out: &Map<String, Value>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<10} {:>8} {:>9} {:>8} {:>7} {:>8} {:>9} {:>10} {:>8} {:>10}",
        "target",
        "n",
        "rmse_um",
        "fit_%",
        "r2",
        "eta_%",
        "max_|r|",
        "mean_|r|",
        "dpk_um",
        "reduce_%"
    );
    for (name, m) in out {
        let f = |k: &str, width: usize, decimals: usize| figure(m, k, width, decimals);
        let _ = writeln!(
            s,
            "{:<10} {:>8} {} {} {} {} {} {} {} {}",
            name,
            m.get("n").and_then(Value::as_u64).unwrap_or(0),
            f("rmse_um", 9, 3),
            f("fit_pct", 8, 2),
            f("r2", 7, 4),
            f("eta_pct", 8, 2),
            f("max_abs_um", 9, 3),
            f("mean_abs_um", 10, 3),
            f("dpk_um", 8, 3),
            f("reduction_pct", 10, 2)
        );
        if let Some(Value::Array(runs)) = m.get("per_run") {
            if runs.len() > 1 {
                for r in runs {
                    let file = r.get("file").and_then(Value::as_str).unwrap_or("?");
                    if let Some(e) = r.get("error").and_then(Value::as_str) {
                        let _ = writeln!(s, "  {file:<30} {e}");
                        continue;
                    }
                    let g = |k: &str, width: usize, decimals: usize| figure(r, k, width, decimals);
                    let _ = writeln!(
                        s,
                        "  {:<30} rmse {}  fit {}%  dpk {}  reduction {}%",
                        file,
                        g("rmse_um", 8, 3),
                        g("fit_pct", 7, 2),
                        g("dpk_um", 8, 3),
                        g("reduction_pct", 7, 2)
                    );
                }
            }
        }
    }
    s
}

/// The number `key` of `v` as a table figure ("-" where it is absent: a
/// run with nothing to score).
fn figure(v: &Value, key: &str, width: usize, decimals: usize) -> String {
    crate::num::shown::figure(v.get(key).and_then(Value::as_f64), width, decimals)
}
