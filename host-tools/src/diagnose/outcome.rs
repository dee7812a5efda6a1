//! What a diagnosis finds, typed: the outcome of [`super::diagnose_aligned`]
//! and the object `diagnose --json` prints (CONTRACT.md sections 1 and 3).
//!
//! Every struct declares its fields in the order the JSON prints its keys
//! (alphabetical: the order the command printed before the outcome was
//! typed), so that serialising it gives the same bytes. Figures are kept
//! rounded as printed ([`super::candidates::round`]); an `f64` that is not
//! finite prints as `null`, as does an `Option` that is `None` (and reads
//! back only into an `Option`: the outcome deserialises from the JSON it
//! prints when its figures are finite).

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

/// The whole diagnosis of a real run against the twin's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// Residual energy by period band of the main channel (and of `dz_um`).
    pub bands: Vec<Band>,
    /// What the verdict's effect is worth to a compensation model.
    pub deployment: Deployment,
    /// The deciding look's baseline and candidates, best held-out rms first.
    pub effects: Vec<Effect>,
    /// The gap (real - sim) of every shared channel.
    pub gap: BTreeMap<String, Gap>,
    /// Why a physical gate set the verdict, if one did.
    pub gate: Option<String>,
    /// Where the held-out part starts, s.
    pub holdout_from_t_s: f64,
    /// Every look at a channel: its verdict and candidates' figures.
    pub looks: Vec<LookFigures>,
    /// The channel the verdict explains.
    pub main_channel: String,
    /// The main channel's gap rms over its noise.
    pub main_gap_snr: f64,
    /// With the twin's machine file: the physical diagnosis
    /// ([`super::physical`]); absent from the JSON without it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub physical: Option<Physical>,
    /// The verdict rule in words.
    pub rule: String,
    /// A second effect claimed with the verdict (a joint pair's other
    /// member), if any.
    pub second: Option<Effect>,
    /// The verdict: an effect's name or `none`.
    pub verdict: String,
    /// The regime segments with the largest share of the residual energy.
    #[serde(rename = "where")]
    pub where_: Vec<Segment>,
}

/// One channel's residual energy by period band, %.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// The channel.
    pub channel: String,
    /// Periods under 10 min.
    pub fast_pct: f64,
    /// The spacing of the even grid the bands are figured on, s.
    pub grid_dt_s: f64,
    /// Periods of 10 min to 2 h.
    pub mid_pct: f64,
    /// The mid band's strongest period, s (`None` without one).
    pub mid_peak_period_s: Option<f64>,
    /// Periods over 2 h.
    pub slow_pct: f64,
}

/// One channel's gap over the whole run, in its unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// Largest absolute residual.
    pub max_abs: f64,
    /// Residual rms.
    pub rms: f64,
}

/// An operating-regime segment's share of a channel's residual energy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// The channel.
    pub channel: String,
    /// Share of its samples above air-cutting power, %.
    pub cutting_pct: f64,
    /// Its first row's time, s.
    pub from_t_s: f64,
    /// Its label (`warm-up 9000 rpm`, ...).
    pub regime: String,
    /// Residual rms in it.
    pub rms: f64,
    /// Its share of the channel's residual energy, %.
    pub share_pct: f64,
    /// The time of the row after it (of its last row at the run's end), s.
    pub to_t_s: f64,
}

/// A fitted candidate explanation (or the `none` baseline), scored on the
/// hold-out: the CONTRACT's effect object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Effect {
    /// `1 - p_adjusted` (`None` for the baseline).
    pub confidence: Option<f64>,
    /// Rms of what it leaves on the fit rows.
    pub fit_rms: f64,
    /// The model form used.
    pub model: String,
    /// Vocabulary name (or `none`).
    pub name: String,
    /// `p_value` after Holm's adjustment over the candidates tested.
    pub p_adjusted: Option<f64>,
    /// One-sided block-bootstrap p-value against the baseline.
    pub p_value: Option<f64>,
    /// As `second` only: the joint pair's name (`a+b`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pair: Option<String>,
    /// Its parameters: nonlinear ones, labels and gains.
    pub params: Params,
    /// Held-out rms over the baseline's.
    pub ratio_to_none: f64,
    /// Held-out rms after subtracting its prediction.
    pub rms_after: f64,
    /// As `second` only: the held-out rms the verdict's effect leaves alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_after_first_alone: Option<f64>,
    /// Held-out rms of the residual.
    pub rms_before: f64,
    /// `100 (1 - after / before)`.
    pub shrink_pct: f64,
}

/// A candidate's parameter: a number, or a label naming what it acts on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Param {
    /// A figure (a gain, a time constant, ...).
    Number(f64),
    /// A label (an input's name, ...).
    Label(String),
    /// Numbers by name (a time constant per sensor, ...).
    Table(BTreeMap<String, f64>),
}

/// Parameters by name.
pub type Params = BTreeMap<String, Param>;

impl Param {
    /// The number, if it is one.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Param::Number(x) => Some(*x),
            Param::Label(_) | Param::Table(_) => None,
        }
    }
}

/// One look at a channel: the rule's thresholds, the verdict and each
/// candidate's figures the rule looks at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LookFigures {
    /// Largest Holm-adjusted p-value that counts.
    pub alpha: f64,
    /// The candidates (not the baseline), best held-out rms first.
    pub candidates: Vec<CandidateFigures>,
    /// The channel looked at.
    pub channel: String,
    /// Largest held-out rms as a fraction of the baseline's.
    pub max_ratio_to_none: f64,
    /// The look's verdict.
    pub verdict: String,
}

/// A candidate's figures on a look.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateFigures {
    /// The candidate.
    pub name: String,
    /// Holm-adjusted p-value.
    pub p_adjusted: Option<f64>,
    /// Raw p-value.
    pub p_value: Option<f64>,
    /// Held-out rms over the baseline's.
    pub ratio_to_none: f64,
    /// Held-out shrink of the raw residual, %.
    pub shrink_pct: f64,
}

/// The deployment view ([`super::deploy`]): a compensation model trained
/// on the sim, on the sim plus the effect and on the real fit part, or why
/// there is none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Deployment {
    /// The models trained and scored.
    Compared(Box<Comparison>),
    /// No model: no displacement or no temperature channel to train on.
    Skipped {
        /// The compensation model's kind.
        model: String,
        /// Why there is none.
        note: String,
    },
}

impl Deployment {
    /// The comparison, if the models were trained.
    pub fn comparison(&self) -> Option<&Comparison> {
        match self {
            Deployment::Compared(c) => Some(c),
            Deployment::Skipped { .. } => None,
        }
    }

    /// The compensation model's kind.
    pub fn model(&self) -> &str {
        match self {
            Deployment::Compared(c) => &c.model,
            Deployment::Skipped { model, .. } => model,
        }
    }
}

/// The deployment comparison's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// The effect added to the sim (absent for a `none` verdict).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<String>,
    /// Rms of the target on the real run's held-out rows, um.
    pub held_out_uncompensated_rms_um: f64,
    /// With an effect: how much adding it lowers the held-out rmse, %
    /// (not finite, printed `null`, when either rmse is missing).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub improvement_pct: Option<f64>,
    /// The temperature channels regressed on.
    pub inputs: Vec<String>,
    /// The compensation model's kind.
    pub model: String,
    /// For a `none` verdict: why there is no effect to add.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// The compensated channel.
    pub target: String,
    /// What the models are trained and scored on.
    pub trained_on: String,
    /// Trained on the real run's fit part (the reference).
    pub trained_on_real_fit_part: Trained,
    /// Trained on the nominal sim.
    pub trained_on_sim: Trained,
    /// Trained on the sim plus the effect (`None` for a `none` verdict).
    pub trained_on_sim_plus_effect: Option<Trained>,
}

/// One compensation model's score on the real hold-out, or its failure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Trained {
    /// Trained and scored.
    Scored {
        /// `1 - mean|y - yhat| / mean|y|`, %.
        reduction_pct: f64,
        /// Held-out rmse, um.
        rmse_um: f64,
    },
    /// The solver refused.
    Failed {
        /// Why.
        error: String,
    },
}

impl Trained {
    /// The held-out rmse, um, if trained and finite.
    pub fn rmse_um(&self) -> Option<f64> {
        match self {
            Trained::Scored { rmse_um, .. } => finite(*rmse_um),
            Trained::Failed { .. } => None,
        }
    }
}

/// The physical diagnosis ([`super::physical`]): the twin recalibrated on
/// the fit part, then each effect switched on in it and refitted; held-out
/// rms on `channel`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Physical {
    /// The effect whose twin leaves the smallest held-out rms (a
    /// description, not a verdict).
    pub best: Option<String>,
    /// The channel the shrink is reported on.
    pub channel: Option<String>,
    /// Each effect, smallest held-out rms first.
    pub effects: Vec<PhysicalEffect>,
    /// Held-out rms per channel of the recalibrated twin (`None` where it
    /// has no hold-out figure).
    pub gap_after_recalibration: BTreeMap<String, Option<f64>>,
    /// Held-out rms per channel of the sim as given.
    pub gap_of_sim: BTreeMap<String, f64>,
    /// The recalibrated twin's held-out rms on `channel` over the noise.
    pub gap_snr: f64,
    /// The machine file, as given.
    pub machine: String,
    /// The method in words.
    pub method: String,
    /// The noise on `channel` (of the whitest held-out residual).
    pub noise_sigma: f64,
    /// The machine's factors refitted on the fit part.
    pub recalibrated: TwinFit,
    /// Wall time, s.
    pub seconds: f64,
    /// Twin simulations run in all.
    pub simulations: usize,
}

/// One effect switched on in the twin and refitted (or why not).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhysicalEffect {
    /// Held-out rms per channel of the twin with the effect (`None` if it
    /// was not fitted).
    pub held_out_rms: Option<BTreeMap<String, Option<f64>>>,
    /// The effect's form in words, or why it was not fitted.
    pub model: String,
    /// The vocabulary name.
    pub name: String,
    /// The effect's fitted parameters.
    pub params: Params,
    /// Held-out rms on `channel` of the twin with the effect.
    pub rms_after: f64,
    /// ... of the recalibrated twin.
    pub rms_before: f64,
    /// `100 (1 - after / before)`.
    pub shrink_pct: f64,
    /// The machine's factors refitted with the effect (`None` if not fitted).
    pub twin: Option<TwinFit>,
}

/// The machine's refitted factors (relative to the machine file) and how
/// the fit went.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TwinFit {
    /// Exponent of the bearing loss in speed.
    pub bearing_exponent: f64,
    /// Factor on every node's heat capacity.
    pub capacity_factor: f64,
    /// Whether the fit converged.
    pub converged: bool,
    /// Factor on every conductance to the room air.
    pub g_ambient_factor: f64,
    /// Factor on every heat source.
    pub heat_factor: f64,
    /// Simulations the fit ran.
    pub simulations: usize,
}

/// `x` if it is finite (a figure the JSON prints as a number).
pub fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// `x` as the JSON prints it (`43200.0`, `null` if not finite): for text
/// that quotes the JSON's figures.
pub fn json_number(x: f64) -> String {
    Value::from(x).to_string()
}
