//! ARMA trainer (seed 001). Placeholder: being written.

use super::Fitted;
use crate::dataset::Dataset;
use anyhow::{bail, Result};
use clap::Args;

/// ARMA options of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct ArmaArgs {
    /// arma: largest AR order tried.
    #[arg(long, default_value_t = 4)]
    pub max_p: usize,
}

/// Fits `--model arma`.
pub fn fit(_ds: &Dataset, _args: &ArmaArgs) -> Result<Fitted> {
    bail!("arma: not implemented yet")
}
