//! The `refit` job: self-adaptive compensation (seed 002, section 4: the
//! NC re-builds its model "when the relationship between temperature and
//! deformation changes, such as the working environment, and the
//! re-installation of the machine tool").
//!
//! Three steps, each documented in `docs/fit.md` ("refit"):
//!
//! 1. **Test.** The old model's residual on the new runs is regressed on a
//!    bias, a drift in time and a gain on its own prediction; a HAC Wald test
//!    ([`stats`]) says whether that is more than autocorrelated noise, and the
//!    fitted systematic error must reach `--min-effect-um` to matter. With
//!    `--baseline` runs, a new-run rmse or dpk beyond `--tolerance` times the
//!    baseline's also counts. A target that passes neither is unchanged.
//! 2. **Update** (changed targets only), estimated on the first
//!    `1 - --holdout-fraction` of each new run: linear and PCR models by
//!    recursive least squares with forgetting from the old coefficients
//!    ([`rls`]), PCR on its components (kept); TF banks by a least-squares
//!    gain per entry (seed 004 Eq. 6: each numerator scaled, poles kept);
//!    or, with `--method window`, a plain least-squares refit of the same
//!    structure on the last `--window-h` hours of the update part.
//! 3. **Keep or not.** Old and updated models are scored on the held-out
//!    tail of every run (`crate::score::score`); an updated target is kept
//!    only if its held-out rmse is lower. If no target is kept, or nothing
//!    changed, `--out` gets the old blob byte for byte.
//!
//! The job's shape (docs/architecture.md): [`RefitParams`] ->
//! [`RefitParams::check`] -> [`ValidRefitParams`] -> [`refit`] over the
//! model in service and runs in memory -> [`RefitOutcome`], whose
//! [`RefitReport`] serialises to `refit --json`'s object (less `out`). The
//! command line (`cli::refit`) reads the files, writes the blob, prints.

mod bounds;
mod change;
pub use change::holdout_from_s;
pub mod outcome;
mod rls;
pub mod stats;
mod structure;
mod update;

pub use change::Verdict;
pub use outcome::RefitReport;

use crate::data::cells::Cells;
use crate::data::runfile::RunFile;
use crate::score::{score, TargetScore};
use anyhow::{bail, Result};
use model_core::ValidModel;
use outcome::SettingsReport;
use update::{Update, UpdateSettings};

/// How a changed model is updated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Method {
    /// Recursive least squares with forgetting from the old coefficients
    /// (TF banks: least-squares entry gains over the whole update part).
    Rls,
    /// Plain least squares of the same structure on the last --window-h hours.
    Window,
}

impl Method {
    /// The name the JSON and the flag use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rls => "rls",
            Self::Window => "window",
        }
    }
}

/// The data an update works on: the new runs, their measured outputs and
/// where each run's held-out tail starts.
pub(crate) struct UpdateData<'r> {
    pub(crate) runs: &'r [RunFile],
    pub(crate) ys: &'r [Vec<Cells<'r>>],
    pub(crate) split: &'r [usize],
}

/// What `refit` tests and how it updates; [`Default`] is the CLI's defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct RefitParams {
    /// With baseline runs: a new-run rmse or dpk above this multiple of the
    /// baseline's (and at least `min_effect_um` above it) flags a change.
    pub tolerance: f64,
    /// Smallest systematic error (um) that counts as a change.
    pub min_effect_um: f64,
    /// Significance level of the HAC Wald test.
    pub alpha: f64,
    /// How to update a changed model.
    pub method: Method,
    /// RLS forgetting factor per sample (`None`: `1 - dt / memory`).
    pub forgetting: Option<f64>,
    /// RLS memory, hours: the default forgetting factor's time constant.
    pub memory_h: f64,
    /// RLS prior weight, hours of new samples.
    pub prior_h: f64,
    /// `Method::Window`: refit on the last this many hours of the update part.
    pub window_h: f64,
    /// Fraction of each new run (by time, at its end) held out for scoring.
    pub holdout_fraction: f64,
}

impl Default for RefitParams {
    fn default() -> Self {
        Self {
            tolerance: 1.5,
            min_effect_um: 1.0,
            alpha: 0.01,
            method: Method::Rls,
            forgetting: None,
            memory_h: 4.0,
            prior_h: 1.0,
            window_h: 8.0,
            holdout_fraction: 0.3,
        }
    }
}

/// [`RefitParams`] that passed [`RefitParams::check`].
#[derive(Clone, Debug)]
pub struct ValidRefitParams(RefitParams);

impl std::ops::Deref for ValidRefitParams {
    type Target = RefitParams;
    fn deref(&self) -> &RefitParams {
        &self.0
    }
}

impl RefitParams {
    /// Every value in its range.
    pub fn check(&self) -> Result<ValidRefitParams> {
        if !(self.holdout_fraction > 0.0 && self.holdout_fraction < 1.0) {
            bail!(
                "--holdout-fraction {} must be in (0, 1)",
                self.holdout_fraction
            );
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            bail!("--alpha {} must be in (0, 1)", self.alpha);
        }
        if !(self.min_effect_um >= 0.0 && self.min_effect_um.is_finite()) {
            bail!("--min-effect-um must be a finite number >= 0");
        }
        if !(self.tolerance >= 1.0 && self.tolerance.is_finite()) {
            bail!("--tolerance must be a finite factor >= 1");
        }
        if let Some(l) = self.forgetting {
            if !(l > 0.0 && l <= 1.0) {
                bail!("--forgetting {l} must be in (0, 1]");
            }
        }
        for (name, v) in [
            ("--memory-h", self.memory_h),
            ("--prior-h", self.prior_h),
            ("--window-h", self.window_h),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                bail!("{name} must be a positive number of hours");
            }
        }
        Ok(ValidRefitParams(self.clone()))
    }
}

/// The model in service: decoded, and its blob byte for byte (written back
/// unchanged when nothing is updated).
pub struct InService<'m> {
    /// The decoded model.
    pub model: &'m ValidModel,
    /// Its blob.
    pub bytes: &'m [u8],
}

/// What [`refit`] produced.
pub struct RefitOutcome {
    /// The model's outputs, in its order.
    pub outputs: Vec<String>,
    /// Step 1 per output.
    pub verdicts: Vec<Verdict>,
    /// The old model's scores (update part, held-out tails).
    pub before: Vec<TargetScore>,
    /// The written model's scores.
    pub after: Vec<TargetScore>,
    /// The updated model, if any output's update was kept.
    pub model: Option<ValidModel>,
    /// The blob to write: the updated model's, or the old one byte for byte.
    pub bytes: Vec<u8>,
    /// The figures, serialisable.
    pub report: RefitReport,
}

/// Tests the model in service on the new `runs` (and the tolerance rule on
/// `baseline` runs), updates the changed outputs, keeps an update only if
/// it lowers that output's held-out rmse. All in memory.
pub fn refit(
    p: &ValidRefitParams,
    old: InService,
    runs: &[RunFile],
    baseline: &[RunFile],
) -> Result<RefitOutcome> {
    let outputs: Vec<String> = old.model.outputs().iter().map(|o| o.to_string()).collect();
    let ys = change::measured_outputs(runs, &outputs)?;
    change::refuse_flat_outputs(&outputs, &ys)?;
    let split = change::holdout_starts(runs, p.holdout_fraction);

    // 1. The test, on every row of the new runs.
    let preds = change::predictions(old.model, runs)?;
    let verdicts = change::test_outputs(p, old.model, (runs, baseline), &preds, &ys)?;
    let pairs: Vec<(&RunFile, usize)> = runs.iter().zip(&split).map(|(r, s)| (r, *s)).collect();
    let before = score(old.model, &pairs)?;

    // 2. and 3. The update of the changed targets only, kept if better.
    let (dt_s, settings) = update::update_settings(p, runs)?;
    let data = UpdateData {
        runs,
        ys: &ys,
        split: &split,
    };
    let u = update_step(old.model, &data, &verdicts, &settings, &before)?;
    let bytes = match &u.model {
        Some(m) => crate::data::blobfile::encode(m)?,
        None => old.bytes.to_vec(),
    };
    let report = RefitReport {
        changed: verdicts.iter().any(|v| v.changed),
        test: outcome::test_report(p, baseline.len(), &outputs, &verdicts),
        method: p.method.name(),
        settings: settings_report(p, dt_s, &settings),
        update: u.entries.clone(),
        before: outcome::parts(&before),
        after: outcome::parts(&u.after),
        kept: if u.model.is_some() { "new" } else { "old" },
        targets_updated: u.kept_targets.clone(),
        notes: u.notes.clone(),
        skipped_rows: crate::data::source::skipped_rows(runs.iter().chain(baseline)),
        bytes: bytes.len(),
    };
    Ok(RefitOutcome {
        outputs,
        verdicts,
        before,
        after: u.after,
        model: u.model,
        bytes,
        report,
    })
}

/// Steps 2 and 3 when any output changed; else nothing updated.
fn update_step(
    old: &ValidModel,
    data: &UpdateData,
    verdicts: &[Verdict],
    settings: &UpdateSettings,
    before: &[TargetScore],
) -> Result<Update> {
    if verdicts.iter().any(|v| v.changed) {
        return update::update_changed(old, data, verdicts, settings, before);
    }
    Ok(Update {
        notes: Vec::new(),
        entries: Default::default(),
        after: before.to_vec(),
        kept_targets: Vec::new(),
        model: None,
    })
}

/// The settings as the JSON reports them.
fn settings_report(p: &RefitParams, dt_s: f64, s: &UpdateSettings) -> SettingsReport {
    SettingsReport {
        dt_s,
        forgetting: s.lambda,
        memory_h: dt_s / (1.0 - s.lambda).max(f64::MIN_POSITIVE) / 3600.0,
        prior_h: p.prior_h,
        window_h: (p.method == Method::Window).then_some(p.window_h),
        holdout_fraction: p.holdout_fraction,
    }
}
