//! What `select` is asked to do ([`SelectParams`], the flags of
//! `thermcomp select` less the files) and its check into
//! [`ValidSelectParams`], which the job (job.rs) and every method
//! (methods.rs) take.

use super::{grey, Method};
use anyhow::{bail, Result};

/// What to select and how: the flags of `thermcomp select` less the files.
#[derive(Clone, Debug)]
pub struct SelectParams {
    /// Target column(s); grey and maxtree take one.
    pub target: Vec<String>,
    /// Candidate input columns; empty: every `T<number>` of the first run
    /// but the targets.
    pub inputs: Vec<String>,
    /// The selection method.
    pub method: Method,
    /// Dimensionless processing before grey correlation (grey, wgrey).
    pub scale: grey::Scale,
    /// Distinguishing coefficient of the grey correlation coefficient.
    pub xi: f64,
    /// Weight of the absolute degree in the comprehensive degree (grey).
    pub theta: f64,
    /// Grey clustering level (grey).
    pub level: f64,
    /// Weight of the displacement term of seed 002 Eq. 1 (wgrey).
    pub lambda1: f64,
    /// Weight of the rate-of-change term of seed 002 Eq. 1 (wgrey).
    pub lambda2: f64,
    /// How many of the best inputs to keep per target (wgrey).
    pub top: usize,
    /// Significance level of the regression F test (maxtree).
    pub alpha: f64,
    /// R^2 a larger set of representatives must add (maxtree).
    pub min_gain: f64,
    /// Smallest tolerance 1/VIF of a representative (maxtree).
    pub min_tolerance: f64,
}

/// [`SelectParams`] that passed [`SelectParams::check`].
#[derive(Clone, Debug)]
pub struct ValidSelectParams {
    params: SelectParams,
}

impl SelectParams {
    /// `method` on `target` with `thermcomp select`'s defaults (those of
    /// `--help`; a test holds the two together), every input a candidate.
    pub fn new(target: Vec<String>, method: Method) -> Self {
        Self {
            target,
            inputs: Vec::new(),
            method,
            scale: grey::Scale::Initial,
            xi: 0.5,
            theta: 0.5,
            level: 0.9,
            lambda1: 0.5,
            lambda2: 0.5,
            top: 6,
            alpha: 0.05,
            min_gain: 0.01,
            min_tolerance: 1e-4,
        }
    }

    /// Checks every value against its range and the number of targets
    /// against the method (messages name the CLI's flags).
    pub fn check(&self) -> Result<ValidSelectParams> {
        self.check_grey_weights()?;
        self.check_wgrey_weights()?;
        self.check_maxtree_rule()?;
        if self.method != Method::Wgrey && self.target.len() != 1 {
            bail!(
                "--method {} takes one --target column (got {}); run it once per target, or use --method wgrey",
                self.method.name(),
                self.target.len()
            );
        }
        for t in &self.target {
            if t.trim().is_empty() {
                bail!("--target: empty column name");
            }
        }
        Ok(ValidSelectParams {
            params: self.clone(),
        })
    }

    /// `--xi`, `--theta`, `--level` and `--min-tolerance` in their ranges.
    fn check_grey_weights(&self) -> Result<()> {
        let unit = |name: &str, v: f64| -> Result<()> {
            if !(0.0..=1.0).contains(&v) {
                bail!("--{name} {v}: must lie in [0, 1]");
            }
            Ok(())
        };
        if !(self.xi > 0.0 && self.xi <= 1.0) {
            bail!("--xi {}: must lie in (0, 1]", self.xi);
        }
        unit("theta", self.theta)?;
        unit("level", self.level)?;
        unit("min-tolerance", self.min_tolerance)
    }

    /// `--lambda1`, `--lambda2` (not both 0) and `--top`.
    fn check_wgrey_weights(&self) -> Result<()> {
        for (name, v) in [("lambda1", self.lambda1), ("lambda2", self.lambda2)] {
            if !(v.is_finite() && v >= 0.0) {
                bail!("--{name} {v}: must be a finite number >= 0");
            }
        }
        if self.lambda1 + self.lambda2 <= 0.0 {
            bail!("--lambda1 and --lambda2 are both 0: Eq. 1 would weigh nothing");
        }
        if self.top == 0 {
            bail!("--top 0: keep at least one input");
        }
        Ok(())
    }

    /// `--alpha` and `--min-gain`.
    fn check_maxtree_rule(&self) -> Result<()> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            bail!("--alpha {}: must lie in (0, 1)", self.alpha);
        }
        if !(self.min_gain.is_finite() && self.min_gain >= 0.0) {
            bail!("--min-gain {}: must be a finite number >= 0", self.min_gain);
        }
        Ok(())
    }

    /// The input columns of a selection on runs with `columns` (`source`
    /// names the first run): `inputs`, or every `T<number>` but the targets.
    pub fn inputs_for(&self, columns: &[String], source: &str) -> Result<Vec<String>> {
        let mut inputs: Vec<String> = self.inputs.iter().map(|s| s.trim().to_string()).collect();
        if inputs.is_empty() {
            inputs = columns
                .iter()
                .filter(|c| {
                    crate::data::runfile::is_temperature_column(c) && !self.target.contains(c)
                })
                .cloned()
                .collect();
            if inputs.len() < 2 {
                bail!(
                    "{source}: {} columns named T<number>: name at least two inputs with --inputs",
                    inputs.len()
                );
            }
        }
        if inputs.len() < 2 {
            bail!("--inputs: name at least two columns to choose among");
        }
        for (i, name) in inputs.iter().enumerate() {
            if name.is_empty() {
                bail!("--inputs: empty column name");
            }
            if inputs[..i].contains(name) {
                bail!("--inputs: \"{name}\" is listed twice");
            }
            if self.target.contains(name) {
                bail!("\"{name}\" is both a --target and an input");
            }
        }
        Ok(inputs)
    }
}

impl ValidSelectParams {
    /// The checked parameters.
    pub fn params(&self) -> &SelectParams {
        &self.params
    }
}
