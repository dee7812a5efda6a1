//! `thermcomp bench`: benchmarks of the tool's own methods on twin runs
//! with known answers.
//!
//! - [`gap`]: the blind benchmark of `thermcomp diagnose` (cases in
//!   [`cases`], files in [`report`]; docs/gap-benchmark.md).

pub mod cases;
pub mod gap;
pub mod report;

use anyhow::Result;
use clap::Subcommand;

/// The benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Blind benchmark of the sim-to-real gap diagnosis: many real-like twin
    /// runs with one known effect (or none) on a slightly wrong machine,
    /// diagnosed without being told the effect; confusion matrix, false
    /// alarms and held-out shrink (docs/gap-benchmark.md).
    Gap(gap::GapArgs),
}

/// Runs `thermcomp bench ...`.
pub fn run(c: &BenchCommand) -> Result<()> {
    match c {
        BenchCommand::Gap(a) => gap::run(a),
    }
}
