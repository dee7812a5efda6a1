//! What a selection found, typed: [`SelectOutcome`], one struct per method.
//! `serde_json::to_value(&outcome)` is the object `select --json` prints
//! (sorted keys, non-finite figures as `null`); the text tables are drawn
//! from the same figures by the CLI (`cli::select`).

use crate::num::stats;
use serde::Serialize;
use std::collections::BTreeMap;

/// A selection's result: the method's figures, tagged `"method"`.
// One outcome per call, never stored in bulk: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "method", rename_all = "lowercase")]
pub enum SelectOutcome {
    /// `--method grey`.
    Grey(GreyOutcome),
    /// `--method wgrey`.
    Wgrey(WgreyOutcome),
    /// `--method maxtree`.
    Maxtree(MaxtreeOutcome),
}

impl SelectOutcome {
    /// The sensors picked, in the method's order.
    pub fn selected(&self) -> &[String] {
        match self {
            SelectOutcome::Grey(g) => &g.selected,
            SelectOutcome::Wgrey(w) => &w.selected,
            SelectOutcome::Maxtree(m) => &m.selected,
        }
    }
}

/// Rows used by a computation with the target.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RowCounts {
    /// Rows where every input has a value.
    pub inputs: usize,
    /// Rows where the target and every input have values.
    pub with_target: usize,
    /// Rows left out of the computation with the target.
    pub left_out: usize,
}

/// Which series started at 0 under `--scale initial`, and what all the
/// series of that computation used instead.
#[derive(Debug, Clone, Serialize)]
pub struct ScaleFallback {
    /// The processing asked for.
    pub from: &'static str,
    /// The processing used.
    pub to: &'static str,
    /// The series that start at 0.
    pub zero_start: Vec<String>,
    /// Every series of the computation.
    pub series: Vec<String>,
}

/// A regression's figures.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RegressionFigures {
    /// Multiple correlation coefficient.
    pub r: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// Adjusted R^2.
    pub adj_r2: f64,
    /// F statistic.
    pub f: f64,
    /// Its degrees of freedom (regressors, residual).
    pub df: [usize; 2],
    /// p-value of the F test.
    pub p_value: f64,
    /// The regressors are collinear.
    pub rank_deficient: bool,
}

impl From<&stats::Regression> for RegressionFigures {
    fn from(r: &stats::Regression) -> Self {
        Self {
            r: r.multiple_r(),
            r2: r.r2,
            adj_r2: r.adj_r2,
            f: r.f,
            df: [r.p, r.n.saturating_sub(r.p + 1)],
            p_value: r.p_value,
            rank_deficient: r.rank_deficient,
        }
    }
}

/// `--method grey`'s figures (seed 000).
#[derive(Debug, Clone, Serialize)]
pub struct GreyOutcome {
    /// The target (one).
    pub target: Vec<String>,
    /// The candidate inputs.
    pub inputs: Vec<String>,
    /// The best combination's variables.
    pub selected: Vec<String>,
    /// What "best" means: `"adj_r2"`.
    pub criterion: &'static str,
    /// Rows used.
    pub rows: RowCounts,
    /// `--scale`.
    pub scale: &'static str,
    /// The processing the correlation with the target used.
    pub scale_used: &'static str,
    /// Its fallback, if any.
    pub scale_fallback: Option<ScaleFallback>,
    /// The images of the grey relative degree between the inputs.
    pub relative_images: &'static str,
    /// Their fallback, if any.
    pub relative_fallback: Option<ScaleFallback>,
    /// `--xi`.
    pub xi: f64,
    /// `--theta`.
    pub theta: f64,
    /// `--level`.
    pub level: f64,
    /// Grey absolute degrees between the inputs.
    pub absolute: Vec<Vec<f64>>,
    /// Grey relative degrees between the inputs.
    pub relative: Vec<Vec<f64>>,
    /// Comprehensive degrees between the inputs.
    pub comprehensive: Vec<Vec<f64>>,
    /// The grey clusters.
    pub groups: Vec<Vec<String>>,
    /// Each cluster's typical variable, in input order.
    pub typical: Vec<String>,
    /// Each input's figures.
    pub variables: Vec<GreyVariable>,
    /// Every combination of the typical variables, regressed on the target.
    pub combinations: Vec<Combination>,
    /// Rows skipped as unparsable when reading.
    pub skipped_rows: usize,
    /// Index of the best combination in `combinations`.
    #[serde(skip)]
    pub best: usize,
    /// Scale fallbacks, one line each (stderr and the text report).
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// One input of a grey selection.
#[derive(Debug, Clone, Serialize)]
pub struct GreyVariable {
    /// Column name.
    pub name: String,
    /// Deng's grey coefficient with the target.
    pub grey_coefficient: f64,
    /// Pearson r with the target.
    pub pearson: f64,
    /// Its cluster (0-based).
    pub group: usize,
    /// It is its cluster's typical variable.
    pub typical: bool,
}

/// One combination of typical variables and its regression.
#[derive(Debug, Clone, Serialize)]
pub struct Combination {
    /// The regression's figures.
    #[serde(flatten)]
    pub regression: RegressionFigures,
    /// The variables combined.
    pub variables: Vec<String>,
}

/// `--method wgrey`'s figures (seed 002 Eq. 1).
#[derive(Debug, Clone, Serialize)]
pub struct WgreyOutcome {
    /// The targets, in the order given.
    pub target: Vec<String>,
    /// The candidate inputs.
    pub inputs: Vec<String>,
    /// The inputs in every target's top set.
    pub selected: Vec<String>,
    /// `--scale` (requested).
    pub scale: &'static str,
    /// `--xi`.
    pub xi: f64,
    /// `--lambda1`.
    pub lambda1: f64,
    /// `--lambda2`.
    pub lambda2: f64,
    /// `--top`.
    pub top: usize,
    /// Each target's figures.
    pub per_target: BTreeMap<String, WgreyTarget>,
    /// Rows skipped as unparsable when reading.
    pub skipped_rows: usize,
    /// Scale fallbacks, one line each (stderr and the text report).
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// One target of a wgrey selection.
#[derive(Debug, Clone, Serialize)]
pub struct WgreyTarget {
    /// Rows with the target and every input.
    pub rows: usize,
    /// Rows left out.
    pub left_out: usize,
    /// The processing used.
    pub scale_used: &'static str,
    /// Its fallback, if any.
    pub scale_fallback: Option<ScaleFallback>,
    /// Weighted grey correlativity of each input.
    pub gamma: Vec<f64>,
    /// Every input, best first.
    pub ranking: Vec<String>,
    /// The `--top` best.
    pub top: Vec<String>,
}

/// `--method maxtree`'s figures (seed 003).
#[derive(Debug, Clone, Serialize)]
pub struct MaxtreeOutcome {
    /// The target (one).
    pub target: Vec<String>,
    /// The candidate inputs.
    pub inputs: Vec<String>,
    /// The chosen level's representatives.
    pub selected: Vec<String>,
    /// Rows used.
    pub rows: RowCounts,
    /// Pearson r between the inputs.
    pub pearson: Vec<Vec<f64>>,
    /// |r| between the inputs: the tree's similarity.
    pub similarity: Vec<Vec<f64>>,
    /// The maximal tree's edges, in the order Prim added them.
    pub tree: Vec<TreeEdge>,
    /// Pearson r of each input with the target.
    pub target_correlation: Vec<f64>,
    /// Each level of the tree: groups, representatives, regression.
    pub levels: Vec<MaxtreeLevel>,
    /// Index of the chosen level.
    pub chosen_level: usize,
    /// `--alpha`.
    pub alpha: f64,
    /// `--min-gain`.
    pub min_gain: f64,
    /// `--min-tolerance`.
    pub min_tolerance: f64,
    /// How the level was chosen.
    pub rule: String,
    /// Rows skipped as unparsable when reading.
    pub skipped_rows: usize,
}

/// One edge of the maximal tree.
#[derive(Debug, Clone, Serialize)]
pub struct TreeEdge {
    /// One end.
    pub a: String,
    /// The other end.
    pub b: String,
    /// Its similarity |r|.
    pub weight: f64,
}

/// One level of the maximal tree.
#[derive(Debug, Clone, Serialize)]
pub struct MaxtreeLevel {
    /// The cut: edges of at least this weight join.
    pub lambda: f64,
    /// The groups at this cut.
    pub groups: Vec<Vec<String>>,
    /// Each group's input best correlated with the target.
    pub representatives: Vec<String>,
    /// The representatives' regression on the target.
    #[serde(flatten)]
    pub regression: RegressionFigures,
    /// Condition number of the representatives.
    pub condition_number: f64,
    /// Variance inflation factor of each representative.
    pub vif: Vec<f64>,
    /// The regression passes the F test at `--alpha`.
    pub significant: bool,
}
