//! The options the dynamic trainers (`arx`, `tf`, `gain`) share, and the
//! values they take: how inputs are chosen and the ridge penalty.

use super::orders::OrderRange;
use clap::Args;
use std::path::PathBuf;
use std::str::FromStr;

/// Options of the dynamic trainers (`arx`, `tf`, `gain`) of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct DynamicOptions {
    /// arx, tf: denominator orders tried, MIN..MAX (default arx 1..3, tf 1..2).
    #[arg(long, value_name = "MIN..MAX")]
    pub na: Option<OrderRange>,
    /// arx, tf: numerator lengths tried, MIN..MAX (default arx 1..3, tf 1..2; arx: same for every input).
    #[arg(long, value_name = "MIN..MAX")]
    pub nb: Option<OrderRange>,
    /// arx, tf: input delays tried in samples, MIN..MAX (default arx 0..2, tf 0..1; arx: same for every input).
    #[arg(long, value_name = "MIN..MAX")]
    pub nk: Option<OrderRange>,
    /// arx: order search scores simulation fit by blocked cross-validation over K contiguous folds of each run's calibration samples (1: on the last --search-holdout only, as tf does).
    #[arg(long, default_value_t = 4, value_name = "K")]
    pub search_folds: usize,
    /// arx with --search-folds 1, tf: the search scores simulation fit on the last FRACTION of each run's calibration samples.
    #[arg(long, default_value_t = 0.25, value_name = "FRACTION")]
    pub search_holdout: f64,
    /// arx, tf, arma: model sample time (default: the median sampling step of the first run).
    #[arg(long, value_name = "SECONDS")]
    pub dt_s: Option<f64>,
    /// tf: rounds of SISO ARX backfitting on partial residuals before the joint refinement.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub backfit_rounds: usize,
    /// tf: Levenberg-Marquardt iteration limit of the joint output-error refinement.
    #[arg(long, default_value_t = 60, value_name = "N")]
    pub lm_iterations: usize,
    /// gain: the TF-bank blob whose spindle part gets a new gain g (seed 004, Eq. 6).
    #[arg(long, value_name = "MODEL.bin")]
    pub gain_from: Option<PathBuf>,
    /// gain: inputs whose TF entries are scaled by g (default: every input but ambient_c).
    #[arg(long, value_delimiter = ',', value_name = "COL,..")]
    pub gain_inputs: Vec<String>,
    /// arx, tf: choose the inputs among --inputs by the search itself (forward: greedy, by simulation fit).
    #[arg(long, value_enum, default_value = "off")]
    pub select_inputs: Selection,
    /// arx, tf: with --select-inputs forward, at most K inputs (also capped by the 16-entry bank).
    #[arg(long, default_value_t = 6, value_name = "K")]
    pub max_inputs: usize,
    /// arx, tf: with --select-inputs forward, stop when the best addition raises the search fit by less than this (percentage points).
    #[arg(long, default_value_t = 1.0, value_name = "POINTS")]
    pub min_gain_pct: f64,
    /// arx: ridge penalty of the least squares: "auto" (default: searched with the orders, by search fit), 0 = none, or a number.
    #[arg(long, default_value = "auto", value_name = "auto|LAMBDA")]
    pub ridge: Ridge,
}

/// How `arx` and `tf` choose their inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Selection {
    /// Every `--inputs` column.
    Off,
    /// Greedy forward selection scored by simulation fit on the search-validation part.
    Forward,
}

/// The ridge penalty of `arx` (in the column-scaled basis: every regressor
/// column has unit norm, so the penalty is relative to that).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ridge {
    /// Chosen from [`RIDGE_GRID`] by simulation fit on the search-validation part.
    Auto,
    /// A fixed penalty (0: plain least squares).
    Fixed(f64),
}

impl FromStr for Ridge {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Self::Auto);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(Self::Fixed(v)),
            _ => Err(format!("--ridge {s}: \"auto\" or a number >= 0")),
        }
    }
}
