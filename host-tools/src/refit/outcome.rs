//! What `refit` found and did, typed: [`RefitReport`] serialises (sorted
//! keys, through `serde_json::to_value`) to the object `refit --json`
//! prints, less its `out` (the path the CLI wrote).

use super::change::{BaselineFigures, Verdict};
use crate::eval::MetricsReport;
use crate::score::TargetScore;
use serde::Serialize;
use std::collections::BTreeMap;

/// The change rule, as the JSON states it.
const RULE: &str = "per target: changed if (HAC Wald p < alpha on r ~ c0 + c1 tau_h + c2 yhat, and max|fitted| >= min_effect_um) or (baseline given and new rmse or dpk > tolerance x baseline and >= min_effect_um above it)";

/// `refit --json`'s object, less `out`.
#[derive(Clone, Debug, Serialize)]
pub struct RefitReport {
    /// Any target changed.
    pub changed: bool,
    /// Step 1: the test and its settings.
    pub test: TestReport,
    /// `rls` or `window`.
    pub method: &'static str,
    /// The update settings after defaults are resolved.
    pub settings: SettingsReport,
    /// Per updated output: old and new equation, held-out rmse, kept.
    pub update: BTreeMap<String, UpdateEntry>,
    /// The old model's figures per output.
    pub before: BTreeMap<String, PartsReport>,
    /// The written model's figures per output.
    pub after: BTreeMap<String, PartsReport>,
    /// `new` if an update was kept, else `old`.
    pub kept: &'static str,
    /// The outputs whose update was kept.
    pub targets_updated: Vec<String>,
    /// Why an output was not updated or not kept.
    pub notes: Vec<String>,
    /// Rows the reader left out (`--skip-bad-rows`), new and baseline runs.
    pub skipped_rows: usize,
    /// Size of the blob written, bytes.
    pub bytes: usize,
}

/// Step 1's settings and per-output outcome.
#[derive(Clone, Debug, Serialize)]
pub struct TestReport {
    /// The rule in words.
    pub rule: &'static str,
    /// Significance level of the Wald test.
    pub alpha: f64,
    /// Smallest systematic error that counts, um.
    pub min_effect_um: f64,
    /// The baseline rule's factor.
    pub tolerance: f64,
    /// Baseline runs given.
    pub baseline_runs: usize,
    /// Per output.
    pub targets: BTreeMap<String, TargetTest>,
    /// `changed` or `unchanged`.
    pub decision: &'static str,
}

/// One output's test: the drift test's figures (`null` when too few
/// samples) and the decision.
#[derive(Clone, Debug, Serialize)]
pub struct TargetTest {
    /// Samples tested.
    pub n: Option<usize>,
    /// Bias, um.
    pub c0_um: Option<f64>,
    /// Drift, um/h.
    pub c1_um_per_h: Option<f64>,
    /// Gain error on the prediction.
    pub c2_gain: Option<f64>,
    /// HAC Wald statistic.
    pub wald: Option<f64>,
    /// Its degrees of freedom.
    pub dof: Option<usize>,
    /// Its p-value.
    pub p_value: Option<f64>,
    /// Newey-West lags.
    pub hac_lags: Option<usize>,
    /// Lag-1 autocorrelation of the residual.
    pub rho1: Option<f64>,
    /// Effective sample count.
    pub n_eff: Option<f64>,
    /// The residual's rmse, um.
    pub rmse_um: Option<f64>,
    /// Largest |fitted systematic error|, um.
    pub effect_um: Option<f64>,
    /// How much removing it lowers the rmse, um.
    pub rmse_reduction_um: Option<f64>,
    /// p < alpha.
    pub significant: bool,
    /// effect >= min_effect_um.
    pub relevant: bool,
    /// With baseline runs: their figures and the new runs'.
    pub baseline: Option<BaselineFigures>,
    /// The tolerance rule flags a change.
    pub baseline_flag: bool,
    /// The decision.
    pub changed: bool,
}

impl From<&Verdict> for TargetTest {
    fn from(v: &Verdict) -> Self {
        let t = v.test.as_ref();
        Self {
            n: t.map(|t| t.n),
            c0_um: t.map(|t| t.c0_um),
            c1_um_per_h: t.map(|t| t.c1_um_per_h),
            c2_gain: t.map(|t| t.c2),
            wald: t.map(|t| t.wald),
            dof: t.map(|t| t.dof),
            p_value: t.map(|t| t.p_value),
            hac_lags: t.map(|t| t.lags),
            rho1: t.map(|t| t.rho1),
            n_eff: t.map(|t| t.n_eff),
            rmse_um: t.map(|t| t.rmse_um),
            effect_um: t.map(|t| t.effect_um),
            rmse_reduction_um: t.map(|t| t.rmse_reduction_um),
            significant: v.significant,
            relevant: v.relevant,
            baseline: v.baseline.clone(),
            baseline_flag: v.baseline_flag,
            changed: v.changed,
        }
    }
}

/// The update settings after defaults are resolved.
#[derive(Clone, Debug, Serialize)]
pub struct SettingsReport {
    /// The runs' mean sample time, s.
    pub dt_s: f64,
    /// RLS forgetting factor per sample.
    pub forgetting: f64,
    /// Its memory, hours.
    pub memory_h: f64,
    /// RLS prior weight, hours.
    pub prior_h: f64,
    /// `--method window`: the window, hours.
    pub window_h: Option<f64>,
    /// Held-out fraction of each run.
    pub holdout_fraction: f64,
}

/// One updated output's old and new equation and their held-out rmse.
#[derive(Clone, Debug, Serialize)]
pub struct UpdateEntry {
    /// Before.
    pub old: Equation,
    /// After the update.
    pub new: Equation,
    /// The old equation's held-out rmse, um.
    pub holdout_rmse_old_um: Option<f64>,
    /// The new one's.
    pub holdout_rmse_new_um: Option<f64>,
    /// `new` or `old`.
    pub kept: &'static str,
}

/// An output's coefficients as refit updates them.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum Equation {
    /// A TF bank's entries of the output and their gains.
    Tf {
        /// Entry indices.
        tf_entries: Vec<usize>,
        /// Gain per entry.
        gains: Vec<f64>,
    },
    /// A linear or PCR equation.
    Static {
        /// Intercept.
        intercept: f64,
        /// Slopes (PCR: on the components).
        coef: Vec<f64>,
    },
}

/// One output's figures on the update part and the held-out tail.
#[derive(Clone, Debug, Serialize)]
pub struct PartsReport {
    /// Over the update part (each run's head).
    pub update_part: Option<MetricsReport>,
    /// Over the held-out tails.
    pub holdout: Option<MetricsReport>,
}

/// Per output, by name.
pub(crate) fn parts(scores: &[TargetScore]) -> BTreeMap<String, PartsReport> {
    scores
        .iter()
        .map(|t| {
            let part = PartsReport {
                update_part: t.calibration.as_ref().map(MetricsReport::from),
                holdout: t.holdout.as_ref().map(MetricsReport::from),
            };
            (t.output.clone(), part)
        })
        .collect()
}

/// Step 1's report.
pub(crate) fn test_report(
    p: &super::RefitParams,
    baseline_runs: usize,
    outputs: &[String],
    verdicts: &[Verdict],
) -> TestReport {
    let changed = verdicts.iter().any(|v| v.changed);
    TestReport {
        rule: RULE,
        alpha: p.alpha,
        min_effect_um: p.min_effect_um,
        tolerance: p.tolerance,
        baseline_runs,
        targets: outputs
            .iter()
            .zip(verdicts)
            .map(|(o, v)| (o.clone(), TargetTest::from(v)))
            .collect(),
        decision: if changed { "changed" } else { "unchanged" },
    }
}
