//! What `bp` and `gabp` report (`details` in `fit --json`): the net, how it
//! was trained and, for `gabp`, the GA, the convergence comparison and the
//! held-out figures. Fields are declared in the JSON's key order.

use super::gd::GdReport;
use super::lm::LmReport;
use crate::eval::MetricsReport;
use serde::Serialize;
use std::collections::BTreeMap;

/// A net's held-out figures per target, under eval's keys (`None`: no
/// held-out rows).
pub type HoldoutFigures = Option<BTreeMap<String, MetricsReport>>;

/// What `bp` and `gabp` report.
#[derive(Clone, Debug, Serialize)]
pub struct BpDetails {
    /// Hidden-layer transfer function (`tansig` or `logsig`).
    pub activation: &'static str,
    /// gabp: how the nets converged (absent for bp).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convergence: Option<Convergence>,
    /// Which calibration rows train and which validate.
    pub division: Division,
    /// gabp: the genetic algorithm (absent for bp).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ga: Option<GaFigures>,
    /// Training MSE goal on targets scaled to [-1, 1].
    pub goal_mse: f64,
    /// Where the goal comes from.
    pub goal_rule: String,
    /// Hidden neurons of the net written.
    pub hidden: usize,
    /// How the hidden size was chosen.
    pub hidden_rule: String,
    /// gabp: held-out figures of the nets compared (absent for bp).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holdout: Option<NetHoldouts>,
    /// Initial weights' rule.
    pub init: &'static str,
    /// The Levenberg-Marquardt training of the net written.
    pub lm: LmFigures,
    /// Output-layer transfer function.
    pub output_activation: &'static str,
    /// Weights and biases of the net written.
    pub parameters: usize,
    /// How inputs and targets are scaled.
    pub scaling: &'static str,
    /// `--seed`.
    pub seed: u64,
    /// The training algorithm.
    pub training: &'static str,
}

/// Contiguous blocks of the calibration rows; every K-th validates.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Division {
    /// `--val-blocks`.
    pub blocks: usize,
    /// `--val-every`.
    pub every: usize,
    /// The rule.
    pub rule: &'static str,
    /// Rows that train.
    pub train_rows: usize,
    /// Rows that validate (early stopping).
    pub validation_rows: usize,
}

/// A Levenberg-Marquardt run's figures (MSE on targets scaled to [-1, 1]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LmFigures {
    /// The epoch whose weights were kept.
    pub best_epoch: usize,
    /// Epochs run.
    pub epochs_run: usize,
    /// First epoch at or below the goal.
    pub goal_reached_epoch: Option<usize>,
    /// Seconds to that epoch.
    pub goal_reached_s: Option<f64>,
    /// Seconds in all.
    pub seconds: f64,
    /// Why it stopped.
    pub stop: &'static str,
    /// Training MSE after the last epoch.
    pub train_mse_end: Option<f64>,
    /// Training MSE at the start.
    pub train_mse_start: Option<f64>,
    /// Validation MSE at the kept epoch (`null` without validation rows).
    pub val_mse_best: Option<f64>,
}

impl From<&LmReport> for LmFigures {
    fn from(r: &LmReport) -> Self {
        Self {
            best_epoch: r.best_epoch,
            epochs_run: r.epochs,
            goal_reached_epoch: r.goal_epoch,
            goal_reached_s: r.goal_seconds,
            seconds: r.seconds,
            stop: r.stop,
            train_mse_end: r.train_mse.last().copied(),
            train_mse_start: r.train_mse.first().copied(),
            val_mse_best: r.val_mse.get(r.best_epoch).copied(),
        }
    }
}

/// The genetic algorithm of gabp (seed 000, Eq. 16-17).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GaFigures {
    /// Best training MSE (scaled) after each generation, the initial population first.
    pub best_train_mse: Vec<f64>,
    /// `--ga-crossover`.
    pub crossover: f64,
    /// The fitness function.
    pub fitness: &'static str,
    /// `--ga-generations`.
    pub generations: usize,
    /// Hidden sizes searched, inclusive.
    pub hidden_range: [usize; 2],
    /// `--ga-mutation`.
    pub mutation: f64,
    /// `--ga-population`.
    pub population: usize,
    /// Seconds the GA took.
    pub seconds: f64,
}

/// How the nets gabp is compared with converged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Convergence {
    /// Why no comparison was trained (absent with `--report-convergence`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compared: Option<&'static str>,
    /// The gradient-descent runs (`null` without them).
    pub gd: Option<GdComparison>,
    /// The training MSE goal (scaled targets).
    pub goal_mse: f64,
    /// The Levenberg-Marquardt runs.
    pub lm: LmComparison,
}

/// Levenberg-Marquardt runs: BP at the default size and at the GA's size
/// (with `--report-convergence` only) and GA-BP.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LmComparison {
    /// BP at the default size from Nguyen-Widrow weights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bp: Option<ConvergenceRow>,
    /// BP at the GA's size from Nguyen-Widrow weights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bp_same_hidden: Option<ConvergenceRow>,
    /// GA-BP: from the GA's best individual.
    pub gabp: ConvergenceRow,
}

/// One Levenberg-Marquardt run's convergence (MSE on scaled targets).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConvergenceRow {
    /// Epochs run.
    pub epochs_run: usize,
    /// GA-BP: seconds the GA took (included in the other times).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ga_seconds: Option<f64>,
    /// First epoch at or below the goal.
    pub goal_reached_epoch: Option<usize>,
    /// Seconds to that epoch.
    pub goal_reached_s: Option<f64>,
    /// Hidden neurons.
    pub hidden: usize,
    /// Where its weights started.
    pub init: &'static str,
    /// Seconds in all.
    pub seconds: f64,
    /// Why it stopped.
    pub stop: &'static str,
    /// Training MSE after the last epoch.
    pub train_mse_end: Option<f64>,
    /// Training MSE at the start.
    pub train_mse_start: Option<f64>,
}

impl ConvergenceRow {
    /// The figures of LM run `r` of a net with `hidden` neurons started
    /// from `init`, `extra_s` seconds (the GA's) added to its times.
    pub fn new(hidden: usize, init: &'static str, r: &LmReport, extra_s: f64) -> Self {
        Self {
            epochs_run: r.epochs,
            ga_seconds: None,
            goal_reached_epoch: r.goal_epoch,
            goal_reached_s: r.goal_seconds.map(|s| s + extra_s),
            hidden,
            init,
            seconds: r.seconds + extra_s,
            stop: r.stop,
            train_mse_end: r.train_mse.last().copied(),
            train_mse_start: r.train_mse.first().copied(),
        }
    }
}

/// Gradient-descent runs (traingdx) from the three starts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GdComparison {
    /// The algorithm and its settings.
    pub algorithm: &'static str,
    /// BP at the default size.
    pub bp: GdRow,
    /// BP at the GA's size.
    pub bp_same_hidden: GdRow,
    /// `--gd-epochs`.
    pub epoch_cap: usize,
    /// From the GA's best individual.
    pub gabp: GdRow,
}

/// One gradient-descent run's convergence (MSE on scaled targets).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GdRow {
    /// Epochs run.
    pub epochs_run: usize,
    /// First epoch at or below the goal.
    pub goal_reached_epoch: Option<usize>,
    /// Seconds to that epoch.
    pub goal_reached_s: Option<f64>,
    /// Seconds in all.
    pub seconds: f64,
    /// Training MSE at the end.
    pub train_mse_end: f64,
}

impl From<&GdReport> for GdRow {
    fn from(r: &GdReport) -> Self {
        Self {
            epochs_run: r.epochs,
            goal_reached_epoch: r.goal_epoch,
            goal_reached_s: r.goal_seconds,
            seconds: r.seconds,
            train_mse_end: r.final_mse,
        }
    }
}

/// Held-out figures of GA-BP and (with `--report-convergence`) of BP.
#[derive(Clone, Debug, Serialize)]
pub struct NetHoldouts {
    /// BP at the default size.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bp: Option<HoldoutFigures>,
    /// GA-BP.
    pub gabp: HoldoutFigures,
}
