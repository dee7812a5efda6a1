//! The options the dynamic trainers (`arx`, `tf`, `gain`) share, and the
//! values they take: how inputs are chosen and the ridge penalty.

use super::orders::OrderRange;
use super::split::{check_holdout, SearchScheme};
use crate::fit::FitKind;
use anyhow::{bail, Result};
use serde::{Serialize, Serializer};
use std::path::PathBuf;
use std::str::FromStr;

/// Options of the dynamic trainers (`arx`, `tf`, `gain`; `dt_s` also
/// `auto` and `arma`); [`Default`] is `fit`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicOptions {
    /// arx, tf: denominator orders tried, MIN..MAX (default arx 1..3, tf 1..2).
    pub na: Option<OrderRange>,
    /// arx, tf: numerator lengths tried, MIN..MAX (default arx 1..3, tf 1..2; arx: same for every input).
    pub nb: Option<OrderRange>,
    /// arx, tf: input delays tried in samples, MIN..MAX (default arx 0..2, tf 0..1; arx: same for every input).
    pub nk: Option<OrderRange>,
    /// arx: order search scores simulation fit by blocked cross-validation over K contiguous folds of each run's calibration samples (1: on the last --search-holdout only, as tf does).
    pub search_folds: usize,
    /// arx with --search-folds 1, tf: the search scores simulation fit on the last FRACTION of each run's calibration samples.
    pub search_holdout: f64,
    /// arx, tf, arma: model sample time (default: the median sampling step of the first run).
    pub dt_s: Option<f64>,
    /// tf: rounds of SISO ARX backfitting on partial residuals before the joint refinement.
    pub backfit_rounds: usize,
    /// tf: Levenberg-Marquardt iteration limit of the joint output-error refinement.
    pub lm_iterations: usize,
    /// gain: the TF-bank blob whose spindle part gets a new gain g (seed 004, Eq. 6).
    pub gain_from: Option<PathBuf>,
    /// gain: inputs whose TF entries are scaled by g (default: every input but ambient_c).
    pub gain_inputs: Vec<String>,
    /// arx, tf: choose the inputs among --inputs by the search itself (forward: greedy, by simulation fit).
    pub select_inputs: Selection,
    /// arx, tf: with --select-inputs forward, at most K inputs (also capped by the 16-entry bank).
    pub max_inputs: usize,
    /// arx, tf: with --select-inputs forward, stop when the best addition raises the search fit by less than this (percentage points).
    pub min_gain_pct: f64,
    /// arx: ridge penalty of the least squares: "auto" (default: searched with the orders, by search fit), 0 = none, or a number.
    pub ridge: Ridge,
}

impl DynamicOptions {
    /// Checks what needs no data for `kind`: the search split (`arx`: folds
    /// or a tail; `tf`: a tail) and the selection threshold. The cap on the
    /// inputs selected depends on the dataset
    /// ([`super::select::max_selected`]).
    pub fn check(&self, kind: FitKind) -> Result<()> {
        match kind {
            FitKind::Arx => {
                SearchScheme::new(self.search_folds, self.search_holdout).map(|_| ())?
            }
            FitKind::Tf => check_holdout(self.search_holdout)?,
            _ => return Ok(()),
        }
        let threshold = self.min_gain_pct;
        if self.select_inputs == Selection::Forward && !(threshold.is_finite() && threshold >= 0.0)
        {
            bail!("--min-gain-pct {threshold} must be >= 0");
        }
        Ok(())
    }
}

impl Default for DynamicOptions {
    fn default() -> Self {
        Self {
            na: None,
            nb: None,
            nk: None,
            search_folds: 4,
            search_holdout: 0.25,
            dt_s: None,
            backfit_rounds: 3,
            lm_iterations: 60,
            gain_from: None,
            gain_inputs: Vec::new(),
            select_inputs: Selection::Off,
            max_inputs: 6,
            min_gain_pct: 1.0,
            ridge: Ridge::Auto,
        }
    }
}

/// How `arx` and `tf` choose their inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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

/// As `--ridge` reads it: `"auto"` or the penalty.
impl Serialize for Ridge {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::Fixed(v) => s.serialize_f64(*v),
        }
    }
}
