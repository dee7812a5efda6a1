//! `thermcomp demo`: the flags and the printing of the demo's outcome.

use crate::data::fsio;
use crate::demo::{self, DemoParams};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `thermcomp demo` (none needed).
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Folder for everything the demo writes (run files, model blobs,
    /// candump log, diagnose report); created if missing, files in it
    /// overwritten.
    #[arg(long, default_value = "thermcomp-demo")]
    pub out: PathBuf,
    /// Print one JSON object with every stage's figures instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Small budgets (12 h runs at 60 s, a 6 x 3 GA, short ARX/TF/ARMA
    /// searches): for unoptimised builds such as the test suite's. Coarser figures.
    #[arg(long)]
    pub quick: bool,
}

/// Runs `thermcomp demo`.
pub fn run(a: &DemoArgs) -> Result<()> {
    let params = DemoParams {
        out: a.out.clone(),
        quick: a.quick,
    };
    let out = demo::demo(&params)?;
    if a.json {
        fsio::print_line(&serde_json::to_value(&out)?.to_string())
    } else {
        fsio::print(&demo::summary_text(&out))
    }
}
