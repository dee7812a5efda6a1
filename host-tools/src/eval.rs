//! `thermcomp eval`: a model's predictions scored against the measured
//! columns, over all runs together and per run (CONTRACT.md section 1).

use crate::data::source::{ModelSource, RunSource};
use crate::runner;
use anyhow::{anyhow, Result};
use clap::Args;
use model_core::metrics::{Metrics, MetricsAccumulator};
use serde_json::{json, Map, Value};
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
}

/// The contract's metric keys (CONTRACT.md section 1) and a few more.
pub fn metrics_json(m: &Metrics) -> Value {
    json!({
        "n": m.n,
        "rmse_um": m.rmse,
        "fit_pct": m.fit_pct,
        "r2": m.r2,
        "eta_pct": m.eta_pct,
        "max_abs_um": m.max_abs,
        "mean_abs_um": m.mean_abs,
        "min_abs_um": m.min_abs,
        "dpk_um": m.dpk,
        "reduction_pct": m.reduction_pct,
        "residual_mean_um": m.mean,
        "residual_min_um": m.residual_min,
        "residual_max_um": m.residual_max,
    })
}

/// Runs `thermcomp eval`.
pub fn run(a: &EvalArgs) -> Result<()> {
    let model = a.model.load()?;
    if model.kind() == model_core::ModelKind::Arma {
        eprintln!("note: an arma model forecasts one step ahead from the measured series itself: these figures hold only where the error is measured every dt_s on the machine (docs/arma.md)");
    }
    let map = a.runs.column_map()?;
    let runs = a.runs.read(map.model_columns(&model, true))?;
    let skipped_rows = crate::data::source::skipped_rows(&runs);
    // A five-point model's tip drift is scored too, where the run has it.
    let names = runner::prediction_names(&model);
    let n_model = model.outputs().len();
    let n_out = names.len();
    let mut all = vec![MetricsAccumulator::new(); n_out];
    let mut per_run: Vec<Vec<Value>> = vec![Vec::new(); n_out];
    let mut unscored = vec![0usize; n_out];
    for run in &runs {
        let p = runner::predict(&model, run, &map)?;
        for note in &p.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        for (k, name) in names.iter().enumerate() {
            let col = map.column(name);
            if k >= n_model && run.column(col).is_none() {
                eprintln!(
                    "note: {}: no measured {col}: the tool-tip {name} is not scored",
                    run.path.display()
                );
                continue;
            }
            let y = run.column(col).ok_or_else(|| {
                anyhow!(
                    "{}: no measured column \"{col}\" to compare output \"{name}\" with (use --map {name}=COLUMN)",
                    run.path.display()
                )
            })?;
            let mut acc = MetricsAccumulator::new();
            let mut skipped = 0usize;
            for (row, yi) in y.iter().enumerate() {
                match (yi, p.values[k].get(row).copied().flatten()) {
                    (Some(yi), Some(yhat)) => {
                        // Both are finite: the reader rejects non-finite
                        // cells and the runner non-finite outputs.
                        acc.push(*yi, yhat).map_err(|e| anyhow!("{name}: {e}"))?;
                        all[k].push(*yi, yhat).map_err(|e| anyhow!("{name}: {e}"))?;
                    }
                    _ => skipped += 1,
                }
            }
            if skipped > 0 {
                eprintln!(
                    "note: {}: {name}: {skipped} of {} rows not scored (no prediction or no measured {col}); n counts the scored rows",
                    run.path.display(),
                    run.len()
                );
            }
            unscored[k] += skipped;
            let mut entry = match acc.finish() {
                Ok(m) => metrics_json(&m),
                Err(e) => json!({"error": e.to_string()}),
            };
            if let Value::Object(o) = &mut entry {
                o.insert("file".into(), json!(run.path.display().to_string()));
                o.insert("rows_not_scored".into(), json!(skipped));
            }
            per_run[k].push(entry);
        }
    }
    let mut out = Map::new();
    for (k, name) in names.iter().enumerate() {
        if k >= n_model && per_run[k].is_empty() {
            continue;
        }
        let m = all[k].clone().finish().map_err(|e| {
            anyhow!("output \"{name}\": nothing to score ({e}): no row has both a prediction and a measurement")
        })?;
        let mut obj = metrics_json(&m);
        if let Value::Object(o) = &mut obj {
            o.insert("column".into(), json!(map.column(name)));
            o.insert("rows_not_scored".into(), json!(unscored[k]));
            // Rows the reader left out (--skip-bad-rows), per target
            // object: the contract keys eval's object by target only.
            o.insert("skipped_rows".into(), json!(skipped_rows));
            o.insert(
                "per_run".into(),
                Value::Array(std::mem::take(&mut per_run[k])),
            );
        }
        out.insert(name.to_string(), obj);
    }
    if a.json {
        crate::data::fsio::print_line(&Value::Object(out).to_string())?;
    } else {
        crate::data::fsio::print(&table_text(&out))?;
    }
    Ok(())
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
        let f = |k: &str| m.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN);
        let _ = writeln!(
            s,
            "{:<10} {:>8} {:>9.3} {:>8.2} {:>7.4} {:>8.2} {:>9.3} {:>10.3} {:>8.3} {:>10.2}",
            name,
            m.get("n").and_then(Value::as_u64).unwrap_or(0),
            f("rmse_um"),
            f("fit_pct"),
            f("r2"),
            f("eta_pct"),
            f("max_abs_um"),
            f("mean_abs_um"),
            f("dpk_um"),
            f("reduction_pct")
        );
        if let Some(Value::Array(runs)) = m.get("per_run") {
            if runs.len() > 1 {
                for r in runs {
                    let g = |k: &str| r.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN);
                    let _ = writeln!(
                        s,
                        "  {:<30} rmse {:>8.3}  fit {:>7.2}%  dpk {:>8.3}  reduction {:>7.2}%",
                        r.get("file").and_then(Value::as_str).unwrap_or("?"),
                        g("rmse_um"),
                        g("fit_pct"),
                        g("dpk_um"),
                        g("reduction_pct")
                    );
                }
            }
        }
    }
    s
}
