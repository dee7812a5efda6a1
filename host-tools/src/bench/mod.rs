//! `thermcomp bench`: benchmarks of the tool's own methods with known
//! answers.
//!
//! - [`gap`]: the blind benchmark of `thermcomp diagnose`
//!   (docs/gap-benchmark.md): by default on the plant zoo ([`zoo`]:
//!   independently built plants, one held out), with `--twin` on
//!   twin-derived cases ([`cases`]). Both share [`outcome`] (what a
//!   diagnosis said, running cases in parallel), [`summary`] (confusion
//!   matrix and rates) and [`report`] (tables and SVG).

pub mod cases;
pub mod gap;
pub mod outcome;
pub mod report;
pub mod summary;
pub mod zoo;

use anyhow::Result;
use clap::Subcommand;

/// The benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Blind benchmark of the sim-to-real gap diagnosis: real machines with
    /// one known effect (or none) and a mismatch, diagnosed without being
    /// told the effect; confusion matrix, false alarms and held-out shrink
    /// (docs/gap-benchmark.md). Runs the plant zoo (plants the diagnosis
    /// was not built around; one held out) unless --twin.
    Gap(gap::GapArgs),
}

/// Runs `thermcomp bench ...`.
pub fn run(c: &BenchCommand) -> Result<()> {
    match c {
        BenchCommand::Gap(a) => gap::run(a),
    }
}
