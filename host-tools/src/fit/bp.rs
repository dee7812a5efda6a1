//! BP network and GA-BP trainers (seed 000). Placeholder: being written.

use super::Fitted;
use crate::dataset::Dataset;
use anyhow::{bail, Result};
use clap::Args;

/// BP and GA-BP options of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct BpArgs {
    /// bp, gabp: random seed (training is deterministic for a given seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Fits `--model bp` (`genetic = false`) or `--model gabp`.
pub fn fit(_ds: &Dataset, _args: &BpArgs, _genetic: bool) -> Result<Fitted> {
    bail!("bp: not implemented yet")
}
