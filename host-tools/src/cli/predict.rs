//! `thermcomp predict`: the flags, the model and runs read, the typed job
//! ([`crate::predict::predict_files`]) and its summary printed.

use super::source::{ModelSource, RunSource};
use crate::data::fsio;
use crate::predict::{check_interval, predict_files};
use anyhow::Result;
use clap::Args;
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
    /// `1 + growth d` where `d` is how far the inputs lie outside the
    /// calibration envelope, in envelope widths, and `growth` the blob's,
    /// calibrated on the CV folds). Needs a model with bounds (`fit --model auto`).
    #[arg(long)]
    pub interval: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `thermcomp predict`.
pub fn run(a: &PredictArgs) -> Result<()> {
    let model = a.model.load()?;
    check_interval(&model, a.interval)?;
    let map = a.runs.column_map()?;
    map.check_names(&model)?;
    let opts = a.runs.read_options(map.model_columns(&model, false));
    let inputs = [a.model.paths(), a.runs.paths()].concat();
    fsio::check_distinct(&inputs, &[fsio::named("--out", &a.out)])?;
    let o = predict_files(&model, &a.runs.data, &opts, &map, a.interval, &a.out)?;
    if a.json {
        fsio::print_line(&serde_json::to_value(&o)?.to_string())
    } else {
        eprintln!(
            "wrote {} ({} rows from {} run(s))",
            a.out.display(),
            o.rows,
            o.runs
        );
        Ok(())
    }
}
